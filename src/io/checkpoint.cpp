#include "io/checkpoint.hpp"

#include <algorithm>
#include <concepts>
#include <cstring>
#include <fmt/format.h>
#include <fstream>
#include <iterator>
#include <string_view>
#include <utility>
#include <type_traits>

#include "core/environment.hpp"
#include "core/files.hpp"
#include "core/fnv.hpp"
#include "io/output_files.hpp"
#include "io/scene_io.hpp"
#include "mca/error.hpp"

namespace mca::io {
namespace {

// Format 8: magic, scene TOML, model fingerprint, frame, total steps, wall seconds, the state (fields(State)
// below), an FNV-1a checksum of all the bytes before it, magic again as an end marker. Numbers are in the
// writing machine's byte order: a checkpoint is for resuming a run where it was written. Format 7 had no
// way a contact touches (ContactPair::face), format 6 had no
// links' damage (State::link_damage, softening), format 5 had
// float32 velocities and angular velocities (automata and projectiles), format 4 had no
// bending moments of explicit links (surface mode), format 3 stored
// the links one per pair (now: three slots per automaton, core/model.hpp), format 2 had no checksum (a
// flipped byte in the state was resumed from), format 1 wrote structs with their padding.
constexpr char kMagic[8] = {'M', 'C', 'A', 'C', 'K', 'P', 'T', '8'};
constexpr char kMagicPrefix[7] = {'M', 'C', 'A', 'C', 'K', 'P', 'T'};

template <class T, class U>
concept either = std::same_as<std::remove_const_t<T>, U>;
template <class T>
concept scalar = std::is_arithmetic_v<std::remove_const_t<T>> || std::is_enum_v<std::remove_const_t<T>>;

// What is saved of each type, in order. The writer, the reader and the size count below all walk these
// lists, so a field added to State is one line in fields(State). Structs go field by field: their padding
// bytes hold whatever the memory held and would make equal states differ on disk. (A bool field is saved
// as one byte 0/1; numbers, enums, fixed arrays, std::vector and std::string of these work as they are.)
template <class A, either<Vec3> T>
void fields(A& a, T& v) { a(v.x, v.y, v.z); }
template <class A, either<DVec3> T>
void fields(A& a, T& v) { a(v.x, v.y, v.z); }
template <class A, either<Quat> T>
void fields(A& a, T& v) { a(v.w, v.x, v.y, v.z); }
template <class A, either<Sym3> T>
void fields(A& a, T& v) { a(v.xx, v.yy, v.zz, v.xy, v.yz, v.zx); }
template <class A, either<ContactHistory> T>
void fields(A& a, T& v) { a(v.ut, v.mr); }
template <class A, either<ContactPair> T>
void fields(A& a, T& v) { a(v.i, v.j, v.h, v.face); }
template <class A, either<BodyContact> T>
void fields(A& a, T& v) { a(v.automaton, v.h); }
template <class A, either<ProjectilePair> T>
void fields(A& a, T& v) { a(v.p, v.q, v.h); }
template <class A, either<BreakRecord> T>
void fields(A& a, T& v) { a(v.step, v.link, v.criterion); }
template <class A, either<ProjectileState> T>
void fields(A& a, T& p) {
  a(p.position, p.velocity, p.angular_velocity, p.orientation, p.force, p.contacts, p.ground, p.work);
}
template <class A, either<State> T>
void fields(A& a, T& s) {
  a(s.step, s.time);
  a(s.x, s.v, s.w, s.q, s.s, s.mean_stress, s.f, s.t);
  a(s.intact, s.link_ut, s.link_moment, s.link_damage);
  a(s.contacts, s.ground_contacts, s.x_at_rebuild);
  a(s.projectiles, s.projectile_contacts);
  a(s.breaks, s.broken_by, s.initial_energy);
  a(s.grip_work, s.grip_force);
}

// Bytes one saved T takes (a vector counts its length field only), and whether T is "flat": saved
// bytes == object bytes, no padding, no vectors, so an array of T can be copied as one block.
struct Counter {
  std::size_t bytes = 0;
  bool nested = false;
  template <class... Ts>
  void operator()(Ts&... vs) { (item(vs), ...); }
  template <scalar T>
  void item(T&) { bytes += sizeof(T); }
  void item(bool&) { bytes += 1; }
  template <class T, std::size_t N>
  void item(T (&a)[N]) { for (auto& e : a) item(e); }
  template <class T>
  void item(std::vector<T>&) { bytes += sizeof(std::uint64_t); nested = true; }
  void item(std::string&) { bytes += sizeof(std::uint64_t); nested = true; }
  template <class T>
    requires(!scalar<T>)
  void item(T& v) { fields(*this, v); }
};

struct Layout {
  std::size_t bytes;
  bool flat;
};

template <class T>
const Layout& layout() {
  static const Layout l = [] {
    T v{};
    Counter c;
    c.item(v);
    return Layout{c.bytes, !c.nested && c.bytes == sizeof(T) && std::is_trivially_copyable_v<T> &&
                               !std::is_same_v<T, bool>};
  }();
  return l;
}

struct Writer {
  std::ostream& os;
  Fnv1a checksum;  // of every byte written
  template <class... Ts>
  void operator()(const Ts&... vs) { (item(vs), ...); }
  void raw(const void* p, std::size_t n) {
    checksum.bytes(p, n);
    os.write(static_cast<const char*>(p), static_cast<std::streamsize>(n));
  }
  template <scalar T>
  void item(const T& v) { raw(&v, sizeof v); }
  void item(const bool& b) { item(static_cast<std::uint8_t>(b ? 1 : 0)); }
  template <class T, std::size_t N>
  void item(const T (&a)[N]) { for (const auto& e : a) item(e); }
  template <class T>
  void item(const std::vector<T>& v) {
    item(static_cast<std::uint64_t>(v.size()));
    if (layout<T>().flat) {
      raw(v.data(), v.size() * sizeof(T));
    } else {
      for (const auto& e : v) item(e);
    }
  }
  void item(const std::string& s) {
    item(static_cast<std::uint64_t>(s.size()));
    raw(s.data(), s.size());
  }
  template <class T>
    requires(!scalar<T>)
  void item(const T& v) { fields(*this, v); }
};

[[noreturn]] void damaged_checkpoint(const std::filesystem::path& path, const std::string& what) {
  throw Error(fmt::format("checkpoint '{}' is damaged ({}); use an earlier checkpoint (remove this one) or start "
                          "the run again",
                          path.string(), what));
}

// A file without its end marker was cut short: a copy or a transfer that stopped (mca itself writes to a
// temporary name and renames).
std::string no_end_marker(std::uint64_t size) {
  return fmt::format("its {} bytes do not end with the end marker: cut short, or bytes added or changed at its end",
                     size);
}

struct Reader {
  const std::string& data;
  const std::filesystem::path& path;
  std::size_t at = 0;
  [[noreturn]] void damaged(const std::string& what) const { damaged_checkpoint(path, what); }
  // n items of at least `size` bytes must follow; written without products so a damaged count cannot
  // overflow, and checked before any allocation, so it cannot allocate more than the file holds.
  void need(std::uint64_t n, std::size_t size = 1) {
    if (n > (data.size() - at) / std::max<std::size_t>(size, 1))
      damaged(fmt::format("truncated: wanted {} items of {} bytes at offset {}, the file has {} bytes", n, size, at,
                          data.size()));
  }
  template <class... Ts>
  void operator()(Ts&... vs) { (item(vs), ...); }
  void raw(void* p, std::size_t n) {
    need(n);
    if (n) std::memcpy(p, data.data() + at, n);
    at += n;
  }
  template <scalar T>
  void item(T& v) { raw(&v, sizeof v); }
  void item(bool& b) {
    std::uint8_t u = 0;
    item(u);
    if (u > 1) damaged(fmt::format("a flag at offset {} is {}", at - 1, u));
    b = u == 1;
  }
  template <class T, std::size_t N>
  void item(T (&a)[N]) { for (auto& e : a) item(e); }
  template <class T>
  void item(std::vector<T>& v) {
    std::uint64_t n = 0;
    item(n);
    need(n, layout<T>().bytes);
    v.resize(n);
    if (layout<T>().flat) {
      raw(v.data(), n * sizeof(T));
    } else {
      for (auto& e : v) item(e);
    }
  }
  void item(std::string& s) {
    std::uint64_t n = 0;
    item(n);
    need(n);
    s.assign(data, at, n);
    at += n;
  }
  template <class T>
    requires(!scalar<T>)
  void item(T& v) { fields(*this, v); }
};

}  // namespace

std::string checkpoint_name(std::int64_t frame) { return fmt::format("frame_{:06d}.mcack", frame); }

std::vector<std::filesystem::path> list_checkpoints(const std::filesystem::path& dir) {
  constexpr std::string_view prefix = "frame_", suffix = ".mcack";
  std::vector<std::pair<std::int64_t, std::filesystem::path>> found;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return {};
  for (const auto& e : std::filesystem::directory_iterator(dir, ec))
    if (const auto n = io::numbered(e.path().filename().string(), prefix, suffix); n && e.is_regular_file(ec))
      found.emplace_back(*n, e.path());
  // Equal numbers ("frame_12" and "frame_000012") are ordered by name, so the order never depends on
  // the folder's listing order.
  std::sort(found.begin(), found.end());
  std::vector<std::filesystem::path> paths;
  for (auto& [frame, path] : found) paths.push_back(std::move(path));
  return paths;
}

void write_checkpoint(const std::filesystem::path& path, const Checkpoint& cp) {
  write_file_atomic(path, [&](std::ostream& os) {
    Writer w{os, {}};
    w.raw(kMagic, sizeof kMagic);
    w(cp.scene_toml.empty() ? scene_to_toml(cp.scene) : cp.scene_toml);
    w(cp.model_fingerprint, cp.frame, cp.total_steps, cp.wall_seconds);
    w(cp.state);
    const std::uint64_t sum = w.checksum.h;  // a copy: writing it feeds the checksum
    w(sum);
    w.raw(kMagic, sizeof kMagic);  // end marker: a file cut short fails to load
  }, true, Durability::synced);  // a resume depends on it: on the disk before the older ones are removed
}

Checkpoint read_checkpoint(const std::filesystem::path& path, bool picked) {
  files::require_regular_file(path, "a checkpoint",
                              "pass the output folder of a run started with --checkpoint-every N");
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw Error(fmt::format("cannot open checkpoint '{}': {}; pass the output folder of a run started with "
                            "--checkpoint-every N",
                            path.string(), std::strerror(errno)));
  // The header first, from the first 16 bytes: a file that is no checkpoint (2 GB of anything) is
  // refused without being read whole (it took 18 s and 4 GB).
  char head[16] = {};
  in.read(head, sizeof head);
  // (A file of a checkpoint's name that is none: a resume takes the newest name, so it must go.)
  const auto not_one = [&] {
    return Error(fmt::format("'{}' is not an mca checkpoint (bad header): {}", path.string(),
                             picked ? "move it out of its folder, or remove it, to use the checkpoint before it"
                                    : "give a .mcack file that mca wrote (a checkpoint of mca run or "
                                      "Simulation.checkpoint)"));
  };
  if (in.gcount() < static_cast<std::streamsize>(sizeof head) || std::memcmp(head, kMagicPrefix, sizeof kMagicPrefix) != 0)
    throw not_one();
  if (head[7] != kMagic[7]) {
    if (head[7] < '0' || head[7] > '9') throw not_one();
    throw Error(fmt::format("checkpoint '{}' has format {} and this mca reads format {}; resume the run with the "
                            "mca that wrote it, or start the run again",
                            path.string(), head[7], kMagic[7]));
  }
  // Its end marker and its size before it is read whole: a file of the name that is something else, 20 GB
  // behind a checkpoint's header, took 27 s and the machine's memory to be refused.
  in.seekg(0, std::ios::end);
  const auto size = static_cast<std::uint64_t>(in.tellg());
  char tail[sizeof kMagic] = {};
  if (size >= sizeof head + sizeof tail) {
    in.seekg(static_cast<std::streamoff>(size - sizeof tail));
    in.read(tail, sizeof tail);
  }
  if (!in || std::memcmp(tail, kMagic, sizeof kMagic) != 0) damaged_checkpoint(path, no_end_marker(size));
  if (const double machine = machine_memory_bytes(); machine > 0 && static_cast<double>(size) > 0.9 * machine)
    throw Error(fmt::format("checkpoint '{}' holds {:.1f} GB, more than this machine's memory can read back ({:.1f} "
                            "GB): resume it on a larger machine, or, if it is no checkpoint of this run, remove it to "
                            "resume from the one before",
                            path.string(), static_cast<double>(size) / 1e9, machine / 1e9));
  in.seekg(0);
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  Reader r{data, path};
  // The checksum first: a damaged byte anywhere is reported as damage, before anything is parsed.
  constexpr std::size_t kTail = sizeof(std::uint64_t) + sizeof kMagic;
  if (data.size() < sizeof kMagic + kTail) r.damaged("truncated");
  Fnv1a sum;
  sum.bytes(data.data(), data.size() - kTail);
  std::uint64_t stored = 0;
  std::memcpy(&stored, data.data() + data.size() - kTail, sizeof stored);
  if (std::memcmp(data.data() + data.size() - sizeof kMagic, kMagic, sizeof kMagic) != 0)  // (changed meanwhile)
    r.damaged(no_end_marker(data.size()));
  if (stored != sum.h) r.damaged("its checksum does not match its contents");
  r.at = sizeof kMagic;
  Checkpoint cp;
  r(cp.scene_toml);
  r(cp.model_fingerprint, cp.frame, cp.total_steps, cp.wall_seconds);
  r(cp.state);
  std::uint64_t checksum = 0;
  r(checksum);
  r.need(sizeof kMagic);
  if (std::memcmp(data.data() + r.at, kMagic, sizeof kMagic) != 0) r.damaged("no end marker");
  if (r.at + sizeof kMagic != data.size())
    r.damaged(fmt::format("{} bytes after the end marker", data.size() - r.at - sizeof kMagic));
  // Parsed last: a damaged state is reported as such, not as a scene error.
  cp.scene = parse_scene(cp.scene_toml, path.string() + " (embedded scene)");
  return cp;
}

SolverDef::Backend check_checkpoint_scene(const Checkpoint& cp, const std::filesystem::path& checkpoint,
                                          const std::filesystem::path& run_dir) {
  const std::filesystem::path own = run_dir / "scene.toml";
  const std::string fix = fmt::format(
      "resume it in the folder of the run that wrote it, or remove it from {} (and start this folder's run again "
      "if no checkpoint of its own is left); to run its scene, start it with mca run",
      checkpoint.parent_path().string());
  std::error_code ec;
  if (!std::filesystem::is_regular_file(own, ec)) {
    const std::string kind = files::non_regular_kind(own);
    throw Error(fmt::format("checkpoint '{}': {} {}, so the folder's scene is unknown and the checkpoint "
                            "cannot be told to be this run's (mca run writes scene.toml into every run folder); "
                            "restore scene.toml, or {}",
                            checkpoint.string(), own.string(),
                            kind.empty() ? "is missing" : fmt::format("is {}, not the run's scene file", kind), fix));
  }
  // Both as the writer gives them back: every key, in one order, numbers in their shortest form. Where the
  // step runs is not the scene (every backend continues a checkpoint with the same bits; a run resumed on
  // another backend writes that one into its checkpoints).
  SceneDef own_scene = load_scene_file(own), cp_scene = cp.scene;
  const SolverDef::Backend own_backend = own_scene.solver.backend;
  own_scene.solver.backend = cp_scene.solver.backend = SolverDef::Backend::automatic;
  const std::string mine = scene_to_toml(own_scene);
  const std::string theirs = scene_to_toml(cp_scene);
  if (mine == theirs) return own_backend;
  std::size_t a = 0, b = 0;
  std::string line_mine, line_theirs, section;
  for (;;) {
    const std::size_t ea = mine.find('\n', a), eb = theirs.find('\n', b);
    line_mine = mine.substr(a, ea == std::string::npos ? std::string::npos : ea - a);
    line_theirs = theirs.substr(b, eb == std::string::npos ? std::string::npos : eb - b);
    if (line_mine != line_theirs || ea == std::string::npos || eb == std::string::npos) break;
    if (!line_mine.empty() && line_mine[0] == '[') section = line_mine;
    a = ea + 1;
    b = eb + 1;
  }
  const auto shown = [](const std::string& l) { return l.empty() ? std::string("(nothing)") : "'" + l + "'"; };
  throw Error(fmt::format("checkpoint '{}' is of another scene than this run folder's {}: {}{} there, {} in the "
                          "checkpoint; {}",
                          checkpoint.string(), own.string(), section.empty() ? "" : "in " + section + ", ",
                          shown(line_mine), shown(line_theirs), fix));
}

}  // namespace mca::io
