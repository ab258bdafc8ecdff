#include "io/output_files.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <fstream>
#include <sys/file.h>
#include <limits>
#include <string_view>
#include <system_error>
#include <unistd.h>
#include <utility>
#include <vector>

#include "core/text.hpp"
#include "mca/error.hpp"

namespace mca::io {

namespace fs = std::filesystem;

OutputLock::OutputLock(const std::filesystem::path& dir) {
  fd_ = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd_ < 0) throw Error(fmt::format("cannot open the output folder '{}': {}", dir.string(), std::strerror(errno)));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    ::close(fd_);
    fd_ = -1;
    if (e == EWOULDBLOCK) {
      throw Error(fmt::format("another mca run or resume is writing into '{}' (it holds the folder's lock); wait for "
                              "it to end, or give another output folder (--out)",
                              dir.string()));
    }
    throw Error(fmt::format("cannot lock the output folder '{}': {}", dir.string(), std::strerror(e)));
  }
}

OutputLock::~OutputLock() {
  if (fd_ >= 0) ::close(fd_);
}

void prepare_output_dir(const fs::path& dir) {
  const auto fail = [&](const std::string& reason) {
    return Error(fmt::format(
        "output folder '{}' is not usable: {}; choose another output folder (--out) or fix its permissions",
        dir.string(), reason));
  };

  std::error_code ec;
  // A link to a folder not made yet (a scratch disk's): "File exists" said neither. (Given with a trailing
  // separator, the link is the name without it.)
  const fs::path link = dir.has_filename() || !dir.has_parent_path() ? dir : dir.parent_path();
  if (fs::is_symlink(fs::symlink_status(link, ec)) && !fs::exists(link, ec) && !ec) {  // (a loop sets ec)
    // The folder to make is where the chain of links ends.
    fs::path end = link;
    for (int hops = 0; hops < 40 && fs::is_symlink(fs::symlink_status(end, ec)); ++hops) {
      const fs::path target = fs::read_symlink(end, ec);
      if (ec) break;
      end = target.is_absolute() ? target : (end.parent_path() / target).lexically_normal();
    }
    throw fail(fmt::format("it is a symbolic link to '{}', which does not exist; make that folder first (mkdir -p {})",
                           fs::read_symlink(link, ec).string(),
                           text::shell_word(end.is_absolute() ? end.string() : "./" + end.string())));
  }
  fs::create_directories(dir, ec);
  if (ec) throw fail(ec.message());
  if (!fs::is_directory(dir, ec)) throw fail("it exists and is not a folder");

  // Permission bits do not tell the whole story (read-only mounts, ACLs, quotas), so try a real file: a new
  // one of this process's name, never through a link there (one to a user's file was emptied and written).
  const fs::path probe = dir / fmt::format(".mca_write_probe.{}", ::getpid());
  fs::remove(probe, ec);  // (a link itself, not what it points at)
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) throw fail(std::strerror(errno));
  const bool written = ::write(fd, "probe", 5) == 5;
  const int err = errno;
  ::close(fd);
  if (!written) {
    fs::remove(probe, ec);
    throw fail(std::strerror(err));
  }
  if (!fs::remove(probe, ec) || ec) throw fail(ec ? ec.message() : "could not remove a probe file");
}

namespace {
// What a run writes into each of its subfolders, for messages.
constexpr std::pair<const char*, const char*> kSubfolders[] = {
    {"frames", "the VTK frames"},          {"surface", "the bound surface's frames"},
    {"fragments", "the fragments' meshes"}, {"checkpoints", "its checkpoints"},
    {"render", "the rendered frames"}};

std::string subfolder_use(const std::string& name) {
  for (const auto& [n, use] : kSubfolders)
    if (name == n) return use;
  return "its files";
}
}  // namespace

void check_no_linked_subfolders(const fs::path& dir) {
  for (const auto& [name, use] : kSubfolders) {
    std::error_code ec;
    const fs::path sub = dir / name;
    if (fs::is_symlink(fs::symlink_status(sub, ec))) {
      const fs::path target = fs::read_symlink(sub, ec);
      throw Error(fmt::format("'{}' is a symbolic link{}: a run writes {} there and removes an earlier run's, and it "
                              "writes and removes nothing outside its output folder; replace the link with a folder, "
                              "or give the run an output folder there (--out)",
                              sub.string(), ec ? std::string() : fmt::format(" (to '{}')", target.string()), use));
    }
  }
}

void check_inputs_outside_subfolders(const fs::path& dir,
                                     const std::vector<std::pair<std::string, std::string>>& inputs) {
  for (const auto& [key, path] : inputs) {
    std::error_code ec;
    const fs::path file = fs::weakly_canonical(path, ec);
    if (ec) continue;
    for (const auto& [name, use] : kSubfolders) {
      const fs::path sub = fs::weakly_canonical(dir / name, ec);
      if (ec) continue;
      const auto rel = file.lexically_relative(sub);
      if (rel.empty() || *rel.begin() == "..") continue;
      throw Error(fmt::format("{} = '{}' lies in '{}', where the run writes {} and removes an earlier run's: it would "
                              "remove or overwrite the file it reads; copy the file out of the output folder and give "
                              "that path, or give the run another output folder (--out)",
                              key, path, (dir / name).string(), use));
    }
  }
}

void check_output_subfolders(const fs::path& dir, const std::vector<std::string>& names) {
  // A run clears an earlier run's files out of every subfolder, whatever it writes itself: a subfolder
  // that is a symbolic link would have it remove and write files outside the output folder.
  check_no_linked_subfolders(dir);
  for (const std::string& name : names) {
    std::error_code ec;
    const fs::path sub = dir / name;
    if (fs::exists(fs::symlink_status(sub, ec)) && !fs::is_directory(sub, ec)) {
      throw Error(fmt::format("'{}' is there and is not a folder: the run writes {} into a folder of that name; move "
                              "or remove it",
                              sub.string(), subfolder_use(name)));
    }
  }
}

fs::path output_subfolder(const fs::path& dir, const std::string& name) {
  const fs::path sub = dir / name;
  std::error_code ec;
  fs::create_directories(sub, ec);
  if (ec || !fs::is_directory(sub)) {
    throw Error(fmt::format("cannot make the folder '{}' for {}: {}; move or remove what is there",
                            sub.string(), subfolder_use(name),
                            ec ? ec.message() : std::string("it is there and is not a folder")));
  }
  return sub;
}

std::string scene_folder_name(const std::string& scene_name) {
  // Only characters that mean nothing to a path or a shell survive; every other character becomes '_'
  // (one per UTF-8 character, not per byte, so "béton" reads as "b_ton"). A leading '.' would give a
  // hidden folder or "."/".." (the output folder's parent), a leading '-' an option: both become '_'.
  constexpr std::size_t kMaxLength = 100;  // well under the 255 bytes of a file name
  std::string folder;
  for (const char ch : scene_name) {
    if (folder.size() == kMaxLength) break;
    const auto c = static_cast<unsigned char>(ch);
    if ((c & 0xC0) == 0x80) continue;  // a UTF-8 continuation byte: its character already gave '_'
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
                       c == '-' || c == '.';
    folder += plain ? ch : '_';
  }
  for (char& c : folder) {
    if (c != '.' && c != '-') break;
    c = '_';
  }
  return folder.empty() ? "scene" : folder;
}

namespace {

bool all_digits(std::string_view t) {
  return !t.empty() && t.size() <= 18 && std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// A name of temporary_path's form, "<name>.<pid>.<n><suffix>": its name and pid.
struct Owned {
  std::string name;
  long pid = 0;
};
std::optional<Owned> owned_name(const std::string& name, std::string_view suffix) {
  if (!name.ends_with(suffix)) return std::nullopt;
  const std::string stem = name.substr(0, name.size() - suffix.size());
  const auto counter_dot = stem.rfind('.');
  if (counter_dot == std::string::npos || counter_dot == 0 || !all_digits(stem.substr(counter_dot + 1)))
    return std::nullopt;
  const auto pid_dot = stem.rfind('.', counter_dot - 1);
  if (pid_dot == std::string::npos || pid_dot == 0) return std::nullopt;
  const std::string pid = stem.substr(pid_dot + 1, counter_dot - pid_dot - 1);
  if (!all_digits(pid)) return std::nullopt;
  return Owned{stem.substr(0, pid_dot), std::stol(pid)};
}

// "<name>.<pid>.<n>.tmp" -> pid, or 0 when the name is not one of write_file_atomic's temporaries.
long temporary_owner(const std::string& name) {
  const auto owned = owned_name(name, ".tmp");
  if (!owned) return 0;
  // Only temporaries of the files a run writes: a user's "notes.2024.01.tmp" is left alone.
  static const std::string_view ours[] = {".vtu", ".vtp", ".pvd", ".csv", ".json", ".toml", ".mcack", ".ply", ".obj", ".png", ".mp4"};
  if (std::none_of(std::begin(ours), std::end(ours), [&](std::string_view ext) {
        return owned->name.size() > ext.size() && owned->name.ends_with(ext);
      }))
    return 0;
  return owned->pid;
}

// fsync of a file or folder by path (a stream does not expose its descriptor).
void sync_path(const fs::path& p, bool folder) {
  const int fd = ::open(p.c_str(), O_RDONLY | O_CLOEXEC | (folder ? O_DIRECTORY : 0));
  if (fd < 0) throw std::system_error(errno, std::generic_category(), "open " + p.string());
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) throw std::system_error(err, std::generic_category(), "fsync " + p.string());
}

}  // namespace

namespace {
// kill(pid, 0) fails with ESRCH only when no such process exists (a pid reused since is taken as alive: its
// files are left, which is safe).
bool gone(long pid) {
  return pid > 0 && (pid > std::numeric_limits<pid_t>::max() ||
                     (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH));
}

// StagedRemoval's names: a file set aside is NAME.<pid>.<n>.mca-aside beside it; the output folder holds
// .mca-committing.<pid> while a session removes what it set aside.
constexpr std::string_view kAside = ".mca-aside", kNew = ".mca-new", kCommitting = ".mca-committing.",
                           kProbe = ".mca_write_probe.";

// "NAME.<pid>.<n><suffix>" -> NAME, or "" for any other name.
std::string owner_of(const std::string& name, std::string_view suffix) {
  const auto owned = owned_name(name, suffix);
  return owned ? owned->name : "";
}
}  // namespace

std::string marker_of(const std::string& name) { return owner_of(name, kNew); }

std::string marked_name(const fs::path& p) {
  std::string name = marker_of(p.filename().string());
  if (name.empty()) return "";
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(p, ec);
  return !ec && fs::is_regular_file(status) && fs::file_size(p, ec) == 0 && !ec ? name : "";
}

void remove_stale_temporaries(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return;
  std::vector<fs::path> doomed;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    // (A write probe of prepare_output_dir, left by a session killed at it, too.)
    const long probe = name.starts_with(kProbe) && all_digits(name.substr(kProbe.size()))
                           ? std::stol(name.substr(kProbe.size()))
                           : 0;
    if ((gone(temporary_owner(name)) || gone(probe)) && e.is_regular_file(ec)) doomed.push_back(e.path());
  }
  for (const auto& p : doomed) fs::remove(p, ec);
}

SetAsideFound put_back_set_aside(const fs::path& root, const std::vector<std::string>& folders,
                                 const std::function<bool(const std::string&, const std::string&)>& ours) {
  SetAsideFound found;
  std::error_code ec;
  // Sessions take the folder's lock first and call this before anything else, so what is set aside here is
  // a killed session's (whatever its process id says: one of another pid namespace, or one reused since,
  // looks alive); one session's at most, as each session before it put back or removed its predecessor's.
  std::vector<fs::path> markers;
  for (const auto& e : fs::directory_iterator(root, ec))
    if (const std::string name = e.path().filename().string();
        name.starts_with(kCommitting) && all_digits(name.substr(kCommitting.size())))
      markers.push_back(e.path());
  const bool committing = !markers.empty();
  // Removes `p` (", " + what it is, for the message), or stops the session naming it.
  const auto remove_or_stop = [&](const fs::path& p, std::string_view what) {
    if (!fs::remove(p, ec) || ec)
      throw Error(fmt::format("cannot remove '{}'{} ({}); remove it by hand, then run again", p.string(), what,
                              ec ? ec.message() : "it is gone"));
  };
  std::vector<std::string> in = {""};
  in.insert(in.end(), folders.begin(), folders.end());
  for (const std::string& folder : in) {
    const fs::path d = folder.empty() ? root : root / folder;
    if (!fs::is_directory(fs::symlink_status(d, ec))) continue;  // (never through a link)
    std::vector<std::pair<fs::path, std::string>> aside, written;
    for (const auto& e : fs::directory_iterator(d, ec)) {
      const std::string name = e.path().filename().string();
      if (const std::string original = owner_of(name, kAside); !original.empty() && ours(folder, original))
        aside.emplace_back(e.path(), original);
      else if (const std::string made = marked_name(e.path()); !made.empty() && ours(folder, made))
        written.emplace_back(e.path(), made);
    }
    std::sort(aside.begin(), aside.end());
    std::sort(written.begin(), written.end());
    // What it wrote where the earlier run had none: removed where its run had not begun, then the marker.
    for (const auto& [marker, made] : written) {
      if (!committing) {
        const fs::path p = d / made;
        if (fs::exists(fs::symlink_status(p, ec))) {
          remove_or_stop(p, ", which a session stopped before its run began had written");
          ++found.withdrawn;
        }
      }
      remove_or_stop(marker, "");
    }
    // Each is put back or removed, or the session stops here: one left aside would be taken later for one
    // of a session stopped before it began, and put back over a newer run's file.
    for (const auto& [p, original] : aside) {
      if (committing) {
        // It had begun to remove them: its run had begun, and what is left of them goes.
        remove_or_stop(p, ", a file of an earlier run that a session had set aside to remove");
        ++found.removed;
      } else {
        // Stopped before: its run had not begun, and the earlier one comes back whole, over what it had
        // written at those names (its scene file).
        fs::rename(p, d / original, ec);
        if (ec)
          throw Error(fmt::format("cannot put back '{}', a file of the run in {} that a session stopped before it "
                                  "began had set aside, at its name '{}' ({}); rename it by hand (mv {} {}), then "
                                  "run again",
                                  p.string(), root.string(), original, ec.message(), text::shell_word(p.string()),
                                  text::shell_word((d / original).string())));
        ++found.restored;
      }
    }
  }
  for (const auto& m : markers) remove_or_stop(m, "");
  return found;
}

fs::path temporary_path(const fs::path& path, std::string_view suffix) {
  // The process id keeps other processes off this name, the counter other calls of this process.
  static std::atomic<std::uint64_t> counter{0};
  fs::path tmp = path;
  tmp += fmt::format(".{}.{}{}", ::getpid(), counter++, suffix);
  return tmp;
}

std::string write_failure_fix(int err) {
  switch (err) {
    case ENOSPC:
    case EDQUOT:
      return "free disk space (or quota) for the output folder";
    case EROFS:
      return "the output folder is on a read-only file system: give the run a writable one";
    case EFBIG:
      return "the file reached a size limit (the process's, ulimit -f, or the file system's)";
    case EISDIR:
      return "a folder stands at the file's name: move or remove it";
    case EACCES:
    case EPERM:
      return "check the output folder's permissions";
    default:
      return "check the disk and the output folder";
  }
}

void write_file_atomic(const fs::path& path, const std::function<void(std::ostream&)>& write,
                       bool binary, Durability durability) {
  const fs::path tmp = temporary_path(path);

  const auto discard_tmp = [&] {
    std::error_code ignored;
    fs::remove(tmp, ignored);
  };
  // err: the failure's error number (EIO where a stream failed without one), or 0 for the caller's own
  // error (no advice about the disk).
  const auto fail = [&](const std::string& reason, int err) {
    discard_tmp();
    return Error(fmt::format("could not write '{}': {}{}", path.string(), reason,
                             err ? "; " + write_failure_fix(err) : std::string()));
  };

  std::ofstream out;
  const auto mode = std::ios::out | std::ios::trunc | (binary ? std::ios::binary : std::ios::openmode{});
  out.open(tmp, mode);
  if (!out) {
    const int err = errno ? errno : EIO;
    throw fail(fmt::format("cannot create '{}': {}", tmp.string(), std::strerror(err)), err);
  }

  try {
    write(out);
  } catch (const std::exception& e) {
    out.close();
    throw fail(e.what(), 0);
  } catch (...) {
    out.close();
    discard_tmp();
    throw;
  }

  out.flush();
  if (!out) {
    const int err = errno ? errno : EIO;
    out.close();
    throw fail(fmt::format("writing failed ({})", std::strerror(err)), err);
  }
  // close() writes out the last buffered bytes; a full disk can surface only here.
  out.close();
  if (!out) {
    const int err = errno ? errno : EIO;
    throw fail(fmt::format("closing failed ({})", std::strerror(err)), err);
  }

  // The data must be on the disk before the rename is: otherwise a power loss can leave the new name
  // pointing at an empty or partial file.
  if (durability == Durability::synced) {
    try {
      sync_path(tmp, false);
    } catch (const std::system_error& e) {
      throw fail(e.what(), e.code().value());
    }
  }

  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw fail(fmt::format("cannot rename '{}' onto it: {}", tmp.string(), ec.message()), ec.value() ? ec.value() : EIO);
  if (durability == Durability::synced) {
    // The rename is an entry in the folder: only a synced folder keeps it.
    try {
      sync_path(path.has_parent_path() ? path.parent_path() : fs::path("."), true);
    } catch (const std::system_error& e) {
      throw Error(fmt::format("could not write '{}': {}; {}", path.string(), e.what(),
                              write_failure_fix(e.code().value())));
    }
  }
}

std::optional<std::int64_t> numbered(const std::string& name, std::string_view prefix, std::string_view extension) {
  if (name.size() <= prefix.size() + extension.size() || name.compare(0, prefix.size(), prefix) != 0 ||
      name.compare(name.size() - extension.size(), extension.size(), extension) != 0)
    return std::nullopt;
  const std::string_view digits(name.data() + prefix.size(), name.size() - prefix.size() - extension.size());
  // 18 digits at most: the number fits an int64 without a check.
  if (digits.size() > 18 || !std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return std::nullopt;
  std::int64_t n = 0;
  for (char c : digits) n = 10 * n + (c - '0');
  return n;
}


bool StagedRemoval::stage(const fs::path& p) {
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(p, ec);
  if (!fs::exists(status)) {
    if (!ec || ec == std::errc::no_such_file_or_directory || ec == std::errc::not_a_directory) return false;
  } else if (fs::is_directory(status) && !fs::is_empty(p, ec) && !ec) {
    ec = std::make_error_code(std::errc::directory_not_empty);
  } else {
    ec.clear();
    // (Not ".tmp": a killed session's files set aside go back to their names, where its temporaries are
    // removed; put_back_set_aside.)
    const fs::path tmp = temporary_path(p, kAside);
    fs::rename(p, tmp, ec);
    if (!ec) {
      staged_.emplace_back(p, tmp);
      return true;
    }
  }
  restore();
  throw Error(fmt::format("cannot remove '{}', an output of an earlier run in this folder ({}); nothing was removed: "
                          "remove it by hand or use another --out folder",
                          p.string(), ec.message()));
}

void StagedRemoval::will_write(const fs::path& p) {
  written_.push_back(p);
  if (std::any_of(staged_.begin(), staged_.end(), [&](const auto& s) { return s.first == p; })) return;
  // (O_EXCL: the name is this process's own; a marker that cannot be made leaves the file unmarked, as
  // before markers were.)
  const fs::path marker = temporary_path(p, kNew);
  if (const int fd = ::open(marker.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600); fd >= 0) {
    ::close(fd);
    new_markers_.push_back(marker);
  }
}

void StagedRemoval::commit() {
  std::error_code ec;
  written_.clear();
  if (staged_.empty() && new_markers_.empty()) return;
  // The marker first: a session killed among the removals leaves the rest to be removed, not put back.
  const fs::path marker = root_ / fmt::format("{}{}", kCommitting, ::getpid());
  if (const int fd = ::open(marker.c_str(), O_WRONLY | O_CREAT | O_NOFOLLOW | O_CLOEXEC, 0600); fd >= 0) ::close(fd);
  // (One that cannot be removed keeps the marker: the next session removes it, never puts it back.)
  bool all = true;
  for (const auto& [name, tmp] : staged_) all = fs::remove(tmp, ec) && !ec && all;
  // (Its markers of files new to the folder after them, under the same marker: one left would later have a
  // session remove a file of this run.)
  for (const auto& m : new_markers_) all = fs::remove(m, ec) && !ec && all;
  new_markers_.clear();
  if (all) fs::remove(marker, ec);
  staged_.clear();
}

void StagedRemoval::restore() noexcept {
  std::error_code ec;
  for (const auto& p : written_) fs::remove(p, ec);
  written_.clear();
  for (const auto& m : new_markers_) fs::remove(m, ec);
  new_markers_.clear();
  for (auto it = staged_.rbegin(); it != staged_.rend(); ++it) fs::rename(it->second, it->first, ec);
  staged_.clear();
}

}  // namespace mca::io
