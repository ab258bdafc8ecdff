// Surface mode as a plate (docs/model-notes.md, "Surface mode", "Bending"): the explicit links' bending and
// twisting springs against Kirchhoff plate theory, D = E t^3 / (12 (1 - nu^2)), on a regular mesh
// (equilateral triangles: link directions 60 degrees apart), the same with jittered vertices (uneven
// triangles) and a regular mesh of right triangles (directions not evenly spread, links not perpendicular
// to their edges).
//  - A free strip bent by end couples: kappa_xx = m / (D (1 - nu^2)) for a moment m per width, and the
//    anticlastic curvature kappa_yy = -nu kappa_xx (m_y = D (kappa_yy + nu kappa_xx) = 0 on the free sides).
//  - A free square plate twisted by self-balanced corner forces (P up at two opposite corners, down at the
//    other two): pure twist, m_xy = P / 2 (a corner force is 2 m_xy, Kirchhoff), w = P x y / (2 D (1 - nu)),
//    so supported at three corners the fourth deflects P c^2 / (2 D (1 - nu)) (Timoshenko and
//    Woinowsky-Krieger, Theory of plates and shells, 2nd ed., ch. 2, pure bending: the plate loaded at
//    its corners). For forces spread over the automata
//    near a corner the work conjugate of the twist is Q = sum f_k x_k y_k (= P c^2 for point forces), and
//    the plate's compliance is sum f_k w_k = Q^2 / (2 D (1 - nu) c^2): the measure of twist stiffness.
//  - The strip twisted by end torques: kappa_xy = T / (2 D (1 - nu) W).
// The loads are small (deflections 1e-3 of the thickness), so the geometrically nonlinear model answers
// as a linear plate; local damping brings it to rest.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "lattice/lattice.hpp"
#include "mesh_fixtures.hpp"
#include "sim/engine.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {

namespace fs = std::filesystem;

// A strip of n x m equilateral triangles' rows: vertices (i a + (j odd ? a / 2 : 0), j a sqrt(3) / 2).
mesh::TriMesh equilateral_mesh(int n, int m, double a) {
  mesh::TriMesh t;
  const double h = a * std::sqrt(3.0) / 2;
  for (int j = 0; j <= m; ++j)
    for (int i = 0; i <= n; ++i) t.vertices.push_back({a * i + (j % 2 ? 0.5 * a : 0.0), h * j, 0.0});
  auto at = [&](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) {
      if (j % 2 == 0) {
        t.faces.push_back({at(i, j), at(i + 1, j), at(i, j + 1)});
        t.faces.push_back({at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
      } else {
        t.faces.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
        t.faces.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
      }
    }
  return t;
}

// equilateral_mesh with its interior vertices moved by up to `share` of a in x and y (a fixed
// pseudo-random sequence): triangles of uneven shapes and sizes, links at uneven angles to their edges.
mesh::TriMesh jittered_mesh(int n, int m, double a, double share) {
  mesh::TriMesh s = equilateral_mesh(n, m, a);
  std::uint32_t seed = 12345;
  auto next = [&] {
    seed = seed * 1664525u + 1013904223u;
    return (static_cast<double>(seed >> 8) / 16777216.0) * 2 - 1;
  };
  for (int j = 1; j < m; ++j)
    for (int i = 1; i < n; ++i) {
      auto& v = s.vertices[static_cast<std::size_t>(j * (n + 1) + i)];
      v[0] += share * a * next();
      v[1] += share * a * next();
    }
  return s;
}

enum class MeshKind { equilateral, right, jittered };

const char* name_of(MeshKind k) {
  return k == MeshKind::equilateral ? "equilateral" : k == MeshKind::right ? "right triangles" : "jittered equilateral";
}

// The mesh of about L x W (lengths along x, y) with triangles of side about a.
mesh::TriMesh make_mesh(MeshKind k, double L, double W, double a) {
  if (k == MeshKind::right) return test::sheet_mesh(static_cast<int>(std::lround(L / a)), static_cast<int>(std::lround(W / a)), a);
  const int n = static_cast<int>(std::lround(L / a)), m = static_cast<int>(std::lround(W / (a * std::sqrt(3.0) / 2)));
  return k == MeshKind::equilateral ? equilateral_mesh(n, m, a) : jittered_mesh(n, m, a, 0.15);
}

struct Plate {
  double E = 30e9, nu = 0, t = 0.005;
  double D() const { return E * t * t * t / (12 * (1 - nu * nu)); }
};

// w = c0 + c1 x + c2 y + kxx x^2 / 2 + kyy y^2 / 2 + kxy x y fitted by least squares to the points given.
struct Quadratic {
  double kxx = 0, kyy = 0, kxy = 0;
};

Quadratic fit_quadratic(const std::vector<std::array<double, 3>>& p) {
  double A[6][7] = {};
  for (const auto& q : p) {
    const double x = q[0], y = q[1], w = q[2];
    const double f[6] = {1, x, y, 0.5 * x * x, 0.5 * y * y, x * y};
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) A[r][c] += f[r] * f[c];
      A[r][6] += f[r] * w;
    }
  }
  test::gauss_jordan(A);
  return {A[3][6] / A[3][3], A[4][6] / A[4][4], A[5][6] / A[5][5]};
}

// Removes from the forces f_k (z) on the points (x_k, y_k) their least-squares fit a + b x + c y, so that
// they are self-balanced: no net force and no net moment about x or y. keep = 1 fits a + c y only (the
// moment about y kept: a couple bending along x), keep = 2 a + b x (the moment about x kept: a torque).
void balance(std::vector<double>& f, const std::vector<std::array<double, 2>>& xy, int keep = 0) {
  double A[3][4] = {};
  for (std::size_t k = 0; k < f.size(); ++k) {
    const double g[3] = {1, keep == 1 ? 0.0 : xy[k][0], keep == 2 ? 0.0 : xy[k][1]};
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) A[r][c] += g[r] * g[c];
      A[r][3] += g[r] * f[k];
    }
  }
  if (keep == 1) A[1][1] = 1;  // the x column is zero: b = 0
  if (keep == 2) A[2][2] = 1;  // the y column is zero: c = 0
  test::gauss_jordan(A);
  const double a = A[0][3] / A[0][0], b = A[1][3] / A[1][1], c = A[2][3] / A[2][2];
  for (std::size_t k = 0; k < f.size(); ++k) f[k] -= a + b * xy[k][0] + c * xy[k][1];
}

// A surface-mode scene of the mesh (no gravity, local damping), whose automata `loaded` (their initial
// centres `at`) carry the vertical forces `f`, each through a [[load]] box about its centre.
SceneDef plate_scene(const test::TempDir& dir, const mesh::TriMesh& mesh, const Plate& p) {
  test::write_mesh_file(dir.path() / "plate.obj", mesh);
  SceneDef s = test::block_scene(1, 1, 1, 0.01, test::test_material(p.E, p.nu, 2400));
  s.objects[0].shape = Shape::mesh;
  s.objects[0].mesh = (dir.path() / "plate.obj").string();
  s.objects[0].fill = MeshFill::surface;
  s.objects[0].shell_thickness = p.t;
  s.solver.gravity = {0, 0, 0};
  s.solver.local_damping = 0.2;
  return s;
}

void add_loads(SceneDef& s, const std::vector<DVec3>& at, const std::vector<double>& f) {
  const double h = 1e-5;
  for (std::size_t k = 0; k < at.size(); ++k) {
    LoadDef l;
    l.name = "load" + std::to_string(k);
    l.min = {at[k].x - h, at[k].y - h, at[k].z - h};
    l.max = {at[k].x + h, at[k].y + h, at[k].z + h};
    l.force = {0, 0, f[k]};
    s.loads.push_back(l);
  }
}

// Runs until the fitted curvatures over the automata `measured` change by less than 1e-4 of their size
// from one stretch to the next; returns the last fit and the displacements' z of all automata.
Quadratic settle(Engine& sim, const std::vector<std::size_t>& measured, std::vector<double>& wz) {
  const Model& m = sim.model();
  const int steps = 2000;
  Quadratic last{1e30, 1e30, 1e30}, q;
  for (int k = 0; k < 400; ++k) {
    EXPECT_EQ(sim.advance(steps).flags, kHealthy);
    std::vector<std::array<double, 3>> pts;
    for (auto a : measured) pts.push_back({m.position0[a].x, m.position0[a].y, sim.state().x[a].z - m.position0[a].z});
    q = fit_quadratic(pts);
    const double size = std::max({std::fabs(q.kxx), std::fabs(q.kyy), std::fabs(q.kxy)});
    const double change = std::max({std::fabs(q.kxx - last.kxx), std::fabs(q.kyy - last.kyy), std::fabs(q.kxy - last.kxy)});
    last = q;
    if (k > 3 && change < 1e-4 * size) break;
  }
  wz.assign(m.size(), 0.0);
  for (std::size_t a = 0; a < m.size(); ++a) wz[a] = sim.state().x[a].z - m.position0[a].z;
  return q;
}

struct StripResult {
  double anticlastic;  // -kappa_yy / kappa_xx
  double bending;      // kappa_xx / (m / (D (1 - nu^2)))
  double twist;        // twisted: kappa_xy / (T / (2 D (1 - nu) W))
};

// A free strip L x W along x bent by end couples: at each end the automata of the outermost band a wide
// pushed up, those of the next band down (balanced per end: each end is a pure couple M about y). The
// curvatures are fitted over the middle half of the length.
// twisted: the ends' loads are torques about x instead (forces in proportion to y, balanced per end),
// T = sum f y at each end; a Kirchhoff strip of width W twists at kappa_xy = T / (2 D (1 - nu) W) (half
// the torque from m_xy = D (1 - nu) kappa_xy across the width, half from the free sides' Kirchhoff shear:
// Saint-Venant's G W t^3 / 3 of a thin strip).
StripResult strip_bending(MeshKind kind, double nu, bool twisted = false) {
  test::TempDir dir;
  const double L = 0.16, W = 0.05, a = 0.01;
  Plate p;
  p.nu = nu;
  const mesh::TriMesh mesh = make_mesh(kind, L, W, a);
  SceneDef s = plate_scene(dir, mesh, p);
  const Model m0 = lattice::build_model(s);
  double xmin = 1e30, xmax = -1e30, ymin = 1e30, ymax = -1e30;
  for (const auto& q : m0.position0) {
    xmin = std::min(xmin, q.x), xmax = std::max(xmax, q.x), ymin = std::min(ymin, q.y), ymax = std::max(ymax, q.y);
  }
  const double xc = 0.5 * (xmin + xmax), yc = 0.5 * (ymin + ymax);
  double mesh_w = 0;
  {
    double lo = 1e30, hi = -1e30;
    for (const auto& v : mesh.vertices) lo = std::min(lo, v[1]), hi = std::max(hi, v[1]);
    mesh_w = hi - lo;
  }
  // Moment per width m: curvature 1e-3 t / W^2 (small against the thickness across the width).
  const double kappa = 1e-3 * p.t / (W * W), moment = kappa * p.D() * (1 - nu * nu) * mesh_w;
  std::vector<DVec3> at;
  std::vector<double> f;
  double M_right = 0;
  for (int end : {-1, 1}) {
    std::vector<DVec3> e_at;
    std::vector<double> e_f;
    std::vector<std::array<double, 2>> e_xy;
    for (std::size_t k = 0; k < m0.size(); ++k) {
      const double d = end > 0 ? xmax - m0.position0[k].x : m0.position0[k].x - xmin;  // from the end
      if (d < 2 * a) {
        e_at.push_back(m0.position0[k]);
        e_f.push_back(twisted ? end * (m0.position0[k].y - yc) : d < a ? 1.0 : -1.0);
        e_xy.push_back({m0.position0[k].x, m0.position0[k].y});
      }
    }
    balance(e_f, e_xy, twisted ? 2 : 1);
    double Mk = 0;  // moment about y (about x when twisted) per unit force: sum f (x - xc) (f (y - yc))
    for (std::size_t k = 0; k < e_f.size(); ++k) Mk += e_f[k] * (twisted ? e_xy[k][1] - yc : e_xy[k][0] - xc);
    const double scale = moment / std::fabs(Mk);
    for (std::size_t k = 0; k < e_f.size(); ++k) {
      at.push_back(e_at[k]);
      f.push_back(e_f[k] * scale);
      if (end > 0) M_right += e_f[k] * scale * (twisted ? e_xy[k][1] - yc : e_xy[k][0] - xc);
    }
  }
  add_loads(s, at, f);
  Engine sim(s);
  std::vector<std::size_t> middle;
  for (std::size_t k = 0; k < m0.size(); ++k)
    if (std::fabs(m0.position0[k].x - xc) < 0.25 * (xmax - xmin)) middle.push_back(k);
  std::vector<double> wz;
  const Quadratic q = settle(sim, middle, wz);
  if (twisted) return {0, 0, std::fabs(q.kxy) / (std::fabs(M_right) / (2 * p.D() * (1 - nu) * mesh_w))};
  const double expected = std::fabs(M_right) / mesh_w / (p.D() * (1 - nu * nu));
  return {-q.kyy / q.kxx, std::fabs(q.kxx) / expected, 0};
}

// A free square plate of side c twisted by balanced forces at its corners: the automata within a of each
// corner share P, up at (-, -) and (+, +), down at the other two. Returns the plate's twist compliance
// over plate theory's, sum f w / (Q^2 / (2 D (1 - nu) c^2)), and the fitted kappa_xy over Q / (2 D (1 - nu) c^2).
std::array<double, 4> plate_twist(MeshKind kind, double nu) {
  test::TempDir dir;
  const double c = 0.1, a = 0.01;
  Plate p;
  p.nu = nu;
  const mesh::TriMesh mesh = make_mesh(kind, c, c, a);
  double x0 = 1e30, x1 = -1e30, y0 = 1e30, y1 = -1e30;
  for (const auto& v : mesh.vertices) x0 = std::min(x0, v[0]), x1 = std::max(x1, v[0]), y0 = std::min(y0, v[1]), y1 = std::max(y1, v[1]);
  SceneDef s = plate_scene(dir, mesh, p);
  const Model m0 = lattice::build_model(s);
  double xmin = 1e30, xmax = -1e30, ymin = 1e30, ymax = -1e30;
  for (const auto& q : m0.position0) {
    xmin = std::min(xmin, q.x), xmax = std::max(xmax, q.x), ymin = std::min(ymin, q.y), ymax = std::max(ymax, q.y);
  }
  const double xc = 0.5 * (xmin + xmax), yc = 0.5 * (ymin + ymax);
  const double cx = x1 - x0, cy = y1 - y0;  // the mesh's sides
  double area = 0;  // the mesh's (the equilateral mesh's sides along y are zigzags)
  for (const auto& t : mesh.faces) area += 0.5 * mesh::twice_area(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]);
  // Corner forces: twist of 1e-3 t / c^2.
  const double P = 1e-3 * p.t / (c * c) * 2 * p.D() * (1 - nu);
  std::vector<DVec3> at;
  std::vector<double> f;
  std::vector<std::array<double, 2>> xy;
  for (int sx : {-1, 1})
    for (int sy : {-1, 1}) {
      const double X = sx < 0 ? xmin : xmax, Y = sy < 0 ? ymin : ymax;
      std::vector<std::size_t> near;
      for (std::size_t k = 0; k < m0.size(); ++k)
        if (std::fabs(m0.position0[k].x - X) < a && std::fabs(m0.position0[k].y - Y) < a) near.push_back(k);
      for (auto k : near) {
        at.push_back(m0.position0[k]);
        f.push_back(sx * sy * P / static_cast<double>(near.size()));
        xy.push_back({m0.position0[k].x - xc, m0.position0[k].y - yc});
      }
    }
  balance(f, xy);
  double Q = 0;
  for (std::size_t k = 0; k < f.size(); ++k) Q += f[k] * xy[k][0] * xy[k][1];
  add_loads(s, at, f);
  Engine sim(s);
  std::vector<std::size_t> inner;
  for (std::size_t k = 0; k < m0.size(); ++k)
    if (std::fabs(m0.position0[k].x - xc) < 0.35 * cx && std::fabs(m0.position0[k].y - yc) < 0.35 * cy) inner.push_back(k);
  std::vector<double> wz;
  const Quadratic q = settle(sim, inner, wz);
  double work = 0;
  for (std::size_t k = 0; k < f.size(); ++k) {
    // The loaded automata are found again by their centres (the loads' boxes).
    for (std::size_t n = 0; n < m0.size(); ++n)
      if (m0.position0[n].x == at[k].x && m0.position0[n].y == at[k].y) work += f[k] * wz[n];
  }
  // The loads' rectangle: the corner automata's centroids lie about a / 3 in from the sides, so the
  // plate between the loads is smaller than the mesh (by 13 % in area on 10 x 10 triangles' squares).
  double fx = 0, fy = 0, fs = 0;
  for (std::size_t k = 0; k < f.size(); ++k) {
    fx += std::fabs(f[k] * xy[k][0]);
    fy += std::fabs(f[k] * xy[k][1]);
    fs += std::fabs(f[k]);
  }
  const double spanned = 4 * (fx / fs) * (fy / fs);
  const double plate = 2 * p.D() * (1 - nu) * area, between = 2 * p.D() * (1 - nu) * spanned;
  return {work / (Q * Q / plate), q.kxy / (Q / plate), work / (Q * Q / between), q.kxy / (Q / between)};
}

// Plate theory: -kappa_yy / kappa_xx = nu within 0.05 and kappa_xx within 10 % on equilateral triangles,
// regular or jittered, at nu = 0 and 0.3 (measured: 0.000 / 0.293 and 1.000 / 0.951 regular, 0.007 / 0.296
// and 0.999 / 0.954 jittered). On right triangles (sheet_mesh: three link directions at 27, 63 and 135
// degrees, links not perpendicular to their edges) the up and down triangles' rotations shift against each
// other and the anticlastic ratio falls short at nu = 0.3: -0.044 and 0.192 measured (the springs'
// analysis gives -0.05 and 0.19), kappa_xx 1.03; that mesh is held to 0.12 (docs/model-notes.md). Before
// the plate's constants: -0.14 / -0.09 regular, -0.19 / -0.14 right triangles, kappa_xx 0.85-0.91.
TEST(ShellBending, AFreeStripBentByEndCouplesCurvesAsAPlate) {
  for (MeshKind kind : {MeshKind::equilateral, MeshKind::right, MeshKind::jittered})
    for (double nu : {0.0, 0.3}) {
      const StripResult r = strip_bending(kind, nu);
      std::printf("free strip, %s, nu = %.1f: -kappa_yy / kappa_xx = %.3f, kappa_xx / plate theory = %.3f\n",
                  name_of(kind), nu, r.anticlastic, r.bending);
      EXPECT_NEAR(r.anticlastic, nu, kind == MeshKind::right ? 0.12 : 0.05) << name_of(kind) << ", nu = " << nu;
      EXPECT_NEAR(r.bending, 1.0, 0.1) << name_of(kind) << ", nu = " << nu;
    }
}

// A square plate 10 triangles' squares wide twisted by corner forces. The reference is ambiguous on such
// a mesh by the corner automata's inset: their centroids lie about a / 3 in from the sides, and plate
// theory on the mesh's square or on the loads' smaller rectangle differ by 25 %; plate theory lies
// between the two (measured: compliance / plate theory 1.12-1.13 and 0.87-0.89 on equilateral triangles,
// 1.19-1.20 and 0.94 on right ones; before the plate's constants 0.70-0.85 on the mesh's square: 1.18-1.43
// times too stiff). The strip twisted by end torques below has no such ambiguity.
TEST(ShellBending, ASquarePlateTwistedByCornerForcesIsAsStiffAsAPlate) {
  for (MeshKind kind : {MeshKind::equilateral, MeshKind::right, MeshKind::jittered})
    for (double nu : {0.0, 0.3}) {
      const auto r = plate_twist(kind, nu);
      std::printf("twisted plate, %s, nu = %.1f: compliance / plate theory = %.3f (stiffness ratio %.3f), "
                  "kappa_xy / plate theory = %.3f; on the loads' rectangle %.3f and %.3f\n",
                  name_of(kind), nu, r[0], 1 / r[0], r[1], r[2], r[3]);
      EXPECT_GT(r[0], 1.0) << name_of(kind) << ", nu = " << nu;
      EXPECT_LT(r[2], 1.0) << name_of(kind) << ", nu = " << nu;
      EXPECT_LT(r[0], 1.25) << name_of(kind) << ", nu = " << nu;
      EXPECT_GT(r[2], 0.8) << name_of(kind) << ", nu = " << nu;
    }
}

// Plate theory in twist: a free strip 5 triangles' squares wide twisted by end torques, kappa_xy within
// 10 % on equilateral triangles, regular or jittered, at nu = 0 and 0.3 (measured 1.07-1.08: the strip
// is that much softer than a thin Kirchhoff strip; a solid one of this t / W = 0.1 is 6 % softer,
// Saint-Venant's J = W t^3 / 3 (1 - 0.63 t / W)). On right triangles 1.16-1.18 measured, held to 0.2.
TEST(ShellBending, AFreeStripTwistedByEndTorquesIsAsStiffAsAPlate) {
  for (MeshKind kind : {MeshKind::equilateral, MeshKind::right, MeshKind::jittered})
    for (double nu : {0.0, 0.3}) {
      const double r = strip_bending(kind, nu, true).twist;
      std::printf("twisted strip, %s, nu = %.1f: kappa_xy / plate theory = %.3f\n", name_of(kind), nu, r);
      EXPECT_NEAR(r, 1.0, kind == MeshKind::right ? 0.2 : 0.1) << name_of(kind) << ", nu = " << nu;
    }
}

}  // namespace
}  // namespace mca
