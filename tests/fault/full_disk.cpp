// A full disk for tests, at one file: loaded into mca with LD_PRELOAD, it makes rename() onto a path that
// ends in $MCA_TEST_FULL_AT fail with ENOSPC, as the rename of a file written to a full disk would (mca
// writes every output to a temporary name, then renames it). Everything else goes to the C library.
#include <dlfcn.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

extern "C" int rename(const char* from, const char* to) {
  using Rename = int (*)(const char*, const char*);
  static const Rename real = reinterpret_cast<Rename>(dlsym(RTLD_NEXT, "rename"));
  const char* at = std::getenv("MCA_TEST_FULL_AT");
  if (at && *at && to) {
    const std::size_t n = std::strlen(to), m = std::strlen(at);
    if (n >= m && std::strcmp(to + n - m, at) == 0) {
      errno = ENOSPC;
      return -1;
    }
  }
  return real(from, to);
}
