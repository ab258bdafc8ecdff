// `mca info`: what a scene will cost before running it.
#include <cstdlib>
#include <fmt/format.h>
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>

#include "app/commands.hpp"
#include "app/frame_output.hpp"
#include "backend/cuda/device_memory.hpp"
#include "core/text.hpp"
#include "io/json_text.hpp"
#include "io/scene_io.hpp"
#include "lattice/lattice.hpp"
#include "sim/engine.hpp"

namespace mca::app {

std::string backend_text(const std::string& name) {
  if (name.rfind("cpu", 0) != 0) return name;  // (the instruction sets are the CPU backend's)
  const char* forced = std::getenv("MCA_SIMD");
  if (forced && *forced) return fmt::format("{} (instruction set chosen by MCA_SIMD={})", name, forced);
  return name + " (the widest instruction set this processor runs; MCA_SIMD=scalar, sse2, avx2 or avx512 picks another)";
}

namespace {

std::string box_text(const std::array<double, 3>& lo, const std::array<double, 3>& hi, const char* unit) {
  return fmt::format("[{:.7g}, {:.7g}, {:.7g}] to [{:.7g}, {:.7g}, {:.7g}]{} ({:.4g} x {:.4g} x {:.4g}{})", lo[0], lo[1],
                     lo[2], hi[0], hi[1], hi[2], unit, hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], unit);
}

void print_mesh(const MeshSummary& ms, const std::string& object, std::size_t automata, double mass_scaling) {
  fmt::print("mesh             {} (object {})\n", ms.path, object);
  using text::count;
  fmt::print("  vertices       {}, faces {}\n", ms.vertices, ms.faces);
  if (ms.boundary_edges == 0 && ms.non_manifold_edges == 0) {
    fmt::print("  surface        closed (no boundary or non-manifold edges){}\n",
               ms.degenerate_faces ? "; " + count(ms.degenerate_faces, "degenerate face") : std::string());
  } else {
    fmt::print("  surface        {} in {}, {}, {}\n", count(ms.boundary_edges, "boundary edge"), count(ms.holes, "hole"),
               count(ms.non_manifold_edges, "non-manifold edge"), count(ms.degenerate_faces, "degenerate face"));
  }
  if (ms.shells > 1)
    fmt::print("  shells         {} connected surfaces, {} of them around cavities (left empty)\n", ms.shells, ms.cavities);
  fmt::print("  in the file    {}\n", box_text(ms.file_lo, ms.file_hi, ""));
  fmt::print("  in the scene   {} (scale {:.6g}), volume {:.4g} m^3\n", box_text(ms.lo, ms.hi, " m"), ms.scale,
             ms.volume);
  if (ms.surface) {
    fmt::print("  automata       {}, one per triangle (fill = \"surface\"), shell {:.4g} m thick\n", automata,
               ms.shell_thickness);
    fmt::print("  links          {} across shared edges{}{}\n", ms.links,
               ms.unlinked_edges ? fmt::format("; {} left unlinked", count(ms.unlinked_edges, "non-manifold edge"))
                                 : std::string(),
               ms.duplicate_faces ? fmt::format("; {} left out", count(ms.duplicate_faces, "repeated triangle"))
                                  : std::string());
    if (ms.pieces > 1)
      fmt::print("  pieces         the shell starts as {} pieces, which no link joins (its mesh's separate parts{}): "
                 "each moves on its own from the first step\n",
                 ms.pieces, ms.unlinked_edges ? ", and parts meeting only at non-manifold edges" : "");
    if (mass_scaling > 0) {
      fmt::print("  mass scaling   {} automata given {:.4g} kg, {:.3g} % of the shell's {:.4g} kg, to reach a critical step of "
                 "{:.4g} s ({:g} x the shell's median; solver.mass_scaling, 0 for none)\n",
                 ms.mass_scaled, ms.added_mass, ms.mesh_mass > 0 ? 100 * ms.added_mass / ms.mesh_mass : 0.0, ms.mesh_mass,
                 ms.scaled_step, mass_scaling);
    } else {
      fmt::print("  mass scaling   none (solver.mass_scaling = 0): the automata keep the mesh's lumped masses\n");
    }
  } else {
    fmt::print("  automata       {} (cells inside found in {:.2f} s)\n", automata, ms.fill_seconds);
    if (ms.dropped_automata > 0) {
      fmt::print("  dropped        {} inside the mesh, in {}, that no lattice link joins to the body (the mesh is "
                 "thinner than a cell between them; {} would fall off at t = 0): the object starts as one piece per "
                 "solid\n",
                 count(ms.dropped_automata, "cell"), count(ms.dropped_pieces, "piece"),
                 ms.dropped_automata == 1 ? "it" : "they");
    } else {
      fmt::print("  dropped        none (every cell inside is linked to the body)\n");
    }
  }
}

}  // namespace

int info(const std::optional<std::string>& path, bool json, const std::optional<std::string>& backend) {
  SceneDef scene = path ? io::load_scene_file(*path) : io::load_default_scene();
  if (backend) scene.solver.backend = backend_from_name(*backend, "--backend");
  // Progress of a long build on stderr, not with --json: a program reading the output (often with stderr
  // joined to it) gets the JSON alone.
  std::optional<lattice::BuildProgress> building;
  if (!json) building.emplace();
  Engine::check_environment();  // a bad MCA_SIMD or MCA_BACKEND, before the model is built
  // A scene that asks for the CUDA backend (or MCA_BACKEND=cuda) is described on a machine without a GPU too
  // (on the CPU, which computes the same state), saying why its backend cannot run here.
  std::string gpu_why;
  const std::string gpu = cuda_device(&gpu_why);
  // The backend asked for: the scene's, or for auto what MCA_BACKEND names.
  const SolverDef::Backend asked = scene.solver.backend == SolverDef::Backend::automatic
                                       ? backend_from_environment().value_or(SolverDef::Backend::automatic)
                                       : scene.solver.backend;
  const bool cuda_missing = asked == SolverDef::Backend::cuda && gpu.empty();
  const char* asked_by = backend                                               ? "--backend"
                         : scene.solver.backend == SolverDef::Backend::automatic ? "MCA_BACKEND"
                                                                                 : "solver.backend";
  // The model is built once, with the CPU backend; the GPU backend a run would take (the emulation where
  // asked for) is then started beside it, for what its device arrays hold, or for why it cannot hold them.
  SceneDef probe = scene;
  probe.solver.backend = SolverDef::Backend::cpu;
  const Engine sim(probe);
  building.reset();
  std::string backend_name = sim.backend().name(), gpu_full;
  std::optional<std::size_t> gpu_bytes;
  if (asked == SolverDef::Backend::cuda_emulation || (!gpu.empty() && asked != SolverDef::Backend::cpu)) {
    const SolverDef::Backend kind = asked == SolverDef::Backend::automatic ? SolverDef::Backend::cuda : asked;
    try {
      // (as a new run starts it: from the first state, which it then reads for its energy)
      const auto b = start_backend(sim.model(), kind, scene.source, initial_state(sim.model()));
      (void)b->state();
      backend_name = b->name();
      gpu_bytes = gpu::DeviceMemory::held();
    } catch (const Error& e) {
      // (auto leaves a model the GPU refuses to the CPU, whatever the reason, as a run does)
      if (asked != SolverDef::Backend::automatic && !dynamic_cast<const gpu::DeviceMemoryFull*>(&e)) throw;
      gpu_full = e.what();
      if (asked != SolverDef::Backend::automatic)
        backend_name = kind == SolverDef::Backend::cuda_emulation ? "cuda-emulation" : "cuda";
    }
  }
  const Model& m = sim.model();
  const std::int64_t frames = sim.frame_count();
  const std::int64_t steps = sim.total_steps();
  MemoryEstimate memory = estimate_memory(m, scene.output);
  const double bytes = memory.arrays;  // the arrays, the options' per-slot ones included
  MemoryEstimate memory_rendered = estimate_memory(m, scene.output, 1280, 720);
  memory.emulated_gpu = memory_rendered.emulated_gpu = emulated_gpu_bytes(backend_name, gpu_bytes.value_or(0));
  // What a run writes (frame 0 and `frames` more), and the pictures --render adds at its default size.
  const OutputEstimate output = estimate_output(m, scene.output, frames + 1);
  const OutputEstimate rendered = estimate_output(m, scene.output, frames + 1, 1280, 720);
  if (json) {
    nlohmann::json j;
    j["scene"] = scene.name;
    j["scene_file"] = scene.source;
    j["automata"] = m.size();
    j["links"] = m.link_count();
    j["spacing"] = m.spacing;
    const std::string lattice = lattice_kind(m);
    j["lattice"] = lattice.empty() ? "none (surface mode)" : lattice;
    if (!m.object_random.empty()) j["link_bending"] = m.lattice_bending;
    if (lattice == "cubic" && scene.solver.lattice_jitter > 0) j["lattice_jitter"] = scene.solver.lattice_jitter;
    j["time_step"] = m.dt;
    j["critical_time_step"] = m.critical_dt;
    j["time_step_limited_by"] = m.dt_limited_by;
    if (const std::string note = far_out_note(m, scene); !note.empty()) j["far_from_origin"] = note;
    if (const auto notes = mesh_mass_notes(m); !notes.empty()) j["mesh_mass_notes"] = notes;
    if (const auto notes = strain_limit_notes(m); !notes.empty()) j["strain_limit_notes"] = notes;
    if (const std::string note = step_note(m); !note.empty()) j["step_note"] = note;
    if (const std::string note = frame_step_note(m, scene); !note.empty()) j["frame_step_note"] = note;
    if (const std::string note = surface_format_note(scene); !note.empty()) j["surface_format_note"] = note;
    if (const std::string note = coarse_surface_note(m, scene); !note.empty()) j["coarse_surface_note"] = note;
    j["simulated_time"] = static_cast<double>(steps) * m.dt;
    j["frame_interval"] = sim.frame_interval();
    j["steps_per_frame"] = sim.steps_per_frame();
    j["frames"] = frames;
    j["steps"] = steps;
    j["duration"] = scene.output.duration;
    const bool refused = !gpu_full.empty() && asked != SolverDef::Backend::automatic;
    // The backend's name alone (as summary.json gives it), and whether it can run the scene here (why not:
    // cuda_unavailable, gpu_memory_full).
    j["backend"] = cuda_missing ? std::string("cuda") : backend_name;
    j["backend_runs_here"] = !cuda_missing && !refused;
    j["gpu_memory_bytes"] = gpu_bytes ? nlohmann::json(*gpu_bytes) : nlohmann::json(nullptr);
    if (!gpu_full.empty()) j["gpu_memory_full"] = gpu_full;
    j["cuda_device"] = gpu.empty() ? nlohmann::json(nullptr) : nlohmann::json(gpu);
    if (gpu.empty()) j["cuda_unavailable"] = gpu_why;
    j["memory_bytes"] = memory.total();
    j["memory_bytes_with_render"] = memory_rendered.total();
    j["memory_bytes_shattered"] = memory.shattered();
    j["memory"] = {{"arrays", memory.arrays},
                   {"meshes", memory.meshes},
                   {"surface_output", memory.surface_output},
                   {"fragment_meshes", memory.fragment_meshes},
                   {"render_1280x720", memory_rendered.render},
                   {"build", memory.build},
                   {"rubble", memory.rubble}};
    j["memory_bytes_per_automaton"] =
        (bytes - static_cast<double>(estimate_memory_bytes(0))) / static_cast<double>(m.size());
    j["output_bytes"] = output.total();
    j["output_bytes_per_frame"] = output.frame();
    j["output_bytes_with_render"] = rendered.total();
    j["output_bytes_fragment_meshes"] = output.fragment_meshes;
    j["total_mass"] = m.total_mass;
    nlohmann::json objs = nlohmann::json::array();
    std::vector<std::size_t> count(m.object_names.size(), 0);
    for (auto o : m.object) ++count[o];
    for (std::size_t o = 0; o < m.object_names.size(); ++o) objs.push_back({{"name", m.object_names[o]}, {"automata", count[o]}});
    j["objects"] = objs;
    nlohmann::json meshes = nlohmann::json::array();
    for (const MeshSummary& ms : m.meshes) {
      meshes.push_back({{"object", m.object_names[ms.object]},
                        {"file", ms.path},
                        {"vertices", ms.vertices},
                        {"faces", ms.faces},
                        {"closed", ms.boundary_edges == 0 && ms.non_manifold_edges == 0},
                        {"boundary_edges", ms.boundary_edges},
                        {"holes", ms.holes},
                        {"non_manifold_edges", ms.non_manifold_edges},
                        {"degenerate_faces", ms.degenerate_faces},
                        {"shells", ms.shells},
                        {"cavities", ms.cavities},
                        {"file_bounds", {ms.file_lo, ms.file_hi}},
                        {"scale", ms.scale},
                        {"bounds", {ms.lo, ms.hi}},
                        {"volume", ms.volume},
                        {"automata", count[ms.object]},
                        {"fill", ms.surface ? "surface" : "volume"},
                        {"fill_seconds", ms.fill_seconds}});
      if (!ms.surface) {
        meshes.back()["dropped_automata"] = ms.dropped_automata;
        meshes.back()["dropped_pieces"] = ms.dropped_pieces;
      }
      if (ms.surface) {
        meshes.back()["links"] = ms.links;
        meshes.back()["unlinked_edges"] = ms.unlinked_edges;
        meshes.back()["pieces"] = ms.pieces;
        meshes.back()["duplicate_faces"] = ms.duplicate_faces;
        meshes.back()["shell_thickness"] = ms.shell_thickness;
        meshes.back()["mass_scaled_automata"] = ms.mass_scaled;
        meshes.back()["added_mass"] = ms.added_mass;
        meshes.back()["added_mass_share"] = ms.mesh_mass > 0 ? ms.added_mass / ms.mesh_mass : 0.0;
        meshes.back()["mass_scaled_step"] = ms.scaled_step;
      }
    }
    j["meshes"] = meshes;
    std::array<std::size_t, 4> classes{};
    for (auto c : m.strength_class) ++classes[c - 1];
    j["strength_classes"] = classes;
    j["materials"] = m.group_names;
    j["projectiles"] = m.projectiles.size();
    fmt::print("{}\n", io::json_text(j));
    return 0;
  }
  fmt::print("scene            {} ({})\n", scene.name, scene.source);
  fmt::print("automata         {}\n", m.size());
  std::vector<std::size_t> count(m.object_names.size(), 0);
  for (auto o : m.object) ++count[o];
  for (std::size_t o = 0; o < m.object_names.size(); ++o) fmt::print("  object {:<9} {}\n", m.object_names[o], count[o]);
  for (const MeshSummary& ms : m.meshes)
    print_mesh(ms, m.object_names[ms.object], count[ms.object], scene.solver.mass_scaling);
  fmt::print("links            {}\n", m.link_count());
  fmt::print("spacing          {:.4g} m\n", m.spacing);
  if (const std::string lattice = lattice_name(m, scene.solver.lattice_jitter); !lattice.empty())
    fmt::print("lattice          {}\n", lattice);
  // The step as used: safety x critical, shortened to fill frames with whole steps, or given by hand.
  fmt::print("time step        {:.4g} s ({:.3g} of the critical {:.4g} s, set by {}; {})\n", m.dt,
             m.dt / m.critical_dt, m.critical_dt, m.dt_limited_by,
             scene.solver.time_step > 0         ? std::string("given by solver.time_step")
             : frames_set_the_step(m, scene) ? fmt::format("one step a frame of output.frame_rate = {:g}, shorter "
                                                           "than solver.safety = {:g} of the critical step (see the note)",
                                                           scene.output.frame_rate, scene.solver.safety)
                                             : fmt::format("solver.safety = {:g}, fitted to whole steps per frame",
                                                           scene.solver.safety));
  for (const std::string& note : scene_notes(m, scene)) fmt::print("note             {}\n", note);
  // With solver.time_step given, a frame is a whole number of steps and may differ from 1 / frame_rate.
  // (A run shorter than a frame has its last frame at its end: "1 frames" of 1003 steps read as a
  // contradiction of the 501 steps beside it.)
  fmt::print("steps per frame  {} ({} after frame 0, one every {:.6g} s{}; {} steps: {:.6g} s simulated for "
             "output.duration = {:g} s)\n",
             sim.steps_per_frame(), text::count(frames, "frame|frames"), sim.frame_interval(),
             steps < sim.steps_per_frame() ? ", the run shorter than one: its last frame at its end" : "", steps,
             static_cast<double>(steps) * m.dt, scene.output.duration);
  std::array<std::size_t, 4> classes{};
  for (auto c : m.strength_class) ++classes[c - 1];
  fmt::print("strength classes {} / {} / {} / {} (classes 1..4)\n", classes[0], classes[1], classes[2], classes[3]);
  fmt::print("materials        {}\n", fmt::join(m.group_names, ", "));
  fmt::print("projectiles      {}\n", m.projectiles.size());
  if (cuda_missing)
    fmt::print("backend          cuda ({}), which cannot run here: {}\n",
               asked_by, gpu_why);
  else if (!gpu_full.empty() && asked != SolverDef::Backend::automatic)
    fmt::print("backend          {} ({}), whose GPU cannot hold the scene (described here on the CPU): {}\n",
               backend_name, asked_by, gpu_full);
  else if (!gpu_full.empty())
    fmt::print("backend          {}: auto leaves the scene to the CPU, as the GPU cannot hold it: {}\n",
               backend_text(backend_name), gpu_full);
  else
    fmt::print("backend          {}\n", backend_text(backend_name));
  if (gpu_bytes)
    fmt::print("gpu memory       {} of device arrays at the start: a run takes more (the steps' working lists, and "
               "the contact lists as the objects break)\n",
               human_bytes(static_cast<double>(*gpu_bytes)));
  fmt::print("cuda             {}\n", gpu.empty() ? gpu_why : gpu + " (--backend cuda)");
  std::string parts = fmt::format("arrays {:.1f} MB: {:.0f} bytes per automaton, links included", memory.arrays / 1e6,
                                  (bytes - static_cast<double>(estimate_memory_bytes(0))) / static_cast<double>(m.size()));
  if (memory.meshes > 0) parts += fmt::format("; mesh objects {:.1f} MB", memory.meshes / 1e6);
  if (memory.surface_output > 0) parts += fmt::format("; output.surface {:.1f} MB", memory.surface_output / 1e6);
  if (memory.fragment_meshes > 0) parts += fmt::format("; output.fragments {:.1f} MB", memory.fragment_meshes / 1e6);
  if (memory.emulated_gpu > 0) parts += fmt::format("; the emulated GPU's arrays {:.1f} MB", memory.emulated_gpu / 1e6);
  if (memory.build > memory.run())
    fmt::print("memory estimate  {:.1f} MB at the peak of the build (the arrays over the mesh objects' boxes of "
               "cells and the model's {:.1f} MB: parts of a mesh far apart are a box of mostly empty cells, give each "
               "part its own object); the run "
               "then holds {:.1f} MB ({}); --render at 1280x720 adds {:.0f} MB to the run\n",
               memory.build / 1e6, (memory.build - memory.meshes - static_cast<double>(estimate_memory_bytes(0))) / 1e6,
               memory.run() / 1e6, parts, memory_rendered.render / 1e6);
  else
    fmt::print("memory estimate  {:.1f} MB at the peak of a run whose objects keep their links ({}); --render at "
               "1280x720 adds {:.0f} MB\n",
               memory.total() / 1e6, parts, memory_rendered.render / 1e6);
  // (A run that breaks some of its links lies between: the default wall at 2.5 cm, 28 % of its links broken,
  // peaked at 158 MB, for 141 and 229: docs/benchmarks.md.)
  fmt::print("                 the run holds {:.1f} MB if its objects break down to single automata (their "
             "contacts), and between the two as its links break\n",
             (memory.run() + memory.rubble) / 1e6);
  std::string per_frame;
  if (output.vtk_frame > 0) per_frame += fmt::format("VTK {}", human_bytes(output.vtk_frame));
  if (output.surface_frame > 0)
    per_frame += fmt::format("{}surface {}", per_frame.empty() ? "" : ", ", human_bytes(output.surface_frame));
  // (The fragment meshes: a bound, every piece of the fewest automata meshed; a run's are usually far less.)
  const std::string meshes =
      output.fragment_meshes > 0
          ? fmt::format("; the fragment meshes at most {}, were every piece of {}", human_bytes(output.fragment_meshes),
                        text::count(scene.output.fragment_min_automata + 1, "automaton|automata"))
          : std::string();
  fmt::print("output estimate  {} ({} frames{}{}; --render at 1280x720 adds {})\n", human_bytes(output.total()),
             frames + 1, per_frame.empty() ? std::string() : fmt::format(" of {}", per_frame), meshes,
             human_bytes(rendered.total() - output.total()));
  return 0;
}

}  // namespace mca::app
