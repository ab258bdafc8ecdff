#include "analysis/fragment_meshes.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <tbb/parallel_for.h>

#include "grid/uniform_grid.hpp"
#include "mesh/near_triangles.hpp"
#include "mesh/simplify.hpp"
#include "mesh/voxelize.hpp"

namespace mca::analysis {
namespace {

// An object's voxel grid (its automata's starting box, padded) and, for a mesh object, the signed
// distance of its starting surface on it (a shell's pieces find their triangles in Plan::triangles).
struct ObjectGrid {
  mesh::CellBox box;
  std::unique_ptr<mesh::SignedDistance> surface;
  double shell = 0;  // surface mode: half the shell's thickness (the solid is the surface thickened by it)
};

// A shell's pieces are meshed coarser than the lattice's voxel where their surface would take more than
// kShellCoarserPerAutomaton voxels an automaton and their share by area of kShellSurfaceVoxels, finer for a
// thin shell only within kShellVoxelsPerAutomaton an automaton or that share (shell_voxel), and a piece
// with at most kShellBoxVoxels in its box: a piece of a few triangles much larger than the spacing (a flat
// face of a CAD model as two triangles, a cylinder's caps) would otherwise be meshed at the small pieces'
// eighth of the spacing all over (eight such triangles made 12 million faces). A shell of even triangles
// as thick as the lattice's voxel never reaches the bounds.
constexpr double kShellSurfaceVoxels = 2e5, kShellVoxelsPerAutomaton = 64, kShellCoarserPerAutomaton = 256,
                 kShellBoxVoxels = 2e8;

// A piece whose vertices lie mostly (kFlatShare or more) on flat faces or straight edges between them (a
// box's sides, a crack along a lattice plane, a shell's large triangles' faces) has those merged into large
// triangles (mesh::simplify_flat): a collapse moves no point of its surface by over kFlatTolerance voxels, no
// triangle is left lower than kFlatMinHeight voxels across its longest edge. Measured (docs/benchmarks.md,
// "Flat faces merged"): the 9 pieces of a 12-triangle box's shell, 436,288 triangles, 24,942 once merged;
// the cow's pieces have under a tenth of their vertices flat, a sphere's thin shell of 5,120 triangles 0.44
// (its rims are round), and are left as they are: merged, that shell took 5.5 s beside the meshing's 3 s
// and 110 bytes a triangle more, for 1.8 times fewer triangles.
constexpr double kFlatShare = 0.6, kFlatTolerance = 1e-6, kFlatMinHeight = 0.05;
// A lattice's piece (not a shell's) from kLatticeFlatShare: the default wall's large pieces have two flat
// sides and round crack faces, 0.50 to 0.52 of their vertices flat.
constexpr double kLatticeFlatShare = 0.3;

// The most float32's rounding of a piece's coordinates may be, in voxels, for it to be written in float32
// (FragmentMesh::float32, float32_holds): about 350 m from the origin at the default wall's voxel of 1.7 cm.
constexpr double kFloat32Rounding = 0.01;

// What float32 may make of coordinates up to `far` from the origin: four of its units there.
double float32_rounding(double far) { return 4 * far * std::numeric_limits<float>::epsilon(); }

// The rotation of a fragment: the mean of its automata's quaternions, the unit q that maximises
// sum (q . q_a)^2 (the largest eigenvector of sum q_a q_a^T, by power iteration from the mean with signs
// aligned to the first). It does not depend on their signs, and an automaton spun far from its piece
// weighs little (one turned half a turn from it, none); a mean of signs aligned to the first automaton
// took that automaton's sign for the piece's and turned the default scene's pieces up to 21 degrees off.
QuatT<double> mean_rotation(const State& s, const std::vector<std::uint32_t>& members) {
  const Quat& q0 = s.q[members[0]];
  double v[4] = {0, 0, 0, 0};
  for (auto a : members) {
    const Quat& q = s.q[a];
    const double sign = q.w * q0.w + q.x * q0.x + q.y * q0.y + q.z * q0.z < 0 ? -1.0 : 1.0;
    v[0] += sign * q.w;
    v[1] += sign * q.x;
    v[2] += sign * q.y;
    v[3] += sign * q.z;
  }
  double m[4][4] = {};
  for (auto a : members) {
    const double q[4] = {s.q[a].w, s.q[a].x, s.q[a].y, s.q[a].z};
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) m[i][j] += q[i] * q[j];
  }
  double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
  if (!(n > 0)) v[0] = n = 1;  // the aligned mean cancelled out: start from the identity
  for (double& c : v) c /= n;
  for (int it = 0; it < 100; ++it) {  // the matrix is positive semi-definite: no shift is needed
    double w[4] = {0, 0, 0, 0};
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) w[i] += m[i][j] * v[j];
    const double len = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2] + w[3] * w[3]);
    if (!(len > 0)) break;
    double change = 0;
    for (int i = 0; i < 4; ++i) {
      change = std::max(change, std::fabs(w[i] / len - v[i]));
      v[i] = w[i] / len;
    }
    if (change < 1e-12) break;
  }
  return {v[0], v[1], v[2], v[3]};
}

// Taubin smoothing (lambda 0.5, mu -0.53) of the vertices marked `free`, over their mesh neighbours; no
// vertex moves further than `reach` from where it was (a small piece's corners would round off).
void smooth(mesh::TriMesh& m, const std::vector<std::uint8_t>& free, int iterations, double reach) {
  const std::vector<mesh::Point> start = m.vertices;
  std::vector<std::vector<std::uint32_t>> nb(m.vertices.size());
  for (const auto& f : m.faces)
    for (int e = 0; e < 3; ++e) {
      const auto a = f[e], b = f[(e + 1) % 3];
      if (!free[a] && !free[b]) continue;
      nb[a].push_back(b);
      nb[b].push_back(a);
    }
  for (auto& list : nb) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
  }
  std::vector<mesh::Point> next(m.vertices.size());
  for (int it = 0; it < 2 * iterations; ++it) {
    const double factor = it % 2 == 0 ? 0.5 : -0.53;
    for (std::size_t v = 0; v < m.vertices.size(); ++v) {
      next[v] = m.vertices[v];
      if (!free[v] || nb[v].empty()) continue;
      mesh::Point mean{0, 0, 0};
      for (auto u : nb[v])
        for (int a = 0; a < 3; ++a) mean[a] += m.vertices[u][a];
      for (int a = 0; a < 3; ++a) next[v][a] += factor * (mean[a] / static_cast<double>(nb[v].size()) - m.vertices[v][a]);
    }
    m.vertices.swap(next);
  }
  for (std::size_t v = 0; v < m.vertices.size(); ++v) {
    double dd[3], len2 = 0;
    for (int a = 0; a < 3; ++a) {
      dd[a] = m.vertices[v][a] - start[v][a];
      len2 += dd[a] * dd[a];
    }
    if (len2 <= reach * reach) continue;
    const double k = reach / std::sqrt(len2);
    for (int a = 0; a < 3; ++a) m.vertices[v][a] = start[v][a] + k * dd[a];
  }
}

// Polygonizing leaves a few pairs of vertices at one point (on the bunny split in two, 20 of 92,000
// triangles), and each such pair makes the two triangles on its edge zero-area. The pair becomes one vertex
// (the edge collapsed), the triangles that held both are dropped, and the mesh stays closed: each collapsed
// edge had exactly those two triangles. Edges shorter than `tiny` count as such a pair.
void collapse_zero_length_edges(mesh::TriMesh& m, double tiny) {
  std::vector<std::uint32_t> root(m.vertices.size());
  for (std::uint32_t v = 0; v < root.size(); ++v) root[v] = v;
  const auto find = [&](std::uint32_t v) {
    while (root[v] != v) v = root[v] = root[root[v]];
    return v;
  };
  bool any = false;
  for (const auto& f : m.faces)
    for (int e = 0; e < 3; ++e) {
      const auto& a = m.vertices[f[e]];
      const auto& b = m.vertices[f[(e + 1) % 3]];
      const double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
      if (dx * dx + dy * dy + dz * dz > tiny * tiny) continue;
      const std::uint32_t ra = find(f[e]), rb = find(f[(e + 1) % 3]);
      if (ra != rb) root[std::max(ra, rb)] = std::min(ra, rb), any = true;
    }
  if (!any) return;
  // Faces on the merged vertices; those that held both ends of a collapsed edge go.
  std::vector<mesh::Triangle> faces;
  faces.reserve(m.faces.size());
  for (const auto& f : m.faces) {
    const mesh::Triangle t = {find(f[0]), find(f[1]), find(f[2])};
    if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) faces.push_back(t);
  }
  mesh::keep_faces(m, std::move(faces));
}

// Dual contouring's placement (Ju et al. 2002) for the vertices of `m` at its sharp edges and corners. A vertex
// whose triangles bend by more than kBend, or that the Newton steps left off the field's zero (their differences
// span two faces within a twentieth of a voxel of an edge), was made by the polygonizing in the voxel of `box` that
// holds sampled[v], at the mean of the field's crossings of that voxel's edges (of those nearer it than to another
// vertex of the voxel: one is made for each sheet there). Where the object's outer faces alone cross there, the
// vertex goes where the planes at the crossings (their exact points, the gradient a ten thousandth of a voxel
// across) meet nearest to their mean (mesh::feature_point), within kBeyond voxels of its voxel and on the field's
// zero. The quads are then cut on the diagonal that runs along the edges (see below); a triangle left turned over,
// edge-on, thinner than a thousandth of a voxel or facing into the solid takes its vertices' moves (and its quad's
// diagonal) back. `field(p, cursor, &outer)`: the field at p, outer whether its outer term is the one that sets it;
// `gradient(p, apart, g, cursor)`: its gradient into g from differences `apart` voxels across, its length squared
// returned.
template <class Field, class Gradient>
void sharp_features(mesh::TriMesh& m, const std::vector<mesh::Point>& sampled, const mesh::CellBox& box,
                    const Field& field, const Gradient& gradient, const std::function<void()>& poll) {
  constexpr double kBend = 0.95;  // the cosine of the least bend (about 18 degrees)
  // How far beyond its voxel a vertex may go: where an edge passes just outside a voxel whose crossings lie
  // on both its faces, the polygonizing's one vertex there joins both, and only their line does (a turned
  // box kept 158 of its edge vertices on one face with none).
  constexpr double kBeyond = 0.5;
  const double hf = box.d;
  const auto normal = [&](const mesh::Triangle& t) {
    const auto &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    return mesh::Point{u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
  };
  const auto cosine = [](const mesh::Point& a, const mesh::Point& b) {
    const double ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    const double aa = a[0] * a[0] + a[1] * a[1] + a[2] * a[2], bb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
    return aa > 0 && bb > 0 ? ab / std::sqrt(aa * bb) : 0.0;  // (no direction: as if at right angles)
  };
  std::vector<std::vector<std::uint32_t>> faces_of(m.vertices.size());
  for (std::uint32_t f = 0; f < m.faces.size(); ++f)
    for (const auto v : m.faces[f]) faces_of[v].push_back(f);
  std::vector<mesh::Point> before_normal(m.faces.size());
  for (std::size_t f = 0; f < m.faces.size(); ++f) before_normal[f] = normal(m.faces[f]);
  std::vector<std::uint8_t> moved(m.vertices.size(), 0);
  const std::vector<mesh::Point> before = m.vertices;
  // Each vertex's voxel (-1 at the box's outer planes), and all of them sorted.
  std::vector<std::int64_t> voxel_of(m.vertices.size());
  for (std::size_t v = 0; v < m.vertices.size(); ++v) {
    std::int64_t cell[3];
    for (int c = 0; c < 3; ++c) cell[c] = static_cast<std::int64_t>(std::floor((sampled[v][c] - box.origin[c]) / hf));
    voxel_of[v] = cell[0] >= 0 && cell[1] >= 0 && cell[2] >= 0 && cell[0] + 1 < box.n[0] && cell[1] + 1 < box.n[1] &&
                          cell[2] + 1 < box.n[2]
                      ? cell[0] + box.n[0] * (cell[1] + box.n[1] * cell[2])
                      : -1;
  }
  std::vector<std::pair<std::int64_t, std::uint32_t>> voxels(m.vertices.size());  // (voxel, vertex), sorted
  for (std::uint32_t v = 0; v < voxels.size(); ++v) voxels[v] = {voxel_of[v], v};
  std::sort(voxels.begin(), voxels.end());
  tbb::parallel_for(std::size_t{0}, m.vertices.size(), [&](std::size_t v) {
    if (poll && v % 4096 == 0) poll();
    const auto& around = faces_of[v];
    bool bends = false;
    for (std::size_t i = 0; i < around.size() && !bends; ++i)
      for (std::size_t j = i + 1; j < around.size() && !bends; ++j)
        bends = cosine(before_normal[around[i]], before_normal[around[j]]) < kBend;
    mesh::NearTriangles::Cursor cursor;
    bool outer = false;
    const auto& here = m.vertices[v];
    const double rounding =
        16 * std::numeric_limits<double>::epsilon() * std::max({std::fabs(here[0]), std::fabs(here[1]), std::fabs(here[2])});
    if (!bends && std::fabs(field(here, cursor, &outer)) <= std::max(1e-9 * hf, rounding)) return;
    // The voxel: its corners at the very coordinates the polygonizing sampled, inside where the sampled
    // value (float, clamped) is below zero.
    const std::int64_t key = voxel_of[v];
    if (key < 0) return;
    // The other vertices the polygonizing made in the voxel (one for each sheet there): a crossing is this
    // vertex's where it is nearer to it than to them (each was made at its crossings' mean).
    const auto same = std::equal_range(voxels.begin(), voxels.end(), std::pair{key, std::uint32_t{0}},
                                       [](const auto& x, const auto& y) { return x.first < y.first; });
    const auto mine = [&](const mesh::Point& p) {
      const auto dist2 = [&](const mesh::Point& q) {
        return (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]);
      };
      const double own = dist2(sampled[v]);
      for (auto o = same.first; o != same.second; ++o)
        if (o->second != v && dist2(sampled[o->second]) < own) return false;
      return true;
    };
    const std::int64_t cell[3] = {key % box.n[0], key / box.n[0] % box.n[1], key / box.n[0] / box.n[1]};
    mesh::Point corner[8];
    double value[8];
    unsigned inside = 0;
    for (int k = 0; k < 8; ++k) {
      for (int c = 0; c < 3; ++c) corner[k][c] = box.origin[c] + static_cast<double>(cell[c] + ((k >> c) & 1)) * hf;
      value[k] = field(corner[k], cursor, &outer);
      if (static_cast<float>(std::clamp(value[k] / hf, -2.0, 2.0)) < 0) inside |= 1u << k;
    }
    if (inside == 0 || inside == 0xff) return;
    mesh::Point at[12], unit[12];
    int n = 0;
    for (int k = 0; k < 8; ++k)
      for (int c = 0; c < 3; ++c) {
        const int l = k | (1 << c);
        if (l == k || ((inside >> k) & 1) == ((inside >> l) & 1)) continue;
        // The crossing along the edge from k to l: false position (Illinois) on the exact field.
        double t0 = 0, t1 = 1, f0 = value[k], f1 = value[l], t = 0;
        int kept = 0;
        mesh::Point p = corner[k];
        for (int it = 0; it < 40; ++it) {
          t = f0 == f1 ? 0.5 * (t0 + t1) : t0 + (t1 - t0) * f0 / (f0 - f1);
          if (!(t > t0 && t < t1)) t = 0.5 * (t0 + t1);
          p = corner[k];
          p[c] = corner[k][c] + t * hf;
          const double f = field(p, cursor, &outer);
          if (std::fabs(f) <= 1e-9 * hf || t1 - t0 <= 1e-12) break;
          if ((f < 0) == (f0 < 0)) {
            t0 = t, f0 = f;
            if (kept == -1) f1 *= 0.5;
            kept = -1;
          } else {
            t1 = t, f1 = f;
            if (kept == 1) f0 *= 0.5;
            kept = 1;
          }
        }
        if (!mine(p)) continue;
        field(p, cursor, &outer);
        if (!outer) return;  // a crack face crosses the voxel: left as it is
        double gr[3];
        const double g2 = gradient(p, 1e-4, gr, cursor);
        if (!(g2 > 1e-6 && g2 < 1e6)) return;
        const double len = std::sqrt(g2);
        at[n] = p;
        unit[n++] = {gr[0] / len, gr[1] / len, gr[2] / len};
      }
    mesh::Point x;
    mesh::Point lo = corner[0], hi = corner[7];
    for (int c = 0; c < 3; ++c) lo[c] -= kBeyond * hf, hi[c] += kBeyond * hf;
    if (!mesh::feature_point(at, unit, n, 0.05, lo, hi, x)) return;  // none near its voxel
    if (!(std::fabs(field(x, cursor, &outer)) <= 1e-3 * hf)) return;  // off the zero
    m.vertices[v] = x;
    moved[v] = 1;
  });
  // The polygonizing cut each quad on its shorter diagonal. Where corners of it now lie on an edge, the
  // other diagonal may run along it, its triangles on the two faces, where this one's cut under them or
  // stand edge-on: a quad takes the other diagonal where its own triangles are turned (over 89.9 degrees
  // from the quad's before the moves) and the other's are not, or where both are upright and the other's
  // triangles' centres lie nearer the field's zero by half.
  const auto key = [](std::uint32_t a, std::uint32_t b) { return a < b ? std::uint64_t{a} << 32 | b : std::uint64_t{b} << 32 | a; };
  std::unordered_map<std::uint64_t, std::array<std::uint32_t, 2>> edge_faces;  // an edge's two triangles
  std::vector<std::uint64_t> candidates;
  for (std::uint32_t f = 0; f < m.faces.size(); ++f) {
    const auto& t = m.faces[f];
    const bool near = moved[t[0]] || moved[t[1]] || moved[t[2]];
    for (int e = 0; e < 3; ++e) {
      const auto k = key(t[e], t[(e + 1) % 3]);
      auto [it, fresh] = edge_faces.try_emplace(k, std::array<std::uint32_t, 2>{f, f});
      if (!fresh) it->second[1] = f;
      if (near && fresh) candidates.push_back(k);
    }
  }
  for (auto& n : before_normal) {
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (len > 0) n = {n[0] / len, n[1] / len, n[2] / len};
  }
  mesh::NearTriangles::Cursor cursor;
  const auto centre = [&](const mesh::Triangle& t) {
    mesh::Point c;
    for (int i = 0; i < 3; ++i) c[i] = (m.vertices[t[0]][i] + m.vertices[t[1]][i] + m.vertices[t[2]][i]) / 3;
    return c;
  };
  const auto off_zero = [&](const mesh::Triangle& t) {
    bool outer = false;
    return std::fabs(field(centre(t), cursor, &outer));
  };
  const auto upright = [&](const mesh::Triangle& t, const mesh::Point& was) {
    return cosine(normal(t), was) > 1e-3 &&
           mesh::height_across_longest_edge(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]) >= 1e-3 * hf;
  };
  // Upright, and facing out of the solid where it lies: the field's gradient at its centre (near a corner
  // whose voxel holds no vertex for it, a triangle from an edge to a face could turn over within 90 degrees
  // of its bevel's normal).
  const auto facing_out = [&](std::size_t f) {
    const mesh::Triangle& t = m.faces[f];
    if (!upright(t, before_normal[f])) return false;
    double g[3];
    gradient(centre(t), 1e-4, g, cursor);
    return cosine(normal(t), mesh::Point{g[0], g[1], g[2]}) > 0;
  };
  struct Flip {
    std::uint32_t f1, f2;
    mesh::Triangle t1, t2;  // as they were
    mesh::Point w1, w2;     // their normals before the moves
    bool undone = false;
  };
  std::vector<Flip> flips;
  std::vector<std::vector<std::uint32_t>> flips_at(m.faces.size());  // the flips that cut each face, in order
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    if (poll && i % 4096 == 0) poll();
    const std::uint64_t k = candidates[i];
    const auto it = edge_faces.find(k);
    if (it == edge_faces.end() || it->second[0] == it->second[1]) continue;
    const std::uint32_t f1 = it->second[0], f2 = it->second[1];
    // f1 = (a, b, c) with the edge from a to b, f2 = (b, a, d); the quad is a, d, b, c.
    mesh::Triangle t1 = m.faces[f1];
    while (key(t1[0], t1[1]) != k) t1 = {t1[1], t1[2], t1[0]};
    const std::uint32_t a = t1[0], b = t1[1], c = t1[2];
    const mesh::Triangle& t2 = m.faces[f2];
    const std::uint32_t d = t2[0] != a && t2[0] != b ? t2[0] : t2[1] != a && t2[1] != b ? t2[1] : t2[2];
    if (c == d || edge_faces.count(key(c, d))) continue;  // (the other diagonal is an edge already)
    const mesh::Point w1 = before_normal[f1], w2 = before_normal[f2];
    const mesh::Point was = {w1[0] + w2[0], w1[1] + w2[1], w1[2] + w2[2]};
    const mesh::Triangle n1 = {a, d, c}, n2 = {d, b, c};
    if (!upright(n1, was) || !upright(n2, was)) continue;
    if (upright(t1, w1) && upright(t2, w2) && !(off_zero(n1) + off_zero(n2) < 0.5 * (off_zero(t1) + off_zero(t2))))
      continue;
    flips_at[f1].push_back(static_cast<std::uint32_t>(flips.size()));
    flips_at[f2].push_back(static_cast<std::uint32_t>(flips.size()));
    flips.push_back({f1, f2, m.faces[f1], m.faces[f2], w1, w2});
    m.faces[f1] = n1;
    m.faces[f2] = n2;
    before_normal[f1] = before_normal[f2] = was;
    edge_faces.erase(it);
    edge_faces[key(c, d)] = {f1, f2};
    for (auto& f : edge_faces[key(a, d)]) f = f == f2 ? f1 : f;
    for (auto& f : edge_faces[key(b, c)]) f = f == f1 ? f2 : f;
  }
  // A triangle still turned by the moves (or facing into the solid) takes its moved vertices back, and a quad
  // whose other diagonal is turned by that takes its own back (first those of the quads cut since that share
  // a triangle with it), until none is.
  const std::function<void(std::uint32_t)> undo = [&](std::uint32_t i) {
    Flip& x = flips[i];
    for (const std::uint32_t f : {x.f1, x.f2})
      for (auto later = flips_at[f].rbegin(); later != flips_at[f].rend() && *later > i; ++later)
        if (!flips[*later].undone) undo(*later);
    m.faces[x.f1] = x.t1;
    m.faces[x.f2] = x.t2;
    before_normal[x.f1] = x.w1;
    before_normal[x.f2] = x.w2;
    x.undone = true;
  };
  for (bool again = true; again;) {
    if (poll) poll();
    again = false;
    for (std::size_t f = 0; f < m.faces.size(); ++f) {
      const auto& t = m.faces[f];
      if ((!moved[t[0]] && !moved[t[1]] && !moved[t[2]]) || facing_out(f)) continue;
      for (const auto u : t)
        if (moved[u]) m.vertices[u] = before[u], moved[u] = 0, again = true;
    }
    for (std::uint32_t i = static_cast<std::uint32_t>(flips.size()); i-- > 0;) {
      const Flip& x = flips[i];
      if (x.undone || (facing_out(x.f1) && facing_out(x.f2))) continue;
      undo(i);
      again = true;
    }
  }
}

}  // namespace

std::vector<FragmentMesh> fragment_meshes(const Model& m, const State& s, const Fragments& fragments,
                                          std::int64_t min_automata, int cells_per_spacing) {
  std::vector<FragmentMesh> out;
  std::mutex lock;
  for_each_fragment_mesh(m, s, fragments, min_automata, [&](FragmentMesh&& fm) {
    const std::lock_guard<std::mutex> hold(lock);
    out.push_back(std::move(fm));
  }, cells_per_spacing);
  std::sort(out.begin(), out.end(), [](const FragmentMesh& a, const FragmentMesh& b) { return a.fragment < b.fragment; });
  return out;
}

std::vector<std::int32_t> meshed_fragments(const Fragments& fragments, std::int64_t min_automata) {
  std::vector<std::int64_t> size(static_cast<std::size_t>(fragments.count), 0);
  for (const std::int32_t id : fragments.id) ++size[static_cast<std::size_t>(id)];
  std::vector<std::int32_t> chosen;
  for (std::int32_t f = 0; f < fragments.count; ++f)
    if (size[static_cast<std::size_t>(f)] > min_automata) chosen.push_back(f);
  return chosen;
}

int voxels_per_spacing(std::int64_t automata, int cells_per_spacing) {
  const double cbrt_n = std::cbrt(static_cast<double>(std::max<std::int64_t>(automata, 1)));
  return std::clamp(static_cast<int>(std::ceil(24.0 / cbrt_n)), cells_per_spacing, 8);
}

bool float32_holds(double far, double voxel) { return float32_rounding(far) <= kFloat32Rounding * voxel; }

double shell_voxel(double spacing, double half, std::int64_t automata, double area, double narrowest,
                   double object_area, int cells_per_spacing) {
  const double share = object_area > 0 ? std::min(1.0, area / object_area) : 1.0, n = static_cast<double>(automata);
  // The lattice's voxel, coarser where the piece's surface would take more than its share of
  // kShellSurfaceVoxels and kShellCoarserPerAutomaton voxels an automaton (large triangles), finer for a
  // small piece's narrowest triangle within that bound, and finer for a thin shell within its share and
  // kShellVoxelsPerAutomaton an automaton.
  const double coarse = std::sqrt(2 * area / std::max(kShellSurfaceVoxels * share, kShellCoarserPerAutomaton * n));
  const double fine = std::sqrt(2 * area / std::max(kShellSurfaceVoxels * share, kShellVoxelsPerAutomaton * n));
  double h = std::max(spacing / voxels_per_spacing(automata, cells_per_spacing), coarse);
  if (automata <= 27 && narrowest > 0) h = std::max(std::min(h, 0.5 * narrowest), coarse);
  h = std::max(std::min(h, half), std::min(h, fine));
  return std::max(h, half / 8);
}

void for_each_fragment_mesh(const Model& m, const State& s, const Fragments& fragments, std::int64_t min_automata,
                            const std::function<void(FragmentMesh&&)>& sink, int cells_per_spacing,
                            const std::function<void()>& poll) {
  const double d = m.spacing, h = d / cells_per_spacing;
  const std::vector<std::int32_t> chosen = meshed_fragments(fragments, min_automata);
  if (chosen.empty()) return;
  std::vector<std::vector<std::uint32_t>> members(static_cast<std::size_t>(fragments.count));
  for (std::size_t a = 0; a < m.size(); ++a) members[static_cast<std::size_t>(fragments.id[a])].push_back(static_cast<std::uint32_t>(a));

  // Per object: its grid, and its starting surface's signed distance where it has one (a shell's
  // triangles, by fragment, below).
  const std::size_t n_obj = m.object_names.size();
  std::vector<ObjectGrid> grids(n_obj);
  for (const MeshSummary& ms : m.meshes)
    if (ms.surface) grids[static_cast<std::size_t>(ms.object)].shell = 0.5 * ms.shell_thickness;
  std::vector<mesh::TriMesh> rest(n_obj);
  std::vector<std::vector<std::int32_t>> rest_piece(n_obj);  // each rest triangle's fragment
  std::vector<std::vector<std::uint32_t>> piece_faces(static_cast<std::size_t>(fragments.count));  // a shell's
  std::vector<double> object_area(n_obj, 0.0);  // a shell's triangles' area
  for (std::size_t f = 0; f < m.surface.faces(); ++f) {
    const std::uint32_t a = m.surface.automaton[f];
    const auto o = static_cast<std::size_t>(m.object[a]);
    mesh::TriMesh& r = rest[o];
    const auto base = static_cast<std::uint32_t>(r.vertices.size());
    for (int c = 0; c < 3; ++c) {
      const Vec3 off = m.surface.offset[3 * f + c];
      r.vertices.push_back({m.position0[a].x + off.x, m.position0[a].y + off.y, m.position0[a].z + off.z});
    }
    if (grids[o].shell > 0) {
      piece_faces[static_cast<std::size_t>(fragments.id[a])].push_back(static_cast<std::uint32_t>(r.faces.size()));
      object_area[o] += 0.5 * mesh::twice_area(r.vertices[base], r.vertices[base + 1], r.vertices[base + 2]);
    }
    r.faces.push_back({base, base + 1, base + 2});
    rest_piece[o].push_back(fragments.id[a]);
  }
  // The random lattice's objects and the jittered cubic lattice's (Model::cell0): a site lies anywhere in its
  // cell (within lattice_jitter of its centre), and its Voronoi cell reaches up to sqrt(3) d from it; the
  // object's solid is the union of its cells. (A jittered site's own cube bounded its piece until a hostile
  // review found the cubes' gaps: a jittered box's mesh folded on 204 edges, 15 % of its volume missing.)
  const auto random_object = [&](std::size_t o) {
    return (!m.object_random.empty() && m.object_random[o] != 0) || (!m.link_rest.empty() && !m.cell0.empty());
  };
  const std::vector<DVec3>& centre = m.cell0.empty() ? m.position0 : m.cell0;  // each automaton's cell
  std::vector<std::array<double, 6>> object_box(n_obj, {INFINITY, INFINITY, INFINITY, -INFINITY, -INFINITY, -INFINITY});
  for (std::size_t a = 0; a < m.size(); ++a) {
    auto& b = object_box[static_cast<std::size_t>(m.object[a])];
    const double p[3] = {centre[a].x, centre[a].y, centre[a].z};
    for (int c = 0; c < 3; ++c) {
      b[c] = std::min(b[c], p[c]);
      b[3 + c] = std::max(b[3 + c], p[c]);
    }
  }
  for (std::size_t o = 0; o < n_obj; ++o) {
    const auto& b = object_box[o];
    if (!(b[0] <= b[3]) || grids[o].shell > 0) continue;
    ObjectGrid& g = grids[o];
    g.box.d = h;
    for (int c = 0; c < 3; ++c) {
      const double lo = b[c] - 1.5 * d;  // the cells, the mesh beyond them and a margin of outside voxels
      g.box.origin[c] = lo;
      g.box.n[c] = static_cast<std::int64_t>(std::ceil((b[3 + c] + 1.5 * d - lo) / h)) + 1;
    }
    if (!rest[o].faces.empty()) g.surface = std::make_unique<mesh::SignedDistance>(rest[o], g.box, 3.0f);
  }

  // Each piece's voxel and box. A lattice piece: its automata's box, padded by the mesh shell and a margin.
  // A shell's piece: its triangles' box, padded by the shell (at least a voxel thick, so that a shell
  // thinner than the voxel is not lost between the samples) and a margin; its voxel shell_voxel's, coarser
  // where its box would hold over kShellBoxVoxels.
  struct Plan {
    double hf = 0, shell = 0;
    mesh::CellBox box;
    const mesh::NearTriangles* triangles = nullptr;  // a shell's: its object's, by fragment
    // The farthest a shell's piece asks for them (0: not a shell's piece): beyond this the field is clamped
    // at two voxels: a point's own triangles within the shell and two voxels, and others within four voxels
    // more, are all that set it; half a voxel more of each for the Newton steps' differences.
    double reach() const { return shell > 0 ? shell + 7 * hf : 0; }
  };
  std::vector<Plan> plan(chosen.size());
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    const auto& mem = members[static_cast<std::size_t>(chosen[k])];
    const auto obj = static_cast<std::size_t>(m.object[mem[0]]);
    const auto n = static_cast<std::int64_t>(mem.size());
    Plan& p = plan[k];
    p.hf = d / voxels_per_spacing(n, cells_per_spacing);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, pad = 0;
    if (grids[obj].shell > 0) {
      double area = 0, narrowest = INFINITY;
      for (const std::uint32_t f : piece_faces[static_cast<std::size_t>(chosen[k])]) {
        const mesh::Triangle& t = rest[obj].faces[f];
        const auto& vs = rest[obj].vertices;
        area += 0.5 * mesh::twice_area(vs[t[0]], vs[t[1]], vs[t[2]]);
        if (const double height = mesh::height_across_longest_edge(vs[t[0]], vs[t[1]], vs[t[2]]); height > 0)
          narrowest = std::min(narrowest, height);
        for (const std::uint32_t v : t)
          for (int c = 0; c < 3; ++c) {
            lo[c] = std::min(lo[c], rest[obj].vertices[v][c]);
            hi[c] = std::max(hi[c], rest[obj].vertices[v][c]);
          }
      }
      if (!(lo[0] <= hi[0])) {  // (no triangle: nothing to mesh)
        p.hf = 0;
        continue;
      }
      p.hf = shell_voxel(d, grids[obj].shell, n, area, narrowest == INFINITY ? 0 : narrowest, object_area[obj],
                         cells_per_spacing);
      for (int round = 0; round < 8; ++round) {
        p.shell = std::max(grids[obj].shell, p.hf);
        pad = p.shell + 3 * p.hf;
        double voxels = 1;
        for (int c = 0; c < 3; ++c) voxels *= (hi[c] - lo[c] + 2 * pad) / p.hf + 1;
        if (voxels <= kShellBoxVoxels) break;
        p.hf *= 1.01 * std::cbrt(voxels / kShellBoxVoxels);
      }
    } else {
      pad = random_object(obj) ? 1.8 * d : 1.2 * d;  // an automaton's solid lies within sqrt(3) d or d / 2
      for (auto a : mem) {
        const double q[3] = {m.position0[a].x, m.position0[a].y, m.position0[a].z};
        for (int c = 0; c < 3; ++c) {
          lo[c] = std::min(lo[c], q[c]);
          hi[c] = std::max(hi[c], q[c]);
        }
      }
    }
    p.box.d = p.hf;
    for (int c = 0; c < 3; ++c) {
      p.box.origin[c] = lo[c] - pad;
      p.box.n[c] = static_cast<std::int64_t>(std::ceil((hi[c] - lo[c] + 2 * pad) / p.hf)) + 1;
    }
  }
  // A shell's triangles, by fragment, for each class of its pieces' reaches (within a factor of two),
  // over those pieces' boxes: one grid of the largest reach made a fine piece beside a coarse one (a 0.2 m
  // patch and an 8 m frame of one object) read cells of the frame's size, each listing the whole patch.
  std::map<std::pair<std::size_t, int>, std::pair<double, mesh::Bounds>> classes;  // (object, class) -> reach, box
  const auto class_of = [&](std::size_t k) { return std::pair{static_cast<std::size_t>(m.object[members[static_cast<std::size_t>(chosen[k])][0]]), std::ilogb(plan[k].reach())}; };
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    if (plan[k].reach() == 0) continue;
    const mesh::CellBox& b = plan[k].box;
    auto [it, fresh] = classes.try_emplace(class_of(k));
    auto& [reach, box] = it->second;
    reach = std::max(reach, plan[k].reach());
    for (int c = 0; c < 3; ++c) {
      const double lo = b.origin[c], hi = b.origin[c] + static_cast<double>(b.n[c]) * b.d;
      box.lo[c] = fresh ? lo : std::min(box.lo[c], lo);
      box.hi[c] = fresh ? hi : std::max(box.hi[c], hi);
    }
  }
  std::map<std::pair<std::size_t, int>, std::unique_ptr<mesh::NearTriangles>> triangles;
  for (const auto& [key, what] : classes)
    triangles[key] = std::make_unique<mesh::NearTriangles>(rest[key.first], rest_piece[key.first], what.first, &what.second);
  for (std::size_t k = 0; k < chosen.size(); ++k)
    if (plan[k].reach() > 0) plan[k].triangles = triangles.at(class_of(k)).get();

  // Each lattice object's automata binned by cells of size d (their starting centres): the 27 cells around
  // a point hold every automaton within d of it, and the terms below keep the nearest. On the random
  // lattice the bins are 2 d (a point of the object has its nearest site within sqrt(3) d: its own cell's
  // holds one), and its cells' centres are binned apart, by d (a point in a cell is within sqrt(3) d / 2 of
  // its centre).
  std::vector<std::unique_ptr<UniformGrid>> buckets(n_obj), cells(n_obj);
  // On those lattices, the sides of each automaton's cell with another cell of its object beyond (bit 2 k
  // along axis k, 2 k + 1 against it): the union of the cells is bounded by them only past them.
  std::vector<std::uint8_t> cell_sides;
  for (auto frag : chosen) {
    const auto o = static_cast<std::size_t>(m.object[members[static_cast<std::size_t>(frag)][0]]);
    if (buckets[o] || grids[o].shell > 0) continue;
    std::vector<std::uint32_t> ids;
    for (std::size_t a = 0; a < m.size(); ++a)
      if (static_cast<std::size_t>(m.object[a]) == o) ids.push_back(static_cast<std::uint32_t>(a));
    buckets[o] = std::make_unique<UniformGrid>();
    buckets[o]->build(m.position0.data(), ids.size(), random_object(o) ? 2 * d : d, ids.data());
    if (random_object(o)) {
      cells[o] = std::make_unique<UniformGrid>();
      cells[o]->build(m.cell0.data(), ids.size(), d, ids.data());
      if (cell_sides.empty()) cell_sides.assign(m.size(), 0);
      const auto& axes = m.object_axes[o];
      tbb::parallel_for(std::size_t{0}, ids.size(), [&](std::size_t i) {
        const std::uint32_t a = ids[i];
        for (int side = 0; side < 6; ++side) {
          const Vec3& e = axes[static_cast<std::size_t>(side / 2)];
          const double step = side % 2 == 0 ? d : -d;
          const DVec3 q{m.cell0[a].x + step * e.x, m.cell0[a].y + step * e.y, m.cell0[a].z + step * e.z};
          bool there = false;
          cells[o]->for_each_candidate(q, [&](std::uint32_t b) { const DVec3 r = m.cell0[b] - q; there = there || dot(r, r) < 0.0625 * d * d; });
          if (there) cell_sides[a] |= static_cast<std::uint8_t>(1u << side);
        }
      });
    }
  }
  const auto mesh_one = [&](std::size_t k) {
    const std::int32_t frag = chosen[k];
    const auto& mem = members[static_cast<std::size_t>(frag)];
    const auto obj = static_cast<std::size_t>(m.object[mem[0]]);
    const ObjectGrid& g = grids[obj];
    const auto& axes = m.object_axes[obj];
    const bool random = random_object(obj);
    const Plan& plan_k = plan[k];
    const double hf = plan_k.hf;
    const mesh::CellBox& fb = plan_k.box;
    if (hf == 0) return;  // (a shell's piece without triangles)
    // The object's signed distance at a point: trilinear in its grid.
    auto surface_at = [&](double x, double y, double z) {
      const double p[3] = {x, y, z};
      double w[3];
      std::int64_t c[3];
      for (int a = 0; a < 3; ++a) {
        const double u = (p[a] - g.box.origin[a]) / h;
        c[a] = static_cast<std::int64_t>(std::floor(u));
        w[a] = u - static_cast<double>(c[a]);
      }
      double sum = 0;
      for (int k8 = 0; k8 < 8; ++k8) {
        const int bx = k8 & 1, by = (k8 >> 1) & 1, bz = (k8 >> 2) & 1;
        sum += (bx ? w[0] : 1 - w[0]) * (by ? w[1] : 1 - w[1]) * (bz ? w[2] : 1 - w[2]) *
               g.surface->at(c[0] + bx, c[1] + by, c[2] + bz);
      }
      return sum;
    };
    // The two parts of the field at a point: outside the object (its surface, or the own cells) and past
    // the bisector towards another fragment's automaton (-inf without one); +inf outside everything.
    struct Terms {
      double outer, split;
    };
    auto terms = [&](double x, double y, double z, mesh::NearTriangles::Cursor& cursor) -> Terms {
      // Surface mode: the shell, its piece's starting triangles thickened on both sides (an open surface
      // has no inside), split from the other pieces' halfway between their triangles: the distance past
      // the bisector plane of the two triangles' closest points (exact where they are points; half the
      // distances' difference crossed a crack face above two triangles meeting in a plane quadratically,
      // x |x| / 4 z at a height z, and the vertices there crowded and folded).
      if (plan_k.triangles) {
        // (The sampled field is clamped at two voxels, and the Newton steps look within two and a half.)
        const auto t = plan_k.triangles->nearest({x, y, z}, frag, plan_k.shell + 2.5 * hf, 4.5 * hf, plan_k.shell - 2.5 * hf, cursor);
        if (t.own == INFINITY) return {INFINITY, INFINITY};
        if (t.other == INFINITY) return {t.own - plan_k.shell, -INFINITY};
        const double ax = t.own_at[0] - t.other_at[0], ay = t.own_at[1] - t.other_at[1], az = t.own_at[2] - t.other_at[2];
        const double apart = std::sqrt(ax * ax + ay * ay + az * az);
        const double split = apart > 1e-9 * hf ? (t.own - t.other) * (t.own + t.other) / (2 * apart) : 0.5 * (t.own - t.other);
        return {t.own - plan_k.shell, split};
      }
      double own = INFINITY, other = INFINITY;
      std::uint32_t nearest = 0, rival = 0;
      buckets[obj]->for_each_candidate(DVec3{x, y, z}, [&](std::uint32_t b) {
        const double dx = m.position0[b].x - x, dy = m.position0[b].y - y, dz = m.position0[b].z - z;
        const double r2 = dx * dx + dy * dy + dz * dz;
        if (fragments.id[b] == frag) {
          if (r2 < own) {
            own = r2;
            nearest = b;
          }
        } else if (r2 < other) {
          other = r2;
          rival = b;
        }
      });
      if (own == INFINITY) return {INFINITY, INFINITY};
      // The distance from the bisector plane of the nearest own and other automata: exact. (The cubic
      // lattice's keeps d for their distance, exact for lattice neighbours; the random lattice's sites may
      // lie a hundredth of d apart, whose bisector the field would cross a hundred times too gently.)
      const double apart = random ? length(m.position0[nearest] - m.position0[rival]) : d;
      const double split = other == INFINITY ? -INFINITY : (own - other) / (2 * apart);
      // Outside the own cells: past the nearest own automaton's cube, or on the random lattice the union of
      // the object's cells (the bisectors part them among the fragments). Past the cube at c0 of the cubic
      // lattice's automaton a (kNoLink: every side counts), whose sides with an own cell beyond count only
      // past them (they are inside the piece: with them the field was zero there too, and the Newton steps
      // of the vertices near them went along them, leaving pits up to a fifth of a voxel deep in an object
      // turned off the world's axes; a hostile review; past such a side, where the nearest own automaton
      // lies beyond the candidates' reach, far out of the piece, it still counts).
      // (A hair inside the cell's faces: a voxel centre exactly on a face between two own cells would
      // read 0, outside, and leave a hollow there.)
      // `inner(k, above)`: whether the side along (above) or against axis k is such a side.
      const auto past_cube = [&](const DVec3& c0, const auto& inner) {
        const double px = x - c0.x, py = y - c0.y, pz = z - c0.z;
        double past = -INFINITY;
        for (std::size_t k = 0; k < 3; ++k) {
          const Vec3& e = axes[k];
          const double along = px * e.x + py * e.y + pz * e.z;
          for (const bool above : {true, false}) {
            const double side = (above ? along : -along) - 0.5 * d * (1 + 1e-6);
            if (side > 0 || !inner(k, above)) past = std::max(past, side);
          }
        }
        return past;
      };
      // On the random and jittered lattices, the union of the object's cells: a side between two of them
      // counts likewise only past it (with it the field within a cell's reach of a face was no deeper than
      // the nearest side between cells, and the Newton steps there went along that side: faces dented by up
      // to a tenth of a voxel).
      double cube = INFINITY;
      if (random) {
        cells[obj]->for_each_candidate(DVec3{x, y, z}, [&](std::uint32_t b) {
          cube = std::min(cube, past_cube(m.cell0[b], [&](std::size_t k, bool above) { return (cell_sides[b] >> (2 * k + !above) & 1) != 0; }));
        });
      } else {
        cube = past_cube(m.position0[nearest], [&](std::size_t k, bool above) {
          const std::uint32_t b = (above ? m.neighbour : m.neighbour_below)[k * m.size() + nearest];
          return b != Model::kNoLink && fragments.id[b] == frag;
        });
      }
      // A mesh object: up to a cell beyond the own cells, where the surface lies between them and the mesh.
      if (g.surface) return {std::max(surface_at(x, y, z), cube - d), split};
      return {cube, split};
    };
    mesh::TriMesh solid = mesh::polygonize(fb, [&](std::int64_t kk, float* plane) {  // each voxel on its own
      if (poll) poll();
      mesh::NearTriangles::Cursor cursor;
      std::size_t cell = 0;
      for (std::int64_t jj = 0; jj < fb.n[1]; ++jj)
        for (std::int64_t ii = 0; ii < fb.n[0]; ++ii, ++cell) {
          const Terms t = terms(fb.origin[0] + ii * hf, fb.origin[1] + jj * hf, fb.origin[2] + kk * hf, cursor);
          plane[cell] = static_cast<float>(std::clamp(std::max(t.outer, t.split) / hf, -2.0, 2.0));
        }
    });
    // Polygonizing places each vertex at the mean of its voxel's crossings of the sampled field, which
    // bevels a convex edge or corner by about a voxel (a box's pieces kept 95 to 99 % of their cells). Each
    // vertex is moved onto the field's own zero, max(outer, split) evaluated exactly rather than sampled:
    // Newton steps along its gradient (central differences a twentieth of a voxel apart; where two faces
    // meet, the difference spans both and the step goes towards their edge). Flat faces do not move.
    const auto exact = [&](double x, double y, double z, mesh::NearTriangles::Cursor& cursor) {
      const Terms t = terms(x, y, z, cursor);
      return std::max(t.outer, t.split);
    };
    // The field's gradient at p: central differences `apart` voxels apart; returns its length squared.
    const auto gradient = [&](const mesh::Point& p, double apart, double* g, mesh::NearTriangles::Cursor& cursor) {
      double g2 = 0;
      for (int c = 0; c < 3; ++c) {
        mesh::Point hi = p, lo = p;
        hi[c] += 0.5 * apart * hf;
        lo[c] -= 0.5 * apart * hf;
        // (over the points' own distance: far from the origin their rounding is a part of it)
        g[c] = (exact(hi[0], hi[1], hi[2], cursor) - exact(lo[0], lo[1], lo[2], cursor)) / (hi[c] - lo[c]);
        g2 += g[c] * g[c];
      }
      return g2;
    };
    if (poll) poll();
    const std::vector<mesh::Point> sampled = solid.vertices;  // each in the voxel it was made for
    tbb::parallel_for(std::size_t{0}, solid.vertices.size(), [&](std::size_t v) {
      if (poll && v % 4096 == 0) poll();
      mesh::NearTriangles::Cursor cursor;
      mesh::Point& p = solid.vertices[v];
      for (int step = 0; step < 2; ++step) {
        const double f = exact(p[0], p[1], p[2], cursor);
        if (!(std::fabs(f) <= 2 * hf)) break;  // off the field (outside every term): left where it is
        double g[3];
        const double g2 = gradient(p, 0.1, g, cursor);
        if (!(g2 > 1e-6 && g2 < 1e6)) break;  // no direction (or an infinite term nearby)
        if (!(f * f <= 4 * hf * hf * g2)) break;  // a step of over two voxels: a gentle slope, left where it is
        for (int c = 0; c < 3; ++c) p[c] -= f * g[c] / g2;
      }
    });
    // A primitive's edges and corners off the voxels' axes (an object turned, a cylinder's rims): a vertex
    // moved onto the nearest zero lies on one face or the other, and the triangles between such vertices
    // zigzag along the edge (a turned box kept 5,810 triangles where the unturned one has 104). Where the
    // triangles at a vertex bend, and the object's outer faces alone cross its voxel, the vertex goes where
    // their planes meet nearest to the crossings (sharp_features); the crack faces stay as they were.
    if (!g.surface && !plan_k.triangles)
      sharp_features(solid, sampled, fb, [&](const mesh::Point& p, mesh::NearTriangles::Cursor& cursor, bool* outer) {
        const Terms t = terms(p[0], p[1], p[2], cursor);
        *outer = t.outer >= t.split;
        return std::max(t.outer, t.split);
      }, gradient, poll);
    // Smoothing the crack faces (the vertices where the bisector term is the one at zero, well inside the
    // object): Taubin's lambda|mu steps flatten the cell-face staircase without shrinking the piece; the
    // outer surface stays as resampled.
    if (poll) poll();
    std::vector<std::uint8_t> crack(solid.vertices.size(), 0);
    mesh::NearTriangles::Cursor cursor;
    for (std::size_t v = 0; v < solid.vertices.size(); ++v) {
      const auto& p = solid.vertices[v];
      const Terms t = terms(p[0], p[1], p[2], cursor);
      crack[v] = t.split > t.outer && t.outer < -0.5 * hf;
    }
    smooth(solid, crack, 4, 0.3 * hf);
    collapse_zero_length_edges(solid, 1e-9 * hf);
    // A speck: a closed shell of a few triangles much smaller than the voxel, where the sampled field
    // dipped just below zero between several automata (the default wall's fragment 6 at 30 ms: a void of 12
    // triangles, 1 x 2 x 1 mm, in a piece of a 1.7 cm voxel, folded by the Newton steps so that its triangles
    // crossed each other). The sampling resolves no feature of the field so small.
    mesh::drop_small_shells(solid, 0.5 * hf);
    if (poll) poll();
    if (mesh::flat_vertex_share(solid, kFlatTolerance * hf) >= (plan_k.triangles ? kFlatShare : kLatticeFlatShare))
      mesh::simplify_flat(solid, kFlatTolerance * hf, kFlatMinHeight * hf, poll);
    FragmentMesh fm;
    fm.fragment = frag;
    fm.automata = static_cast<std::int64_t>(mem.size());
    fm.mesh = std::move(solid);
    // Carried from the starting frame to the fragment's pose.
    const auto R = mean_rotation(s, mem);
    double c0[3] = {0, 0, 0}, c1[3] = {0, 0, 0};
    for (auto a : mem) {
      c0[0] += m.position0[a].x;
      c0[1] += m.position0[a].y;
      c0[2] += m.position0[a].z;
      c1[0] += s.x[a].x;
      c1[1] += s.x[a].y;
      c1[2] += s.x[a].z;
    }
    for (int c = 0; c < 3; ++c) {
      c0[c] /= static_cast<double>(mem.size());
      c1[c] /= static_cast<double>(mem.size());
    }
    for (auto& v : fm.mesh.vertices) {
      const double r[3] = {v[0] - c0[0], v[1] - c0[1], v[2] - c0[2]};
      const DVec3 t = rotated(R, {r[0], r[1], r[2]});
      v = {c1[0] + t.x, c1[1] + t.y, c1[2] + t.z};
    }
    // Vertices the Newton steps brought within float32's rounding of each other at the pose's coordinates
    // (at a box's corners) would be one point in the file, their triangles of no area: merged, where that
    // rounding is under a hundredth of the voxel. Farther from the origin the piece is written in double:
    // merged at float32's rounding, a box 1e4 m out had a fold of two triangles on one edge, 1e5 m out 8
    // triangles and an eighth of its volume (unmerged, float32 made such pieces empty; a hostile review).
    double far = 0;
    for (const auto& v : fm.mesh.vertices) far = std::max({far, std::fabs(v[0]), std::fabs(v[1]), std::fabs(v[2])});
    fm.float32 = float32_holds(far, hf);
    if (fm.float32) collapse_zero_length_edges(fm.mesh, float32_rounding(far));
    fm.volume = mesh::signed_volume(fm.mesh);
    if (poll) poll();
    sink(std::move(fm));
  };
  // Pieces of more than kMeshedAlone automata one at a time (each fills the machine with its own loops,
  // and what it holds grows with its surface: four boxes meshed side by side on two threads held twice one's
  // memory), then the rest side by side.
  std::vector<std::size_t> small;
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    if (static_cast<std::int64_t>(members[static_cast<std::size_t>(chosen[k])].size()) > kMeshedAlone) mesh_one(k);
    else small.push_back(k);
  }
  tbb::parallel_for(std::size_t{0}, small.size(), [&](std::size_t i) { mesh_one(small[i]); });
}

}  // namespace mca::analysis
