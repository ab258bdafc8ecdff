// mca::Simulation (include/mca/simulation.hpp): the public wrapper around the Engine.
#include "mca/simulation.hpp"

#include "analysis/fragments.hpp"
#include "sim/engine.hpp"

namespace mca {

struct Simulation::Impl {
  explicit Impl(const SceneDef& scene) : engine(scene) {}
  Engine engine;
};

Simulation::Simulation(const SceneDef& scene) : impl_(std::make_unique<Impl>(scene)) {}
Simulation::~Simulation() = default;
Simulation::Simulation(Simulation&&) noexcept = default;
Simulation& Simulation::operator=(Simulation&&) noexcept = default;

std::size_t Simulation::automata() const { return impl_->engine.model().size(); }
std::size_t Simulation::links() const { return impl_->engine.model().link_count(); }
double Simulation::time_step() const { return impl_->engine.model().dt; }
int Simulation::steps_per_frame() const { return impl_->engine.steps_per_frame(); }
double Simulation::time() const { return impl_->engine.time(); }

StepStatus Simulation::advance(int steps) {
  return impl_->engine.advance(steps).flags == kHealthy ? StepStatus::ok : StepStatus::unstable;
}

Frame Simulation::frame() const {
  const Model& m = impl_->engine.model();
  const State& s = impl_->engine.state();
  const std::size_t n = m.size();
  Frame f;
  f.step = s.step;
  f.time = s.time;
  f.position.resize(n);
  f.velocity.resize(n);
  f.orientation.resize(n);
  f.damage.resize(n);
  for (std::size_t a = 0; a < n; ++a) {
    const Vec3 p = to_vec3(s.x[a]);
    f.position[a] = {p.x, p.y, p.z};
    const Vec3 v = to_vec3(s.v[a]);
    f.velocity[a] = {v.x, v.y, v.z};
    f.orientation[a] = {s.q[a].w, s.q[a].x, s.q[a].y, s.q[a].z};
  }
  automaton_damage(m, s.intact.data(), s.link_damage.empty() ? nullptr : s.link_damage.data(), f.damage.data());
  const auto frags = analysis::label_model_fragments(m, s.intact.data());
  f.fragment = frags.id;
  f.fragments = frags.count;
  for (const auto& p : s.projectiles)
    f.projectile_position.push_back({static_cast<float>(p.position.x), static_cast<float>(p.position.y),
                                     static_cast<float>(p.position.z)});
  f.broken_links = s.broken_by[0] + s.broken_by[1];
  return f;
}

}  // namespace mca
