#include "io/checkpoint.hpp"

#include <cstring>
#include <fmt/format.h>
#include <fstream>
#include <iterator>

#include "io/output_files.hpp"
#include "io/scene_io.hpp"
#include "mca/error.hpp"

namespace mca::io {
namespace {

constexpr char kMagic[8] = {'M', 'C', 'A', 'C', 'K', 'P', 'T', '1'};

struct Writer {
  std::ostream& os;
  template <class T>
  void pod(const T& v) {
    os.write(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    pod<std::uint64_t>(v.size());
    os.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
  }
  void str(const std::string& s) {
    pod<std::uint64_t>(s.size());
    os.write(s.data(), static_cast<std::streamsize>(s.size()));
  }
};

struct Reader {
  const std::string& data;
  const std::filesystem::path& path;
  std::size_t at = 0;
  // n items of `size` bytes must follow; written without products so a damaged count cannot overflow.
  void need(std::size_t n, std::size_t size = 1) {
    if (n > (data.size() - at) / size)
      throw Error(fmt::format("checkpoint '{}' is truncated (wanted {} items of {} bytes at offset {}, file has {} "
                              "bytes); use an earlier checkpoint or start the run again",
                              path.string(), n, size, at, data.size()));
  }
  template <class T>
  T pod() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, data.data() + at, sizeof(T));
    at += sizeof(T);
    return v;
  }
  template <class T>
  void vec(std::vector<T>& v) {
    const auto n = pod<std::uint64_t>();
    need(n, sizeof(T));
    v.resize(n);
    std::memcpy(v.data(), data.data() + at, n * sizeof(T));
    at += n * sizeof(T);
  }
  std::string str() {
    const auto n = pod<std::uint64_t>();
    need(n);
    std::string s = data.substr(at, n);
    at += n;
    return s;
  }
};

}  // namespace

void write_checkpoint(const std::filesystem::path& path, const Checkpoint& cp) {
  write_file_atomic(path, [&](std::ostream& os) {
    Writer w{os};
    os.write(kMagic, sizeof kMagic);
    w.str(cp.scene_toml.empty() ? scene_to_toml(cp.scene) : cp.scene_toml);
    w.pod(cp.frame);
    w.pod(cp.total_steps);
    w.pod(cp.wall_seconds);
    const State& s = cp.state;
    w.pod(s.step);
    w.pod(s.time);
    w.vec(s.x);
    w.vec(s.v);
    w.vec(s.w);
    w.vec(s.q);
    w.vec(s.s);
    w.vec(s.mean_stress);
    w.vec(s.f);
    w.vec(s.t);
    w.vec(s.intact);
    w.vec(s.link_ut);
    w.vec(s.contacts);
    w.vec(s.ground_contacts);
    w.vec(s.x_at_rebuild);
    w.pod<std::uint64_t>(s.projectiles.size());
    for (const auto& p : s.projectiles) {
      w.pod(p.position);
      w.pod(p.velocity);
      w.pod(p.angular_velocity);
      w.pod(p.orientation);
      w.pod(p.force);
      w.vec(p.contacts);
      w.pod(p.ground);
      w.pod(p.work);
    }
    w.vec(s.projectile_contacts);
    w.vec(s.breaks);
    w.pod(s.broken_by[0]);
    w.pod(s.broken_by[1]);
    w.pod(s.initial_energy);
    w.vec(s.grip_work);
    w.vec(s.grip_force);
    os.write(kMagic, sizeof kMagic);  // end marker: a file cut short fails to load
  });
}

Checkpoint read_checkpoint(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw Error(fmt::format("cannot open checkpoint '{}': {}; pass the output folder of a run started with "
                            "--checkpoint-every N",
                            path.string(), std::strerror(errno)));
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (data.size() < 16 || std::memcmp(data.data(), kMagic, 8) != 0)
    throw Error(fmt::format("'{}' is not an mca checkpoint (bad header)", path.string()));
  Reader r{data, path};
  r.at = 8;
  Checkpoint cp;
  cp.scene_toml = r.str();
  cp.scene = parse_scene(cp.scene_toml, path.string() + " (embedded scene)");
  cp.frame = r.pod<std::int64_t>();
  cp.total_steps = r.pod<std::int64_t>();
  cp.wall_seconds = r.pod<double>();
  State& s = cp.state;
  s.step = r.pod<std::int64_t>();
  s.time = r.pod<double>();
  r.vec(s.x);
  r.vec(s.v);
  r.vec(s.w);
  r.vec(s.q);
  r.vec(s.s);
  r.vec(s.mean_stress);
  r.vec(s.f);
  r.vec(s.t);
  r.vec(s.intact);
  r.vec(s.link_ut);
  r.vec(s.contacts);
  r.vec(s.ground_contacts);
  r.vec(s.x_at_rebuild);
  const auto np = r.pod<std::uint64_t>();
  // Each projectile takes at least its fixed fields and its contact count.
  r.need(np, sizeof(DVec3) + 3 * sizeof(Vec3) + sizeof(Quat) + sizeof(std::uint64_t));
  s.projectiles.resize(np);
  for (auto& p : s.projectiles) {
    p.position = r.pod<DVec3>();
    p.velocity = r.pod<Vec3>();
    p.angular_velocity = r.pod<Vec3>();
    p.orientation = r.pod<Quat>();
    p.force = r.pod<Vec3>();
    r.vec(p.contacts);
    p.ground = r.pod<ContactHistory>();
    p.work = r.pod<double>();
  }
  r.vec(s.projectile_contacts);
  r.vec(s.breaks);
  s.broken_by[0] = r.pod<std::int64_t>();
  s.broken_by[1] = r.pod<std::int64_t>();
  s.initial_energy = r.pod<double>();
  r.vec(s.grip_work);
  r.vec(s.grip_force);
  r.need(8);
  if (std::memcmp(data.data() + r.at, kMagic, 8) != 0)
    throw Error(fmt::format("checkpoint '{}' is damaged (no end marker)", path.string()));
  return cp;
}

}  // namespace mca::io
