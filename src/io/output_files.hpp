#pragma once
// Output folders and crash-safe file writes. A run may be interrupted at any moment (Ctrl-C, a killed
// job, a full disk); readers such as ParaView must then see either the previous complete file or none,
// never a truncated one, so every output goes to a temporary name first and is renamed into place.
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>

namespace mca::io {

// Creates `dir` (with parents) and proves it is writable by creating and removing a probe file, so a
// bad --out folder fails before the simulation spends any time. Throws mca::Error naming the folder.
void prepare_output_dir(const std::filesystem::path& dir);

// The folder name for a scene's default output folder out/<folder>. A scene file can come from anywhere,
// so its name must not choose where a run writes (and deletes earlier outputs).
std::string scene_folder_name(const std::string& scene_name);

// Calls `write` on a stream to `path` + ".tmp" in the same folder (rename is atomic only within one
// file system), flushes and checks the stream, then renames onto `path`. On any failure, including
// an exception from `write`, the temporary file is removed and mca::Error naming `path` is thrown;
// an existing file at `path` is then left untouched.
void write_file_atomic(const std::filesystem::path& path,
                       const std::function<void(std::ostream&)>& write, bool binary = true);

}  // namespace mca::io
