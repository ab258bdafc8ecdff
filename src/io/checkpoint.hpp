#pragma once
// Checkpoints: the scene (as TOML) and the full state, links and contact histories included, so that
// a resumed run ends bitwise equal to an uninterrupted one.
#include <cstdint>
#include <filesystem>
#include <string>

#include "core/state.hpp"
#include "mca/scene.hpp"

namespace mca::io {

struct Checkpoint {
  SceneDef scene;
  State state;
  std::int64_t frame = 0;       // frames written so far (the next frame to write is this one)
  std::int64_t total_steps = 0;  // steps the run is to reach
  double wall_seconds = 0;      // wall time spent before the checkpoint
  std::string scene_toml;
};

void write_checkpoint(const std::filesystem::path& path, const Checkpoint& cp);
// Throws mca::Error naming the file when it is missing, truncated or not a checkpoint.
Checkpoint read_checkpoint(const std::filesystem::path& path);

}  // namespace mca::io
