#pragma once
// Output folders and crash-safe file writes. A run may be interrupted at any moment (Ctrl-C, a killed
// job, a full disk); readers such as ParaView must then see either the previous complete file or none,
// never a truncated one, so every output goes to a temporary name first and is renamed into place.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace mca::io {

// Creates `dir` (with parents) and proves it is writable by creating and removing a probe file, so a
// bad --out folder fails before the simulation spends any time. Throws mca::Error naming the folder.
void prepare_output_dir(const std::filesystem::path& dir);

// The folders `names` (of frames, surface, fragments, checkpoints, render) that a run will write into inside
// its output folder: one that is there as something else (a file named `frames`) is refused, naming it and
// the fix, before anything is written. Found late, it stopped a run partway, with no checkpoint, in a raw
// error. Every one of those subfolders that is a symbolic link is refused, written or not: a run clears an
// earlier run's files out of each, and would remove and write files outside its output folder through it.
void check_output_subfolders(const std::filesystem::path& dir, const std::vector<std::string>& names);
// That check of links alone, made again before each frame's files are written (a subfolder made a link
// while the run went on).
void check_no_linked_subfolders(const std::filesystem::path& dir);
// Refuses a file the run reads (`inputs`: what names it, such as "object[0].mesh", and its path) that lies
// in a subfolder of `dir` the run writes and clears (frames, surface, fragments, checkpoints, render): the
// run would remove or overwrite its own input (a fragment mesh of an earlier run given as the mesh was
// read, then written over).
void check_inputs_outside_subfolders(const std::filesystem::path& dir,
                                     const std::vector<std::pair<std::string, std::string>>& inputs);
// `dir / name`, made where it is missing; mca::Error naming it, what goes there and the fix where it
// cannot be (a file of that name, permissions).
std::filesystem::path output_subfolder(const std::filesystem::path& dir, const std::string& name);

// Holds the output folder's lock (flock on the folder itself, no file added) for its lifetime: a second
// mca run or resume into the same folder is refused while one writes there (two runs at once mixed their
// frames, stats and summaries, and both exited 0). Throws mca::Error naming the folder.
class OutputLock {
 public:
  explicit OutputLock(const std::filesystem::path& dir);
  ~OutputLock();
  OutputLock(const OutputLock&) = delete;
  OutputLock& operator=(const OutputLock&) = delete;

 private:
  int fd_ = -1;
};

// The folder name for a scene's default output folder out/<folder>. A scene file can come from anywhere,
// so its name must not choose where a run writes (and deletes earlier outputs).
std::string scene_folder_name(const std::string& scene_name);

enum class Durability {
  // Renamed into place: readers never see a half file; a power loss may lose the newest writes.
  renamed,
  // Also flushed to the disk (fsync of the file before the rename, of its folder after): once the call
  // returns the file survives a power loss. Costs a disk flush per file; used for checkpoints.
  synced,
};

// Calls `write` on a stream to a temporary file in the same folder (rename is atomic only within one
// file system), flushes and checks the stream, then renames onto `path`. The temporary name is
// `path` + ".<pid>.<n>.tmp", unique per process and call, so writers of one file in several processes
// or threads never share one. On any failure, including an exception from `write`, the temporary file
// is removed and mca::Error naming `path` is thrown; an existing file at `path` is then left untouched.
void write_file_atomic(const std::filesystem::path& path,
                       const std::function<void(std::ostream&)>& write, bool binary = true,
                       Durability durability = Durability::renamed);

// What to do about a write that failed with the error number `err`, after "; ": free disk space (a full disk
// or quota), a read-only file system, a folder at the file's name, or the output folder in general.
std::string write_failure_fix(int err);

// A temporary name for `path` in the same folder, as write_file_atomic uses: `path` + ".<pid>.<n>.tmp". For
// files written by another program (the video, by ffmpeg) and renamed into place by the caller; with another
// `suffix`, StagedRemoval's names of files set aside.
std::filesystem::path temporary_path(const std::filesystem::path& path, std::string_view suffix = ".tmp");

// Removes the temporary files write_file_atomic left in `dir` (not below) for the outputs of a run
// (.vtu, .vtp, .pvd, .csv, .json, .toml, .mcack, .ply, .obj, .png, .mp4) when their process is gone (a killed run), and
// prepare_output_dir's write probes; those of running processes and every other file stay. A missing folder
// is fine.
void remove_stale_temporaries(const std::filesystem::path& dir);

// Where `p` is a marker StagedRemoval::will_write makes (NAME.<pid>.<n>.mca-new, an empty regular file: a
// link, a folder or a file with something in it is not one, whatever its name), the NAME it marks; else "".
std::string marked_name(const std::filesystem::path& p);
// The NAME of a marker's file name NAME.<pid>.<n>.mca-new, by the name alone (else "").
std::string marker_of(const std::string& name);

// What a killed session had set aside (StagedRemoval) in `root` and its `folders`, of the names `ours(folder,
// name)` takes for a run's: put back at their names (over what it had written there) where it was killed
// before it began to remove them, else removed (its marker there, also where a removal had failed); a file
// it wrote where the earlier run had none (its NAME.<pid>.<n>.mca-new beside it) goes too where it was killed
// before it began. For a session to call first, under the folder's lock; mca::Error naming a file it can put
// back or remove neither.
struct SetAsideFound {
  std::size_t restored = 0, removed = 0;
  std::size_t withdrawn = 0;  // files it had written where the earlier run had none, removed
};
SetAsideFound put_back_set_aside(const std::filesystem::path& root, const std::vector<std::string>& folders,
                                 const std::function<bool(const std::string& folder, const std::string& name)>& ours);

// The number of a file named as a run numbers its outputs, `prefix` + 1 to 18 digits + `extension`
// (automata_000012.vtu: 12); none for any other name (automata_mine.vtu).
std::optional<std::int64_t> numbered(const std::string& name, std::string_view prefix, std::string_view extension);

// The files of an earlier session that a session removes, removed all or none: each is first renamed to a
// name beside it (its own + ".<pid>.<n>.mca-aside"), and removed only at commit(). Where one cannot be (a
// read-only folder, an immutable file), those set aside go back to their names and an mca::Error names it;
// so does the destructor put them back when the session stops before commit() (a
// renderer that cannot start, a scene file that cannot be written, a stop signal), and remove the files
// the session wrote meanwhile (will_write()). A session killed before commit() leaves them for the next
// (put_back_set_aside); one killed in it, a marker in `root` (the output folder) that says to remove them.
class StagedRemoval {
 public:
  explicit StagedRemoval(std::filesystem::path root) : root_(std::move(root)) {}
  StagedRemoval(const StagedRemoval&) = delete;
  StagedRemoval& operator=(const StagedRemoval&) = delete;
  ~StagedRemoval() { restore(); }
  // Sets `p` aside where it is there (a path through a file, as a file named `render`, holds nothing);
  // returns whether it was. A folder that holds files is refused: it could not be removed.
  bool stage(const std::filesystem::path& p);
  // A file the session is about to write before commit() (its scene file, render.json): removed by
  // restore(). Where the earlier run had none at that name, a marker NAME.<pid>.<n>.mca-new beside it says so
  // until commit(), so that a session killed before then has it removed by the next (put_back_set_aside).
  void will_write(const std::filesystem::path& p);
  // Removes what was set aside (one that cannot be removed now is removed by the next session: the marker
  // that says so stays).
  void commit();
  // Removes what the session wrote and puts what was set aside back at its name, the last first.
  void restore() noexcept;

 private:
  std::filesystem::path root_;
  std::vector<std::pair<std::filesystem::path, std::filesystem::path>> staged_;  // (name, temporary name)
  std::vector<std::filesystem::path> written_;
  std::vector<std::filesystem::path> new_markers_;
};

}  // namespace mca::io
