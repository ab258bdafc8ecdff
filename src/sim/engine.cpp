#include "sim/engine.hpp"

#include <cmath>
#include <fmt/format.h>

#include "lattice/lattice.hpp"
#include "mca/error.hpp"
#include "sim/state_check.hpp"

namespace mca {

namespace {
Model build_for_frames(const SceneDef& scene, int& steps_per_frame) {
  Model m = lattice::build_model(scene);
  const double frame = 1.0 / scene.output.frame_rate;
  const double stable = m.dt;
  const double steps = std::max(1.0, std::ceil(frame / stable - 1e-9));
  if (steps > 1e9) {
    throw Error(fmt::format("{}: output.frame_rate = {:g} asks for {:.3g} steps of {:.3g} s per frame; raise "
                            "output.frame_rate (frames per simulated second) so a frame is at most 1e9 steps",
                            scene.source, scene.output.frame_rate, steps, stable));
  }
  steps_per_frame = static_cast<int>(steps);
  if (scene.solver.time_step <= 0) m.dt = static_cast<float>(frame / steps_per_frame);
  return m;
}
}  // namespace

Engine::Engine(const SceneDef& scene) : scene_(scene) {
  model_ = build_for_frames(scene_, steps_per_frame_);
  backend_ = make_cpu_backend(model_);
  backend_->upload(initial_state(model_));
}

Engine::Engine(const SceneDef& scene, const State& state, const std::string& source,
               std::optional<std::uint64_t> fingerprint)
    : scene_(scene) {
  model_ = build_for_frames(scene_, steps_per_frame_);
  // The fingerprint first: when the scene was edited, "another model" is the cause to report, not the
  // first array whose size it changed.
  if (fingerprint) {
    const std::uint64_t rebuilt = model_fingerprint(model_);
    if (rebuilt != *fingerprint)
      throw Error(fmt::format("{}: its embedded scene does not give the model the state was saved from (model "
                              "fingerprint {:016x}, saved {:016x}): the file was edited or damaged, or written by "
                              "another version of mca; use an earlier checkpoint (remove this one) or start the "
                              "run again",
                              source, rebuilt, *fingerprint));
  }
  check_state(model_, state, source);
  backend_ = make_cpu_backend(model_);
  backend_->upload(state);
}

std::int64_t Engine::frame_count() const {
  return std::max<std::int64_t>(1, std::llround(scene_.output.duration * scene_.output.frame_rate));
}

namespace {
struct Fnv {
  std::uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t k = 0; k < n; ++k) {
      h ^= c[k];
      h *= 1099511628211ull;
    }
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    bytes(v.data(), v.size() * sizeof(T));
  }
};
}  // namespace

std::uint64_t state_hash(const State& s) {
  Fnv f;
  f.bytes(&s.step, sizeof s.step);
  f.vec(s.x);
  f.vec(s.v);
  f.vec(s.w);
  f.vec(s.q);
  f.vec(s.intact);
  f.vec(s.link_ut);
  f.vec(s.mean_stress);
  for (const auto& c : s.contacts) {
    f.bytes(&c.i, sizeof c.i);
    f.bytes(&c.j, sizeof c.j);
    f.bytes(&c.ut, sizeof c.ut);
  }
  for (const auto& p : s.projectiles) {
    f.bytes(&p.position, sizeof p.position);
    f.bytes(&p.velocity, sizeof p.velocity);
    f.bytes(&p.angular_velocity, sizeof p.angular_velocity);
  }
  return f.h;
}

}  // namespace mca
