#include "app/frame_output.hpp"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <fcntl.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <mutex>
#include <optional>
#include <tbb/task_arena.h>
#include <unistd.h>

#include "analysis/fragment_meshes.hpp"
#include "analysis/surface.hpp"
#include "core/text.hpp"
#include "lattice/lattice.hpp"
#include "io/checkpoint.hpp"
#include "io/output_files.hpp"
#include "io/scene_io.hpp"
#include "io/vtk_writer.hpp"
#include "mca/error.hpp"

namespace mca::app {

namespace {
// The renderer's memory (estimate_memory), from the peaks of runs with and without --render.
constexpr double kRenderFixedBytes = 100e6, kRenderBytesPerPixel = 24, kRenderBytesPerAutomaton = 400,
                 kRenderBytesPerTriangle = 500;
// The fragment meshes' memory per voxel of a piece's surface (estimate_memory), from the peaks of runs with
// and without output.fragments: 160 to 240 bytes for volume fills (the armadillo, the bunny, a box in 2,745
// pieces), 320 to 380 for shells (the cow, spheres of 20,480 and 81,920 triangles), which are meshed on
// both sides (390 to 570 until 2026-12-07, when a shell's pieces were cut from its signed distance's grid);
// 450 since a flat shell's pieces are merged (mesh::simplify_flat, about 110 bytes a triangle while it runs:
// a box shell of 4,800 triangles broken by a ball peaked 2 to 5 % over what 400 counted; a hostile review).
constexpr double kFragmentBytesPerSurfaceVoxel = 250, kFragmentBytesPerShellVoxel = 450, kFragmentBytesPerThread = 6e6;
// A volume-filled mesh object's least (estimate_memory): on the first thread and on each other.
constexpr double kMeshFillFixedBytes = 12e6, kMeshFillBytesPerThread = 8e6;

// The area of each object's bound surface triangles (m^2; 0 for an object without).
std::vector<double> surface_area_by_object(const Model& m) {
  std::vector<double> area(m.object_names.size(), 0.0);
  for (std::size_t f = 0; f < m.surface.faces(); ++f) {
    const Vec3* c = &m.surface.offset[3 * f];
    area[static_cast<std::size_t>(m.object[m.surface.automaton[f]])] += 0.5 * static_cast<double>(length(cross(c[1] - c[0], c[2] - c[0])));
  }
  return area;
}

// Each object's automata.
std::vector<std::int64_t> automata_by_object(const Model& m) {
  std::vector<std::int64_t> automata(m.object_names.size(), 0);
  for (std::size_t a = 0; a < m.size(); ++a) ++automata[static_cast<std::size_t>(m.object[a])];
  return automata;
}
}  // namespace

std::string far_out_note(const Model& m, const SceneDef& scene) {
  double r = 0;
  for (const DVec3& p : m.position0) r = std::max(r, std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z));
  for (const ProjectileDef& p : scene.projectiles)
    r = std::max(r, std::sqrt(p.position[0] * p.position[0] + p.position[1] * p.position[1] + p.position[2] * p.position[2]));
  if (!(r > 1e3)) return "";
  // A coordinate of size r moves in steps of its unit in the last place: a step's v dt under half of it is lost.
  const double ulp = std::nextafter(r, INFINITY) - r;
  return fmt::format("the scene reaches {:.0f} m from the origin, where its double positions resolve {:.2g} m: a step "
                     "of {:.3g} s moves nothing slower than about {:.2g} m/s there, and a body at rest keeps small "
                     "speeds it does not move by (on the cubic lattice, gaining energy: docs/model-notes.md, \"Far "
                     "from the origin\"); a scene within 1 km of the origin behaves as at it: move its objects, "
                     "projectiles and ground there",
                     r, ulp, static_cast<double>(m.dt), 0.5 * ulp / static_cast<double>(m.dt));
}

std::vector<std::string> mesh_mass_notes(const Model& m) {
  std::vector<std::string> notes;
  const double d = m.spacing;
  for (const MeshSummary& ms : m.meshes) {
    if (!(ms.volume > 0) || ms.automata == 0) continue;
    const auto o = static_cast<std::size_t>(ms.object);
    const std::string name = o < m.object_names.size() ? m.object_names[o] : std::to_string(o);
    if (!ms.surface) {
      // A volume fill holds a cell of d^3 an automaton: few of them miss the shape by a share of a cell
      // each (a bunny of 0.025 m^3 in 3 automata of 0.3 m held 0.081 m^3, 3.2 times its mass).
      const double held = static_cast<double>(ms.automata) * d * d * d, ratio = held / ms.volume;
      if (ratio > 0.8 && ratio < 1.25) continue;
      // (An open mesh fills only at spacings wider than its holes: a finer one is refused until they are closed.)
      const std::string finer =
          ms.boundary_edges > 0
              ? std::string("a finer spacing needs its holes closed first (it is open: MeshLab, Filters > Remeshing > "
                            "Close Holes)")
              : fmt::format("a spacing of about {:.3g} m gives it 1,000 automata", std::cbrt(ms.volume / 1000));
      notes.push_back(fmt::format("object '{}': its {} at spacing {:.4g} m {} {:.4g} m^3 where its mesh encloses "
                                  "{:.4g} m^3 ({:.2f} times): the spacing is coarse for it, and its mass is off by as "
                                  "much; {}",
                                  name, text::count(ms.automata, "automaton|automata"), d,
                                  ms.automata == 1 ? "holds" : "hold", held, ms.volume, ratio, finer));
      continue;
    }
    // A shell of the default thickness (the mean link length) around a mesh of few, large triangles is
    // thicker than the body it bounds (a cube of 1 m in 12 triangles: 0.52 m, three times the solid's mass).
    // An open mesh (a panel, a box without a lid) bounds no solid: no note.
    if (ms.boundary_edges > 0 || ms.non_manifold_edges > 0) continue;
    double mass = 0, solid = 0;
    for (std::size_t a = 0; a < m.size(); ++a) {
      if (static_cast<std::size_t>(m.object[a]) != o) continue;
      mass += m.mass[a];
      solid = std::max(solid, static_cast<double>(m.groups[m.group[a]].density) * ms.volume);
    }
    mass -= ms.added_mass;
    if (!(mass > solid) || !(solid > 0)) continue;
    notes.push_back(fmt::format("object '{}': its shell of {:.3g} m weighs {:.4g} kg, more than the solid it bounds "
                                "would ({:.4g} kg): the shell is thicker than the body; give object.shell_thickness "
                                "(well under the body's size) or a mesh of more, smaller triangles",
                                name, ms.shell_thickness, mass, solid));
  }
  return notes;
}

std::string step_note(const Model& m) {
  const double ratio = m.objects_critical_dt / m.critical_dt;
  if (!(ratio >= 10) || m.dt_limited_by.rfind("projectile", 0) != 0) return "";
  return fmt::format("the critical time step ({:.3g} s) is set by {}, {:.0f} times shorter than the objects' own "
                     "({:.3g} s): the run takes that many times the steps; a larger or denser ball (or a kinematic "
                     "one) lets it take the objects' step",
                     m.critical_dt, m.dt_limited_by, ratio, m.objects_critical_dt);
}

// Frames shorter than the automatic step (safety x critical) make the step: one a frame.
// (Read off the step taken, so that it agrees with the fitting of steps to frames at the limit: one step a
// frame, a hundredth or more below safety x critical.)
bool frames_set_the_step(const Model& m, const SceneDef& scene) {
  const double frame = 1.0 / scene.output.frame_rate, dt = m.dt;
  return scene.solver.time_step <= 0 && frame < scene.output.duration && dt >= frame * (1 - 1e-6) &&
         dt < 0.99 * scene.solver.safety * m.critical_dt;
}

std::string frame_step_note(const Model& m, const SceneDef& scene) {
  if (!frames_set_the_step(m, scene)) return "";
  const double stable = scene.solver.safety * m.critical_dt;
  return fmt::format("output.frame_rate = {:g} asks for frames of {:.3g} s, shorter than the automatic time step "
                     "({:.4g} s, solver.safety = {:g} of the critical {:.4g} s): each frame is one step, {:.3g} times "
                     "shorter, and the run takes that many times the steps; a frame_rate of at most {} gives frames "
                     "of ten steps or more, each within a tenth of the automatic step",
                     scene.output.frame_rate, 1.0 / scene.output.frame_rate, stable, scene.solver.safety,
                     m.critical_dt, stable / m.dt, text::at_most(0.1 / stable, 3));
}

std::string surface_format_note(const SceneDef& scene) {
  const OutputDef& o = scene.output;
  if (o.surface || o.surface_format != OutputDef::SurfaceFormat::obj) return "";
  const bool mesh = std::any_of(scene.objects.begin(), scene.objects.end(),
                                [](const ObjectDef& ob) { return ob.shape == Shape::mesh; });
  return mesh ? "output.surface_format = \"obj\" writes nothing: output.surface is false (set surface = true to write "
                "the mesh objects' triangles each frame)"
              : "output.surface_format = \"obj\" writes nothing: the surface outputs are the triangles of mesh "
                "objects, and the scene has none";
}

std::string coarse_surface_note(const Model& m, const SceneDef& scene) {
  // The bound surface opens only between whole triangles, each carried by one automaton: a volume-filled
  // mesh of triangles spanning several automata shows none of the cracks inside them (a box of 12 triangles
  // shattered into dozens of pieces stayed a closed box in surface.pvd). Surface-mode objects are their
  // triangles, one automaton each.
  if (!scene.output.surface || m.surface.faces() == 0) return "";
  std::vector<char> shell(scene.objects.size());
  for (const MeshSummary& ms : m.meshes)
    if (ms.surface && ms.object >= 0 && static_cast<std::size_t>(ms.object) < shell.size()) shell[ms.object] = 1;
  const double limit = 3 * m.spacing;
  std::size_t volume_faces = 0, coarse = 0;
  double longest = 0;
  for (std::size_t f = 0; f < m.surface.faces(); ++f) {
    if (shell[static_cast<std::size_t>(m.object[m.surface.automaton[f]])]) continue;
    ++volume_faces;
    const Vec3* c = &m.surface.offset[3 * f];
    const double edge = std::max({static_cast<double>(length(c[1] - c[0])), static_cast<double>(length(c[2] - c[1])),
                                  static_cast<double>(length(c[0] - c[2]))});
    longest = std::max(longest, edge);
    if (edge > limit) ++coarse;
  }
  if (coarse == 0 || 10 * coarse < volume_faces) return "";
  return fmt::format(
      "output.surface: {} of the {} triangles of the volume-filled mesh objects are longer than 3 spacings (up to "
      "{:.3g} m at spacing {:.3g} m); the surface opens only between whole triangles, each carried by one automaton, "
      "so the cracks inside them do not show in surface.pvd; subdivide the mesh to about the spacing (Blender's "
      "Subdivide or Remesh) for a surface that opens with the lattice",
      coarse, volume_faces, longest, m.spacing);
}

std::vector<std::string> thin_shell_notes(const Model& m, const SceneDef& scene) {
  // A shell's fragment meshes are its triangles thickened, sampled in a voxel that its surface bounds from
  // below (analysis::shell_voxel); a shell thinner than two voxels is meshed two voxels thick (a 0.2 mm shell
  // on a sphere of 5,120 triangles became 9 mm), which a user reading the meshes' volumes or their look
  // should be told. (Estimated for the object taken whole, as its memory is: small pieces mesh finer.)
  std::vector<std::string> notes;
  if (!scene.output.fragments) return notes;
  const std::vector<double> area = surface_area_by_object(m);
  const std::vector<std::int64_t> automata = automata_by_object(m);
  for (const MeshSummary& ms : m.meshes) {
    if (!ms.surface || ms.object < 0 || static_cast<std::size_t>(ms.object) >= area.size()) continue;
    const auto o = static_cast<std::size_t>(ms.object);
    const double half = 0.5 * ms.shell_thickness;
    const double hv = analysis::shell_voxel(m.spacing, half, automata[o], area[o], 0, area[o]);
    if (!(hv > 1.1 * half)) continue;
    notes.push_back(fmt::format(
        "object '{}': its shell_thickness {:.3g} m is meshed about {:.2g} m thick in its fragment meshes "
        "(output.fragments): the voxel they are sampled in is bounded by the shell's surface ({:.3g} m^2 over {}), "
        "and {:.2g} m is the finest; fragments.csv gives the pieces' volumes at the shell's thickness",
        m.object_names[o], ms.shell_thickness, 2 * hv, area[o], text::count(automata[o], "automaton|automata"), hv));
  }
  return notes;
}

std::vector<std::string> strain_limit_notes(const Model& m) {
  // In uniaxial tension the stress criterion ends a link at the strain c sigma_t / E, the displacement
  // criterion at eps_b (class factors and link strengths scale both alike, softening both by its factor
  // ku). A material that sets a higher strength or a stiffness of its own and keeps its base's
  // fracture_strain breaks by displacement first: weaker than its strength says, or its softening cut short
  // (a [[material]] of base "concrete" with a tensile_strength of 9 MPa broke more links than concrete's
  // 3 MPa). Equal strains (within 1 %) break alike.
  std::vector<std::string> notes;
  std::vector<char> used(m.groups.size());
  for (const std::uint8_t g : m.group) used[g] = 1;
  const double c = m.stress_coefficient;
  for (std::size_t g = 0; g < m.groups.size(); ++g) {
    const GroupParams& p = m.groups[g];
    const double at_strength = c * p.tensile_strength / p.youngs;
    if (!used[g] || !(p.fracture_strain < 0.99 * at_strength)) continue;
    const std::string name = g < m.group_names.size() ? m.group_names[g] : std::to_string(g);
    notes.push_back(fmt::format(
        "material \"{}\": its links reach fracture_strain = {:.3g} before the strain at which the stress criterion "
        "ends them in tension ({}tensile_strength / youngs_modulus = {:.3g}{}): they break by displacement, {}; for "
        "the stress criterion to govern, set fracture_strain = {:.3g} in its [[material]] (1.5 times that strain, the "
        "rule the built-in materials follow at stress_coefficient 1)",
        name, p.fracture_strain, c == 1 ? "" : fmt::format("solver.stress_coefficient {:g} x ", c), at_strength,
        p.fracture_energy > 0 ? ", both times the softening's factor" : "",
        p.fracture_energy > 0 ? "before their softening has taken fracture_energy"
                              : fmt::format("at about {:.3g} MPa instead of {:.3g} MPa", 1e-6 * p.youngs * p.fracture_strain,
                                            1e-6 * c * p.tensile_strength),
        1.5 * at_strength));
  }
  return notes;
}

std::vector<std::string> scene_notes(const Model& m, const SceneDef& scene) {
  std::vector<std::string> notes;
  for (std::string& n : strain_limit_notes(m)) notes.push_back(std::move(n));
  if (std::string n = far_out_note(m, scene); !n.empty()) notes.push_back(std::move(n));
  for (std::string& n : mesh_mass_notes(m)) notes.push_back(std::move(n));
  if (std::string n = step_note(m); !n.empty()) notes.push_back(std::move(n));
  if (std::string n = frame_step_note(m, scene); !n.empty()) notes.push_back(std::move(n));
  if (std::string n = surface_format_note(scene); !n.empty()) notes.push_back(std::move(n));
  if (std::string n = coarse_surface_note(m, scene); !n.empty()) notes.push_back(std::move(n));
  for (std::string& n : thin_shell_notes(m, scene)) notes.push_back(std::move(n));
  return notes;
}

std::string lattice_kind(const Model& m) {
  if (!m.object_random.empty()) return "random";
  const bool volume = std::find(m.object_surface.begin(), m.object_surface.end(), 0) != m.object_surface.end();
  return volume ? "cubic" : "";
}

std::string lattice_name(const Model& m, double jitter) {
  const std::string kind = lattice_kind(m);
  if (kind == "random") return fmt::format("random (link_bending {:g})", m.lattice_bending);
  return kind == "cubic" && jitter > 0 ? fmt::format("cubic (lattice_jitter {:g})", jitter) : kind;
}

OutputEstimate estimate_output(const Model& m, const OutputDef& o, std::int64_t frames, int render_width,
                               int render_height) {
  OutputEstimate e;
  e.frames = frames;
  const auto n = static_cast<double>(m.size());
  // A .vtu (FrameWriter::write_frame, io::write_vtu): about 2 KB of XML, then raw blocks with an 8-byte
  // length each: per point the 12 fields (84 bytes) and its position (12), per cell connectivity, offset and
  // type (9 with Int32 indices); each intact link a line cell of 13 bytes.
  if (o.vtk) {
    e.vtk_frame = 2000 + 15 * 8 + 105 * n;
    if (o.links) e.vtk_frame += 13 * static_cast<double>(m.link_count());
    const auto np = static_cast<double>(m.projectiles.size());
    if (np > 0) e.vtk_frame += 950 + 7 * 8 + (12 + 12 + 4 + 12 + 9) * np;
    // The .pvd collections list every frame: about 90 bytes an entry.
    e.per_run += (np > 0 ? 2 : 1) * 90.0 * static_cast<double>(frames);
  }
  // The bound surface (analysis::posed_surface) at frame 0: one vertex per mesh vertex, each triangle with
  // its fragment number. PLY: 12 bytes a vertex, 17 a face; OBJ: about 36 and 24 characters.
  if (o.surface && m.surface.faces() > 0) {
    // (Split between fragments, a triangle takes its own corners: a shell broken to pieces has up to three
    // vertices a triangle, 162 became 960 for 320 triangles; counted so, the disk check's bound.)
    const auto f = static_cast<double>(m.surface.faces());
    const double v = std::max(static_cast<double>(m.surface.vertices), 3 * f);
    e.surface_frame = o.surface_format == OutputDef::SurfaceFormat::obj ? 36 * v + 24 * f : 300 + 12 * v + 17 * f;
    // With the VTK frames, its PolyData too (frames/surface_NNNNNN.vtp: 12 bytes a vertex; a triangle's three
    // Int64 indices, its offset and its fragment, 36 bytes) and surface.pvd's entries.
    if (o.vtk) {
      e.vtk_frame += 1100 + 12 * v + 36 * f;
      e.per_run += 90.0 * static_cast<double>(frames);
    }
  }
  // A rendered frame: the PNG (compression level 1) of the bunny at 1280x720 is 0.52 MB, 0.57 bytes a pixel
  // (a mostly flat background); the H.264 video adds a few per cent. Once: the contact sheet (six tiles at
  // half size, 0.68 MB at 1280x720) and the plots (about 120 KB).
  if (render_width > 0 && render_height > 0) {
    const double pixels = static_cast<double>(render_width) * static_cast<double>(render_height);
    e.render_frame = 0.6 * pixels;
    e.per_run += 0.75 * pixels + 200000;
  }
  // stats.csv: at most 12 characters a cell, 17 cells and three a grip. summary.json about 14 KB, and with
  // scene.toml about 450 bytes a projectile; fragments.csv at most a row per automaton (every automaton its
  // own fragment), about 300 characters (measured 290).
  e.per_run += 12.0 * (17 + 3 * static_cast<double>(m.grip_names.size())) * static_cast<double>(frames);
  e.per_run += 20000 + 450 * static_cast<double>(m.projectiles.size()) + 300 * n;
  // Two checkpoints are kept, and a third is written before the oldest goes: the state, about 250 bytes an
  // automaton (measured) and 40 an explicit link.
  if (o.checkpoint_every > 0) {
    e.checkpoints = 3 * (250 * n + 40 * static_cast<double>(m.explicit_links.size()) + 20000);
    e.per_run += e.checkpoints;
  }
  // The fragment meshes at the end (output.fragments), at most: every automaton in a piece of the fewest
  // automata meshed, fragment_min_automata + 1 (the most surface a volume can have). A piece's mesh (binary
  // PLY) takes about 60 bytes per square voxel of its surface, its voxel the spacing over
  // analysis::voxels_per_spacing (8 for pieces of 27 automata and fewer); a piece of k automata has a
  // surface of at least 6 k^(2/3) d^2. Measured (bytes a square voxel): 38 to 46 for pieces of 1 to 15 cubic
  // cells, 47 to 56 for random-lattice cells, 59 and 66 for random-lattice pieces of 7 and 173 automata
  // bounded by a mesh; single cells took 15 KB (cubic) and 18 to 22 KB (random) each, where this counted
  // 1.6 KB until a review filled a disk with them at a run's end. A shell's automaton: at least that, or its
  // triangle's two sides and rim (its perimeter times the meshed thickness) in the voxel of a piece of such
  // triangles (analysis::shell_voxel: finer for a thin shell or a sliver, coarser for a large triangle;
  // counted as a cell, eight triangles of a 0.8 m plate had 23 KB where their pieces took 0.6 MB each).
  // The pieces of a primitive object (box, sphere, cylinder) on the plain cubic lattice are its cells'
  // faces, flat but for their rounded edges and corners, and merged (mesh::simplify_flat; 0.87 to 0.90 of
  // a single cell's vertices are flat): single cells take 1.8 to 2.1 KB where they took 14.8 KB sampled,
  // larger pieces less of it; counted at kMergedCell of a cell.
  if (o.fragments) {
    constexpr double kMergedCell = 0.15;
    const std::int64_t fewest = o.fragment_min_automata + 1;
    const double k = static_cast<double>(fewest);
    const double voxels = analysis::voxels_per_spacing(fewest);
    const double cell = 60 * 6 * voxels * voxels / std::cbrt(k);
    std::vector<char> flat_cells(m.object_names.size(), m.link_rest.empty() ? 1 : 0);  // (not jittered)
    for (const MeshSummary& ms : m.meshes)
      if (ms.object >= 0 && static_cast<std::size_t>(ms.object) < flat_cells.size()) flat_cells[ms.object] = 0;
    for (std::size_t a = 0; a < m.size(); ++a)
      e.fragment_meshes += flat_cells[static_cast<std::size_t>(m.object[a])] && !m.random_automaton(a) ? kMergedCell * cell : cell;
    std::vector<double> half_shell(m.object_names.size(), 0.0);
    for (const MeshSummary& ms : m.meshes)
      if (ms.surface) half_shell[static_cast<std::size_t>(ms.object)] = 0.5 * ms.shell_thickness;
    const std::vector<double> object_area = surface_area_by_object(m);
    const double d = m.spacing;
    for (std::size_t f = 0; f < m.surface.faces(); ++f) {
      const auto o = static_cast<std::size_t>(m.object[m.surface.automaton[f]]);
      const double s = half_shell[o];
      if (s == 0) continue;
      const Vec3* c = &m.surface.offset[3 * f];
      const mesh::Point p[3] = {{c[0].x, c[0].y, c[0].z}, {c[1].x, c[1].y, c[1].z}, {c[2].x, c[2].y, c[2].z}};
      const double area = 0.5 * mesh::twice_area(p[0], p[1], p[2]);
      const double rim = length(c[1] - c[0]) + length(c[2] - c[1]) + length(c[0] - c[2]);
      const double h = analysis::shell_voxel(d, s, fewest, k * area, mesh::height_across_longest_edge(p[0], p[1], p[2]),
                                             object_area[o]);
      e.fragment_meshes += std::max(0.0, 60 * (2 * area + 2 * rim * std::max(s, h)) / (h * h) - cell);
    }
    // Pieces far from the origin are written in double (analysis::float32_holds): 24 bytes a vertex where
    // float32 takes 12, about half a vertex a triangle of 13 to 17 bytes (counted where float32 does not hold
    // the farthest automaton in the finest voxel, an eighth of the spacing).
    double far = 0;
    for (const DVec3& p : m.position0) far = std::max({far, std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
    if (!analysis::float32_holds(far, m.spacing / 8)) e.fragment_meshes *= 1.5;
    e.per_run += e.fragment_meshes;
  }
  return e;
}

MemoryEstimate estimate_memory(const Model& m, const OutputDef& o, int render_width, int render_height) {
  MemoryEstimate e;
  const double threads = tbb::this_task_arena::max_concurrency();  // (each holds buffers of its own)
  std::size_t random = 0;
  for (std::size_t a = 0; a < m.size(); ++a) random += m.random_automaton(a);
  e.arrays = static_cast<double>(estimate_memory_bytes(m.size(), m.explicit_links.size(), random));
  e.rubble = static_cast<double>(estimate_rubble_bytes(m.size(), random));
  // The options' per-slot arrays (three lattice slots an automaton): a strength spread's factors (4
  // bytes), a jittered lattice's rest lengths and inverses (12; and its cells' centres, 24 an automaton), softening's damage in the state and in
  // the engine's copy of it (8) and the contact search's flags (1).
  const double slots = static_cast<double>(m.lattice_slots());
  if (!m.link_strength.empty()) e.arrays += 4.0 * slots;
  if (!m.link_rest.empty()) e.arrays += 12.0 * slots + 24.0 * static_cast<double>(m.size());  // (and Model::cell0)
  if (m.softening()) e.arrays += 9.0 * slots;
  // Mesh objects, per triangle: assimp's scene and the welded mesh (vertices, faces, the weld map), the
  // checks' edge tables, the shells, the surface bound to automata (66 bytes) kept for the run; the
  // fill's distance grids at the spacing are small beside them. Measured: `mca info scenes/bunny.toml`
  // (75,408 triangles) peaks 23 MB above a box of as many automata, 305 bytes a triangle.
  e.meshes = 310.0 * static_cast<double>(m.surface.faces());
  // A volume fill's signed distance (OpenVDB, on every thread) keeps about 12 MB of pages however small the
  // mesh, and 8 MB more on each thread beyond the first (measured: a turned 12-triangle cube of 840
  // automata peaked 8 MB above a box of 1,728 on one thread, 15 MB on two; mca info counted neither).
  if (std::any_of(m.meshes.begin(), m.meshes.end(), [](const MeshSummary& ms) { return !ms.surface; }))
    e.meshes = std::max(e.meshes, kMeshFillFixedBytes + kMeshFillBytesPerThread * (threads - 1));
  // The build: before the run's arrays exist, each volume-filled mesh holds arrays over its whole box of
  // cells (measured: two 0.3 m cubes 100 m apart at 5 mm, 72 M cells, peaked at 829 MB, 794 MB of them
  // the cells', where the run's arrays are 358 MB).
  // The box is the mesh's in its file times its scale, in cells of the spacing, 11 bytes a cell
  // (lattice.cpp, mesh_fill; 2 more per mesh region, left out here); the model's own arrays (88 bytes an
  // automaton, estimate_memory_bytes) are built meanwhile.
  e.build = static_cast<double>(estimate_memory_bytes(0)) + e.meshes + 88.0 * static_cast<double>(m.size());
  for (const MeshSummary& ms : m.meshes) {
    if (ms.surface) continue;
    double cells = 1;
    for (int c = 0; c < 3; ++c)
      cells *= std::max(1.0, std::round((ms.file_hi[c] - ms.file_lo[c]) * ms.scale / static_cast<double>(m.spacing)));
    e.build += 11.0 * cells;
  }
  // A frame's posed surface and the bytes written from it: measured 1.9 MB for the bunny's 1.73 MB frames.
  if (o.surface && m.surface.faces() > 0)
    e.surface_output = 1.1 * estimate_output(m, o, 1).surface_frame;
  // Fragment meshes (analysis/fragment_meshes.cpp): each piece is meshed and written on its own, those of
  // more than kMeshedAlone automata one at a time, so the peak is the largest piece's, or as many small
  // pieces as threads side by side. What a piece holds grows with its surface in voxels of a third of the
  // spacing (the field's band in OpenVDB, the mesh and its smoothing, the object's signed distance), plus
  // a slab of 34 planes of the field across its box. A piece's surface is counted as its object's doubled
  // (the crack faces of a half): a mesh object's triangles, another object's box; a small piece's as a cube
  // of kMeshedAlone cells (finer voxels for fewer automata keep it about that).
  if (o.fragments && m.size() > 0) {
    const double d = m.spacing, h = d / 3;
    const std::size_t n_obj = m.object_names.size();
    std::vector<std::array<double, 6>> box(n_obj, {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY});
    for (std::size_t a = 0; a < m.size(); ++a) {
      auto& b = box[static_cast<std::size_t>(m.object[a])];
      const double p[3] = {m.position0[a].x, m.position0[a].y, m.position0[a].z};
      for (int c = 0; c < 3; ++c) {
        b[c] = std::min(b[c], p[c]);
        b[3 + c] = std::max(b[3 + c], p[c]);
      }
    }
    std::vector<double> area = surface_area_by_object(m);  // m^2
    const std::vector<std::int64_t> automata = automata_by_object(m);
    double peak = 0, small = 0;
    for (std::size_t o = 0; o < n_obj; ++o) {
      const auto& b = box[o];
      if (!(b[0] <= b[3])) continue;
      double side[3];
      for (int c = 0; c < 3; ++c) side[c] = b[3 + c] - b[c] + 2.4 * d;
      if (area[o] == 0) area[o] = 2 * (side[0] * side[1] + side[1] * side[2] + side[2] * side[0]);
      const auto shell = std::find_if(m.meshes.begin(), m.meshes.end(), [&](const MeshSummary& ms) {
        return ms.surface && static_cast<std::size_t>(ms.object) == o;
      });
      // (A shell's voxel is its own, analysis::shell_voxel's, the whole object taken as one piece: a large
      // frame of few triangles counted at the spacing's third made 11 GB of a run that peaked at 111 MB.)
      const double hv = shell == m.meshes.end() ? h
                                                : analysis::shell_voxel(d, 0.5 * shell->shell_thickness, automata[o], area[o], 0, area[o]);
      const double plane = (std::ceil(side[0] / hv) + 1) * (std::ceil(side[1] / hv) + 1);
      const double per_voxel = shell != m.meshes.end() ? kFragmentBytesPerShellVoxel : kFragmentBytesPerSurfaceVoxel;
      peak = std::max(peak, per_voxel * 2 * area[o] / (hv * hv) + 34 * 4 * plane);
      const double side_cells = std::cbrt(static_cast<double>(analysis::kMeshedAlone)), across = (side_cells + 2.4) * 3 + 1;
      small = std::max(small, per_voxel * 2 * 6 * side_cells * side_cells * 9 + 34 * 4 * across * across);
    }
    // Each thread beyond the first adds its own buffers (OpenVDB's mesher, the allocator's arenas): measured
    // 4 to 6 MB on a second thread, whatever the piece (8,000 or 64,000 automata).
    e.fragment_meshes = std::max(peak, threads * small) + kFragmentBytesPerThread * (threads - 1);
  }
  // The renderer: Mesa's OpenGL (llvmpipe and its compiled shaders) and EGL, the picture's buffers, and
  // per frame the snapshot and its vertex buffers (a cube per automaton, or three vertices per triangle of
  // the bound surface). Measured with /usr/bin/time (docs/benchmarks.md, "Memory").
  if (render_width > 0 && render_height > 0) {
    const double pixels = static_cast<double>(render_width) * static_cast<double>(render_height);
    e.render = kRenderFixedBytes + kRenderBytesPerPixel * pixels + kRenderBytesPerAutomaton * static_cast<double>(m.size()) +
               kRenderBytesPerTriangle * static_cast<double>(m.surface.faces());
  }
  return e;
}

double emulated_gpu_bytes(const std::string& backend_name, std::size_t held) {
  return backend_name.rfind("cuda-emulation", 0) == 0 ? static_cast<double>(held) : 0.0;
}

void check_memory_fits(const MemoryEstimate& e, const SceneDef& scene) {
  static constexpr const char* kEmulatedPart = "the emulated GPU's arrays";
  const lattice::MemoryLimit limit = lattice::memory_limit(scene);
  const double need = e.run();
  if (need <= limit.bytes) return;
  struct Part {
    double bytes;
    const char* name;
    const char* fix;
  };
  std::vector<Part> parts = {
      {e.arrays, "arrays", "increase solver.spacing (the arrays fall with its cube)"},
      {e.meshes, "mesh objects", "use meshes of fewer triangles"},
      {e.surface_output, "surface output", "leave out the surface output (output.surface = false)"},
      {e.fragment_meshes, "fragment meshes", "leave out the fragment meshes (output.fragments = false)"},
      {e.render, "rendering", "render smaller pictures (--render-size) or leave out --render"},
      {e.emulated_gpu, kEmulatedPart,
       "run it on the CPU backend (--backend cpu: the same bits, without the emulation's copy of the state)"}};
  std::erase_if(parts, [](const Part& p) { return p.bytes <= 0; });
  std::sort(parts.begin(), parts.end(), [](const Part& a, const Part& b) { return a.bytes > b.bytes; });
  std::vector<std::string> listed;
  for (const Part& p : parts) listed.push_back(fmt::format("{} {}", p.name, human_bytes(p.bytes)));
  // The fix of the largest part; of the emulated GPU's where the run fits without them, however small.
  const bool emulation_over = e.emulated_gpu > 0 && need - e.emulated_gpu <= limit.bytes;
  const Part& fix = emulation_over ? *std::find_if(parts.begin(), parts.end(),
                                                   [&](const Part& p) { return p.name == kEmulatedPart; })
                                   : parts.front();
  throw Error(fmt::format("{}: the run would hold about {} at its peak ({}; mca info gives the figures), {}; {}, or {}",
                          scene.source, human_bytes(need), fmt::join(listed, ", "), limit.over, fix.fix,
                          limit.instead));
}

void check_output_fits(const OutputEstimate& e, const std::filesystem::path& dir, const SceneDef& scene) {
  std::error_code ec;
  const std::filesystem::space_info space = std::filesystem::space(dir, ec);
  if (ec) return;  // a file system that does not say: nothing to compare with
  const double free = static_cast<double>(space.available);
  if (e.total() <= free) return;
  std::vector<std::string> parts;
  if (e.vtk_frame > 0) parts.push_back(fmt::format("VTK {}", human_bytes(e.vtk_frame)));
  if (e.surface_frame > 0) parts.push_back(fmt::format("surface {}", human_bytes(e.surface_frame)));
  if (e.render_frame > 0) parts.push_back(fmt::format("pictures {}", human_bytes(e.render_frame)));
  // (stats.csv is a row a frame, in per_run: with --no-vtk a run of billions of frames is its rows alone)
  std::vector<std::string> once = {"stats.csv, its row a frame", "fragments.csv", "the summary"};
  if (e.checkpoints > 0) once.push_back(fmt::format("checkpoints {}", human_bytes(e.checkpoints)));
  if (e.fragment_meshes > 0) once.push_back(fmt::format("fragment meshes {}", human_bytes(e.fragment_meshes)));
  throw Error(fmt::format(
      "{}: the run would write about {} into {} ({} frames{}, at output.frame_rate = {:g} frames per simulated "
      "second; {} for {}), more than the {} free there (an earlier run's files there, which this run replaces, "
      "count as used); lower output.frame_rate, shorten output.duration (or --steps), {}{}or free disk space",
      scene.source, human_bytes(e.total()), dir.string(), e.frames,
      e.frame() > 0 ? fmt::format(" of {} each: {}", human_bytes(e.frame()), fmt::join(parts, ", ")) : std::string(),
      scene.output.frame_rate, human_bytes(e.per_run), fmt::join(once, ", "), human_bytes(free),
      e.vtk_frame > 0 ? "leave out the VTK frames (--no-vtk or output.vtk = false), " : "",
      e.fragment_meshes > 0 ? "raise output.fragment_min_automata or leave out the fragment meshes, " : ""));
}

std::vector<std::string> frame_subfolders(const SceneDef& scene) {
  std::vector<std::string> names;
  if (scene.output.vtk) names.emplace_back("frames");
  if (scene.output.surface && std::any_of(scene.objects.begin(), scene.objects.end(),
                                          [](const ObjectDef& o) { return o.shape == Shape::mesh; }))
    names.emplace_back("surface");
  return names;
}

std::vector<std::string> run_subfolders(const SceneDef& scene, bool render) {
  std::vector<std::string> names = frame_subfolders(scene);
  if (scene.output.fragments) names.emplace_back("fragments");
  names.emplace_back("checkpoints");  // (also without --checkpoint-every: Ctrl-C at a frame's end saves one)
  if (render) names.emplace_back("render");
  return names;
}

std::vector<std::pair<std::string, std::string>> mesh_inputs(const SceneDef& scene) {
  std::vector<std::pair<std::string, std::string>> out;
  for (std::size_t o = 0; o < scene.objects.size(); ++o) {
    const ObjectDef& obj = scene.objects[o];
    if (obj.shape == Shape::mesh) out.emplace_back(fmt::format("{}: object[{}].mesh", scene.source, o), obj.mesh);
    for (std::size_t r = 0; r < obj.regions.size(); ++r)
      if (!obj.regions[r].mesh.empty())
        out.emplace_back(fmt::format("{}: object[{}].region[{}].mesh", scene.source, o, r), obj.regions[r].mesh);
  }
  return out;
}

FrameWriter::FrameWriter(std::filesystem::path dir, const Model& model, const OutputDef& output)
    : dir_(std::move(dir)),
      model_(model),
      vtk_(output.vtk),
      links_(output.links),
      surface_(output.surface && model.surface.faces() > 0),
      surface_format_(output.surface_format),
      fragment_meshes_(output.fragments),
      fragment_min_automata_(output.fragment_min_automata) {
  if (vtk_) io::output_subfolder(dir_, "frames");
  if (surface_) io::output_subfolder(dir_, "surface");
}

std::size_t FrameWriter::write_fragment_meshes(const State& s, const analysis::Fragments& frags,
                                              const std::function<void(std::size_t, std::size_t)>& each,
                                              const std::function<void()>& poll) {
  if (!fragment_meshes_) return 0;
  io::check_no_linked_subfolders(dir_);
  io::output_subfolder(dir_, "fragments");
  const std::size_t total = analysis::meshed_fragments(frags, fragment_min_automata_).size();
  // Each mesh is written as it is made and let go: a shattered run's thousands of pieces are not all held.
  std::size_t written = 0;
  std::mutex lock;
  analysis::for_each_fragment_mesh(model_, s, frags, fragment_min_automata_, [&](analysis::FragmentMesh&& fm) {
    const auto path = dir_ / fmt::format("fragments/fragment_{:03d}.ply", fm.fragment);
    if (fm.float32) {
      const mesh::FloatMesh out = mesh::to_float(fm.mesh);
      fm.mesh = {};
      io::write_file_atomic(path, [&](std::ostream& os) { mesh::write_ply(os, out); });
    } else {
      io::write_file_atomic(path, [&](std::ostream& os) { mesh::write_ply(os, fm.mesh); });
    }
    const std::lock_guard<std::mutex> hold(lock);
    ++written;
    if (each) each(written, total);
  }, 3, poll);
  return written;
}

std::string FrameWriter::surface_name(std::int64_t frame, OutputDef::SurfaceFormat format) {
  return fmt::format("surface/surface_{:06d}.{}", frame, format == OutputDef::SurfaceFormat::obj ? "obj" : "ply");
}

analysis::Fragments FrameWriter::fragments(const State& s) const {
  return analysis::label_model_fragments(model_, s.intact.data());
}

FrameStats FrameWriter::stats(std::int64_t frame, const State& s, const analysis::Fragments& frags) const {
  FrameStats st;
  st.frame = frame;
  st.time = s.time;
  st.energy = compute_energies(model_, s);
  st.broken_displacement = s.broken_by[0];
  st.broken_stress = s.broken_by[1];
  st.fragments = frags.count;
  std::vector<double> mass(static_cast<std::size_t>(frags.count), 0.0);
  for (std::size_t a = 0; a < model_.size(); ++a) mass[frags.id[a]] += model_.mass[a];
  double largest = 0;
  for (double m : mass) largest = std::max(largest, m);
  st.largest_share = model_.total_mass > 0 ? largest / model_.total_mass : 0;
  st.grip_force = s.grip_force;
  return st;
}

void FrameWriter::write_frame(std::int64_t frame, const State& s, const analysis::Fragments& frags) {
  // (Checked at the start as well: a subfolder made a link while the run went on is not written through.)
  io::check_no_linked_subfolders(dir_);
  std::optional<mesh::FloatMesh> posed;
  if (surface_) {
    const mesh::FloatMesh& m = posed.emplace(analysis::posed_surface(model_, s, frags.id));
    const bool obj = surface_format_ == OutputDef::SurfaceFormat::obj;
    io::write_file_atomic(dir_ / surface_name(frame, surface_format_), [&](std::ostream& os) {
      if (obj) mesh::write_obj(os, m);
      else mesh::write_ply(os, m);
    });
  }
  if (!vtk_) return;
  const std::size_t n = model_.size();
  std::vector<float> xyz(3 * n), disp(3 * n), vel(3 * n), spin(3 * n), damage(n), seq(n), smean(n);
  std::vector<std::int32_t> group(n), cls(n), object(n);
  for (std::size_t a = 0; a < n; ++a) {
    const Vec3 p = to_vec3(s.x[a]);
    xyz[3 * a] = p.x;
    xyz[3 * a + 1] = p.y;
    xyz[3 * a + 2] = p.z;
    const Vec3 d = delta(model_.position0[a], s.x[a]);
    disp[3 * a] = d.x;
    disp[3 * a + 1] = d.y;
    disp[3 * a + 2] = d.z;
    const Vec3 v = to_vec3(s.v[a]), w = to_vec3(s.w[a]);
    vel[3 * a] = v.x;
    vel[3 * a + 1] = v.y;
    vel[3 * a + 2] = v.z;
    spin[3 * a] = w.x;
    spin[3 * a + 1] = w.y;
    spin[3 * a + 2] = w.z;
    seq[a] = von_mises(s.s[a]);
    smean[a] = mean_stress(s.s[a]);
    group[a] = model_.group[a];
    cls[a] = model_.strength_class[a];
    object[a] = model_.object[a];
  }
  automaton_damage(model_, s.intact.data(), s.link_damage.empty() ? nullptr : s.link_damage.data(), damage.data());
  // The orientations are written from the state as they are: (w, x, y, z) floats, as mca::Frame::orientation.
  static_assert(sizeof(Quat) == 4 * sizeof(float) && offsetof(Quat, w) == 0 && offsetof(Quat, z) == 3 * sizeof(float),
                "a Quat is four floats w, x, y, z");
  std::vector<io::PointField> fields = {
      {"velocity", 3, vel.data(), nullptr},
      {"displacement", 3, disp.data(), nullptr},
      {"angular_velocity", 3, spin.data(), nullptr},
      {"orientation", 4, reinterpret_cast<const float*>(s.q.data()), nullptr},
      {"group", 1, nullptr, group.data()},
      {"strength_class", 1, nullptr, cls.data()},
      {"object", 1, nullptr, object.data()},
      {"fragment", 1, nullptr, frags.id.data()},
      {"damage", 1, damage.data(), nullptr},
      {"equivalent_stress", 1, seq.data(), nullptr},
      {"mean_stress", 1, smean.data(), nullptr},
      {"radius", 1, model_.radius.data(), nullptr},
  };
  std::vector<std::array<std::uint32_t, 2>> lines;
  if (links_) {
    model_.for_each_link([&](std::size_t l, std::uint32_t i, std::uint32_t j, int) {
      if (s.intact[l]) lines.push_back({i, j});
    });
  }
  const std::string name = fmt::format("frames/automata_{:06d}.vtu", frame);
  io::write_vtu(dir_ / name, n, xyz.data(), fields, links_ ? &lines : nullptr);
  automata_pvd_.emplace_back(s.time, name);
  io::write_pvd(dir_ / "automata.pvd", automata_pvd_);

  // With the VTK frames, the surface for ParaView, whose PLY reader drops the faces' fragment and whose file
  // series of PLY counts frames, not seconds: a PolyData with a `fragment` cell array, in surface.pvd at the
  // frame's time (after the frame's automata: a frame whose automata cannot be written lists no surface).
  if (posed) {
    const std::string name = fmt::format("frames/surface_{:06d}.vtp", frame);
    io::write_vtp(dir_ / name, posed->vertices.size(), posed->vertices.empty() ? nullptr : posed->vertices.front().data(),
                  posed->faces, posed->face_value_name, posed->face_values);
    surface_pvd_.emplace_back(s.time, name);
    io::write_pvd(dir_ / "surface.pvd", surface_pvd_);
  }

  if (!model_.projectiles.empty()) {
    const std::size_t np = model_.projectiles.size();
    std::vector<float> pxyz(3 * np), pvel(3 * np), prad(np);
    for (std::size_t p = 0; p < np; ++p) {
      const auto& ps = s.projectiles[p];
      pxyz[3 * p] = static_cast<float>(ps.position.x);
      pxyz[3 * p + 1] = static_cast<float>(ps.position.y);
      pxyz[3 * p + 2] = static_cast<float>(ps.position.z);
      pvel[3 * p] = static_cast<float>(ps.velocity.x);
      pvel[3 * p + 1] = static_cast<float>(ps.velocity.y);
      pvel[3 * p + 2] = static_cast<float>(ps.velocity.z);
      prad[p] = model_.projectiles[p].radius;
    }
    const std::string pname = fmt::format("frames/projectiles_{:06d}.vtu", frame);
    io::write_vtu(dir_ / pname, np, pxyz.data(),
                  {{"velocity", 3, pvel.data(), nullptr}, {"radius", 1, prad.data(), nullptr}});
    projectile_pvd_.emplace_back(s.time, pname);
    io::write_pvd(dir_ / "projectiles.pvd", projectile_pvd_);
  }
}

namespace {

constexpr RunFile kRunFiles[] = {
    {RunPart::scene, "", "scene.toml", ""},
    {RunPart::stats, "", "stats.csv", ""},
    {RunPart::end, "", "summary.json", ""},
    {RunPart::end, "", "fragments.csv", ""},
    {RunPart::end, "fragments", "fragment_", ".ply"},
    {RunPart::plots, "render", "energies.png", ""},
    {RunPart::plots, "render", "broken_links.png", ""},
    {RunPart::plots, "render", "fragment_masses.png", ""},
    {RunPart::frames, "", "automata.pvd", ""},
    {RunPart::frames, "", "projectiles.pvd", ""},
    {RunPart::frames, "", "surface.pvd", ""},
    {RunPart::frames, "frames", "automata_", ".vtu"},
    {RunPart::frames, "frames", "projectiles_", ".vtu"},
    {RunPart::frames, "frames", "surface_", ".vtp"},
    {RunPart::frames, "surface", "surface_", ".ply"},
    {RunPart::frames, "surface", "surface_", ".obj"},
    {RunPart::checkpoints, "checkpoints", "frame_", ".mcack"},
    {RunPart::rendering, "render", "render.json", ""},
    {RunPart::rendering, "render", "video.mp4", ""},
    {RunPart::rendering, "render", "contact_sheet.png", ""},
    {RunPart::rendering, "render", "frame_", ".png"},
};

// Calls `found(name, regular, numbered)` for each entry of `dir` at a name of `parts` (relative to dir, in
// the table's order): whether it is a regular file (through a link) or something else (a folder, a FIFO),
// and whether the name is a numbered one.
template <class Found>
void visit_run_names(const std::filesystem::path& dir, std::initializer_list<RunPart> parts, Found found) {
  std::error_code ec;
  for (const RunFile& f : kRunFiles) {
    if (std::find(parts.begin(), parts.end(), f.part) == parts.end()) continue;
    const std::filesystem::path folder = dir / f.folder;
    const std::string prefix = *f.folder ? std::string(f.folder) + "/" : std::string();
    if (!*f.extension) {
      // (A broken link is there too: exists() follows it.)
      if (std::filesystem::exists(std::filesystem::symlink_status(folder / f.name, ec)))
        found(prefix + f.name, std::filesystem::is_regular_file(folder / f.name, ec), false);
      continue;
    }
    if (!std::filesystem::is_directory(folder, ec)) continue;
    std::vector<std::pair<std::string, bool>> names;
    for (const auto& e : std::filesystem::directory_iterator(folder, ec))
      if (io::numbered(e.path().filename().string(), f.name, f.extension))
        names.emplace_back(prefix + e.path().filename().string(), e.is_regular_file(ec));
    std::sort(names.begin(), names.end());
    for (const auto& [name, regular] : names) found(name, regular, true);
  }
}

constexpr std::initializer_list<RunPart> kAllParts = {RunPart::scene,  RunPart::stats,       RunPart::end,
                                                      RunPart::plots,  RunPart::frames,      RunPart::checkpoints,
                                                      RunPart::rendering};

}  // namespace

std::vector<std::string> run_files_in(const std::filesystem::path& dir, std::initializer_list<RunPart> parts) {
  std::vector<std::string> found;
  // (A fixed name is listed whatever is there: a folder of the name is not left alone by a removal either;
  // a numbered one only as a regular file.)
  visit_run_names(dir, parts, [&](const std::string& name, bool regular, bool numbered) {
    if (regular || !numbered) found.push_back(name);
  });
  return found;
}

void check_run_names_are_files(const std::filesystem::path& dir) {
  visit_run_names(dir, kAllParts, [&](const std::string& name, bool regular, bool) {
    if (regular) return;
    std::error_code ec;
    const bool folder = std::filesystem::is_directory(dir / name, ec);
    throw Error(fmt::format("'{}' is {} at the name of a file a run writes or replaces there: the run would stop "
                            "when it came to it (a checkpoint or a frame hours in); move or remove it, or write to "
                            "another folder",
                            (dir / name).string(),
                            folder ? "a folder" : "not a regular file (a FIFO, a device, a broken link)"));
  });
}

std::size_t stage_run_files(io::StagedRemoval& removal, const std::filesystem::path& dir,
                            std::initializer_list<RunPart> parts) {
  std::size_t staged = 0;
  for (const std::string& name : run_files_in(dir, parts)) staged += removal.stage(dir / name);
  return staged;
}

std::size_t remove_run_files(const std::filesystem::path& dir, std::initializer_list<RunPart> parts) {
  io::StagedRemoval removal(dir);
  const std::size_t removed = stage_run_files(removal, dir, parts);
  removal.commit();
  return removed;
}

void remove_empty_output_folders(const std::filesystem::path& dir, bool rendering, bool ends_only) {
  for (const std::string& sub : run_file_folders()) {
    if (ends_only && sub != "fragments" && sub != "render") continue;
    std::error_code ec;
    if (rendering && sub == "render") continue;
    // (A symbolic link is never removed: a subfolder that is one is refused before, check_output_subfolders.)
    if (!std::filesystem::is_symlink(dir / sub, ec) && std::filesystem::is_directory(dir / sub, ec) &&
        std::filesystem::is_empty(dir / sub, ec) && !ec)
      std::filesystem::remove(dir / sub, ec);
  }
}

std::vector<std::string> run_file_folders() {
  std::vector<std::string> folders;
  for (const RunFile& f : kRunFiles)
    if (*f.folder && std::find(folders.begin(), folders.end(), f.folder) == folders.end())
      folders.emplace_back(f.folder);
  return folders;
}

namespace {
SceneHead scene_head_of(const std::filesystem::path& file) {
  std::string head;
  if (std::ifstream in(file); in) {
    head.resize(4096);
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
  }
  SceneHead h;
  const std::size_t mark = head.find(io::kWrittenByMca);
  h.by_mca = mark != std::string::npos && head.find('\n') + 1 >= mark;  // on the first line, or after the comment
  long long steps = 0;
  if (h.by_mca && std::sscanf(head.c_str(), "# This run: --steps %lld ", &steps) == 1) h.steps = steps;
  return h;
}
}  // namespace

SceneHead read_scene_head(const std::filesystem::path& dir) { return scene_head_of(dir / "scene.toml"); }

std::string summary_status(const std::filesystem::path& dir) {
  std::string status;
  if (std::ifstream in(dir / "summary.json"); in) {
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_object() && j.contains("status") && j["status"].is_string()) status = j["status"].get<std::string>();
  }
  return status;
}

namespace {

// check_folder_is_a_runs on the run a folder holds: files of its names that no run of mca wrote, or a run
// that did not finish.
void check_earlier_run(const std::filesystem::path& dir, std::string_view another, std::string_view continue_with) {
  const std::string folder = text::shell_word(dir.string());
  std::error_code ec;
  if (read_scene_head(dir).by_mca) {
    const auto saved = io::list_checkpoints(dir / "checkpoints");
    if (saved.empty()) return;
    if (summary_status(dir) == "finished") return;
    throw Error(fmt::format("{} holds a run that did not finish (its newest checkpoint: {}); continue it with: {}. To "
                            "start it afresh instead, remove its checkpoints first (rm -r {}), or give {}",
                            dir.string(), saved.back().filename().string(),
                            continue_with.empty() ? "mca resume " + folder : std::string(continue_with),
                            text::shell_word((dir / "checkpoints").string()), another));
  }
  const std::vector<std::string> found =
      run_files_in(dir, {RunPart::scene, RunPart::stats, RunPart::end, RunPart::plots, RunPart::frames,
                         RunPart::checkpoints, RunPart::rendering});
  if (found.empty()) return;
  const std::size_t shown = std::min<std::size_t>(found.size(), 4);
  throw Error(fmt::format(
      "{} holds {}{}, of the names a run of mca writes, but no run of mca (its scene.toml {}); the run would replace "
      "or remove them. Give {}, or move them out of this one",
      dir.string(), fmt::join(found.begin(), found.begin() + static_cast<std::ptrdiff_t>(shown), ", "),
      found.size() > shown ? fmt::format(" and {} more", found.size() - shown) : "",
      std::filesystem::exists(dir / "scene.toml", ec) ? "was not written by mca" : "is missing", another));
}

}  // namespace

void check_folder_is_a_runs(const std::filesystem::path& dir, std::string_view another,
                            std::string_view continue_with) {
  check_earlier_run(dir, another, continue_with);
  check_run_names_are_files(dir);
}

namespace {
// What put_back_set_aside found in `dir`, said (none where it found nothing).
std::vector<std::string> set_aside_notes(const std::filesystem::path& dir, const io::SetAsideFound& found) {
  std::vector<std::string> notes;
  const auto one = [](std::size_t n, const char* single, const char* plural) { return n == 1 ? single : plural; };
  if (found.restored > 0)
    notes.push_back(fmt::format("{} of the run in {} that a session stopped before it began had set aside {} back at "
                                "{}",
                                text::count(found.restored, "file"), dir.string(), one(found.restored, "is", "are"),
                                one(found.restored, "its name", "their names")));
  if (found.removed > 0)
    notes.push_back(fmt::format("{} in {} that a session had set aside to remove {} removed",
                                text::count(found.removed, "file"), dir.string(), one(found.removed, "is", "are")));
  if (found.withdrawn > 0)
    notes.push_back(fmt::format("{} that a session stopped before its run began had written in {} {} removed",
                                text::count(found.withdrawn, "file"), dir.string(), one(found.withdrawn, "is", "are")));
  return notes;
}

// Whether `name` in the run folder's `folder` ("" for the folder itself) is a name of the table.
bool is_run_file(const std::string& folder, const std::string& name) {
  return std::any_of(std::begin(kRunFiles), std::end(kRunFiles), [&](const RunFile& f) {
    return folder == f.folder && (*f.extension ? io::numbered(name, f.name, f.extension).has_value() : name == f.name);
  });
}

io::SetAsideFound put_back_set_aside(const std::filesystem::path& dir) {
  // Only in the folder of a run of mca (its scene.toml by mca, or set aside, or none yet where a session
  // marked the one it was about to write: killed there, it left nothing else), and only names of the table: a
  // user's summary.json.1.2.mca-aside in a folder of their own, or notes.txt.1.2.mca-aside, is left alone.
  bool run = read_scene_head(dir).by_mca, marked = false;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (!run && name.starts_with("scene.toml.") && name.ends_with(".mca-aside")) run = scene_head_of(e.path()).by_mca;
    if (io::marked_name(e.path()) == "scene.toml") marked = true;
  }
  if (!run && marked && !std::filesystem::exists(std::filesystem::symlink_status(dir / "scene.toml", ec))) run = true;
  if (!run) return {};
  // (A marker of a run file that a new run had set aside as no session's, stage_earlier_run: back too, as
  // the folder was.)
  return io::put_back_set_aside(dir, run_file_folders(), [](const std::string& folder, const std::string& name) {
    return is_run_file(folder, name) || is_run_file(folder, io::marker_of(name));
  });
}
}  // namespace

void stage_earlier_run(io::StagedRemoval& removal, const std::filesystem::path& dir) {
  stage_run_files(removal, dir, kEarlierRun);
  removal.stage(dir / "scene.toml");
  std::vector<std::filesystem::path> strays;
  std::error_code ec;
  std::vector<std::string> folders = run_file_folders();
  folders.insert(folders.begin(), "");
  for (const std::string& folder : folders) {
    const std::filesystem::path d = folder.empty() ? dir : dir / folder;
    if (!std::filesystem::is_directory(std::filesystem::symlink_status(d, ec))) continue;  // (never through a link)
    for (const auto& e : std::filesystem::directory_iterator(d, ec))
      if (const std::string marked = io::marked_name(e.path()); !marked.empty() && is_run_file(folder, marked))
        strays.push_back(e.path());
  }
  for (const auto& p : strays) removal.stage(p);
}

std::vector<std::string> FrameWriter::recover_folder(const std::filesystem::path& dir) {
  std::vector<std::string> notes = set_aside_notes(dir, put_back_set_aside(dir));
  io::remove_stale_temporaries(dir);
  for (const std::string& sub : run_file_folders()) io::remove_stale_temporaries(dir / sub);
  // (And a subfolder a stopped or killed session made and left empty, render/: the writers make them again.)
  remove_empty_output_folders(dir, false);
  return notes;
}

std::vector<std::int64_t> FrameWriter::restore(std::int64_t frames,
                                               const std::function<double(std::int64_t)>& time_of) {
  automata_pvd_.clear();
  projectile_pvd_.clear();
  surface_pvd_.clear();
  // A frame is listed whole or not at all: collections that each left out their own missing files no
  // longer lined up (a reader pairs their entries), and a frame written again was listed twice.
  std::vector<std::int64_t> missing;
  // A file is there whole: a regular file, not empty, and a VTK file ending as the writer ends it, with
  // "</VTKFile>" (then white space alone: an editor's newline is fine). An empty or cut-short frame, an
  // interrupted copy of the folder, was listed, and ParaView read no points there.
  const auto there = [&](const std::string& name) {
    const std::filesystem::path p = dir_ / name;
    std::error_code ec;
    const auto size = std::filesystem::file_size(p, ec);
    if (ec || size == 0 || !std::filesystem::is_regular_file(p, ec)) return false;
    if (!name.ends_with(".vtu") && !name.ends_with(".vtp")) return true;
    const std::size_t n = std::min<std::size_t>(size, 64);
    std::ifstream in(p, std::ios::binary);
    std::string tail(n, '\0');
    in.seekg(static_cast<std::streamoff>(size - n));
    if (!in.read(tail.data(), static_cast<std::streamsize>(n))) return false;
    tail.erase(tail.find_last_not_of(" \t\r\n") + 1);
    return tail.ends_with("</VTKFile>");
  };
  for (std::int64_t f = 0; f < frames; ++f) {
    const std::string automata = fmt::format("frames/automata_{:06d}.vtu", f);
    const std::string surface = fmt::format("frames/surface_{:06d}.vtp", f);
    const std::string projectiles = fmt::format("frames/projectiles_{:06d}.vtu", f);
    const bool whole = (!surface_ || there(surface_name(f, surface_format_))) &&
                       (!vtk_ || (there(automata) && (!surface_ || there(surface)) &&
                                  (model_.projectiles.empty() || there(projectiles))));
    if (!whole) {
      missing.push_back(f);
      continue;
    }
    if (!vtk_) continue;
    const double t = time_of(f);
    automata_pvd_.emplace_back(t, automata);
    if (surface_) surface_pvd_.emplace_back(t, surface);
    if (!model_.projectiles.empty()) projectile_pvd_.emplace_back(t, projectiles);
  }
  // Written now, not with the next frame: a run with no frame left to write keeps them.
  if (vtk_) {
    io::write_pvd(dir_ / "automata.pvd", automata_pvd_);
    if (surface_) io::write_pvd(dir_ / "surface.pvd", surface_pvd_);
    if (!model_.projectiles.empty()) io::write_pvd(dir_ / "projectiles.pvd", projectile_pvd_);
  }
  return missing;
}

std::vector<std::string> FrameWriter::restored_files() const {
  std::vector<std::string> names = {"stats.csv"};
  if (vtk_) {
    names.emplace_back("automata.pvd");
    if (surface_) names.emplace_back("surface.pvd");
    if (!model_.projectiles.empty()) names.emplace_back("projectiles.pvd");
  }
  return names;
}

std::vector<std::string> FrameWriter::stats_header(const Model& model) {
  // total_energy = kinetic + elastic + projectile kinetic (elastic includes the contact springs);
  // energy_balance = total_energy - every external work: constant but for damping, friction and breaks.
  std::vector<std::string> h = {"frame", "time", "kinetic_energy", "elastic_energy", "contact_energy",
                                "projectile_kinetic_energy", "gravity_work", "grip_work", "load_work",
                                "projectile_work", "total_energy", "energy_balance", "broken_displacement",
                                "broken_stress", "broken_total", "fragments", "largest_fragment_mass_share"};
  for (const auto& g : model.grip_names) {
    h.push_back(g + "_force_x");
    h.push_back(g + "_force_y");
    h.push_back(g + "_force_z");
  }
  return h;
}

std::string FrameWriter::format_row(const FrameStats& r) const {
  const auto& e = r.energy;
  std::string line = fmt::format(
      "{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{},{},{},{},{:.6f}", r.frame, r.time,
      e.kinetic, e.elastic, e.contact, e.projectile_kinetic, e.gravity_work, e.grip_work, e.load_work,
      e.projectile_work, e.total(), e.total() - e.external_work(), r.broken_displacement, r.broken_stress,
      r.broken_displacement + r.broken_stress, r.fragments, r.largest_share);
  for (const auto& f : r.grip_force) line += fmt::format(",{:.9g},{:.9g},{:.9g}", f.x, f.y, f.z);
  return line;
}

FrameWriter::~FrameWriter() {
  if (stats_fd_ >= 0) ::close(stats_fd_);
}

// stats.csv grows by one row per frame. Rewriting it whole each frame (atomically, like the other
// files) made a run quadratic in its frame count; appending keeps it linear, and a row is one write
// call, so a reader or a killed run sees only whole rows.
void FrameWriter::start_stats(const std::vector<std::string>& rows) {
  const auto path = dir_ / "stats.csv";
  if (stats_fd_ >= 0) ::close(stats_fd_);
  stats_fd_ = -1;
  io::write_file_atomic(path, [&](std::ostream& os) {
    const auto h = stats_header(model_);
    for (std::size_t k = 0; k < h.size(); ++k) os << (k ? "," : "") << h[k];
    os << "\n";
    for (const auto& r : rows) os << r << "\n";
  }, false);
  stats_fd_ = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
  if (stats_fd_ < 0)
    throw Error(fmt::format("could not open '{}' to append to it: {}; check the output folder", path.string(),
                            std::strerror(errno)));
}

void FrameWriter::append_stats(const std::string& row) {
  const auto path = dir_ / "stats.csv";
  if (stats_fd_ < 0) throw Error(fmt::format("'{}' was not started (start_stats)", path.string()));
  const std::string line = row + "\n";
  // A write can take part of the row before the disk fills: the file is then cut back to where the row
  // began, so that it holds whole rows only.
  const off_t before = ::lseek(stats_fd_, 0, SEEK_END);
  std::size_t done = 0;
  while (done < line.size()) {
    const ssize_t n = ::write(stats_fd_, line.data() + done, line.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : ENOSPC;  // (a write of nothing: no room)
      if (done > 0 && before >= 0) (void)!::ftruncate(stats_fd_, before);
      throw Error(fmt::format("could not write '{}': {}; {}", path.string(),
                              n < 0 ? std::strerror(err) : "nothing written", io::write_failure_fix(err)));
    }
    done += static_cast<std::size_t>(n);
  }
}

void FrameWriter::sync_stats() {
  if (stats_fd_ >= 0 && ::fdatasync(stats_fd_) != 0) {
    const int err = errno;
    throw Error(fmt::format("could not write '{}' to the disk: {}; {}", (dir_ / "stats.csv").string(),
                            std::strerror(err), io::write_failure_fix(err)));
  }
}

}  // namespace mca::app
