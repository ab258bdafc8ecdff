#pragma once
// Checkpoints: the scene (as TOML) and the full state, links and contact histories included, so that
// a resumed run ends bitwise equal to an uninterrupted one. A checkpoint file is untrusted input when it
// is read back: read_checkpoint only guarantees well-formed arrays; whether the state fits the model of
// the embedded scene is for check_state and model_fingerprint (sim/state_check.hpp) to decide.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/state.hpp"
#include "mca/scene.hpp"

namespace mca::io {

struct Checkpoint {
  SceneDef scene;
  State state;
  std::int64_t frame = 0;       // frames written so far (the next frame to write is this one)
  std::int64_t total_steps = 0;  // steps the run is to reach
  double wall_seconds = 0;      // wall time spent before the checkpoint
  std::uint64_t model_fingerprint = 0;  // model_fingerprint() of the model the state belongs to
  std::string scene_toml;
};

// "frame_NNNNNN.mcack" for the checkpoint saved after frame N: six digits, more past 999999.
std::string checkpoint_name(std::int64_t frame);
// The checkpoints (regular files named by checkpoint_name) in `dir`, oldest first by the frame number
// in their names: as text, frame_1000000 would sort before frame_999999. Other files are ignored; a
// missing folder has none.
std::vector<std::filesystem::path> list_checkpoints(const std::filesystem::path& dir);

// Equal checkpoints give byte-identical files (no padding bytes are written).
void write_checkpoint(const std::filesystem::path& path, const Checkpoint& cp);
// Throws mca::Error naming the file when it is missing, truncated, damaged, of an older format or not a
// checkpoint. Never allocates much more than the file's size, whatever its counts say. `picked`: the file is
// the newest of a folder's (a resume's), so that one of its name that is no checkpoint is to be moved away;
// else the user named it.
Checkpoint read_checkpoint(const std::filesystem::path& path, bool picked = true);

// A checkpoint belongs to the run whose folder it is resumed in: that folder's scene.toml (the scene as
// run, which `mca run` writes) must be the checkpoint's scene, key for key. A checkpoint of another scene
// copied into the folder would write that scene's frames, stats and summary beside the folder's own.
// Throws mca::Error naming both files, the first key that differs and the fix; a folder without
// scene.toml is refused too (it is not a run's folder, or its scene was removed). Where the step runs is not
// compared: returns the folder's solver.backend, which a resume without --backend takes (not the
// checkpoint's, which is the backend of the session that wrote it).
SolverDef::Backend check_checkpoint_scene(const Checkpoint& cp, const std::filesystem::path& checkpoint,
                                          const std::filesystem::path& run_dir);

}  // namespace mca::io
