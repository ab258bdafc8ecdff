#include "io/output_files.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <system_error>

#include "mca/error.hpp"

namespace mca::io {

namespace fs = std::filesystem;

void prepare_output_dir(const fs::path& dir) {
  const auto fail = [&](const std::string& reason) {
    return Error(fmt::format(
        "output folder '{}' is not usable: {}; choose another --out folder or fix its permissions",
        dir.string(), reason));
  };

  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw fail(ec.message());
  if (!fs::is_directory(dir, ec)) throw fail("it exists and is not a folder");

  // Permission bits do not tell the whole story (read-only mounts, ACLs, quotas), so try a real file.
  const fs::path probe = dir / ".mca_write_probe";
  {
    std::ofstream out(probe, std::ios::binary | std::ios::trunc);
    if (!out) throw fail(std::strerror(errno));
    out << "probe";
    out.flush();
    if (!out) {
      const std::string reason = std::strerror(errno);
      out.close();
      fs::remove(probe, ec);
      throw fail(reason);
    }
  }
  if (!fs::remove(probe, ec) || ec) throw fail(ec ? ec.message() : "could not remove a probe file");
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

void write_file_atomic(const fs::path& path, const std::function<void(std::ostream&)>& write,
                       bool binary) {
  fs::path tmp = path;
  tmp += ".tmp";

  const auto discard_tmp = [&] {
    std::error_code ignored;
    fs::remove(tmp, ignored);
  };
  const auto fail = [&](const std::string& reason, bool io_failure = true) {
    discard_tmp();
    return Error(fmt::format("could not write '{}': {}{}", path.string(), reason,
                             io_failure ? "; check free disk space and the --out folder" : ""));
  };

  std::ofstream out;
  const auto mode = std::ios::out | std::ios::trunc | (binary ? std::ios::binary : std::ios::openmode{});
  out.open(tmp, mode);
  if (!out) throw fail(fmt::format("cannot create '{}': {}", tmp.string(), std::strerror(errno)));

  try {
    write(out);
  } catch (const std::exception& e) {
    out.close();
    throw fail(e.what(), false);
  } catch (...) {
    out.close();
    discard_tmp();
    throw;
  }

  out.flush();
  if (!out) {
    const std::string reason = std::strerror(errno);
    out.close();
    throw fail(fmt::format("writing failed ({})", reason));
  }
  // close() writes out the last buffered bytes; a full disk can surface only here.
  out.close();
  if (!out) throw fail(fmt::format("closing failed ({})", std::strerror(errno)));

  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) throw fail(fmt::format("cannot rename '{}' onto it: {}", tmp.string(), ec.message()));
}

}  // namespace mca::io
