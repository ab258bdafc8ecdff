#pragma once
// The text of mca's JSON outputs (summary.json, render.json, mca info --json, mca bench --json).
#include <nlohmann/json.hpp>
#include <string>

namespace mca::io {

// `j` indented by 2. A string that is not UTF-8 (a path of a file system that takes any bytes, a scene
// file's among them) is written with U+FFFD in place of its bad bytes: nlohmann's dump threw, and a run
// that had taken every step failed to write its summary.json.
inline std::string json_text(const nlohmann::json& j) {
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace mca::io
