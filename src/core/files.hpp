#pragma once
// Input files must be regular files: a FIFO blocks the reader until something writes to it (forever, from
// a scene path typed by mistake), a device such as /dev/zero never ends, a directory or socket cannot be
// read. Every reader of a file named by the user (scene, mesh, checkpoint, `mca view --script`) asks here
// first, so they refuse such paths alike.
#include <filesystem>
#include <string>
#include <string_view>

namespace mca::files {

// What `path` is when it exists and is not a regular file (symbolic links followed): "a directory",
// "a FIFO (named pipe)", "a character device", "a block device", "a socket" or "a file of an unknown kind";
// "" for a regular file or a path that does not exist (its reader reports that in its own words).
std::string non_regular_kind(const std::filesystem::path& path);

// Throws mca::Error "<path>: is <kind>, not <what> (mca reads only regular files); <fix>" when
// non_regular_kind(path) is not empty.
void require_regular_file(const std::filesystem::path& path, std::string_view what, std::string_view fix);

}  // namespace mca::files
