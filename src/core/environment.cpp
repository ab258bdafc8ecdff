#include "core/environment.hpp"

#include <cstdlib>
#include <string_view>
#include <unistd.h>

#include <fmt/format.h>

#include "mca/error.hpp"

namespace mca {

namespace {
// An on/off variable: unset, empty or 0 off, 1 on; anything else an mca::Error naming it and what 1 does.
bool switched_on(const char* name, const char* what_one_does) {
  const char* env = std::getenv(name);
  const std::string_view v = env ? env : "";
  if (v.empty() || v == "0") return false;
  if (v == "1") return true;
  throw Error(fmt::format("{} = '{}': give 1 ({}) or 0, or unset it", name, v, what_one_does));
}
}  // namespace

bool profile_requested() {
  return switched_on("MCA_PROFILE", "print the time of each pass of the step when the backend ends");
}

bool cuda_sync_requested() {
  return switched_on("MCA_CUDA_SYNC", "the CUDA backend waits for each kernel, so that an error names the kernel");
}

double machine_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? static_cast<double>(pages) * static_cast<double>(size) : 0.0;
}

MemoryLimit memory_limit(double setting_bytes) {
  const double machine = machine_memory_bytes();  // (0 where it cannot tell)
  if (machine > 0 && 0.9 * machine < setting_bytes)
    return {0.9 * machine,
            fmt::format("more than the {:.1f} GB a run may take of this machine's {:.1f} GB (90 %)", 0.9 * machine / 1e9,
                        machine / 1e9),
            "run it on a larger machine"};
  return {setting_bytes, fmt::format("over solver.max_memory_gb = {:g}", setting_bytes / 1e9),
          "raise solver.max_memory_gb if the machine has it"};
}

}  // namespace mca
