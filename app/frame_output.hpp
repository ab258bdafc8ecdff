#pragma once
// What a run writes per frame and at its end: VTK frames and their .pvd collections, stats.csv and
// summary.json. Only reads the state.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analysis/fragments.hpp"
#include "backend/backend.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "core/text.hpp"
#include "io/output_files.hpp"
#include "mca/scene.hpp"

namespace mca {
class Engine;
}

namespace mca::app {

struct FrameStats {
  std::int64_t frame = 0;
  double time = 0;
  Energies energy;
  std::int64_t broken_displacement = 0, broken_stress = 0;
  std::int32_t fragments = 0;
  double largest_share = 0;
  std::vector<Vec3> grip_force;
};

// What a run writes into its folder, estimated before it starts: `mca run` and `mca resume` refuse a run
// that would not fit the free disk, `mca info` shows it. Frames are counted at their frame-0 size (VTK
// frames keep it; intact links, with output.links, only go; a bound surface grows where it splits between
// fragments, up to three vertices per triangle; rendered frames at a measured share of their pixels).
struct OutputEstimate {
  std::int64_t frames = 0;     // frames the run writes (frame 0 included)
  double vtk_frame = 0;        // bytes of one frame's automata and projectiles .vtu
  double surface_frame = 0;    // one frame's surface file (output.surface)
  double render_frame = 0;     // one frame's PNG and its share of the video (--render)
  double per_run = 0;          // stats.csv, the .pvd collections, summary, fragments.csv, checkpoints, fragment meshes
  double checkpoints = 0;      // of per_run: the checkpoints on disk at once
  double fragment_meshes = 0;  // of per_run: the fragment meshes at the end (output.fragments)
  double frame() const { return vtk_frame + surface_frame + render_frame; }
  double total() const { return static_cast<double>(frames) * frame() + per_run; }
};
// `frames`: the frames to write (a new run: the plan's frames after frame 0, plus 1). render_width and
// render_height: the picture size of --render (0: not rendered).
OutputEstimate estimate_output(const Model& model, const OutputDef& output, std::int64_t frames, int render_width = 0,
                               int render_height = 0);
using text::human_bytes;
// A scene that reaches beyond 1 km from the origin: what its double positions resolve there and the
// slowest speed a step moves (docs/model-notes.md, "Far from the origin"), for mca run and mca info to
// print; empty for a scene within 1 km.
std::string far_out_note(const Model& model, const SceneDef& scene);
// Notes on mesh objects whose mass misses their mesh's: a volume fill of few automata (their cells hold
// under 0.8 or over 1.25 times the volume the mesh encloses), a shell heavier than the solid it bounds.
std::vector<std::string> mesh_mass_notes(const Model& model);
// A note where a projectile sets a critical step ten times or more shorter than the objects' own (a ball
// of 1 um beside a wall: 95 million steps for 10 ms); "" otherwise.
std::string step_note(const Model& model);
// Frames shorter than the automatic step make it (one step a frame): how many times shorter, and the
// frame_rate that gives frames of ten steps or more.
std::string frame_step_note(const Model& m, const SceneDef& scene);
// A note where output.surface_format is "obj" but output.surface is false (or the scene has no mesh object
// whose surface it could write), so that nothing is written in it; "" otherwise (the default "ply" cannot
// be told from one given).
std::string surface_format_note(const SceneDef& scene);
// output.surface on volume-filled mesh objects of triangles longer than 3 spacings (a tenth of them or
// more): the surface opens only between whole triangles, so the cracks inside them do not show; "" else.
std::string coarse_surface_note(const Model& model, const SceneDef& scene);
// A note for each material the automata use whose links reach fracture_strain before the strain at which
// the stress criterion ends them in tension (c tensile_strength / youngs_modulus): they break by
// displacement, weaker than the strength says, their softening cut short.
std::vector<std::string> strain_limit_notes(const Model& model);
// With output.fragments, a note for each shell that its fragment meshes thicken by over a tenth (a shell
// thinner than the voxel its surface bounds them to is meshed that voxel thick on each side): the
// thickness they will have.
std::vector<std::string> thin_shell_notes(const Model& model, const SceneDef& scene);
// Every note above that applies, in the order mca info and mca run print them.
std::vector<std::string> scene_notes(const Model& model, const SceneDef& scene);
// Whether the scene's frames are shorter than its automatic time step, which they then make (one step a
// frame; scene_notes says so).
bool frames_set_the_step(const Model& m, const SceneDef& scene);
// The lattice of the model's volume fills: "random", "cubic", or "" when every object is in surface mode;
// lattice_name as mca run and mca info print it, "random (link_bending 0.1)" for the random one, "cubic
// (lattice_jitter 0.25)" for a jittered cubic one (`jitter`: the scene's solver.lattice_jitter).
std::string lattice_kind(const Model& model);
std::string lattice_name(const Model& model, double jitter = 0);
// Throws mca::Error when the estimate exceeds the space free in `dir` (which exists): the bytes, the frames and
// their size, the space free, and the fix.
void check_output_fits(const OutputEstimate& estimate, const std::filesystem::path& dir, const SceneDef& scene);

// The peak memory of a run, by what holds it (`mca info`; compare summary.json's peak_memory_bytes): the
// arrays of the model, state and backend (estimate_memory_bytes), the mesh objects (the triangles read and
// checked, the fill, the surface bound to automata), a frame's bound surface (output.surface), the voxel
// fields of the fragment meshes at the end (output.fragments) and the OpenGL renderer (--render); or the
// build's, when higher: the program, the meshes and the arrays over the mesh objects' boxes of cells
// (build; two 0.3 m cubes 100 m apart in one mesh at 5 mm peaked at 829 MB where the run's arrays are
// 358 MB).
// `rubble` is what the run holds on top when its objects break down to single automata (their contact
// pairs; estimate_rubble_bytes), not counted in total().
struct MemoryEstimate {
  double arrays = 0, meshes = 0, surface_output = 0, fragment_meshes = 0, render = 0, build = 0, rubble = 0;
  // The CUDA backend's emulation holds its device arrays in the host's memory (emulated_gpu_bytes).
  double emulated_gpu = 0;
  double run() const { return arrays + meshes + surface_output + fragment_meshes + render + emulated_gpu; }
  double total() const { return std::max(run(), build); }
  double shattered() const { return std::max(run() + rubble, build); }
};
MemoryEstimate estimate_memory(const Model& model, const OutputDef& output, int render_width = 0,
                               int render_height = 0);
// Refuses a run whose peak (e.run(): the arrays, the mesh objects, the surface and fragment meshes it writes,
// the renderer) exceeds solver.max_memory_gb or 90 % of the machine's memory, naming the parts and the fix
// of the largest. (The build checks the arrays before it allocates them; this is the rest.)
void check_memory_fits(const MemoryEstimate& e, const SceneDef& scene);
// What the CUDA backend's emulation adds to a run's host memory, given what its device arrays hold at the
// start (`held`, gpu::DeviceMemory::held()); 0 for any other backend. Counted at the arrays themselves:
// beside the CPU backend's estimate (whose own arrays it does not hold), the default wall peaked 8.8 MB
// higher on the emulation (device arrays 8.6 MB at the start, 13.0 at their most), a random-lattice wall of
// 38,400 automata 38 MB higher after 100 steps (73 MB at the start).
double emulated_gpu_bytes(const std::string& backend_name, std::size_t held);

// The subfolders of the output folder that FrameWriter writes each frame into: frames (output.vtk), surface
// (output.surface and a mesh object); and those of a run's end and stops: fragments (output.fragments),
// checkpoints. (For io::check_output_subfolders.)
std::vector<std::string> frame_subfolders(const SceneDef& scene);
std::vector<std::string> run_subfolders(const SceneDef& scene, bool render);
// The mesh files a scene reads (objects' and regions'), each with the key that names it
// (io::check_inputs_outside_subfolders).
std::vector<std::pair<std::string, std::string>> mesh_inputs(const SceneDef& scene);

// What a run writes into its folder, by part. One table serves the check of a folder before a run (files
// of these names and no run of mca there are refused) and every removal of an earlier run's files.
enum class RunPart : std::uint8_t {
  scene,        // scene.toml (written over, never removed)
  stats,        // stats.csv (written over)
  end,          // summary.json, fragments.csv and the fragment meshes: the run's end
  plots,        // the plots of tools/plot_run.py in render/
  frames,       // the VTK frames, the bound surfaces and their .pvd collections
  checkpoints,  // checkpoints/frame_NNNNNN.mcack
  rendering,    // render/: render.json, the PNG frames, video.mp4, contact_sheet.png
};
struct RunFile {
  RunPart part;
  const char* folder;     // "" for the run's folder itself
  const char* name;       // the file's name, or the prefix of a numbered one
  const char* extension;  // "" for a fixed name; else a numbered one's: name + 1 to 18 digits + extension
};
// What a new run in a folder removes of an earlier run there: all it wrote but the scene file, which it
// writes over (a rendered run draws its own pictures, an unrendered one must not leave a rendering that a
// resume would go on with).
inline constexpr std::initializer_list<RunPart> kEarlierRun = {RunPart::end,    RunPart::plots, RunPart::checkpoints,
                                                               RunPart::frames, RunPart::stats, RunPart::rendering};
// The files of `parts` that `dir` holds, relative to it (numbered ones only of the run's own form:
// frames/automata_000012.vtu, not frames/automata_mine.vtu), in the table's order.
std::vector<std::string> run_files_in(const std::filesystem::path& dir, std::initializer_list<RunPart> parts);
// Removes them, all or none (an error naming a file that cannot be removed); returns how many there were.
std::size_t remove_run_files(const std::filesystem::path& dir, std::initializer_list<RunPart> parts);
// Sets them aside in `removal` (removed at its commit, put back if it is not made); returns how many.
std::size_t stage_run_files(io::StagedRemoval& removal, const std::filesystem::path& dir,
                            std::initializer_list<RunPart> parts);
// What a new run (mca run, the Python module's first write_frame) sets aside in `removal` before it writes its
// scene file: the earlier run's files of kEarlierRun, its scene file, and markers of the table's names
// (StagedRemoval::will_write) that no session of mca left (the one before it cleared any of its own): one
// kept would have a later session remove this run's file by it.
void stage_earlier_run(io::StagedRemoval& removal, const std::filesystem::path& dir);
// Refuses a folder (or anything but a regular file) at a name of the table in `dir`: the run would stop when
// it came to write that file (a checkpoint at frame 2,000, hours in) or to replace it.
void check_run_names_are_files(const std::filesystem::path& dir);
// The table's folders below the run's: frames, surface, fragments, checkpoints, render.
std::vector<std::string> run_file_folders();
// Folders of outputs this session may not write, left empty by the removals (the writers make them again);
// `rendering`: render/ is made for this session's pictures. A resume, whose writer has made its folders
// already, passes only those of the end's outputs (`ends_only`).
void remove_empty_output_folders(const std::filesystem::path& dir, bool rendering, bool ends_only = false);

// The first 4 KB of a run folder's scene.toml (empty without one): whether mca wrote it, and the step
// count of a --steps run (the comment at its top).
struct SceneHead {
  bool by_mca = false;
  std::optional<std::int64_t> steps;
};
SceneHead read_scene_head(const std::filesystem::path& dir);

// The status summary.json in dir gives ("finished", "interrupted", ...; empty where there is none or it is
// not one of mca's).
std::string summary_status(const std::filesystem::path& dir);

// A new run replaces an earlier run's files in its folder. It refuses a folder whose files of those names
// are not a run's (no scene.toml of mca's: a user's summary.json, a folder of another program), and one
// whose run did not finish and can be resumed (checkpoints, and no summary of a finished run): one
// command typed for another must not cost either; and one with something not a file at a name the run
// writes (check_run_names_are_files). `another`: the fix's other folder ("another --out folder"; the Python
// module's write_frame names its own); `continue_with`: how to continue the run that did not finish (empty:
// "mca resume DIR").
void check_folder_is_a_runs(const std::filesystem::path& dir, std::string_view another = "another --out folder",
                            std::string_view continue_with = {});

// The end of a run in `dir` from the engine's state: summary.json (`status`: "finished", "interrupted", ...)
// and fragments.csv, every fragment heaviest first (mca run at its end, the Python module's
// close_output(finish=True)). `wall_before`: the wall seconds of the sessions before this one (a resume's
// checkpoint's); `session_wall` and `session_steps` this session's, which give the rate; `resumed_from`: the
// checkpoint a resumed session started from (its scene is then the folder's scene.toml), else empty.
void write_summary(const std::filesystem::path& dir, const Engine& sim, const analysis::Fragments& frags,
                   double wall_before, double session_wall, std::int64_t session_steps, int threads,
                   const std::string& status, const std::filesystem::path& resumed_from);

class FrameWriter {
 public:
  // Writes what `output` asks for: VTK frames (vtk, links) and the bound surface (surface, surface_format).
  FrameWriter(std::filesystem::path dir, const Model& model, const OutputDef& output);
  ~FrameWriter();
  FrameWriter(const FrameWriter&) = delete;
  FrameWriter& operator=(const FrameWriter&) = delete;
  // Fragments of the state (for stats and VTK).
  analysis::Fragments fragments(const State& s) const;
  FrameStats stats(std::int64_t frame, const State& s, const analysis::Fragments& frags) const;
  void write_frame(std::int64_t frame, const State& s, const analysis::Fragments& frags);
  std::string format_row(const FrameStats& row) const;
  // Starts stats.csv: header + `rows` (each from format_row), written atomically. Once per run (a new
  // run: frame 0; a resume: the rows up to its checkpoint).
  void start_stats(const std::vector<std::string>& rows);
  // Appends one row (one write call, so readers see whole rows). Throws mca::Error naming the file.
  void append_stats(const std::string& row);
  // Puts the rows appended so far on the disk (fdatasync), before a checkpoint that a resume reads them
  // back to: a crash after the checkpoint then cannot have lost them.
  void sync_stats();
  // The first thing a session (mca run, resume, the Python module's first write_frame) does in its folder,
  // under its lock: the files of a run that a killed session had set aside in `dir` and its folders go
  // back to their names, or go where it had begun to remove them (io::put_back_set_aside, only in the
  // folder of a run of mca), and the temporary files a killed run left go (their names are unique per
  // process, so nothing else would ever replace them). Returns what it says of the files set aside.
  static std::vector<std::string> recover_folder(const std::filesystem::path& dir);
  // Rebuilds the .pvd collections after a resume from the frames 0..frames-1 whose files are all on disk
  // whole (frame f at time_of(f)), and writes them; returns the frames of which a file is missing (removed
  // since the run wrote it), empty or cut short (a VTK file that does not end as written), which every
  // collection leaves out.
  std::vector<std::int64_t> restore(std::int64_t frames, const std::function<double(std::int64_t)>& time_of);
  // What restore() and start_stats() write, relative to the folder: stats.csv and the collections.
  std::vector<std::string> restored_files() const;
  static std::vector<std::string> stats_header(const Model& model);
  // At the end of a run (output.fragments): fragments/fragment_NNN.ply for each fragment of more than
  // output.fragment_min_automata automata, each written as it is made; returns how many. `each(done,
  // total)` is called after each is written (one call at a time; it may throw to stop the rest), `poll`
  // often while a piece is meshed (from several threads; it may throw to stop there).
  std::size_t write_fragment_meshes(const State& s, const analysis::Fragments& frags,
                                    const std::function<void(std::size_t done, std::size_t total)>& each = {},
                                    const std::function<void()>& poll = {});
  // The bound surface's file of a frame, relative to the output folder.
  static std::string surface_name(std::int64_t frame, OutputDef::SurfaceFormat format);

 private:
  std::filesystem::path dir_;
  const Model& model_;
  bool vtk_, links_, surface_;
  OutputDef::SurfaceFormat surface_format_;
  bool fragment_meshes_;
  std::int64_t fragment_min_automata_;
  std::vector<std::pair<double, std::string>> automata_pvd_, projectile_pvd_, surface_pvd_;
  int stats_fd_ = -1;  // stats.csv, open for appending after start_stats
};

}  // namespace mca::app
