#pragma once
// User-facing errors. Thrown at the edges (scene parsing, model building, the command line, output
// folders), and from inside a step only where the machine refuses it (a GPU whose memory is full). The message names the file, the key, the bad value and
// the fix; the command prints it and exits non-zero.
#include <stdexcept>
#include <string>

namespace mca {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace mca
