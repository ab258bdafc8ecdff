// File-system faults for tests, at one file each, loaded into mca with LD_PRELOAD (root or not: the tests
// run as either). Everything else goes to the C library.
// - A full disk: rename() of a temporary file (".tmp") onto a path that ends in $MCA_TEST_FULL_AT fails with
//   ENOSPC, as the rename of a file written to a full disk would (mca writes every output to a temporary
//   name, then renames it); a file set aside going back to its name is no new data and goes through.
// - A file that cannot be removed, as an immutable one (chattr +i) or one in a folder the user may not
//   write: rename() from, and remove() or unlink() of, a path that ends in $MCA_TEST_PINNED_AT fail with EPERM.
#include <dlfcn.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

namespace {
bool ends_in(const char* path, const char* variable) {
  const char* at = std::getenv(variable);
  if (!path || !at || !*at) return false;
  const std::size_t n = std::strlen(path), m = std::strlen(at);
  return n >= m && std::strcmp(path + n - m, at) == 0;
}

template <class F>
F next(const char* name) {
  return reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

// Whether `path` is the pinned file (errno set to EPERM where it is).
bool pinned(const char* path) {
  if (!ends_in(path, "MCA_TEST_PINNED_AT")) return false;
  errno = EPERM;
  return true;
}
}  // namespace

extern "C" int rename(const char* from, const char* to) {
  static const auto real = next<int (*)(const char*, const char*)>("rename");
  const std::size_t n = from ? std::strlen(from) : 0;
  if (ends_in(to, "MCA_TEST_FULL_AT") && n > 4 && std::strcmp(from + n - 4, ".tmp") == 0) {
    errno = ENOSPC;
    return -1;
  }
  return pinned(from) ? -1 : real(from, to);
}

extern "C" int remove(const char* path) {
  static const auto real = next<int (*)(const char*)>("remove");
  return pinned(path) ? -1 : real(path);
}

extern "C" int unlink(const char* path) {
  static const auto real = next<int (*)(const char*)>("unlink");
  return pinned(path) ? -1 : real(path);
}
