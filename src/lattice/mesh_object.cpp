#include "lattice/mesh_object.hpp"

#include <chrono>
#include <cmath>
#include <fmt/format.h>

#include "mca/error.hpp"

namespace mca::lattice {
namespace {

std::string where(const SceneDef& scene, std::size_t index) {
  const ObjectDef& o = scene.objects[index];
  return fmt::format("{}: object[{}] '{}'", scene.source, index, o.name);
}

// Reads a mesh file, naming the scene and the key in front of the loader's message.
mesh::TriMesh read(const SceneDef& scene, const std::string& key, const std::string& path) {
  try {
    return mesh::read_mesh(path);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}: {}", scene.source, key, e.what()));
  }
}

// Moves the file's coordinates into the object frame: centre of `b` to the origin, times `scale`.
void to_object_frame(mesh::TriMesh& m, const mesh::Bounds& b, double scale) {
  const mesh::Point c = b.centre();
  for (auto& v : m.vertices)
    for (int a = 0; a < 3; ++a) v[a] = (v[a] - c[a]) * scale;
}

std::string extent_text(const mesh::Point& e, const char* unit) {
  return fmt::format("{:.4g} x {:.4g} x {:.4g}{}", e[0], e[1], e[2], unit);
}

}  // namespace

MeshObject prepare_mesh_object(const SceneDef& scene, std::size_t index) {
  const ObjectDef& o = scene.objects[index];
  const std::string key = fmt::format("object[{}].mesh", index);
  MeshObject m;
  m.mesh = read(scene, key, o.mesh);
  m.file_vertices = m.mesh.vertices.size();
  m.file_bounds = mesh::bounds(m.mesh);
  m.topology = mesh::topology(m.mesh);
  const mesh::Point e = m.file_bounds.extent();
  const double largest = m.file_bounds.largest_extent();
  m.scale = o.fit_size > 0 ? o.fit_size / largest : o.scale;
  for (int a = 0; a < 3; ++a) {
    if (!(e[a] > 1e-9 * largest)) {
      throw Error(fmt::format("{}: the mesh {} is flat: its extent along {} is {:g} (the box is {} in the file's "
                              "units), a surface with no inside to fill with automata; give a closed solid",
                              where(scene, index), o.mesh, "xyz"[a], e[a], extent_text(e, "")));
    }
  }
  if (!std::isfinite(largest * m.scale) || largest * m.scale > 1e7) {
    throw Error(fmt::format("{}: the mesh {} is {} in the file's units, {:.4g} m across at scale {:g}; check scale "
                            "(the factor from the file's units to metres) or give fit_size",
                            where(scene, index), o.mesh, extent_text(e, ""), largest * m.scale, m.scale));
  }
  to_object_frame(m.mesh, m.file_bounds, m.scale);
  m.volume = std::fabs(mesh::signed_volume(m.mesh));
  for (std::size_t r = 0; r < o.regions.size(); ++r) {
    if (o.regions[r].shape != Shape::mesh) {
      m.regions.emplace_back();
      continue;
    }
    mesh::TriMesh rm = read(scene, fmt::format("object[{}].region[{}].mesh", index, r), o.regions[r].mesh);
    // The region shares the object mesh's frame: the same centre and scale.
    to_object_frame(rm, m.file_bounds, m.scale);
    m.regions.emplace_back(std::move(rm));
  }
  return m;
}

MeshFillResult fill_mesh_object(const SceneDef& scene, std::size_t index, const MeshObject& m,
                                const mesh::CellBox& box, bool with_regions) {
  const ObjectDef& o = scene.objects[index];
  const double d = box.d;
  const double hole = m.topology.largest_hole * m.scale;
  // Holes up to about a cell wide are closed by the signed distance's band; wider ones let the outside in.
  if (m.topology.holes > 0 && hole > 1.5 * d) {
    throw Error(fmt::format(
        "{}: the mesh {} is open: {} boundary edges in {} hole{}, the largest {:.4g} m across ({:.3g} cells at spacing "
        "{:.4g} m), and a volume fill needs a closed surface (holes under about a cell are closed). Repair the mesh "
        "(MeshLab: Filters > Remeshing > Close Holes; Blender: Mesh > Clean Up > Fill Holes) or increase "
        "solver.spacing above {:.3g} m",
        where(scene, index), o.mesh, m.topology.boundary_edges, m.topology.holes, m.topology.holes == 1 ? "" : "s", hole,
        hole / d, d, hole / 1.5));
  }
  const auto t0 = std::chrono::steady_clock::now();
  MeshFillResult r;
  r.inside = mesh::interior_cells(m.mesh, box);
  for (auto c : r.inside) r.count += c;
  const double expected = m.volume / (d * d * d);
  const double ten_k = std::cbrt(m.volume / 1e4);
  if (r.count == 0) {
    throw Error(fmt::format("{}: the mesh {} ({:.4g} x {:.4g} x {:.4g} m after scaling, {:.4g} m^3) holds no lattice "
                            "cell at spacing {:.4g} m; decrease solver.spacing (about {:.3g} m gives 10,000 automata) "
                            "or scale the mesh up",
                            where(scene, index), o.mesh, m.extent(0), m.extent(1), m.extent(2), m.volume, d, ten_k));
  }
  // A surface whose sign cannot be told (holes, or two shells crossing) fills far less or more than it
  // encloses.
  if (expected > 200 && (r.count < 0.5 * expected || r.count > 2.0 * expected)) {
    throw Error(fmt::format(
        "{}: filling the mesh {} gave {} automata where its enclosed volume {:.4g} m^3 gives about {:.0f} at spacing "
        "{:.4g} m: its inside cannot be told from its outside ({} boundary edges, {} non-manifold edges). Repair "
        "the mesh into one closed surface (MeshLab: Close Holes, Remove Duplicate Faces; Blender: 3D-Print toolbox)",
        where(scene, index), o.mesh, r.count, m.volume, expected, d, m.topology.boundary_edges,
        m.topology.non_manifold_edges));
  }
  if (with_regions) {
    for (std::size_t k = 0; k < m.regions.size(); ++k) {
      r.regions.emplace_back();
      if (!m.regions[k]) continue;
      r.regions.back() = mesh::interior_cells(*m.regions[k], box);
      std::int64_t in_region = 0;
      for (std::size_t c = 0; c < r.inside.size(); ++c) in_region += r.inside[c] & r.regions.back()[c];
      if (in_region == 0) {
        throw Error(fmt::format("{}: region[{}] (mesh {}) holds no automaton of the object at spacing {:.4g} m; its "
                                "mesh must lie inside the object's, in the same units and frame as the object's file",
                                where(scene, index), k, o.regions[k].mesh, d));
      }
    }
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace mca::lattice
