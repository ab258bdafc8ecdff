#include "core/environment.hpp"

#include <cstdlib>
#include <string_view>

#include <fmt/format.h>

#include "mca/error.hpp"

namespace mca {

bool profile_requested() {
  const char* env = std::getenv("MCA_PROFILE");
  const std::string_view v = env ? env : "";
  if (v.empty() || v == "0") return false;
  if (v == "1") return true;
  throw Error(fmt::format("MCA_PROFILE = '{}': give 1 (print the time of each pass of the step when the backend "
                          "ends) or 0, or unset it",
                          v));
}

}  // namespace mca
