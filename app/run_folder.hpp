#pragma once
// A run's folder going on from its newest checkpoint: what `mca resume` does to it before its first step,
// and the Python module's write_frame into the folder of the checkpoint its Simulation was resumed from.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "app/frame_output.hpp"
#include "app/render_output.hpp"
#include "io/checkpoint.hpp"

namespace mca {
class Engine;
}

namespace mca::app {

// The frames of a run: frame k at step min(k x steps_per_frame, total_steps).
struct Plan {
  std::int64_t total_steps = 0;
  std::int64_t total_frames = 0;  // frames after frame 0
};

// The frames of a run of `total_steps` at `steps_per_frame`: rounded up (its last frame shorter where the
// steps are no multiple of a frame's).
Plan plan_of(std::int64_t total_steps, std::int64_t steps_per_frame);

// The frame clock of checkpoint `cp` (read from `source`, "checkpoint 'PATH'") of the run in folder `dir`,
// stepped by `sim` (built from it): throws mca::Error where its counters disagree (a damaged or edited file),
// where it was saved between two frames (mca.Simulation.checkpoint; `between_frames`: what the message
// then says a run's frames go on from and how to go on, mca resume's where empty), and where the folder's
// run is of another step count (a checkpoint copied in from another run of the same scene).
Plan checkpoint_plan(const std::filesystem::path& dir, const Engine& sim, const io::Checkpoint& cp,
                     const std::string& source, std::string_view between_frames = {});

// How a session goes on in the folder.
struct GoingOn {
  bool draw = true;             // render the frames it adds when the run was rendered (render/render.json)
  std::string_view not_drawn;   // else why not, as the warning says it ("--no-render")
  bool check_fits = true;       // the disk and memory the rest of the run takes (check_run_fits)
  bool quiet = false;           // no notes
  const std::atomic<int>* stop = nullptr;  // the run's stop signal, for the renderer
  std::function<void(const std::string&)> warn;  // a warning (`mca resume`: "warning: ..." on stderr)
  std::function<void(const std::string&)> note;  // a note, unless quiet (`mca resume`: "mca: ...")
};
struct FolderGoingOn {
  std::unique_ptr<FrameWriter> writer;  // stats.csv and the collections up to the checkpoint's frame written
  std::unique_ptr<RenderOutput> render;  // the rendering, where it goes on
};

// Readies the folder `dir`, whose newest checkpoint `cp` (`plan`: checkpoint_plan's) `sim` was built from
// (and the caller holds the folder's lock), for the frames after the checkpoint's: the frames, rows of
// stats.csv, pictures and collection entries past it and the run's end (summary, fragments; the plots
// where steps are left) are removed, all or none, after the checks of a resume (subfolders, the files of a
// run's names, meshes it reads, the room the rest of the run takes); the checkpoint's own frame is written
// again where its files were lost. Throws mca::Error with the folder as it was where a check fails.
FolderGoingOn go_on_in_folder(const std::filesystem::path& dir, const Engine& sim, const io::Checkpoint& cp,
                              const Plan& plan, const GoingOn& how);

}  // namespace mca::app
