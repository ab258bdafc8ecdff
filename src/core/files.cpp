#include "core/files.hpp"

#include <fmt/format.h>

#include "mca/error.hpp"

namespace mca::files {

std::string non_regular_kind(const std::filesystem::path& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status s = fs::status(path, ec);  // follows symbolic links; no open, so a FIFO cannot block
  switch (s.type()) {
    case fs::file_type::regular:
    case fs::file_type::not_found:
      return "";
    case fs::file_type::directory: return "a directory";
    case fs::file_type::fifo: return "a FIFO (named pipe)";
    case fs::file_type::character: return "a character device";
    case fs::file_type::block: return "a block device";
    case fs::file_type::socket: return "a socket";
    default:
      // A path that cannot be examined (a folder on the way without permission) is left to its reader,
      // whose open reports the reason.
      if (ec) return "";
      return "a file of an unknown kind";
  }
}

void require_regular_file(const std::filesystem::path& path, std::string_view what, std::string_view fix) {
  const std::string kind = non_regular_kind(path);
  if (kind.empty()) return;
  throw Error(fmt::format("{}: is {}, not {} (mca reads only regular files); {}", path.string(), kind, what, fix));
}

}  // namespace mca::files
