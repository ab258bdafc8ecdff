#include "lattice/mesh_object.hpp"

#include "analysis/fragments.hpp"

#include "lattice/lattice.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <map>

#include "core/text.hpp"
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
    return mesh::read_mesh(path, scene.solver.max_memory_gb * 1e9);
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

// Whether point p is inside the triangles `faces` of m: the parity of the crossings of a ray from p (a
// direction no mesh aligns with by accident).
bool inside_by_parity(const mesh::TriMesh& m, const std::vector<std::uint32_t>& faces, const mesh::Point& p) {
  const double dir[3] = {1.0, 0.0012345, 0.0023456};
  int crossings = 0;
  for (auto f : faces) {
    const auto& a = m.vertices[m.faces[f][0]];
    const auto& b = m.vertices[m.faces[f][1]];
    const auto& c = m.vertices[m.faces[f][2]];
    const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double h[3] = {dir[1] * e2[2] - dir[2] * e2[1], dir[2] * e2[0] - dir[0] * e2[2], dir[0] * e2[1] - dir[1] * e2[0]};
    const double det = e1[0] * h[0] + e1[1] * h[1] + e1[2] * h[2];
    if (det == 0) continue;
    const double s[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
    const double u = (s[0] * h[0] + s[1] * h[1] + s[2] * h[2]) / det;
    if (u < 0 || u > 1) continue;
    const double q[3] = {s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]};
    const double v = (dir[0] * q[0] + dir[1] * q[1] + dir[2] * q[2]) / det;
    if (v < 0 || u + v > 1) continue;
    if ((e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det > 0) ++crossings;
  }
  return crossings % 2 == 1;
}

// Whether box a lies in box b (touching allowed: a cavity may touch the surface around it).
bool within(const mesh::Bounds& a, const mesh::Bounds& b) {
  const double tol = 1e-9 * b.largest_extent();
  for (int k = 0; k < 3; ++k)
    if (!(a.lo[k] >= b.lo[k] - tol && a.hi[k] <= b.hi[k] + tol)) return false;
  return true;
}

// A point of a shell off its vertices (where another shell may touch it): its largest triangle's centroid.
mesh::Point probe_point(const mesh::TriMesh& m, const mesh::Shell& sh) {
  double best = -1;
  mesh::Point p{0, 0, 0};
  for (auto f : sh.faces) {
    const auto& a = m.vertices[m.faces[f][0]];
    const auto& b = m.vertices[m.faces[f][1]];
    const auto& c = m.vertices[m.faces[f][2]];
    const double area2 = mesh::twice_area(a, b, c);
    if (area2 > best) {
      best = area2;
      for (int k = 0; k < 3; ++k) p[k] = (a[k] + b[k] + c[k]) / 3.0;
    }
  }
  return p;
}

bool same_shell(const mesh::Shell& a, const mesh::Shell& b) {
  const double tol = 1e-9 * std::max(a.bounds.largest_extent(), b.bounds.largest_extent());
  for (int k = 0; k < 3; ++k)
    if (std::fabs(a.bounds.lo[k] - b.bounds.lo[k]) > tol || std::fabs(a.bounds.hi[k] - b.bounds.hi[k]) > tol) return false;
  return std::fabs(a.volume - b.volume) <= 1e-6 * std::max(a.volume, b.volume);
}

// A shell joined to another only through edges of more than two triangles (two cubes sharing an edge)
// is filled as one surface, and the fill of that surface puts cells outside both next to the shared
// edge (12 for two cubes of 10 cells). Such a shell is split into the pieces its edges of exactly two
// triangles join, when each piece is closed and manifold on its own; otherwise it stays whole.
std::vector<mesh::Shell> split_at_non_manifold_edges(const mesh::TriMesh& m, std::vector<mesh::Shell> in) {
  std::vector<mesh::Shell> out;
  for (mesh::Shell& sh : in) {
    if (sh.manifold) {
      out.push_back(std::move(sh));
      continue;
    }
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> users;  // edge -> faces
    for (std::uint32_t k = 0; k < sh.faces.size(); ++k) {
      const mesh::Triangle& t = m.faces[sh.faces[k]];
      for (int e = 0; e < 3; ++e) users[std::minmax(t[e], t[(e + 1) % 3])].push_back(k);
    }
    std::vector<std::uint32_t> parent(sh.faces.size());
    for (std::uint32_t k = 0; k < parent.size(); ++k) parent[k] = k;
    auto root = [&](std::uint32_t x) {
      while (parent[x] != x) x = parent[x] = parent[parent[x]];
      return x;
    };
    for (const auto& [edge, faces] : users)
      if (faces.size() == 2) parent[root(faces[0])] = root(faces[1]);
    std::map<std::uint32_t, std::vector<std::uint32_t>> pieces;  // root -> faces of the mesh, increasing
    for (std::uint32_t k = 0; k < sh.faces.size(); ++k) pieces[root(k)].push_back(sh.faces[k]);
    if (pieces.size() < 2) {
      out.push_back(std::move(sh));
      continue;
    }
    std::vector<mesh::Shell> split;
    for (const auto& [r, faces] : pieces) {
      mesh::TriMesh piece;  // its own vertices only
      std::map<std::uint32_t, std::uint32_t> index;
      for (auto f : faces) {
        mesh::Triangle t = m.faces[f];
        for (auto& v : t) {
          const auto [it, fresh] = index.try_emplace(v, static_cast<std::uint32_t>(piece.vertices.size()));
          if (fresh) piece.vertices.push_back(m.vertices[v]);
          v = it->second;
        }
        piece.faces.push_back(t);
      }
      std::vector<mesh::Shell> one = mesh::shells(piece);
      if (one.size() != 1 || !one[0].manifold) break;
      for (auto& f : one[0].faces) f = faces[f];
      split.push_back(std::move(one[0]));
    }
    if (split.size() != pieces.size()) {
      out.push_back(std::move(sh));
      continue;
    }
    for (auto& p : split) out.push_back(std::move(p));
  }
  return out;
}

// The solid of a mesh in the object frame: its shells, their nesting and its volume.
Solid make_solid(std::string file, mesh::TriMesh m) {
  Solid s;
  s.file = std::move(file);
  s.topology = mesh::topology(m);
  s.shells = split_at_non_manifold_edges(m, mesh::shells(m));
  const std::size_t n = s.shells.size();
  s.depth.assign(n, 0);
  // A shell of triangles without area encloses nothing (inside a solid it was taken for a cavity and
  // removed a cell): skipped like a repeated shell.
  for (std::size_t a = 0; a < n; ++a)
    if (std::all_of(s.shells[a].faces.begin(), s.shells[a].faces.end(),
                    [&](std::uint32_t f) { return mesh::zero_area(m, m.faces[f]); }))
      s.depth[a] = -1;
  for (std::size_t a = 0; a < n; ++a)
    for (std::size_t b = 0; b < a && s.depth[a] >= 0; ++b)
      if (s.depth[b] >= 0 && same_shell(s.shells[a], s.shells[b])) s.depth[a] = -1;
  for (std::size_t a = 0; a < n; ++a) {
    if (s.depth[a] < 0) continue;
    const mesh::Point probe = probe_point(m, s.shells[a]);
    for (std::size_t b = 0; b < n; ++b)
      if (b != a && s.depth[b] >= 0 && within(s.shells[a].bounds, s.shells[b].bounds) &&
          (!within(s.shells[b].bounds, s.shells[a].bounds) || s.shells[a].volume < s.shells[b].volume) &&
          inside_by_parity(m, s.shells[b].faces, probe))
        ++s.depth[a];
  }
  for (std::size_t a = 0; a < n; ++a) {
    if (s.depth[a] < 0) continue;
    s.volume += (s.depth[a] % 2 == 0 ? 1 : -1) * s.shells[a].volume;
    s.manifold = s.manifold && s.shells[a].manifold;
  }
  s.mesh = std::move(m);
  return s;
}

// The cells of `box` inside the solid: each shell filled on the part of the box around it, solid shells
// added and cavities taken away in order of depth. With `labels`, a cell inside holds which solid shell
// put it there (1 + its rank among the solid shells in that order, 255 for the 255th and later), else 1.
std::vector<std::uint8_t> solid_cells(const Solid& s, const mesh::CellBox& box, bool labels = false) {
  if (s.shells.size() == 1) return mesh::interior_cells(s.mesh, box);
  std::vector<std::uint8_t> inside(static_cast<std::size_t>(box.cells()), 0);
  std::vector<std::size_t> order;
  for (std::size_t k = 0; k < s.shells.size(); ++k)
    if (s.depth[k] >= 0) order.push_back(k);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return s.depth[a] < s.depth[b]; });
  int solid_rank = 0;
  for (std::size_t k : order) {
    const mesh::Shell& sh = s.shells[k];
    std::int64_t lo[3], hi[3];
    mesh::CellBox sub;
    sub.d = box.d;
    bool empty = false;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::floor((sh.bounds.lo[a] - box.origin[a]) / box.d)) - 2);
      hi[a] = std::min<std::int64_t>(box.n[a] - 1, static_cast<std::int64_t>(std::ceil((sh.bounds.hi[a] - box.origin[a]) / box.d)) + 2);
      empty = empty || hi[a] < lo[a];
      sub.n[a] = hi[a] - lo[a] + 1;
      sub.origin[a] = box.origin[a] + static_cast<double>(lo[a]) * box.d;
    }
    if (empty) continue;
    const bool add = s.depth[k] % 2 == 0;
    const std::uint8_t value = labels && add ? static_cast<std::uint8_t>(std::min(255, ++solid_rank)) : 1;
    const std::vector<std::uint8_t> part = mesh::interior_cells(s.mesh, sub, &sh.faces);
    std::size_t c = 0;
    for (std::int64_t kk = 0; kk < sub.n[2]; ++kk)
      for (std::int64_t jj = 0; jj < sub.n[1]; ++jj)
        for (std::int64_t ii = 0; ii < sub.n[0]; ++ii, ++c) {
          if (!part[c]) continue;
          std::uint8_t& cell = inside[static_cast<std::size_t>(((lo[2] + kk) * box.n[1] + lo[1] + jj) * box.n[0] + lo[0] + ii)];
          cell = add ? value : 0;
        }
  }
  return inside;
}

// Cells no lattice link joins to the body of their shell (a piece of the mesh thinner than a cell
// between them: they would fall off at t = 0) are dropped. `inside` holds solid_cells' labels; the body of
// a solid shell is the face-connected piece holding the most of its cells (a piece holding cells of the
// 255th or a later solid shell, which share a label, is kept). On return `inside` holds 0 or 1.
void drop_unlinked(std::vector<std::uint8_t>& inside, const mesh::CellBox& box, MeshFillResult& r) {
  const std::int64_t nx = box.n[0], ny = box.n[1], nz = box.n[2];
  std::vector<bool> seen(inside.size(), false);
  struct Piece {
    std::vector<std::int64_t> cells;
    std::map<std::uint8_t, std::int64_t> of_label;
  };
  std::vector<Piece> pieces;
  std::vector<std::int64_t> queue;
  for (std::int64_t c0 = 0; c0 < static_cast<std::int64_t>(inside.size()); ++c0) {
    if (!inside[static_cast<std::size_t>(c0)] || seen[static_cast<std::size_t>(c0)]) continue;
    Piece p;
    queue.assign(1, c0);
    seen[static_cast<std::size_t>(c0)] = true;
    while (!queue.empty()) {
      const std::int64_t c = queue.back();
      queue.pop_back();
      p.cells.push_back(c);
      ++p.of_label[inside[static_cast<std::size_t>(c)]];
      const std::int64_t i = c % nx, j = (c / nx) % ny, k = c / (nx * ny);
      const std::int64_t next[6] = {i > 0 ? c - 1 : -1,       i + 1 < nx ? c + 1 : -1,
                                    j > 0 ? c - nx : -1,      j + 1 < ny ? c + nx : -1,
                                    k > 0 ? c - nx * ny : -1, k + 1 < nz ? c + nx * ny : -1};
      for (std::int64_t q : next) {
        if (q < 0 || !inside[static_cast<std::size_t>(q)] || seen[static_cast<std::size_t>(q)]) continue;
        seen[static_cast<std::size_t>(q)] = true;
        queue.push_back(q);
      }
    }
    pieces.push_back(std::move(p));
  }
  std::vector<char> keep(pieces.size(), 0);
  std::map<std::uint8_t, std::pair<std::int64_t, std::size_t>> body;  // label -> (its cells, piece)
  for (std::size_t p = 0; p < pieces.size(); ++p)
    for (const auto& [label, n] : pieces[p].of_label) {
      if (label == 255) keep[p] = 1;
      auto [it, fresh] = body.try_emplace(label, n, p);
      if (!fresh && n > it->second.first) it->second = {n, p};
    }
  for (const auto& [label, best] : body) keep[best.second] = 1;
  for (std::size_t p = 0; p < pieces.size(); ++p) {
    if (keep[p]) continue;
    ++r.dropped_pieces;
    r.dropped += static_cast<std::int64_t>(pieces[p].cells.size());
    r.largest_dropped = std::max<std::int64_t>(r.largest_dropped, static_cast<std::int64_t>(pieces[p].cells.size()));
    for (auto c : pieces[p].cells) inside[static_cast<std::size_t>(c)] = 0;
  }
  for (auto& v : inside) v = v ? 1 : 0;
}

// Holes up to about a cell wide are closed by the signed distance's band; wider ones let the outside in.
// (`region`: a region's mesh, which has no fill of its own.)
void refuse_wide_holes(const SceneDef& scene, std::size_t index, const Solid& s, const std::string& what, double d,
                       bool region) {
  const double hole = s.topology.largest_hole;
  if (s.topology.holes == 0 || hole <= 1.5 * d) return;
  // Every refusal below: where it is, what is open, and (an object's mesh, not a region's) the fill that
  // needs no closed surface.
  const std::string open = fmt::format("{}: {} {} is open", where(scene, index), what, s.file);
  const std::string rims = fmt::format("{} in {}", text::count(s.topology.boundary_edges, "boundary edge"),
                                       text::count(s.topology.holes, "hole"));
  const std::string or_surface =
      region ? "" : ", or fill = \"surface\" for a shell of one automaton per triangle, which needs no closed surface";
  // A seam (the rim encloses next to no area: its sides meet without sharing vertices) is no opening a
  // coarser spacing would close over: the mesh wants welding.
  const double width = s.topology.largest_hole_width;
  if (s.topology.boundary_edges == s.topology.edges) {  // (no edge shared: every triangle a rim of its own)
    throw Error(fmt::format(
        "{}: none of its {} edges is shared by two triangles, so its vertices are not welded (each triangle has "
        "corners of its own, apart by a hair or more), and a volume fill needs a closed surface. Weld the mesh "
        "(MeshLab: Filters > Cleaning and Repairing > Merge Close Vertices; Blender: Mesh > Clean Up > Merge by "
        "Distance){}",
        open, s.topology.edges, or_surface));
  }
  // A triangle hanging off an edge of a closed surface (the edge then of three: non-manifold) has its other
  // two edges free: a "hole" of two edges (told to be closed, or welded as a seam), which neither mends.
  // (Every rim of two edges: no opening has so few; a real hole beside edges shared by three is no fin.)
  if (s.topology.non_manifold_edges > 0 && s.topology.boundary_edges == 2 * s.topology.holes) {
    throw Error(fmt::format(
        "{}: {} beside {}: faces hanging off the surface at its non-manifold edges (a stray triangle on an edge), "
        "not an opening, and a volume fill needs a closed surface. Delete them (Blender: Select > Select All by "
        "Trait > Non Manifold, then delete the stray faces; MeshLab: Filters > Cleaning and Repairing > Remove "
        "Faces from Non Manifold Edges){}",
        open, rims, text::count(s.topology.non_manifold_edges, "non-manifold edge"), or_surface));
  }
  if (width < 0.1 * hole) {
    throw Error(fmt::format(
        "{}: {}, the largest {:.4g} m long but about {:.3g} m wide: a seam whose two sides meet without sharing "
        "their vertices (a T-junction: a vertex on another triangle's edge, or vertices a hair apart), and a volume "
        "fill needs a closed surface. Weld the mesh (MeshLab: Filters > Cleaning and Repairing > Merge Close "
        "Vertices, then Remove T-Vertices; Blender: Mesh > Clean Up > Merge by Distance){}",
        open, rims, hole, width, or_surface));
  }
  const bool target = scene.solver.target_automata > 0;
  throw Error(fmt::format(
      "{}: {}, the largest {:.4g} m across ({:.3g} cells at spacing {:.4g} m), and a volume fill needs a closed "
      "surface (holes under about a cell are closed). Repair the mesh (MeshLab: Filters > Remeshing > Close Holes; "
      "Blender: Mesh > Clean Up > Fill Holes), use a coarser spacing (above {:.3g} m{}){}",
      open, rims, hole, hole / d, d, hole / 1.5, target ? ": a smaller solver.target_automata" : ": solver.spacing",
      or_surface));
}

// A format that stores float32 (STL, glTF) has rounded each coordinate to 2^-24 of its magnitude: a model
// far from its file's origin comes with its corners moved by up to that much (a 0.3 m cube 1e6 m out, by
// 6 cm: 125 automata at 0.05 m instead of 216). Refused when it is more than 1 % of `length` (the spacing,
// or a surface object's mean link).
void refuse_float32_rounding(const SceneDef& scene, std::size_t index, const MeshObject& m, double length,
                             const char* what) {
  if (!m.float32) return;
  const double moved = m.file_reach * 0x1p-24 * m.scale;
  if (moved <= 0.01 * length) return;
  throw Error(fmt::format(
      "{}: the mesh {} stores float32 coordinates, and they reach {:.4g} from the file's origin for a model {:.4g} "
      "across: rounding has moved its corners by up to {:.3g} m, {:.0f} % of the {} ({:.4g} m), more than the 1 % "
      "mca accepts. Recentre the model at its file's origin (MeshLab: Filters > Normals, Curvatures and "
      "Orientation > Transform: Translate, Center; Blender: Object > Set Origin > Origin to Geometry, then location "
      "0) and place it with position, or export it as OBJ, OFF or PLY with double coordinates, which mca reads in "
      "double",
      where(scene, index), scene.objects[index].mesh, m.file_reach, m.file_bounds.largest_extent(), moved,
      100 * moved / length,
      what, length));
}

}  // namespace

MeshObject prepare_mesh_object(const SceneDef& scene, std::size_t index) {
  const ObjectDef& o = scene.objects[index];
  const std::string key = fmt::format("object[{}].mesh", index);
  MeshObject m;
  mesh::TriMesh tm = read(scene, key, o.mesh);
  m.file_vertices = tm.vertices.size();
  m.file_bounds = mesh::bounds(tm);
  m.float32 = mesh::float32_format(o.mesh);
  for (int a = 0; a < 3; ++a)
    m.file_reach = std::max({m.file_reach, std::fabs(m.file_bounds.lo[a]), std::fabs(m.file_bounds.hi[a])});
  const mesh::Point e = m.file_bounds.extent();
  const double largest = m.file_bounds.largest_extent();
  m.scale = o.fit_size > 0 ? o.fit_size / largest : o.scale;
  const bool surface = o.fill == MeshFill::surface;
  for (int a = 0; a < 3 && !surface; ++a) {
    if (!(e[a] > 1e-9 * largest)) {
      // A float file far out: the extent may be rounding's, not the model's (a ball 1 m across at 1e12 was
      // called flat along x, where a float steps by 65,536).
      refuse_float32_rounding(scene, index, m, largest * m.scale, "model's size");
      // (A text file far out may have written too few digits to tell its corners apart.)
      throw Error(fmt::format("{}: the mesh {} is flat: its extent along {} is {:g} (the box is {} in the file's "
                              "units), a surface with no inside to fill with automata; give a closed solid, or "
                              "fill = \"surface\" for one automaton per triangle{}",
                              where(scene, index), o.mesh, "xyz"[a], e[a], extent_text(e, ""),
                              m.file_reach > 1e4 * largest
                                  ? fmt::format(". Its coordinates reach {:.3g} for a model {:.3g} across: if it is not "
                                                "flat, the digits the file writes do not tell its corners apart that "
                                                "far out; move it to the origin in the file",
                                                m.file_reach, largest)
                                  : std::string()));
    }
  }
  if (!std::isfinite(largest * m.scale) || largest * m.scale > 1e7) {
    throw Error(fmt::format("{}: the mesh {} is {} in the file's units, {:.4g} m across at scale {:g}; check scale "
                            "(the factor from the file's units to metres) or give fit_size",
                            where(scene, index), o.mesh, extent_text(e, ""), largest * m.scale, m.scale));
  }
  to_object_frame(tm, m.file_bounds, m.scale);
  m.solid = make_solid(o.mesh, std::move(tm));
  for (std::size_t r = 0; r < o.regions.size(); ++r) {
    if (o.regions[r].shape != Shape::mesh) {
      m.regions.emplace_back();
      continue;
    }
    const std::string rkey = fmt::format("object[{}].region[{}].mesh", index, r);
    mesh::TriMesh rm = read(scene, rkey, o.regions[r].mesh);
    const mesh::Point re = mesh::bounds(rm).extent();
    for (int a = 0; a < 3; ++a) {
      if (!(re[a] > 1e-9 * std::max({re[0], re[1], re[2]}))) {
        throw Error(fmt::format("{}: {} = {} is flat (no extent along {}): a region mesh must be a closed solid",
                                where(scene, index), rkey, o.regions[r].mesh, "xyz"[a]));
      }
    }
    // The region shares the object mesh's frame: the same centre and scale.
    to_object_frame(rm, m.file_bounds, m.scale);
    m.regions.emplace_back(make_solid(o.regions[r].mesh, std::move(rm)));
  }
  return m;
}

MeshFillResult fill_mesh_object(const SceneDef& scene, std::size_t index, const MeshObject& m,
                                const mesh::CellBox& box) {
  const double d = box.d;
  refuse_float32_rounding(scene, index, m, d, "spacing");
  refuse_wide_holes(scene, index, m.solid, "the mesh", d, false);
  const auto t0 = std::chrono::steady_clock::now();
  MeshFillResult r;
  r.inside = solid_cells(m.solid, box, true);
  drop_unlinked(r.inside, box, r);
  for (auto c : r.inside) r.count += c;
  const double expected = m.volume() / (d * d * d);
  if (r.count == 0) {
    throw Error(fmt::format("{}: the mesh {} ({:.4g} x {:.4g} x {:.4g} m after scaling, {:.4g} m^3) holds no lattice "
                            "cell at spacing {:.4g} m; decrease solver.spacing ({}) or scale the mesh up",
                            where(scene, index), m.solid.file, m.extent(0), m.extent(1), m.extent(2), m.volume(), d,
                            ten_thousand_spacing(m.volume(), spacing_range(scene))));
  }
  // A surface whose sign cannot be told (crossing shells, open seams) fills far less or more than it
  // encloses; the enclosed volume is exact for manifold shells only.
  // (The cells dropped as unlinked count here: a fill that falls apart is refused with its own message.)
  const std::int64_t filled = r.count + r.dropped;
  if (m.solid.manifold && expected > 50 && (filled < 0.5 * expected || filled > 2.0 * expected)) {
    // A closed surface whose walls are thinner than a cell (a solidified shell of 5 cm at a spacing of 0.1
    // m) fills so too: its fix is the spacing, not a repair (which it was told).
    const bool closed = m.solid.topology.boundary_edges == 0 && m.solid.topology.non_manifold_edges == 0;
    throw Error(fmt::format(
        "{}: filling the mesh {} gave {} automata where its enclosed volume {:.4g} m^3 gives about {:.0f} at spacing "
        "{:.4g} m: its inside cannot be told from its outside ({} boundary edges, {} non-manifold edges). {}",
        where(scene, index), m.solid.file, filled, m.volume(), expected, d, m.solid.topology.boundary_edges,
        m.solid.topology.non_manifold_edges,
        closed ? fmt::format("Its surface is closed: its walls are likely thinner than the spacing (or its shells "
                             "cross each other); {}, or thicken the mesh",
                             scene.solver.target_automata > 0
                                 ? std::string("raise solver.target_automata (about eight times for half the spacing)")
                                 : fmt::format("decrease solver.spacing (e.g. to {:.3g} m)", d / 2))
               : std::string("Repair the mesh into closed surfaces (MeshLab: Close Holes, Remove Duplicate Faces; "
                             "Blender: 3D-Print toolbox)")));
  }
  for (std::size_t k = 0; k < m.regions.size(); ++k) {
    r.regions.emplace_back();
    if (!m.regions[k]) continue;
    refuse_wide_holes(scene, index, *m.regions[k], fmt::format("region[{}] mesh", k), d, true);
    r.regions.back() = solid_cells(*m.regions[k], box);
    std::int64_t in_region = 0;
    for (std::size_t c = 0; c < r.inside.size(); ++c) in_region += r.inside[c] & r.regions.back()[c];
    if (in_region == 0) {
      throw Error(fmt::format("{}: region[{}] (mesh {}) holds no automaton of the object at spacing {:.4g} m; its "
                              "mesh must lie inside the object's, in the same units and frame as the object's file",
                              where(scene, index), k, m.regions[k]->file, d));
    }
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

bool inside_solid(const Solid& s, const mesh::Point& p) {
  std::vector<std::uint32_t> faces;
  for (std::size_t k = 0; k < s.shells.size(); ++k)
    if (s.depth[k] >= 0) faces.insert(faces.end(), s.shells[k].faces.begin(), s.shells[k].faces.end());
  return inside_by_parity(s.mesh, faces, p);
}

SurfaceCells surface_cells(const SceneDef& scene, std::size_t index, const MeshObject& m) {
  const mesh::TriMesh& tm = m.solid.mesh;
  SurfaceCells c;
  // A triangle given twice (the same three vertices) would put two automata at one point: the repeat is
  // left out.
  std::vector<std::uint8_t> repeat(tm.faces.size(), 1);
  const std::vector<std::uint32_t> unique = mesh::unique_triangles(tm);
  for (const std::uint32_t f : unique) repeat[f] = 0;
  c.duplicate_faces = tm.faces.size() - unique.size();
  for (std::size_t f = 0; f < tm.faces.size(); ++f) {
    const auto& a = tm.vertices[tm.faces[f][0]];
    const auto& b = tm.vertices[tm.faces[f][1]];
    const auto& d = tm.vertices[tm.faces[f][2]];
    const double area = 0.5 * mesh::twice_area(a, b, d);
    if (!(area > 0) || repeat[f]) continue;
    c.face.push_back(static_cast<std::uint32_t>(f));
    c.centroid.push_back({(a[0] + b[0] + d[0]) / 3.0, (a[1] + b[1] + d[1]) / 3.0, (a[2] + b[2] + d[2]) / 3.0});
    c.area.push_back(area);
  }
  if (c.face.empty()) {
    throw Error(fmt::format("{}: every triangle of the mesh {} has zero area: surface mode puts one automaton on "
                            "each triangle with an area; check the file",
                            where(scene, index), m.solid.file));
  }
  // The automata on each edge, by a sort of (edge, automaton) entries.
  struct EdgeUse {
    std::uint32_t lo, hi, automaton;
  };
  std::vector<EdgeUse> uses;
  uses.reserve(3 * c.face.size());
  for (std::size_t k = 0; k < c.face.size(); ++k) {
    const auto& f = tm.faces[c.face[k]];
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t u = f[e], v = f[(e + 1) % 3];
      uses.push_back({std::min(u, v), std::max(u, v), static_cast<std::uint32_t>(k)});
    }
  }
  std::sort(uses.begin(), uses.end(), [](const EdgeUse& a, const EdgeUse& b) {
    return a.lo != b.lo ? a.lo < b.lo : a.hi != b.hi ? a.hi < b.hi : a.automaton < b.automaton;
  });
  std::vector<std::pair<std::array<std::uint32_t, 2>, double>> links;
  for (std::size_t s = 0; s < uses.size();) {
    std::size_t e = s + 1;
    while (e < uses.size() && uses[e].lo == uses[s].lo && uses[e].hi == uses[s].hi) ++e;
    if (e - s > 2) ++c.unlinked_edges;
    if (e - s == 2 && uses[s].automaton != uses[s + 1].automaton) {
      const auto& p = tm.vertices[uses[s].lo];
      const auto& q = tm.vertices[uses[s].hi];
      links.push_back({{uses[s].automaton, uses[s + 1].automaton},
                       std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]))});
    }
    s = e;
  }
  std::sort(links.begin(), links.end());
  double sum = 0;
  for (const auto& [l, edge] : links) {
    const auto& a = c.centroid[l[0]];
    const auto& b = c.centroid[l[1]];
    const double r0 = std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
    if (!(r0 > 0)) continue;  // two triangles folded onto each other: no direction to link along
    c.link.push_back(l);
    c.edge.push_back(edge);
    sum += r0;
  }
  c.mean_link = c.link.empty() ? 0.0 : sum / static_cast<double>(c.link.size());
  {  // its pieces: a shell of several, or unlinked at non-manifold edges, starts in them (said by mca info)
    std::vector<std::uint32_t> ends[2];
    for (const auto& l : c.link)
      for (int e = 0; e < 2; ++e) ends[e].push_back(l[e]);
    const std::vector<std::uint8_t> intact(c.link.size(), 1);
    c.pieces = static_cast<std::size_t>(
        analysis::label_fragments(c.face.size(), ends[0].data(), ends[1].data(), intact.data(), c.link.size(), nullptr)
            .count);
  }
  const double t = scene.objects[index].shell_thickness;
  if (t > 0) {
    c.thickness = t;
  } else if (c.mean_link > 0) {
    c.thickness = c.mean_link;
  } else {
    throw Error(fmt::format(
        "{}: no edge of the mesh {} is shared by exactly two triangles{}, so surface mode has no link and no spacing "
        "to take the shell's thickness from; give shell_thickness (metres){}",
        where(scene, index), m.solid.file,
        c.unlinked_edges ? fmt::format(" ({} edges have three or more: non-manifold)", c.unlinked_edges) : std::string(),
        c.unlinked_edges ? " or repair the mesh (MeshLab: Repair non Manifold Edges)" : " or weld the mesh's vertices"));
  }
  // A shell far thinner or thicker than its triangles are apart is outside what its automata (about cubes
  // of the link length) and the time-step bound were built for.
  // The bounds are shown to 4 digits rounded inwards, so that the figures the message gives are accepted
  // (8.585 was shown as the largest and refused: the bound was 8.58499...).
  auto inward = [](double x, bool up) {
    const double unit = std::pow(10.0, std::floor(std::log10(x)) - 3);
    return (up ? std::ceil(x / unit) : std::floor(x / unit)) * unit;
  };
  if (c.mean_link > 0 && (c.thickness < 0.01 * c.mean_link || c.thickness > 100 * c.mean_link)) {
    throw Error(fmt::format("{}: shell_thickness = {:g} m is out of range for the mesh {}: it must be between 0.01 and "
                            "100 times the mean distance of linked triangles ({:.4g} m), {:.4g} to {:.4g} m; remesh the "
                            "model finer or coarser for another thickness",
                            where(scene, index), c.thickness, m.solid.file, c.mean_link,
                            inward(0.01 * c.mean_link, true), inward(100 * c.mean_link, false)));
  }
  if (c.mean_link > 0) refuse_float32_rounding(scene, index, m, c.mean_link, "mean distance of linked triangles");
  return c;
}

}  // namespace mca::lattice
