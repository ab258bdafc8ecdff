#include "lattice/lattice.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fmt/format.h>
#include <limits>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <unordered_map>
#include <unordered_set>

#include "core/environment.hpp"
#include "core/text.hpp"
#include "grid/uniform_grid.hpp"
#include "core/rng.hpp"
#include "lattice/heterogeneity.hpp"
#include "lattice/mesh_object.hpp"
#include "lattice/random_lattice.hpp"
#include "mca/error.hpp"
#include "physics/contact_law.hpp"
#include "physics/link_law.hpp"

namespace mca::lattice {
namespace {

struct Mat3 {
  double m[3][3];
  Vec3d apply(const Vec3d& v) const {
    return {m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2], m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
            m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2]};
  }
};

Mat3 mul(const Mat3& a, const Mat3& b) {
  Mat3 r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) r.m[i][j] += a.m[i][k] * b.m[k][j];
  return r;
}

// Rotation about x, then y, then z (degrees): R = Rz Ry Rx.
Mat3 rotation_matrix(const Vec3d& deg) {
  const double k = std::numbers::pi / 180.0;
  const double a = deg[0] * k, b = deg[1] * k, c = deg[2] * k;
  const Mat3 rx{{{1, 0, 0}, {0, std::cos(a), -std::sin(a)}, {0, std::sin(a), std::cos(a)}}};
  const Mat3 ry{{{std::cos(b), 0, std::sin(b)}, {0, 1, 0}, {-std::sin(b), 0, std::cos(b)}}};
  const Mat3 rz{{{std::cos(c), -std::sin(c), 0}, {std::sin(c), std::cos(c), 0}, {0, 0, 1}}};
  return mul(rz, mul(ry, rx));
}

// The cells of an object's own lattice: dims and which cells are inside the shape.
struct ObjectLattice {
  std::int64_t n[3] = {0, 0, 0};
  double origin[3] = {0, 0, 0};  // centre of cell (0,0,0) in the object frame
  std::vector<std::uint8_t> inside;
  std::vector<std::vector<std::uint8_t>> regions;  // per region: cells inside its mesh (mesh regions only)
  double fill_seconds = 0;
  std::int64_t dropped = 0, dropped_pieces = 0, largest_dropped = 0;  // mesh fills: MeshFillResult's
};

// What a scene's objects are made of beyond their definitions: the meshes of the mesh objects, read once
// per build (null for the primitives), with each mesh's last fill kept so that the spacing search and the
// build fill it once at the chosen spacing.
struct Shapes {
  std::vector<std::unique_ptr<MeshObject>> mesh;
  mutable std::vector<std::optional<std::pair<double, MeshFillResult>>> fill;
  // Per object filled in surface mode: its automata and links (which do not depend on the spacing).
  std::vector<std::optional<SurfaceCells>> surface;
  bool any_mesh = false;  // some object is a mesh filled by volume
  bool any_lattice = false;  // some object is filled by a lattice (not in surface mode)
  const MeshObject* of(std::size_t object) const { return mesh[object].get(); }
  const SurfaceCells* surface_of(std::size_t object) const { return surface[object] ? &*surface[object] : nullptr; }
};

Shapes prepare_shapes(const SceneDef& scene) {
  Shapes S;
  S.mesh.resize(scene.objects.size());
  S.fill.resize(scene.objects.size());
  S.surface.resize(scene.objects.size());
  for (std::size_t o = 0; o < scene.objects.size(); ++o) {
    const ObjectDef& od = scene.objects[o];
    if (od.shape != Shape::mesh) {
      S.any_lattice = true;
      continue;
    }
    S.mesh[o] = std::make_unique<MeshObject>(prepare_mesh_object(scene, o));
    if (od.fill == MeshFill::surface) {
      S.surface[o] = surface_cells(scene, o, *S.mesh[o]);
    } else {
      S.any_mesh = true;
      S.any_lattice = true;
    }
  }
  return S;
}

std::int64_t cells_along(double extent, double d) {
  return std::max<std::int64_t>(1, static_cast<std::int64_t>(std::llround(extent / d)));
}

// The extents of an object's shape along its local axes (`m`: its mesh, for shape mesh).
void shape_extents(const ObjectDef& o, const MeshObject* m, double ext[3]) {
  switch (o.shape) {
    case Shape::box: ext[0] = o.size[0]; ext[1] = o.size[1]; ext[2] = o.size[2]; break;
    case Shape::sphere: ext[0] = ext[1] = ext[2] = 2 * o.radius; break;
    case Shape::cylinder: ext[0] = ext[1] = 2 * o.radius; ext[2] = o.height; break;
    case Shape::mesh:
      for (int a = 0; a < 3; ++a) ext[a] = m->extent(a);
      break;
  }
}

// Cells per axis and the centre of cell (0,0,0) in the object frame: a size is rounded to whole cells.
// (A mesh's cells whose centres are inside it all lie in this frame: a cell beyond it along an axis has
// its centre at least (n + 1) d / 2 > extent / 2 from the centre.)
void lattice_frame(const ObjectDef& o, const MeshObject* m, double d, std::int64_t n[3], double origin[3]) {
  double ext[3] = {0, 0, 0};
  shape_extents(o, m, ext);
  for (int a = 0; a < 3; ++a) {
    n[a] = cells_along(ext[a], d);
    origin[a] = -0.5 * static_cast<double>(n[a] - 1) * d;
  }
}

}  // namespace

MemoryLimit memory_limit(const SceneDef& scene) { return mca::memory_limit(scene.solver.max_memory_gb * 1e9); }

namespace {

// Whether the cell centre (x, y, z) of the object frame lies in the shape.
bool inside_shape(const ObjectDef& o, double x, double y, double z) {
  if (o.shape == Shape::sphere) return x * x + y * y + z * z <= o.radius * o.radius;
  if (o.shape == Shape::cylinder) return x * x + y * y <= o.radius * o.radius && std::fabs(z) <= 0.5 * o.height;
  return true;
}

// The fill of a mesh object (and its mesh regions) at spacing d: the last one if it was at d, else a new
// one (kept).
const MeshFillResult& mesh_fill(const SceneDef& scene, const Shapes& S, std::size_t oi, double d) {
  auto& memo = S.fill[oi];
  if (!memo || memo->first != d) {
    mesh::CellBox box;
    box.d = d;
    lattice_frame(scene.objects[oi], S.of(oi), d, box.n, box.origin);
    // Arrays over the object's whole box of cells, not over its automata: the fill (a byte per cell, kept,
    // and one in flight), its copy in the lattice (one), the cell -> automaton index (8), and two bytes per
    // mesh region. A mesh of two parts far apart is a box of mostly empty cells: two 0.3 m cubes 100 m
    // apart along a diagonal are 8e9 cells at 0.05 m, 97 GB, where one byte per cell (8 GB) was checked and
    // the build died of a bare std::bad_alloc.
    const double cells = static_cast<double>(box.n[0]) * static_cast<double>(box.n[1]) * static_cast<double>(box.n[2]);
    const double per_cell = 11.0 + 2.0 * static_cast<double>(scene.objects[oi].regions.size());
    // (Within solver.max_memory_gb, and within the machine's memory whatever that says: 30 GB of cells on a
    // 24 GB machine had the build killed by the kernel after two minutes.)
    const MemoryLimit limit = memory_limit(scene);
    if (cells * per_cell > limit.bytes) {
      const double solid = S.of(oi)->volume() / (d * d * d);
      const double fits = d * std::cbrt(cells * per_cell / limit.bytes) * 1.05;
      const SpacingRange range = spacing_range(scene);
      throw Error(fmt::format(
          "{}: object[{}] '{}': its bounding box holds {} x {} x {} cells at spacing {:.4g} m ({:.3g} GB at {:g} bytes "
          "per cell while its lattice is built), {}; {} or {}{}",
          scene.source, oi, scene.objects[oi].name, box.n[0], box.n[1], box.n[2], d, cells * per_cell / 1e9, per_cell,
          limit.over,
          fits > range.hi ? fmt::format("no spacing makes it fit (it would take {:.3g} m, more than {}): scale the "
                                        "mesh down",
                                        fits, spacing_bound(range, false))
                          : fmt::format("increase solver.spacing (a spacing of about {:.3g} m fits)", fits),
          limit.instead,
          solid < 0.01 * cells
              ? fmt::format(". The mesh fills {:.2g} % of its box: if it is made of parts far apart, give each part an "
                            "object of its own",
                            100 * solid / cells)
              : std::string()));
    }
    memo.emplace(d, fill_mesh_object(scene, oi, *S.of(oi), box));
  }
  return memo->second;
}

ObjectLattice object_lattice(const SceneDef& scene, const Shapes& S, std::size_t oi, double d) {
  const ObjectDef& o = scene.objects[oi];
  ObjectLattice L;
  lattice_frame(o, S.of(oi), d, L.n, L.origin);
  if (o.shape == Shape::mesh) {
    const MeshFillResult& f = mesh_fill(scene, S, oi, d);
    L.inside = f.inside;
    L.regions = f.regions;
    L.fill_seconds = f.seconds;
    L.dropped = f.dropped;
    L.dropped_pieces = f.dropped_pieces;
    L.largest_dropped = f.largest_dropped;
    return L;
  }
  const std::int64_t total = L.n[0] * L.n[1] * L.n[2];
  L.inside.assign(static_cast<std::size_t>(total), 1);
  if (o.shape == Shape::box) return L;
  std::size_t c = 0;
  for (std::int64_t k = 0; k < L.n[2]; ++k)
    for (std::int64_t j = 0; j < L.n[1]; ++j)
      for (std::int64_t i = 0; i < L.n[0]; ++i, ++c)
        L.inside[c] = inside_shape(o, L.origin[0] + i * d, L.origin[1] + j * d, L.origin[2] + k * d) ? 1 : 0;
  return L;
}

// The count object_lattice would give, without allocating it: row by row along x, where the inside
// cells of a sphere or cylinder row form one interval around x = 0 (its ends found by bisection with
// the same test), so that a tiny spacing is refused by the memory check instead of exhausting memory.
std::int64_t object_count(const SceneDef& scene, const Shapes& S, std::size_t oi, double d) {
  const ObjectDef& o = scene.objects[oi];
  if (const SurfaceCells* sc = S.surface_of(oi)) return static_cast<std::int64_t>(sc->face.size());
  if (o.shape == Shape::mesh) return mesh_fill(scene, S, oi, d).count;
  std::int64_t n[3];
  double origin[3];
  lattice_frame(o, nullptr, d, n, origin);
  if (o.shape == Shape::box) return n[0] * n[1] * n[2];
  std::int64_t count = 0;
  const std::int64_t mid = n[0] / 2;  // the cell nearest x = 0 (its centre is at |x| <= d/2)
  for (std::int64_t k = 0; k < n[2]; ++k)
    for (std::int64_t j = 0; j < n[1]; ++j) {
      const double y = origin[1] + j * d, z = origin[2] + k * d;
      auto in = [&](std::int64_t i) { return inside_shape(o, origin[0] + i * d, y, z); };
      if (!in(mid)) continue;
      std::int64_t lo = 0, hi = mid;  // first inside cell in [0, mid]
      while (lo < hi) {
        const std::int64_t m = (lo + hi) / 2;
        if (in(m)) hi = m;
        else lo = m + 1;
      }
      std::int64_t a = mid, b = n[0] - 1;  // last inside cell in [mid, n-1]
      while (a < b) {
        const std::int64_t m = (a + b + 1) / 2;
        if (in(m)) a = m;
        else b = m - 1;
      }
      count += a - lo + 1;
    }
  return count;
}

bool inside_region(const RegionDef& r, const Vec3d& p) {
  if (r.shape == Shape::sphere) {
    const double dx = p[0] - r.center[0], dy = p[1] - r.center[1], dz = p[2] - r.center[2];
    return dx * dx + dy * dy + dz * dz <= r.radius * r.radius;
  }
  for (int a = 0; a < 3; ++a)
    if (std::fabs(p[a] - r.center[a]) > 0.5 * r.size[a]) return false;
  return true;
}

// A box or sphere region that holds no automaton of its object is refused, as a mesh region is
// (mesh_object.cpp): it is a misplaced centre or a size in the wrong units, and the material it names
// would silently be missing. `first`: the object's first automaton (the rest follow it in M).
void refuse_empty_regions(const SceneDef& scene, const Model& M, std::size_t oi, std::size_t first, double d) {
  const ObjectDef& o = scene.objects[oi];
  for (std::size_t r = 0; r < o.regions.size(); ++r) {
    const RegionDef& g = o.regions[r];
    if (g.shape == Shape::mesh) continue;
    bool any = false;
    for (std::size_t a = first; a < M.size() && !any; ++a)
      any = inside_region(g, {M.position0[a].x, M.position0[a].y, M.position0[a].z});
    if (any) continue;
    const std::string what =
        g.shape == Shape::sphere
            ? fmt::format("sphere of radius {:g} m at center [{:g}, {:g}, {:g}]", g.radius, g.center[0], g.center[1],
                          g.center[2])
            : fmt::format("box of size [{:g}, {:g}, {:g}] m at center [{:g}, {:g}, {:g}]", g.size[0], g.size[1],
                          g.size[2], g.center[0], g.center[1], g.center[2]);
    throw Error(fmt::format("{}: object[{}] '{}': region[{}] ({}) holds no automaton of the object at spacing {:.4g} m; "
                            "regions are in world coordinates and axes: move its center into the object (placed at "
                            "[{:g}, {:g}, {:g}]) or enlarge it, or remove the region",
                            scene.source, oi, o.name, r, what, d, o.position[0], o.position[1], o.position[2]));
  }
}

// The smallest and largest class factors of the classes any object of the scene uses (share > 0): they
// scale the breaking strains.
std::pair<double, double> class_factor_range(const SceneDef& scene) {
  double lo = INFINITY, hi = 0;
  auto take = [&](const HeterogeneityDef& h) {
    for (int c = 0; c < 4; ++c)
      if (h.shares[c] > 0) {
        lo = std::min(lo, h.class_factors[c]);
        hi = std::max(hi, h.class_factors[c]);
      }
  };
  for (const auto& o : scene.objects) take(o.heterogeneity ? *o.heterogeneity : scene.heterogeneity);
  if (hi == 0) return {1.0, 1.0};
  return {lo, hi};
}

// The step computes in float32 (math.hpp): a value it stores must be a normal, finite float. A density of
// 1e-50 or a modulus of 1e39 would otherwise become 0 or inf and the run NaN.
bool fits_float32(double v) {
  const double a = std::fabs(v);
  // Up to where it rounds to the largest float (half a unit of its last place above it: 2^103).
  constexpr double kRoundsToMax = std::numeric_limits<float>::max() + 0x1p103;
  return a >= std::numeric_limits<float>::min() && a < kRoundsToMax;
}

float as_float32(const SceneDef& scene, const std::string& what, double v, const std::string& fix) {
  if (!fits_float32(v)) {
    throw Error(fmt::format("{}: {} = {} does not fit the float32 arithmetic of the solver (magnitudes from {} to "
                            "{}); {}",
                            scene.source, what, text::num(v), text::num(std::numeric_limits<float>::min()),
                            text::num(std::numeric_limits<float>::max()), fix));
  }
  return static_cast<float>(v);
}

// as_float32 for a value of each automaton: `what()` names it only where it does not fit (naming every
// automaton's mass and moment of inertia formatted two strings an automaton while a model was built).
template <class What>
float automaton_float32(const SceneDef& scene, const What& what, double v, const std::string& fix) {
  return fits_float32(v) ? static_cast<float>(v) : as_float32(scene, what(), v, fix);
}

}  // namespace

// A jittered lattice's links lean off the axes, and its automata relax off the affine displacement: the
// interior of a block of it is softer than the cubic lattice's by 1 - 1.521 a^2 + 5.07 a^4 at jitter a
// (measured with the factor 1: 20^3 blocks under uniaxial stress, the affine fit of the middle half's
// displacements, seeds 1 and 2, at a = 0.1, 0.2, 0.25, 0.3: 0.986 / 0.984, 0.951 / 0.946, 0.929 / 0.924,
// 0.907 / 0.901 of the cubic block's modulus, the same at nu = 0.3; Poisson's ratio within 0.190-0.217 for
// an input 0.2). The lattice's moduli are raised by the inverse.
float jitter_stiffness(double a) { return static_cast<float>(1.0 / (1.0 - 1.521 * a * a + 5.07 * a * a * a * a)); }

namespace {

// The smallest strain at which a link may break: below it, float32 rounding of the per-step strain and
// velocity updates (relative 6e-8) is a visible share of the threshold.
constexpr double kMinBreakingStrain = 1e-6;

// `automata`: the material fills objects (projectiles are rigid and never break: no breaking-strain check).
GroupParams group_params(const SceneDef& scene, const MaterialDef& m, const std::string& key,
                         std::pair<double, double> class_factors, bool automata) {
  const std::string q = fmt::format("{} (material \"{}\")", key, m.name);
  const std::string units = "check the units (Pa, kg/m^3)";
  as_float32(scene, q + ".youngs_modulus", m.youngs_modulus, units);
  as_float32(scene, q + ".density", m.density, units);
  as_float32(scene, q + ".tensile_strength", m.tensile_strength, units);
  as_float32(scene, q + ".compressive_strength", m.compressive_strength, units);
  as_float32(scene, q + ".fracture_strain", m.fracture_strain, "use e.g. 1.5e-4 for concrete");
  if (m.fracture_energy != 0)  // (0 is the instant break; 1e-300 would silently become it)
    as_float32(scene, q + ".fracture_energy", m.fracture_energy, "use e.g. 100 for concrete, or 0 for the instant break");
  // The weakest link: the weakest class, and the factor of a strength spread that one link in 1e9 falls
  // below, of this material's modulus or, for its links to another material, the smallest modulus of
  // the scene (a link takes its ends' smaller nonzero one).
  double modulus = m.weibull_modulus;
  for (const MaterialDef& other : scene.materials)
    if (other.weibull_modulus > 0 && (modulus <= 0 || other.weibull_modulus < modulus)) modulus = other.weibull_modulus;
  const double spread = modulus > 0 ? weibull_factor(1e-9, modulus) : 1.0;
  const double weakest = class_factors.first * spread;
  const double breaking = weakest * std::min(m.fracture_strain, m.tensile_strength / m.youngs_modulus);
  if (automata && breaking < kMinBreakingStrain) {
    const text::Distinct bd = text::distinct(breaking, kMinBreakingStrain, 3);
    throw Error(fmt::format(
        "{}: {} breaks at a strain of {} (the smaller of fracture_strain = {:g} and tensile_strength / "
        "youngs_modulus = {:g} / {:g}, times the weakest class factor {:g}{}), below the {} that the float32 "
        "arithmetic of the solver resolves; check youngs_modulus (Pa) and the strengths, or raise them{}",
        scene.source, q, bd.a, m.fracture_strain, m.tensile_strength, m.youngs_modulus, class_factors.first,
        modulus > 0 ? fmt::format(" and the factor {:.3g} one link in 1e9 falls below at weibull_modulus = {:g}", spread,
                                  modulus)
                    : "",
        bd.b,
        modulus > 0 ? fmt::format("; or narrow the links' spread: a larger weibull_modulus (the smallest of the "
                                  "materials' sets it for all: {:g}; at 6 the factor is {:.3g}), or 0 for none",
                                  modulus, weibull_factor(1e-9, 6.0))
                    : ""));
  }
  const double class_factor_max = class_factors.second;
  GroupParams g;
  const double E = m.youngs_modulus, nu = m.poisson_ratio;
  g.youngs = static_cast<float>(E);
  g.poisson = static_cast<float>(nu);
  g.density = static_cast<float>(m.density);
  g.shear_modulus = static_cast<float>(E / (2 * (1 + nu)));
  g.lame_lambda = static_cast<float>(E * nu / ((1 + nu) * (1 - 2 * nu)));
  g.tensile_strength = static_cast<float>(m.tensile_strength);
  g.compressive_strength = static_cast<float>(m.compressive_strength);
  g.fracture_strain = static_cast<float>(m.fracture_strain);
  g.friction = static_cast<float>(m.friction);
  g.restitution = static_cast<float>(m.restitution);
  g.rolling_friction = static_cast<float>(m.rolling_friction);
  g.twisting_friction = static_cast<float>(m.twisting_friction);
  g.damping_time = static_cast<float>(m.damping_time);
  g.fracture_energy = static_cast<float>(m.fracture_energy);
  g.weibull_modulus = static_cast<float>(m.weibull_modulus);
  g.strengthening.law = static_cast<int>(m.strengthening);
  g.strengthening.alpha = static_cast<float>(m.strengthening_alpha);
  // The law stops at the largest strain a link of this material reaches: its breaking strain in
  // tension, the strain of its compressive strength in compression (link_law.hpp).
  if (g.strengthening.law != 0) {
    g.strengthening.cap = static_cast<float>(class_factor_max * std::max(m.fracture_strain, m.compressive_strength / E));
    // The time step shrinks with the square root of the largest factor: refuse laws that would stiffen
    // the material more than 1e4-fold before it breaks (a projectile's material has no links to stiffen).
    const double f = strengthening_factor(g.strengthening, g.strengthening.cap);
    if (automata && !(f <= 1e4)) {
      throw Error(fmt::format(
          "{}: {}.strengthening_alpha = {:g} makes the {} law reach a factor of {:.3g} at the largest strain a link "
          "of it can have ({:.3g}: fracture_strain, or compressive_strength / youngs_modulus, times the largest "
          "class factor); the time step would shrink {:.3g}-fold. Lower strengthening_alpha, or the "
          "fracture_strain and compressive_strength that cap the law (at most a factor of 1e4)",
          scene.source, q, m.strengthening_alpha,
          m.strengthening == StrengtheningLaw::exponential ? "exponential" : "quadratic", f, g.strengthening.cap,
          std::sqrt(f)));
    }
  }
  return g;
}

// The automata of grips and loads: initial centre inside [lo, hi].
bool inside_box(DVec3 p, const Vec3d& lo, const Vec3d& hi) {
  return p.x >= lo[0] && p.x <= hi[0] && p.y >= lo[1] && p.y <= hi[1] && p.z >= lo[2] && p.z <= hi[2];
}

Vec3 to_vec3(const Vec3d& v) { return {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])}; }
DVec3 to_dvec3(const Vec3d& v) { return {v[0], v[1], v[2]}; }

std::string fmt_vec(const Vec3d& v) { return fmt::format("[{:g}, {:g}, {:g}]", v[0], v[1], v[2]); }

// The volume object oi fills with a lattice (0 for a surface-mode object: a count of its own, whatever the
// spacing).
double object_volume(const SceneDef& scene, const Shapes& S, std::size_t oi) {
  const ObjectDef& o = scene.objects[oi];
  if (S.surface_of(oi)) return 0;
  if (o.shape == Shape::mesh) return S.of(oi)->volume();
  if (o.shape == Shape::box) return o.size[0] * o.size[1] * o.size[2];
  if (o.shape == Shape::sphere) return 4.0 / 3.0 * std::numbers::pi * std::pow(o.radius, 3);
  return std::numbers::pi * o.radius * o.radius * o.height;
}

double shapes_volume(const SceneDef& scene, const Shapes& S) {
  double volume = 0;
  for (std::size_t oi = 0; oi < scene.objects.size(); ++oi) volume += object_volume(scene, S, oi);
  return volume;
}

// The spacing that gives about 10,000 automata in `volume`.
double ten_thousand_d(double volume) { return std::cbrt(std::max(volume, 1e-300) / 1e4); }

// The spacing that gives about 10,000 automata, for messages about scenes far too coarse or too fine.
std::string ten_thousand_hint(const SceneDef& scene, const Shapes& S) {
  return ten_thousand_spacing(shapes_volume(scene, S), spacing_range(scene));
}

// The memory a run holds per automaton of the scene's lattice: with the random lattice's explicit links
// (kRandomLinksPerAutomaton; surface-mode objects are counted apart, before this check, in the mesh's).
double bytes_per_automaton(const SceneDef& scene) {
  const bool random = scene.solver.lattice == SolverDef::Lattice::random;
  const auto links = static_cast<std::size_t>(random ? 1000 * kRandomLinksPerAutomaton : 0);
  return static_cast<double>(estimate_memory_bytes(1000, links, random ? 1000 : 0) - estimate_memory_bytes(0)) / 1000;
}

// The spacing at which `automata` at spacing d (a lower bound when `approximate`: half the volume's count)
// would fit in `limit` bytes, `per` bytes each, with 5 % to spare for the rounding of sizes to whole cells.
double spacing_that_fits(double d, double automata, bool approximate, double limit, double per) {
  const double fit = (limit - static_cast<double>(estimate_memory_bytes(0))) / per;
  return d * std::cbrt((approximate ? 2 * automata : automata) / fit) * 1.05;
}

// The fix for a model too large at spacing d, `fits` the spacing that would fit: a larger spacing, or, where
// solver.target_automata chooses the spacing, a lower target (the count falls with the cube of the spacing).
// `automata` is the count spacing_that_fits took (twice a lower bound from the volume).
// A fix of a model over the memory it may take, and whether more memory would be one too.
struct MemoryFix {
  std::string text;
  bool more_memory_helps = true;
};

MemoryFix smaller_model(const SceneDef& scene, double d, double automata, double fits) {
  // (Where no spacing fits, more memory would not either.)
  if (const SpacingRange range = spacing_range(scene); fits > range.hi)
    return {fmt::format("no spacing makes it fit: it would take {:.3g} m, more than {}; scale the objects down",
                        fits, spacing_bound(range, false)),
            false};
  if (scene.solver.target_automata > 0)
    return {fmt::format("lower solver.target_automata (about {:.3g} fits)", automata * std::pow(d / fits, 3.0))};
  return {fmt::format("increase solver.spacing (memory falls with its cube: a spacing of about {:.3g} m fits)", fits)};
}

// The memory a run holds per automaton of a surface-mode object: its triangle's automaton and about 1.5
// explicit links (a closed mesh has 1.5 edges per triangle).
double bytes_per_surface_automaton() {
  return static_cast<double>(estimate_memory_bytes(1000, 1500, 0) - estimate_memory_bytes(0)) / 1000;
}

// Refuses a model over solver.max_memory_gb or the machine's memory: `automata` lattice automata at spacing d
// (a lower bound when `approximate`: half the volume's count) and `surface` automata of surface-mode
// objects, one per triangle, whatever the spacing.
void refuse_over_memory(const SceneDef& scene, double d, double automata, bool approximate, double surface) {
  const double per = bytes_per_automaton(scene), per_surface = bytes_per_surface_automaton();
  const double fixed = static_cast<double>(estimate_memory_bytes(0));
  const double bytes = per * automata + per_surface * surface + fixed;
  const double limit = scene.solver.max_memory_gb * 1e9;
  if (limit <= fixed) {
    throw Error(fmt::format("{}: solver.max_memory_gb = {} leaves nothing for a model: the program takes {} GB "
                            "without one; raise solver.max_memory_gb above it, e.g. to 16 (the default)",
                            scene.source, text::num(scene.solver.max_memory_gb), text::num(fixed / 1e9)));
  }
  // What is over `cap` bytes, and the fix: the lattice's spacing where the surface-mode objects leave it
  // room (their counts are their meshes' triangles, which no spacing changes), else fewer triangles.
  const auto over = [&](double cap) {
    const std::string lattice = fmt::format("{}{:.4g} automata at spacing {:.4g} m", approximate ? "at least " : "",
                                            automata, d);
    const std::string shells = fmt::format("{:.4g} automata of surface-mode objects (one a triangle)", surface);
    const std::string count = surface <= 0 ? lattice : automata <= 0 ? shells : lattice + " and " + shells;
    const double room = cap - per_surface * surface;
    const MemoryFix fix =
        surface <= 0 || (automata > 0 && room > 2 * fixed)
            ? smaller_model(scene, d, approximate ? 2 * automata : automata,
                            spacing_that_fits(d, automata, approximate, room, per))
            : MemoryFix{fmt::format("give the surface-mode objects meshes of fewer triangles (about {:.3g} in all "
                                    "fit, at {:.0f} bytes each; solver.spacing does not change their count)",
                                    std::max(0.0, (cap - fixed - per * automata) / per_surface), per_surface)};
    return std::pair{count, fix};
  };
  const MemoryLimit cap = memory_limit(scene);
  if (bytes > cap.bytes) {
    const auto [count, fix] = over(cap.bytes);
    throw Error(fmt::format("{}: the scene needs {:.3g} GB for {}, {}; {}{}", scene.source, bytes / 1e9, count,
                            cap.over, fix.text, fix.more_memory_helps ? " or " + cap.instead : std::string()));
  }
}

// Objects may touch (automata of two objects d apart: an unlinked contact, as two stacked boxes) but
// not overlap: overlapping automata would start pressed into each other by up to their whole size, a
// stored energy of the order of E d^3 per pair that throws the objects apart (measured: two boxes
// overlapping by 0.1 m released 3e7 J). Objects whose boxes of automata meet are checked automaton by
// automaton through a hash of cells of size d.
void refuse_overlaps(const SceneDef& scene, const Model& M) {
  const std::size_t n_obj = scene.objects.size();
  if (n_obj < 2) return;
  struct Box {
    double lo[3], hi[3];
    std::size_t first = 0, last = 0;  // automata [first, last)
  };
  std::vector<Box> boxes(n_obj);
  for (std::size_t a = 0, o = 0; o < n_obj; ++o) {
    Box& b = boxes[o];
    b.first = a;
    for (int k = 0; k < 3; ++k) {
      b.lo[k] = INFINITY;
      b.hi[k] = -INFINITY;
    }
    for (; a < M.size() && static_cast<std::size_t>(M.object[a]) == o; ++a) {
      const double p[3] = {M.position0[a].x, M.position0[a].y, M.position0[a].z};
      for (int k = 0; k < 3; ++k) {
        b.lo[k] = std::min(b.lo[k], p[k] - M.radius[a]);
        b.hi[k] = std::max(b.hi[k], p[k] + M.radius[a]);
      }
    }
    b.last = a;
  }
  // Object pairs whose boxes meet, found by a sweep along x.
  std::vector<std::size_t> order(n_obj);
  for (std::size_t o = 0; o < n_obj; ++o) order[o] = o;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return boxes[a].lo[0] < boxes[b].lo[0]; });
  // Cells as large as the largest reach (automata of surface-mode objects may be larger than the spacing).
  const double d = std::max<double>(M.spacing, 2.0 * *std::max_element(M.radius.begin(), M.radius.end()));
  for (std::size_t u = 0; u < n_obj; ++u) {
    const Box& A = boxes[order[u]];
    for (std::size_t v = u + 1; v < n_obj && boxes[order[v]].lo[0] < A.hi[0]; ++v) {
      const Box& B = boxes[order[v]];
      bool meet = true;
      for (int k = 1; k < 3; ++k) meet = meet && B.lo[k] < A.hi[k] && A.lo[k] < B.hi[k];
      if (!meet) continue;
      // The smaller object goes into the hash; the other's automata look up the 27 cells around them.
      const bool a_small = A.last - A.first <= B.last - B.first;
      const Box& H = a_small ? A : B;
      const Box& Q = a_small ? B : A;
      auto key = [&](double x, double y, double z) {
        const auto c = [&](double t) { return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(t / d))); };
        return c(x) * 73856093ull ^ c(y) * 19349663ull ^ c(z) * 83492791ull;
      };
      std::unordered_multimap<std::uint64_t, std::uint32_t> cells;
      cells.reserve(H.last - H.first);
      for (std::size_t a = H.first; a < H.last; ++a)
        cells.emplace(key(M.position0[a].x, M.position0[a].y, M.position0[a].z), static_cast<std::uint32_t>(a));
      // Every overlapping pair is counted and the deepest named: the first one found could be a graze, and
      // its depth as the distance to move them was far too little (two shells 0.1 m apart were told 2 mm).
      std::size_t overlapping = 0;
      double deepest = 0, deepest_dist = 0, deepest_reach = 0;
      std::size_t dq = 0, dh = 0;
      for (std::size_t q = Q.first; q < Q.last; ++q) {
        const DVec3 p = M.position0[q];
        for (int dz = -1; dz <= 1; ++dz)
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
              const auto range = cells.equal_range(key(p.x + dx * d, p.y + dy * d, p.z + dz * d));
              for (auto it = range.first; it != range.second; ++it) {
                const std::uint32_t h = it->second;
                const DVec3 dd = ddelta(p, M.position0[h]);
                const double dist = std::sqrt(dot(dd, dd));
                const double reach = static_cast<double>(M.radius[q]) + M.radius[h];
                if (dist >= reach * (1 - 1e-6)) continue;
                ++overlapping;
                if (reach - dist > deepest) {
                  deepest = reach - dist;
                  deepest_dist = dist;
                  deepest_reach = reach;
                  dq = q;
                  dh = h;
                }
              }
            }
      }
      if (overlapping > 0) {
        const ObjectDef &oq = scene.objects[M.object[dq]], &oh = scene.objects[M.object[dh]];
        const DVec3 p = M.position0[dq], ph = M.position0[dh];
        // What surely parts them: their boxes (automata with their radii) apart along the axis where they
        // overlap least (the deepest pair's depth is at most a touching distance, however deep the overlap).
        int axis = 0;
        double part = INFINITY;
        for (int k = 0; k < 3; ++k) {
          const double o = std::min(A.hi[k], B.hi[k]) - std::max(A.lo[k], B.lo[k]);
          if (o < part) {
            part = o;
            axis = k;
          }
        }
        throw Error(fmt::format(
            "{}: object '{}' overlaps object '{}': {} pair{} of their automata overlap, the deepest at [{:.6g}, "
            "{:.6g}, {:.6g}] and [{:.6g}, {:.6g}, {:.6g}], {:.4g} m apart, {:.4g} m closer than the {:.4g} m at "
            "which automata touch. Objects may touch but not overlap (overlapping automata would start compressed "
            "and throw the objects apart); move them apart (by at least {} m; {} m along {} parts their "
            "boxes), or make one object with [[object.region]] blocks for two materials",
            scene.source, oq.name, oh.name, overlapping, overlapping == 1 ? "" : "s", p.x, p.y, p.z, ph.x, ph.y, ph.z,
            deepest_dist, deepest, deepest_reach, text::at_least(deepest, 4), text::at_least(part * 1.001, 4),
            "xyz"[axis]));
      }
    }
  }
}

// x rounded down to a float: a contact radius that reaches no further than the one a scene gives (a ball of
// radius 0.136 is 0.136000007 in float, and one placed on another started pressed into it by 7e-9 m, which
// threw it off at 0.07 m/s).
float float_at_most(double x) {
  const float r = static_cast<float>(x);
  return static_cast<double>(r) > x ? std::nextafter(r, 0.0f) : r;
}

// Nothing may start inside the ground: an automaton pressed into it by delta starts with the energy
// k delta^2 / 2 of its contact (a box 5 mm into the ground, its lattice a row taller than its size, broke
// into 180 pieces at t = 0). A body placed on the ground started pressed into it by the rounding of its
// centres and radii to float (the default wall by 1.1e-8 m at d = 0.05, before lattice_contact_radius): a
// preload of k delta, five times an automaton's weight there, which threw a light or stiff body off the
// ground (a 0.2 m cube of density 0.1 left it at 8 mm/s). What rounding the contact radii leave (up to
// 1e-6 d) is taken out of the objects by lowering the plane until none of their automata overlaps it (one
// plane keeps a stack's placing: an object lifted alone pressed into the one on it). A ball's radius is
// rounded down (float_at_most); what a tilted plane leaves (up to 1e-6 of its radius) lifts that ball alone
// (a ball's rounding, which grows with its radius, lowered the plane under every other body). Deeper is the
// scene's error. Projectiles before `placed` are in flight where the state has them (the viewer's earlier
// shots, one perhaps pressed into the ground by its landing): they take no part.
double deepest_in_the_ground(const Model& M, std::size_t& automaton) {
  double deepest = 0;
  automaton = 0;
  for (std::size_t a = 0; a < M.size(); ++a) {
    const double overlap = ground_overlap(M.position0[a], M.up, M.ground_height, M.radius[a]);
    if (overlap > deepest) {
      deepest = overlap;
      automaton = a;
    }
  }
  return deepest;
}

// Moves a body up, or the ground down, by `overlap()` until that is no more than 0. The overlap is rounded
// to float from a double difference, so a move of exactly the overlap can leave a few units of the last
// place of the height or of the centre (`reach()`: their size); each further move adds those.
template <class Overlap, class Move, class Reach>
bool take_out_rounding(Overlap&& overlap, Move&& move, Reach&& reach) {
  for (int i = 0; i < 8; ++i) {
    const double o = overlap();
    if (!(o > 0)) return true;
    move(o + 4 * std::numeric_limits<double>::epsilon() * reach());
  }
  return !(overlap() > 0);
}

void settle_on_the_ground(const SceneDef& scene, const Shapes& S, Model& M, std::size_t placed) {
  const double d = M.spacing;
  std::size_t at = 0;
  const double deepest = deepest_in_the_ground(M, at);
  if (deepest > 1e-6 * d) {
    const auto oi = static_cast<std::size_t>(M.object[at]);
    const ObjectDef& o = scene.objects[oi];
    std::string why;
    if (S.surface_of(oi)) {
      why = " (surface mode: its automata are the triangles' centroids, each a sphere of its contact radius)";
    } else {
      std::int64_t n[3];
      double origin[3];
      lattice_frame(o, S.of(oi), d, n, origin);
      why = fmt::format(". Its lattice is {} x {} x {} cells of {:g} m ({:g} x {:g} x {:g} m): a size is rounded to "
                        "whole cells",
                        n[0], n[1], n[2], d, n[0] * d, n[1] * d, n[2] * d);
      // A spacing the scene did not give (solver.target_automata chose it): the fix is one that fills the
      // object's height in whole cells, not a move of an object placed on the ground.
      if (scene.solver.target_automata > 0) {
        why += fmt::format("; solver.target_automata = {} chose that spacing: give solver.spacing instead", scene.solver.target_automata);
        int k = -1;  // an unturned box's axis along up
        const float up[3] = {M.up.x, M.up.y, M.up.z};
        for (int c = 0; c < 3; ++c)
          if (std::abs(up[c]) == 1.0f) k = c;
        // Where the box itself is placed on or above the ground, and the spacing leaves its height a part of
        // a cell over: the spacing that fills it with whole cells. (A box placed in the ground is moved up.)
        if (o.shape == Shape::box && k >= 0 && o.rotation[0] == 0 && o.rotation[1] == 0 && o.rotation[2] == 0) {
          const double height = o.size[static_cast<std::size_t>(k)];
          const double bottom = o.position[static_cast<std::size_t>(k)] * up[k] - 0.5 * height;
          const double cells = std::max(1.0, std::round(height / d));
          if (bottom >= scene.ground.height - 1e-6 * d && std::abs(cells * d - height) > 1e-6 * d)
            why += fmt::format(", one that fills its height of {:g} m with whole cells (solver.spacing = {}: {:g} cells)",
                               height, text::num(height / cells), cells);
        }
      }
    }
    throw Error(fmt::format(
        "{}: object '{}' starts {:.4g} m inside the ground (its automaton at [{:.10g}, {:.10g}, {:.10g}], radius {:g} "
        "m, below ground.height = {} along the up axis); move the object up by at least {} m{}",
        scene.source, o.name, deepest, M.position0[at].x, M.position0[at].y, M.position0[at].z, M.radius[at],
        scene.ground.height, text::at_least(deepest, 4), why));
  }
  for (std::size_t p = placed; p < M.projectiles.size(); ++p) {
    const ProjectileParams& P = M.projectiles[p];
    const double overlap = ground_overlap(P.position, M.up, M.ground_height, P.radius);
    if (overlap > 1e-6 * P.radius) {
      throw Error(fmt::format("{}: projectile[{}] '{}' starts {:.4g} m inside the ground (ground.height = {} along "
                              "the up axis); move it up by at least {} m",
                              scene.source, p, P.name, overlap, scene.ground.height, text::at_least(overlap, 4)));
    }
  }
  // What is left is rounding.
  const auto unsettled = [&](const std::string& what) {
    return Error(fmt::format("{}: {} could not be made to start touching the ground rather than pressed into it by the "
                             "rounding of its position (internal: please report the scene)",
                             scene.source, what));
  };
  const double given = M.ground_height;
  std::size_t a = 0;
  if (!take_out_rounding([&] { return deepest_in_the_ground(M, a); }, [&](double by) { M.ground_height -= by; },
                         [&] { return std::abs(M.ground_height) + length(M.position0[a]); }))
    throw unsettled(fmt::format("object '{}'", scene.objects[static_cast<std::size_t>(M.object[a])].name));
  M.ground_lowered = given - M.ground_height;
  for (std::size_t p = placed; p < M.projectiles.size(); ++p) {
    ProjectileParams& P = M.projectiles[p];
    const DVec3 up = to_dvec3(M.up);
    if (!take_out_rounding([&] { return static_cast<double>(ground_overlap(P.position, M.up, M.ground_height, P.radius)); },
                           [&](double by) { P.position += up * by; },
                           [&] { return std::abs(M.ground_height) + length(P.position); }))
      throw unsettled(fmt::format("projectile[{}] '{}'", p, P.name));
  }
}

// Binds each triangle of a mesh object to the automaton nearest its centroid (sec. 5.4). The object's
// automata are `index` (cell -> automaton, -1 outside) over the lattice L; the search grows shell by shell
// around the centroid's cell, and a shell beyond the nearest found so far cannot hold a nearer one.
void bind_surface(Model& M, const MeshObject& mo, const ObjectLattice& L, const std::vector<std::int64_t>& index,
                  const Mat3& R, const Vec3d& position, double d) {
  BoundSurface& S = M.surface;
  const auto base = static_cast<std::uint32_t>(S.vertices);
  const std::int64_t* n = L.n;
  for (const auto& f : mo.solid.mesh.faces) {
    Vec3d c{0, 0, 0};
    for (auto v : f)
      for (int a = 0; a < 3; ++a) c[a] += mo.solid.mesh.vertices[v][a] / 3.0;
    std::int64_t cell[3];
    for (int a = 0; a < 3; ++a)
      cell[a] = std::clamp<std::int64_t>(std::llround((c[a] - L.origin[a]) / d), 0, n[a] - 1);
    std::int64_t best = -1;
    double best_d2 = INFINITY;
    const std::int64_t reach = std::max({n[0], n[1], n[2]});
    for (std::int64_t r = 0; r <= reach; ++r) {
      // Every cell of shell r is at least (r - 1/2) d from the centroid (it lies within half a cell of
      // its cell's centre, clamped cells aside, which only come nearer).
      if (best >= 0 && (r - 1.5) * d > std::sqrt(best_d2)) break;
      for (std::int64_t k = cell[2] - r; k <= cell[2] + r; ++k)
        for (std::int64_t j = cell[1] - r; j <= cell[1] + r; ++j)
          for (std::int64_t i = cell[0] - r; i <= cell[0] + r; ++i) {
            if (std::max({std::llabs(i - cell[0]), std::llabs(j - cell[1]), std::llabs(k - cell[2])}) != r) continue;
            if (i < 0 || j < 0 || k < 0 || i >= n[0] || j >= n[1] || k >= n[2]) continue;
            const std::int64_t a = index[static_cast<std::size_t>((k * n[1] + j) * n[0] + i)];
            if (a < 0) continue;
            const double dx = L.origin[0] + i * d - c[0], dy = L.origin[1] + j * d - c[1], dz = L.origin[2] + k * d - c[2];
            const double d2 = dx * dx + dy * dy + dz * dz;
            if (d2 < best_d2) {  // ties: the first in lattice order
              best_d2 = d2;
              best = a;
            }
          }
    }
    S.automaton.push_back(static_cast<std::uint32_t>(best));
    const DVec3 centre = M.position0[static_cast<std::size_t>(best)];
    for (auto v : f) {
      const Vec3d w = R.apply(mo.solid.mesh.vertices[v]);
      S.corner.push_back(base + v);
      S.offset.push_back(to_vec3({w[0] + position[0] - centre.x, w[1] + position[1] - centre.y,
                                  w[2] + position[2] - centre.z}));
    }
  }
  S.vertices += mo.solid.mesh.vertices.size();
}

// The corners of each mesh vertex, by a counting sort (BoundSurface::first_corner, corners_of).
void index_corners(BoundSurface& S) {
  const std::size_t nc = S.corner.size();
  S.first_corner.assign(S.vertices + 1, 0);
  S.corners_of.resize(nc);
  for (std::size_t c = 0; c < nc; ++c) ++S.first_corner[S.corner[c] + 1];
  for (std::size_t v = 0; v < S.vertices; ++v) S.first_corner[v + 1] += S.first_corner[v];
  std::vector<std::uint32_t> fill(S.first_corner.begin(), S.first_corner.end() - 1);
  for (std::size_t c = 0; c < nc; ++c) S.corners_of[fill[S.corner[c]]++] = static_cast<std::uint32_t>(c);
}

// What both fills report of a mesh object (mca info).
MeshSummary mesh_summary(const MeshObject& mo, std::size_t oi, const std::string& path, const Mat3& R,
                         const Vec3d& position) {
  MeshSummary ms;
  ms.object = static_cast<std::int32_t>(oi);
  ms.path = path;
  ms.vertices = mo.file_vertices;
  ms.faces = mo.solid.mesh.faces.size();
  ms.boundary_edges = mo.solid.topology.boundary_edges;
  ms.non_manifold_edges = mo.solid.topology.non_manifold_edges;
  ms.degenerate_faces = mo.solid.topology.degenerate_faces;
  ms.holes = mo.solid.topology.holes;
  ms.file_lo = mo.file_bounds.lo;
  ms.file_hi = mo.file_bounds.hi;
  ms.scale = mo.scale;
  ms.volume = mo.volume();
  ms.shells = mo.solid.shells.size();
  ms.cavities = static_cast<std::size_t>(
      std::count_if(mo.solid.depth.begin(), mo.solid.depth.end(), [](int k) { return k > 0 && k % 2 == 1; }));
  ms.lo = {INFINITY, INFINITY, INFINITY};
  ms.hi = {-INFINITY, -INFINITY, -INFINITY};
  // The vertices triangles use, as the bounds in the file (a stray vertex is not the model: one at x = 100 beside
  // a unit cube read "100 x 1 x 1 m").
  std::vector<bool> used(mo.solid.mesh.vertices.size(), false);
  for (const mesh::Triangle& t : mo.solid.mesh.faces)
    for (auto v : t) used[v] = true;
  for (std::size_t i = 0; i < used.size(); ++i) {
    if (!used[i]) continue;
    const auto& v = mo.solid.mesh.vertices[i];
    const Vec3d r = R.apply({v[0], v[1], v[2]});
    for (int a = 0; a < 3; ++a) {
      ms.lo[a] = std::min(ms.lo[a], r[a] + position[a]);
      ms.hi[a] = std::max(ms.hi[a], r[a] + position[a]);
    }
  }
  return ms;
}

// The spacing of a scene whose objects are all filled in surface mode: the mean distance of linked
// triangles (or, with no link at all, the side of a cube of an automaton's mean volume). It sets the
// contact skin and the speed check, as the spacing of a lattice does.
double surface_spacing(const Shapes& S) {
  double sum = 0, volume = 0;
  std::size_t links = 0, automata = 0;
  for (const auto& sc : S.surface) {
    if (!sc) continue;
    sum += sc->mean_link * static_cast<double>(sc->link.size());
    links += sc->link.size();
    for (double a : sc->area) volume += a * sc->thickness;
    automata += sc->face.size();
  }
  return links ? sum / static_cast<double>(links) : std::cbrt(volume / static_cast<double>(automata));
}

// The unit normal of triangle f of m (zero for a degenerate one).
Vec3d face_normal(const mesh::TriMesh& m, std::uint32_t f) {
  const auto& a = m.vertices[m.faces[f][0]];
  const auto& b = m.vertices[m.faces[f][1]];
  const auto& c = m.vertices[m.faces[f][2]];
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const Vec3d n{u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
  const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  return len > 0 ? Vec3d{n[0] / len, n[1] / len, n[2] / len} : Vec3d{0, 0, 0};
}

// Automata of an object filled in surface mode (paper sec. 5.4 counts): one per triangle at its centroid,
// of volume (lumped area) x thickness, linked across shared edges (rest length the centroids' distance, cross-section
// the edge's length x thickness), each triangle bound to its own automaton. Strength classes are drawn at
// the centroids (`local`, object frame).
void add_surface_object(Model& M, const SceneDef& scene, const MeshObject& mo, const SurfaceCells& sc, std::size_t oi,
                        const Mat3& R, int base_group, const std::vector<int>& region_groups, std::vector<Vec3>& local) {
  const ObjectDef& o = scene.objects[oi];
  const auto first = static_cast<std::uint32_t>(M.size());
  const std::size_t count = sc.face.size();
  const double t = sc.thickness;
  // Lumped volume (and mass): half the triangle's own area and a share of each linked neighbour's (a
  // neighbour with c links gives 1/(2c) of its area to each), so that the total is the surface's area
  // times the thickness and a sliver triangle between large ones is not a near-massless automaton on
  // stiff links (which would set a step tens of times smaller).
  std::vector<int> links_of(count, 0);
  for (const auto& l : sc.link) {
    ++links_of[l[0]];
    ++links_of[l[1]];
  }
  std::vector<double> lumped(count, 0.0);
  for (std::size_t k = 0; k < count; ++k) lumped[k] = links_of[k] ? 0.5 * sc.area[k] : sc.area[k];
  for (const auto& l : sc.link) {
    lumped[l[0]] += 0.5 * sc.area[l[1]] / links_of[l[1]];
    lumped[l[1]] += 0.5 * sc.area[l[0]] / links_of[l[0]];
  }
  const std::string mass_fix =
      fmt::format("check the density (kg/m^3), the mesh's scale and shell_thickness ({:g} m)", t);
  for (std::size_t k = 0; k < count; ++k) {
    const mesh::Point& c = sc.centroid[k];
    const Vec3d r = R.apply({c[0], c[1], c[2]});
    const Vec3d wp{r[0] + o.position[0], r[1] + o.position[1], r[2] + o.position[2]};
    int g = base_group;
    for (std::size_t rr = 0; rr < o.regions.size(); ++rr)
      if (o.regions[rr].shape == Shape::mesh ? inside_solid(*mo.regions[rr], c) : inside_region(o.regions[rr], wp))
        g = region_groups[rr];
    const double volume = lumped[k] * t;
    const float mass = automaton_float32(
        scene, [&] { return fmt::format("the mass of the automaton of triangle {} of object '{}'", sc.face[k], o.name); },
        M.groups[g].density * volume, mass_fix);
    M.position0.push_back(to_dvec3(wp));
    M.velocity0.push_back(to_dvec3(o.velocity));
    M.mass.push_back(mass);
    M.radius.push_back(0.0f);  // set below from its links
    M.inertia.push_back(0.0f);
    M.volume.push_back(static_cast<float>(volume));
    M.group.push_back(static_cast<std::uint8_t>(g));
    M.object.push_back(static_cast<std::int32_t>(oi));
    M.grip.push_back(-1);
    local.push_back(to_vec3({c[0], c[1], c[2]}));
  }
  if (std::any_of(o.regions.begin(), o.regions.end(), [](const RegionDef& r) { return r.shape == Shape::mesh; })) {
    for (std::size_t rr = 0; rr < o.regions.size(); ++rr) {
      if (o.regions[rr].shape != Shape::mesh) continue;
      const bool any = std::any_of(sc.centroid.begin(), sc.centroid.end(), [&](const mesh::Point& c) { return inside_solid(*mo.regions[rr], c); });
      if (!any) {
        throw Error(fmt::format("{}: object[{}] '{}': region[{}] (mesh {}) holds no triangle centroid of the object; "
                                "its mesh must enclose part of the object's surface, in the same units and frame as "
                                "the object's file",
                                scene.source, oi, o.name, rr, mo.regions[rr]->file));
      }
    }
  }
  // Links, and each automaton's mean and shortest link length.
  auto& E = M.explicit_links;
  std::vector<double> length_sum(count, 0.0), shortest(count, INFINITY);
  for (std::size_t l = 0; l < sc.link.size(); ++l) {
    const std::uint32_t a = first + sc.link[l][0], b = first + sc.link[l][1];
    const DVec3 dd = ddelta(M.position0[a], M.position0[b]);
    const double r0 = std::sqrt(dot(dd, dd));
    E.i.push_back(a);
    E.j.push_back(b);
    E.r0.push_back(r0);
    E.area.push_back(static_cast<float>(sc.edge[l] * t));
    E.edge.push_back(static_cast<float>(sc.edge[l]));
    // The shell's normal: the two triangles' normals (turned to agree), averaged, orthogonal to the link.
    const Vec3d na = R.apply(face_normal(mo.solid.mesh, sc.face[sc.link[l][0]]));
    Vec3d nb = R.apply(face_normal(mo.solid.mesh, sc.face[sc.link[l][1]]));
    if (na[0] * nb[0] + na[1] * nb[1] + na[2] * nb[2] < 0) nb = {-nb[0], -nb[1], -nb[2]};
    DVec3 m{na[0] + nb[0], na[1] + nb[1], na[2] + nb[2]};
    const DVec3 u{dd.x / r0, dd.y / r0, dd.z / r0};
    const double along = dot(m, u);
    m = {m.x - along * u.x, m.y - along * u.y, m.z - along * u.z};
    const double len = std::sqrt(dot(m, m));
    E.normal.push_back(len > 0 ? Vec3{static_cast<float>(m.x / len), static_cast<float>(m.y / len), static_cast<float>(m.z / len)}
                               : Vec3{});
    for (auto k : sc.link[l]) {
      length_sum[k] += r0;
      shortest[k] = std::min(shortest[k], r0);
    }
  }
  M.links += sc.link.size();
  // Contact radius: half its shortest link (so that a link that breaks leaves two automata that touch
  // without overlap, as in a lattice), and no more than 0.49 of the distance to the nearest automaton it
  // is not linked to, so that no unlinked pair starts pressed into each other (around a vertex of a fine
  // or uneven mesh, triangles that share no edge can be closer than linked ones). A triangle without links
  // takes half the side of the square of its area. `size`: half its mean link, for its moment of inertia.
  std::vector<double> radius(count), size(count);
  double largest = 0;
  for (std::size_t k = 0; k < count; ++k) {
    size[k] = links_of[k] ? 0.5 * length_sum[k] / links_of[k] : 0.5 * std::sqrt(sc.area[k]);
    radius[k] = links_of[k] ? 0.5 * shortest[k] : size[k];
    largest = std::max(largest, radius[k]);
  }
  UniformGrid grid;
  grid.build(M.position0.data() + first, count, 2.0 * largest);
  std::vector<std::uint32_t> linked;
  const std::string inertia_fix = fmt::format("check the mesh's scale and shell_thickness ({:g} m)", t);
  for (std::size_t k = 0; k < count; ++k) {
    const DVec3 x = M.position0[first + k];
    double nearest = INFINITY;
    std::size_t nearest_j = k;
    grid.for_each_candidate(x, [&](std::uint32_t j) {
      if (j == k) return;
      const DVec3 dd = ddelta(x, M.position0[first + j]);
      const double dist = std::sqrt(dot(dd, dd));
      if (dist < nearest && dist < 2.0 * largest) {
        // Linked pairs are left out (they touch by construction).
        const std::array<std::uint32_t, 2> key{static_cast<std::uint32_t>(std::min<std::size_t>(k, j)),
                                               static_cast<std::uint32_t>(std::max<std::size_t>(k, j))};
        if (!std::binary_search(sc.link.begin(), sc.link.end(), key)) {
          nearest = dist;
          nearest_j = j;
        }
      }
    });
    const std::size_t a = first + k;
    M.radius[a] = static_cast<float>(std::min(radius[k], 0.49 * nearest));
    // Two triangles whose centroids (nearly) coincide, a duplicate or a fold of the mesh, would make an
    // automaton of no size that nothing can touch (a radius of 2e-17 m was taken without a word).
    if (!(M.radius[a] >= 1e-4 * size[k])) {
      throw Error(fmt::format(
          "{}: object '{}': the centroid of triangle {} of {} lies {:.3g} m from {}, where its links are {:.3g} m "
          "long on average: its automaton would be a sphere of {:.3g} m that nothing touches. The mesh has duplicate "
          "or overlapping triangles there; clean it (MeshLab: Filters > Cleaning and Repairing > Remove Duplicate "
          "Faces, Remove Zero Area Faces)",
          scene.source, o.name, sc.face[k], o.mesh, 0.49 * nearest < radius[k] ? nearest : 2 * radius[k],
          0.49 * nearest < radius[k] ? fmt::format("triangle {}'s", sc.face[nearest_j])
                                     : std::string("a triangle it shares an edge with"),
          2 * size[k], static_cast<double>(M.radius[a])));
    }
    // As a cube whose side is its mean link length (a lattice automaton: m d^2 / 6), whatever its
    // contact radius.
    M.inertia[a] = automaton_float32(
        scene,
        [&] {
          return fmt::format("the moment of inertia of the automaton of triangle {} of object '{}'", sc.face[k], o.name);
        },
        M.mass[a] * (2.0 * size[k]) * (2.0 * size[k]) / 6.0, inertia_fix);
  }
  // Each triangle rides with its own automaton.
  BoundSurface& B = M.surface;
  const auto base = static_cast<std::uint32_t>(B.vertices);
  for (std::size_t k = 0; k < count; ++k) {
    const DVec3 centre = M.position0[first + k];
    B.automaton.push_back(first + static_cast<std::uint32_t>(k));
    for (auto v : mo.solid.mesh.faces[sc.face[k]]) {
      const Vec3d w = R.apply(mo.solid.mesh.vertices[v]);
      B.corner.push_back(base + v);
      B.offset.push_back(to_vec3({w[0] + o.position[0] - centre.x, w[1] + o.position[1] - centre.y,
                                  w[2] + o.position[2] - centre.z}));
    }
  }
  B.vertices += mo.solid.mesh.vertices.size();
}

// Each automaton's explicit links in slot order (Model::ExplicitLinks::first, of), by a counting sort.
void index_explicit_links(Model& M) {
  auto& E = M.explicit_links;
  if (E.size() == 0) return;
  const std::size_t n = M.size();
  E.first.assign(n + 1, 0);
  for (std::size_t k = 0; k < E.size(); ++k) {
    ++E.first[E.i[k] + 1];
    ++E.first[E.j[k] + 1];
  }
  for (std::size_t a = 0; a < n; ++a) E.first[a + 1] += E.first[a];
  E.of.resize(2 * E.size());
  std::vector<std::uint32_t> fill(E.first.begin(), E.first.end() - 1);
  for (std::size_t k = 0; k < E.size(); ++k) {
    E.of[fill[E.i[k]]++] = static_cast<std::uint32_t>(k);
    E.of[fill[E.j[k]]++] = static_cast<std::uint32_t>(k);
  }
}

// Selective mass scaling of the surface-mode objects (solver.mass_scaling = s > 0; docs/model-notes.md,
// "Mass scaling"): per object, the automata whose own critical step (time_step.cpp, its links, contacts
// and dashpots) is below s times the object's median get mass, and the moment of inertia in proportion,
// until they reach it, as explicit finite-element codes give mass to the elements below a target step
// (LS-DYNA's DT2MS). Stiffnesses, volumes and everything else stay; the added mass is real in the model
// (momentum, kinetic energy, weight, fragments' masses all see it) and is reported per object. A mesh's
// sliver triangles (short links across long edges between light automata) set a step far below that of
// its typical automaton: on the paper's cow 5.9e-8 s against a median of 3e-7 s.
void scale_surface_masses(Model& M, double share) {
  if (!(share > 0) || M.meshes.empty()) return;
  std::vector<double> target(M.size(), 0.0);
  for (MeshSummary& ms : M.meshes) {
    if (!ms.surface) continue;
    ms.mesh_mass = 0;
    for (std::size_t a = 0; a < M.size(); ++a)
      if (M.object[a] == ms.object) ms.mesh_mass += M.mass[a];
  }
  const std::vector<double> own = surface_automaton_steps(M);
  for (MeshSummary& ms : M.meshes) {
    if (!ms.surface) continue;
    std::vector<double> steps;
    for (std::size_t a = 0; a < M.size(); ++a)
      if (M.object[a] == ms.object && std::isfinite(own[a])) steps.push_back(own[a]);
    if (steps.empty()) continue;
    auto mid = steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2);
    std::nth_element(steps.begin(), mid, steps.end());
    ms.scaled_step = share * *mid;
    for (std::size_t a = 0; a < M.size(); ++a)
      if (M.object[a] == ms.object) target[a] = ms.scaled_step;
  }
  // An automaton's rows fall as its mass grows (its own terms as 1 / m, its couplings as 1 / sqrt(m), and
  // its neighbours' couplings to it too), so raising each short one by (target / step)^2 and repeating
  // converges from below; a few rounds settle the couplings between neighbours raised together.
  std::vector<double> original(M.mass.begin(), M.mass.end());
  std::vector<double> steps = own;
  for (int round = 0; round < 100; ++round) {
    bool short_of = false;
    for (std::size_t a = 0; a < M.size(); ++a) {
      if (!(steps[a] < target[a])) continue;
      short_of = true;
      const double k = std::min(4.0, (target[a] / steps[a]) * (target[a] / steps[a]) * 1.0001);
      M.mass[a] = static_cast<float>(M.mass[a] * k);
      M.inertia[a] = static_cast<float>(M.inertia[a] * k);
    }
    if (!short_of) break;
    steps = surface_automaton_steps(M);
  }
  M.total_mass = 0;
  for (std::size_t a = 0; a < M.size(); ++a) {
    M.total_mass += M.mass[a];
    if (M.mass[a] == original[a]) continue;
    for (MeshSummary& ms : M.meshes)
      if (ms.object == M.object[a]) {
        ++ms.mass_scaled;
        ms.added_mass += M.mass[a] - original[a];
      }
  }
}

}  // namespace

std::size_t set_time_step(Model& M, float dt) {
  BuildProgress::stage(fmt::format("the contact dashpots for a time step of {:.3g} s", dt));
  M.dt = dt;
  const std::size_t G = M.groups.size(), P = M.projectiles.size();
  const double d = M.spacing;
  // A ratio costs a scan over simulated contacts (discrete_damping_ratio): the P^2 projectile pairs made
  // a build of 500 balls take 22 s. Pairs of like projectiles ask for the same (restitution, omega dt), so
  // each distinct one is worked out once; the table is then P^2 look-ups.
  //
  // Below omega dt = 1e-4 the continuous ratio is taken: the discrete one tends to it (0.497253 against
  // 0.497239 for e = 0.3 at 1e-4: restitution within 1e-5), and the simulated contact it would take lasts
  // pi / (omega dt) steps, more than discrete_restitution runs below 3e-6 (solver.time_step = 1e-12 gave
  // a ratio of 2e-17: no damping at all).
  constexpr double kContinuousBelow = 1e-4;
  std::size_t calibrations = 0;
  std::map<std::pair<double, double>, float> known;
  auto zeta = [&](const ContactMaterial& c, double length, double m_eff) {
    const std::pair<double, double> key{c.restitution, std::sqrt(c.youngs * length / m_eff) * dt};
    const auto [it, fresh] = known.try_emplace(key, 0.0f);
    if (fresh && key.second < kContinuousBelow) {
      it->second = restitution_damping_ratio(key.first);
    } else if (fresh) {
      it->second = discrete_damping_ratio(key.first, key.second);
      ++calibrations;
    }
    return it->second;
  };
  // Balls of distinct radii make the P^2 pairs distinct as well: 1,000 balls of 1,000 radii were 500,000
  // calibrations, 181 s. Between projectiles the ratio is read off a curve per restitution instead: the
  // calibrations at omega dt = 2^(i/16), each worked out once, interpolated linearly in log2(omega dt).
  // Against a calibration of its own, a pair's restitution (discrete_restitution) differs by at most 5e-6
  // below omega dt = 0.01, 7e-4 below 0.1 and 2.5e-3 below 0.2 (measured over e = 0.05 to 0.99; the contact
  // law is held to 0.01). Above 0.2 the discrete law is too uneven between nodes (0.05 off at 1.2), and a
  // pair is calibrated on its own as before: a contact of a few steps, microseconds. The other contacts
  // keep a calibration each (their count grows as G^2 and P G, not P^2), so scenes of one projectile keep
  // their bits.
  constexpr double kNodesPerOctave = 16, kCurveBelow = 0.2;
  std::map<std::pair<double, int>, double> nodes;
  auto node = [&](double e, int i) {
    const auto [it, fresh] = nodes.try_emplace({e, i}, 0.0);
    if (fresh) {
      it->second = discrete_damping_ratio(e, std::exp2(i / kNodesPerOctave));
      ++calibrations;
    }
    return it->second;
  };
  auto zeta_between_balls = [&](const ContactMaterial& c, double length, double m_eff) {
    const double w = std::sqrt(c.youngs * length / m_eff) * dt;
    if (!(w >= kContinuousBelow && w < kCurveBelow)) return zeta(c, length, m_eff);
    const double u = std::log2(w) * kNodesPerOctave, i = std::floor(u);
    const double z0 = node(c.restitution, static_cast<int>(i)), z1 = node(c.restitution, static_cast<int>(i) + 1);
    return static_cast<float>(z0 + (z1 - z0) * (u - i));
  };
  auto mass = [&](std::size_t g) { return M.groups[g].density * d * d * d; };
  M.zeta_pair.assign(G * G, 0.0f);
  M.zeta_ground.assign(G, 0.0f);
  for (std::size_t a = 0; a < G; ++a) {
    for (std::size_t b = 0; b < G; ++b) M.zeta_pair[a * G + b] = zeta(M.contact_material(a, b), d, mass(a) * mass(b) / (mass(a) + mass(b)));
    M.zeta_ground[a] = zeta(M.ground_contact[a], d, mass(a));
  }
  // Against an automaton a grip holds, the free one's mass moves alone (as on the ground).
  const bool grips = !M.grip_velocity.empty();
  M.zeta_pair_held.assign(grips ? G * G : 0, 0.0f);
  for (std::size_t a = 0; grips && a < G; ++a)
    for (std::size_t b = 0; b < G; ++b) M.zeta_pair_held[a * G + b] = zeta(M.contact_material(a, b), d, mass(a));
  M.zeta_projectiles.assign(P * P, 0.0f);
  for (std::size_t p = 0; p < P; ++p) {
    ProjectileParams& A = M.projectiles[p];
    A.zeta_automata.assign(G, 0.0f);
    for (std::size_t g = 0; g < G; ++g)
      A.zeta_automata[g] = zeta(M.projectile_contact(p, g), 2 * std::min<double>(0.5 * d, A.radius),
                                A.kinematic ? mass(g) : mass(g) * A.mass / (mass(g) + A.mass));
    // A held automaton: the ball's mass moves alone (a kinematic ball's contact with one keeps the
    // automaton's, as with a free one: nothing moves either).
    A.zeta_held.assign(grips ? G : 0, 0.0f);
    for (std::size_t g = 0; grips && g < G; ++g)
      A.zeta_held[g] = A.kinematic ? A.zeta_automata[g]
                                   : zeta(M.projectile_contact(p, g), 2 * std::min<double>(0.5 * d, A.radius), A.mass);
    A.zeta_ground = zeta(M.projectile_ground_contact(p), 2.0 * A.radius, A.mass);
    for (std::size_t q = 0; q < P; ++q) {
      const ProjectileParams& B = M.projectiles[q];
      if (q == p || (A.kinematic && B.kinematic)) continue;
      const double m_eff = A.kinematic ? B.mass : B.kinematic ? A.mass : A.mass * B.mass / (A.mass + B.mass);
      M.zeta_projectiles[p * P + q] =
          zeta_between_balls(M.projectile_pair_contact(p, q), 2 * std::min(A.radius, B.radius), m_eff);
    }
  }
  // What a build does after the last call (the Engine's backend sets up its contact lists).
  BuildProgress::stage("preparing the solver (contact lists)");
  return calibrations;
}

namespace {

std::int64_t count_automata(const SceneDef& scene, const Shapes& S, double spacing) {
  std::int64_t n = 0;
  for (std::size_t oi = 0; oi < scene.objects.size(); ++oi) n += object_count(scene, S, oi, spacing);
  return n;
}

// The count at a spacing, for advice, without work that grows with it: a box's and a surface-mode object's
// counted, a sphere's or cylinder's counted where its lattice has few rows (a rod, a disc: the thin shapes
// whose count the volume misjudges), else from its volume as a mesh's (filling it would take a signed-distance
// grid; a sphere of 10 m at 1 mm has 4e8 rows, and its count held a refusal for 28 s).
double estimated_count(const SceneDef& scene, const Shapes& S, double spacing) {
  double n = 0;
  for (std::size_t oi = 0; oi < scene.objects.size(); ++oi) {
    const ObjectDef& o = scene.objects[oi];
    bool counted = S.surface_of(oi) || o.shape == Shape::box;
    if (!counted && o.shape != Shape::mesh) {
      std::int64_t cells[3];
      double origin[3];
      lattice_frame(o, nullptr, spacing, cells, origin);
      counted = static_cast<double>(cells[1]) * static_cast<double>(cells[2]) <= 1e6;
    }
    n += counted ? static_cast<double>(object_count(scene, S, oi, spacing))
                 : object_volume(scene, S, oi) / (spacing * spacing * spacing);
  }
  return n;
}

// The spacing d (a float) in as few digits as read back as it (the model takes the spacing as a float; nine
// digits always do).
std::string spacing_written(double d) {
  for (int digits = 6; digits < 9; ++digits) {
    const std::string text = fmt::format("{:.{}g}", d, digits);
    if (static_cast<double>(static_cast<float>(std::stod(text))) == d) return text;
  }
  return fmt::format("{:.9g}", d);
}

// ", a model of about 15 GB" where a count of automata is a large model (a million or more), for advice that
// leads to one: the thinnest object sets the spacing for all (a rod of 0.8 mm beside a plate of 1 m^2).
std::string size_of_model(const SceneDef& scene, double automata) {
  if (automata < 1e6) return {};
  return fmt::format(", a model of about {}", text::human_bytes(automata * bytes_per_automaton(scene)));
}

// Refuses an object thinner than half the spacing d along a side of its lattice (`meshes_only`: a mesh object
// only, whose fill at d fails; the advice still fits every object).
void refuse_thin_objects(const SceneDef& scene, const Shapes& S, double d, bool meshes_only = false) {
  // An extent under half a cell would round to no cell; it becomes one, a body far larger than asked. (Half
  // a cell itself is one, and the spacing is a float: size = 0.025 at spacing 0.05 was refused.)
  struct Thin {
    std::size_t object = 0;
    int axis = -1;
    double ext[3] = {0, 0, 0};
  } named;
  // The fix is for the thinnest side of every object, whichever side is named (a cylinder 6e-9 m long and 3e-9
  // across was told a spacing that its diameter then refused; a thin sphere beside a thinner plate was told a
  // spacing that the plate then refused); an object that no spacing fits is named first.
  const SpacingRange range = spacing_range(scene);
  double thinnest = INFINITY;
  for (std::size_t oi = 0; oi < scene.objects.size(); ++oi) {
    if (S.surface_of(oi)) continue;
    Thin t{oi};
    shape_extents(scene.objects[oi], S.of(oi), t.ext);
    const double least = std::min({t.ext[0], t.ext[1], t.ext[2]});
    thinnest = std::min(thinnest, least);
    if (meshes_only && scene.objects[oi].shape != Shape::mesh) continue;
    for (int a = 0; a < 3 && t.axis < 0; ++a)
      if (t.ext[a] < 0.5 * d * (1 - 1e-6)) t.axis = a;
    if (t.axis >= 0 && (named.axis < 0 || (least < 0.5 * range.lo &&
                                           std::min({named.ext[0], named.ext[1], named.ext[2]}) >= 0.5 * range.lo)))
      named = t;
  }
  if (named.axis < 0) return;
  const double* ext = named.ext;
  const double own = std::min({ext[0], ext[1], ext[2]});
  const int a = named.axis;
  const text::Distinct hd = text::distinct(ext[a], 0.5 * d);
  // A spacing of the thinnest side or less fits (of twice it or less, at most half a cell); none does below half
  // the least spacing.
  const double fits = std::max(thinnest, range.lo);
  std::string fix;
  if (own < 0.5 * range.lo)
    fix = fmt::format("no spacing fits it: {} is more than twice its thinnest side; make the object larger",
                      spacing_bound(range, true));
  else if (scene.solver.target_automata > 0) {
    // The count at 1.5 times the thinnest side, halfway between the side and twice it (the largest spacing
    // taken): the target chooses a spacing within a few % of it, away from either end. Counted, not scaled by
    // the cube from the target: a plate's count grows as the square of 1 / spacing (one layer of cells), so the
    // cube asked a 2 mm plate for 1.1e7 automata, which then could not be met within 2 %.
    const double at = std::max(1.5 * thinnest, range.lo), count = estimated_count(scene, S, at);
    fix = count <= static_cast<double>(SolverDef::kMaxAutomata)
              ? fmt::format("raise solver.target_automata (it sets the spacing; about {:.3g} gives {:.3g} m{}) or make "
                            "the object larger",
                            count, at, size_of_model(scene, count))
              // (A count no target may ask for: a plate of 1 km by 1 mm.)
              : fmt::format("a spacing that fits it ({:.3g} m) gives about {:.3g} automata, more than the {} a model "
                            "can hold; make the object thicker or smaller",
                            at, count, SolverDef::kMaxAutomata);
  } else {
    // The spacing of 10,000 automata where the objects take it, else the count at the spacing named (a thin
    // plate was told the spacing of 10,000 automata, which it is too thin for).
    std::string there;
    if (ten_thousand_d(shapes_volume(scene, S)) <= fits) {
      there = ten_thousand_hint(scene, S);
    } else {
      const double count = estimated_count(scene, S, fits);
      there = fmt::format("about {:.3g} automata there{}", count, size_of_model(scene, count));
    }
    fix = fmt::format("decrease solver.spacing (to {:.3g} m{}; {}) or make the object larger", fits,
                      fits > range.lo ? " or less" : "", there);
  }
  throw Error(fmt::format("{}: object[{}] '{}' is {:.4g} x {:.4g} x {:.4g} m, {} m along its local {}, less than "
                          "half the spacing {:.4g} m ({} m): its lattice would be a cell of {:.4g} m there; {}",
                          scene.source, named.object, scene.objects[named.object].name, ext[0], ext[1], ext[2], hd.a,
                          "xyz"[a], d, hd.b, d, fix));
}

double spacing_for_target(const SceneDef& scene, const Shapes& S, std::int64_t target) {
  const double volume = shapes_volume(scene, S);
  double best_d = 0;
  std::int64_t best_n = -1;
  auto try_spacing = [&](double d) {
    d = static_cast<double>(static_cast<float>(d));  // (as build_model takes it: the count built is the one seen)
    const std::int64_t n = count_automata(scene, S, d);
    if (best_n < 0 || std::llabs(n - target) < std::llabs(best_n - target)) {
      best_n = n;
      best_d = d;
    }
    return n;
  };
  if (S.any_mesh) {
    // Filling a mesh costs a signed-distance grid, so no bisection: a lattice's count is its volume over
    // d^3 up to the cells cut by the surface, so d <- d (n / target)^(1/3) lands within 2 % in one or two
    // fills. The spacing is rounded to float as build_model will, so its fill is the one kept.
    double d = static_cast<double>(static_cast<float>(std::cbrt(volume / static_cast<double>(target))));
    refuse_over_memory(scene, d, static_cast<double>(target), false, 0);
    for (int it = 0; it < 6; ++it) {
      // (A mesh thinner than half the spacing is not filled: its inside was "told from its outside" by no cell.
      // A shape's count is exact however thin: it is checked at the spacing chosen.)
      refuse_thin_objects(scene, S, d, true);
      const std::int64_t n = try_spacing(d);
      if (std::llabs(n - target) * 200 <= target) break;  // within 0.5 %
      d = static_cast<double>(static_cast<float>(d * std::cbrt(static_cast<double>(n) / static_cast<double>(target))));
    }
    if (best_d != d) count_automata(scene, S, best_d);  // keep the fill of the spacing chosen
  } else {
    // The count falls as d grows; bisect on d between generous bounds, keep the closest count seen.
    double lo = std::cbrt(volume / target) * 0.25, hi = std::cbrt(volume / target) * 4.0;
    try_spacing(lo);
    for (int it = 0; it < 60; ++it) {
      const double mid = 0.5 * (lo + hi);
      const std::int64_t n = try_spacing(mid);
      if (std::llabs(n - target) <= target / 50) break;
      if (n > target) lo = mid;
      else hi = mid;
    }
  }
  // A spacing the materials' float32 numbers do not take (an object of 1e-13 m, of 1e9 m): the model could
  // not be built at any count near the target.
  if (const SpacingRange range = spacing_range(scene); best_d < range.lo || best_d > range.hi) {
    const bool small = best_d < range.lo;
    // The count at that bound, where a model can have it, 10 % inside it (lattice counts step with the spacing).
    const double at_bound =
        (small ? 0.9 : 1.1) * static_cast<double>(target) * std::pow(best_d / (small ? range.lo : range.hi), 3.0);
    throw Error(fmt::format("{}: solver.target_automata = {} takes a spacing of {:.3g} m, {} than {}: scale the "
                            "objects {} (object.scale or fit_size for a mesh, the sizes of a shape){}",
                            scene.source, target, best_d, small ? "less" : "more", spacing_bound(range, small),
                            small ? "up" : "down",
                            at_bound >= 100 && at_bound <= 1.8e8
                                ? fmt::format(", or ask for {} automata (about {:.3g} at that spacing)",
                                              small ? "fewer" : "more", at_bound)
                            : small && at_bound < 100
                                // (So few that lattice counts jump past any target: a spacing says it exactly.)
                                ? fmt::format(", or give solver.spacing ({:.3g} m or more) instead of a count",
                                              range.lo)
                                : std::string()));
  }
  if (static_cast<double>(std::llabs(best_n - target)) > 0.02 * static_cast<double>(target)) {
    // An object too thin for the spacings near the target is what to fix first (its count there jumps).
    refuse_thin_objects(scene, S, best_d);
    // The spacing, not that count as a target: counts do not fall steadily with the spacing (a row of cells
    // enters or leaves a round shape), so the search for the count it found, from another start, found
    // another count, and the advice was followed round after round. The spacing as written gives the count.
    const std::string written = spacing_written(best_d);
    throw Error(fmt::format(
        "{}: solver.target_automata = {} cannot be met within 2 %: the lattice counts of these shapes jump in "
        "steps near it; the closest is {} automata, at solver.spacing = {}: give that spacing instead of "
        "solver.target_automata",
        scene.source, target, best_n, written));
  }
  return best_d;
}

double scene_spacing(const SceneDef& scene, const Shapes& S) {
  return scene.solver.target_automata > 0 ? spacing_for_target(scene, S, scene.solver.target_automata)
                                          : scene.solver.spacing;
}

}  // namespace

std::int64_t count_automata(const SceneDef& scene, double spacing) {
  return count_automata(scene, prepare_shapes(scene), spacing);
}

double spacing_for_target(const SceneDef& scene, std::int64_t target) {
  return spacing_for_target(scene, prepare_shapes(scene), target);
}

double scene_spacing(const SceneDef& scene) { return scene_spacing(scene, prepare_shapes(scene)); }

SpacingRange spacing_range(double density) {
  SpacingRange r;
  constexpr double kMin = std::numeric_limits<float>::min(), kMax = std::numeric_limits<float>::max();
  if (!(density > 0)) return r;
  // (With room for the random lattice's cells, whose volumes spread about d^3: 1.5 times the least spacing,
  // 0.75 times the largest, a factor of 7.6 and 0.24 in rho d^5.)
  const double lo = 1.5 * std::max(std::pow(6 * kMin / density, 0.2), std::cbrt(kMin / density));
  const double hi = 0.75 * std::min(std::pow(6 * kMax / density, 0.2), std::cbrt(kMax / density));
  if (lo > r.lo) {
    r.lo = lo;
    r.lo_float32 = true;
  }
  if (hi < r.hi) {
    r.hi = hi;
    r.hi_float32 = true;
  }
  return r;
}

SpacingRange spacing_range(const SceneDef& scene) {
  SpacingRange r;
  const auto narrow = [&](const std::string& material, const std::string& key) {
    const SpacingRange m = spacing_range(resolve_material(scene, material, key).density);
    if (m.lo > r.lo) r.lo = m.lo, r.lo_float32 = m.lo_float32;
    if (m.hi < r.hi) r.hi = m.hi, r.hi_float32 = m.hi_float32;
  };
  for (std::size_t oi = 0; oi < scene.objects.size(); ++oi) {
    const ObjectDef& o = scene.objects[oi];
    if (o.shape == Shape::mesh && o.fill == MeshFill::surface) continue;  // (no lattice automata)
    const std::string key = fmt::format("object[{}].material", oi);
    narrow(o.material, key);
    for (std::size_t k = 0; k < o.regions.size(); ++k)
      if (!o.regions[k].material.empty()) narrow(o.regions[k].material, fmt::format("object[{}].region[{}].material", oi, k));
  }
  return r;
}

std::string spacing_bound(const SpacingRange& r, bool least) {
  if (!(least ? r.lo_float32 : r.hi_float32))
    return fmt::format("the {} solver.spacing may be ({:g} m)", least ? "least" : "largest", least ? r.lo : r.hi);
  return fmt::format("the {} spacing this scene's materials take ({:.3g} m: {} it an automaton's mass or moment of "
                     "inertia, rho d^5 / 6, leaves the range of float32, the solver's arithmetic)",
                     least ? "least" : "largest", least ? r.lo : r.hi, least ? "below" : "above");
}

std::string ten_thousand_spacing(double volume, const SpacingRange& range) {
  const double s = ten_thousand_d(volume);
  if (s >= range.lo && s <= range.hi) return fmt::format("about {:.3g} m gives 10,000 automata", s);
  const bool small = s < range.lo;
  return fmt::format("10,000 automata would take a spacing of {:.3g} m, {} than {}: scale the objects {} "
                     "(object.scale or fit_size for a mesh, the sizes of a shape)",
                     s, small ? "less" : "more", spacing_bound(range, small), small ? "up" : "down");
}

namespace {

// Refuses, before anything large is allocated, a scene whose model this build cannot address, that exceeds
// solver.max_memory_gb or whose objects are thinner than half a cell; returns the count of automata.
std::int64_t checked_automata_count(const SceneDef& scene, const Shapes& S, double d) {
  // Memory: first from the shapes' volume (so an absurd spacing is refused at once: a lattice fills a
  // shape to within a few cells of its surface, so half the volume estimate is a safe lower bound), then
  // from the exact count.
  constexpr auto kMaxAutomata = static_cast<double>(SolverDef::kMaxAutomata);  // (the backends' link addressing)
  auto refuse_count = [&](double n, bool approximate) {
    if (n <= kMaxAutomata) return;
    throw Error(fmt::format("{}: {}{:.4g} automata at spacing {:.4g} m are more than this build supports (about "
                            "1.8e8); {}",
                            scene.source, approximate ? "at least " : "", n, d,
                            scene.solver.target_automata > 0 ? "lower solver.target_automata" : "increase solver.spacing"));
  };
  const double n_volume = 0.5 * shapes_volume(scene, S) / (d * d * d);
  refuse_thin_objects(scene, S, d);
  double surface = 0;  // (surface-mode objects: their triangles' count, whatever the spacing)
  for (std::size_t oi = 0; oi < scene.objects.size(); ++oi)
    if (const SurfaceCells* sc = S.surface_of(oi)) surface += static_cast<double>(sc->face.size());
  refuse_over_memory(scene, d, n_volume, true, surface);
  refuse_count(n_volume + surface, true);
  const std::int64_t n_est = count_automata(scene, S, d);
  refuse_over_memory(scene, d, static_cast<double>(n_est) - surface, false, surface);
  refuse_count(static_cast<double>(n_est), false);
  return n_est;
}

// The scene's materials as the model's groups, numbered in the order they are first named (objects
// come first: a material that a projectile brings in afterwards fills no automaton).
class GroupTable {
 public:
  GroupTable(const SceneDef& scene, Model& M, double d)
      : scene_(scene), M_(M), d_(d), class_factors_(class_factor_range(scene)) {}
  // The group of material `name`, named at `key`; `automata`: it fills lattice automata (their mass and
  // moment of inertia must be float32 numbers).
  int of(const std::string& name, const std::string& key, bool automata) {
    const SceneDef& scene = scene_;
    Model& M = M_;
    const double d = d_;
    auto it = group_index_.find(name);
    if (it != group_index_.end()) return it->second;
    if (group_index_.size() >= 255) throw Error(fmt::format("{}: more than 255 materials in one scene", scene.source));
    const MaterialDef& m = resolve_material(scene, name, key);
    const int idx = static_cast<int>(M.groups.size());
    M.groups.push_back(group_params(scene, m, key, class_factors_, automata));
    const double mass = m.density * d * d * d;
    const SpacingRange range = spacing_range(m.density);
    const std::string fix =
        fmt::format("check the density (kg/m^3) and solver.spacing ({:g} m): at this density the spacing is safe from "
                    "{:.3g} to {:.3g} m (with room for the random lattice's smaller and larger cells: a cubic lattice "
                    "goes a little past it)",
                    d, range.lo, range.hi);
    if (automata) {
      as_float32(scene, fmt::format("the mass of an automaton of material \"{}\"", name), mass, fix);
      as_float32(scene, fmt::format("the moment of inertia of an automaton of material \"{}\"", name), mass * d * d / 6,
                 fix);
    }
    M.group_names.push_back(name);
    group_index_.emplace(name, idx);
    return idx;
  }

 private:
  const SceneDef& scene_;
  Model& M_;
  double d_;
  std::pair<double, double> class_factors_;  // class_factor_range
  std::map<std::string, int> group_index_;
};

// Lattice neighbours along each axis, per automaton, as the objects are filled (row-major cells: the
// one above has the larger index); joined into Model::neighbour(_below) at the end.
struct AxisNeighbours {
  std::array<std::vector<std::uint32_t>, 3> above, below;
};

// Object oi filled in surface mode: one automaton per triangle, explicit links, no lattice link.
void fill_surface(Model& M, const SceneDef& scene, const Shapes& S, std::size_t oi, const Mat3& R, int base_group,
                  const std::vector<int>& region_groups, std::vector<Vec3>& local, AxisNeighbours& nb, double d) {
  const ObjectDef& o = scene.objects[oi];
  const SurfaceCells& sc = *S.surface_of(oi);
  const std::size_t first = M.size();
  add_surface_object(M, scene, *S.of(oi), sc, oi, R, base_group, region_groups, local);
  refuse_empty_regions(scene, M, oi, first, d);
  for (int a = 0; a < 3; ++a) {  // no lattice links
    nb.above[a].resize(M.size(), Model::kNoLink);
    nb.below[a].resize(M.size(), Model::kNoLink);
  }
  MeshSummary ms = mesh_summary(*S.of(oi), oi, o.mesh, R, o.position);
  ms.surface = true;
  ms.automata = M.size() - first;
  ms.links = sc.link.size();
  ms.unlinked_edges = sc.unlinked_edges;
  ms.pieces = sc.pieces;
  ms.duplicate_faces = sc.duplicate_faces;
  ms.shell_thickness = sc.thickness;
  M.meshes.push_back(std::move(ms));
}

// The random lattice's links of object oi, whose automata [first, M.size()) sit at rs.inside: explicit
// links to its Voronoi neighbours, each of cross-section their shared face and rest length their
// distance; each automaton's volume its Voronoi cell (its mass the density's share of it), its contact
// radius d / 2 (pairs reach the smaller of their radii and their initial distance: Model::contact_reach).
// Boxed in (Model::boxed): a site of a cell inside the object's cells whose Voronoi neighbours are all
// the object's.
void link_random(Model& M, const SceneDef& scene, std::size_t oi, std::size_t first, const RandomSites& rs, double d) {
  const ObjectDef& o = scene.objects[oi];
  const VoronoiLinks v = voronoi_links(rs.inside, rs.ghosts, 1e-6 * d * d);
  const std::size_t count = rs.inside.size();
  const std::string fix = fmt::format("check the density (kg/m^3) and the spacing ({:g} m)", d);
  M.boxed.resize(first, 0);
  M.free_face.resize(first, 0.0f);
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t a = first + k;
    const double volume = v.volume[k];
    M.mass[a] = automaton_float32(
        scene, [&] { return fmt::format("the mass of automaton {} of object '{}'", k, o.name); },
        M.groups[M.group[a]].density * volume, fix);
    const double side = std::cbrt(volume);
    M.inertia[a] = automaton_float32(  // a cube of its volume
        scene, [&] { return fmt::format("the moment of inertia of automaton {} of object '{}'", k, o.name); },
        M.mass[a] * side * side / 6.0, fix);
    M.volume[a] = static_cast<float>(volume);
    M.boxed.push_back(v.interior[k] && rs.deep[k]);
    M.free_face.push_back(static_cast<float>(v.free_face[k]));
  }
  auto& E = M.explicit_links;
  for (std::size_t l = 0; l < v.link.size(); ++l) {
    const auto i = static_cast<std::uint32_t>(first + v.link[l][0]), j = static_cast<std::uint32_t>(first + v.link[l][1]);
    const DVec3 dd = ddelta(M.position0[i], M.position0[j]);
    const double r0 = std::sqrt(dot(dd, dd));
    E.i.push_back(i);
    E.j.push_back(j);
    E.r0.push_back(r0);
    E.area.push_back(static_cast<float>(v.area[l]));
    E.edge.push_back(static_cast<float>(std::sqrt(v.area[l])));
    // No shell normal: a random link's bending spring is a round section's, without axes of its own
    // (volume_link_bending).
    E.normal.push_back({});
  }
  M.links += v.link.size();
}

// The contact radius of a lattice's automata (cubic and random; a jittered site's is at most this): d / 2,
// but never reaching past the faces of an
// object's lattice of n cells of the scene's spacing (`given`, centred on its position). The centres are laid
// out with d, the spacing rounded to float; where that rounded up, an object's outer centres lie (n - 1) (d -
// given) / 2 further out than the scene's spacing puts them, and a sphere of d / 2 reached past its faces
// by that and by the float rounding of the radius: a box standing on another started pressed into it by
// 3e-9 m at d = 0.05, a preload that threw a light box off the one below at 8 mm/s. One radius for every
// object (the step's constants take bodies of one radius as one), rounded down to a float.
float lattice_contact_radius(const SceneDef& scene, const Shapes& S, double given, double d) {
  double room = 0.5 * d;
  for (std::size_t oi = 0; oi < scene.objects.size(); ++oi) {
    if (S.surface_of(oi)) continue;
    std::int64_t n[3];
    double origin[3];
    lattice_frame(scene.objects[oi], S.of(oi), d, n, origin);
    for (int a = 0; a < 3; ++a)
      room = std::min(room, 0.5 * (static_cast<double>(n[a]) * given - static_cast<double>(n[a] - 1) * d));
  }
  return float_at_most(room);
}

// Object oi filled with a lattice of spacing d in its own frame: the cells inside it, their links to
// their face neighbours, and for a mesh its bound surface and summary. `contact`: the lattice's
// contact radius (lattice_contact_radius).
void fill_lattice(Model& M, const SceneDef& scene, const Shapes& S, std::size_t oi, const Mat3& R, int base_group,
                  const std::vector<int>& region_groups, std::vector<Vec3>& local, AxisNeighbours& nb, double d,
                  float contact) {
  const ObjectDef& o = scene.objects[oi];
  const std::string okey = fmt::format("object[{}]", oi);
  const float fd = static_cast<float>(d);
  const double jitter = scene.solver.lattice_jitter;
  const ObjectLattice L = object_lattice(scene, S, oi, d);
  const std::size_t first = M.size();
  std::vector<std::int64_t> index(L.inside.size(), -1);
  // The random lattice: a site at a random point of each cell (and ghosts around the object).
  const bool random = scene.solver.lattice == SolverDef::Lattice::random;
  RandomSites rs;
  if (random) rs = random_sites(L.n, L.origin, d, L.inside, scene.solver.seed, oi);
  std::size_t c = 0;
  for (std::int64_t k = 0; k < L.n[2]; ++k)
    for (std::int64_t j = 0; j < L.n[1]; ++j)
      for (std::int64_t i = 0; i < L.n[0]; ++i, ++c) {
        if (!L.inside[c]) continue;
        index[c] = static_cast<std::int64_t>(M.size());
        const Vec3d lp{L.origin[0] + i * d, L.origin[1] + j * d, L.origin[2] + k * d};
        const Vec3d r = R.apply(lp);
        const Vec3d wp{r[0] + o.position[0], r[1] + o.position[1], r[2] + o.position[2]};
        int g = base_group;
        for (std::size_t rr = 0; rr < o.regions.size(); ++rr)
          if (o.regions[rr].shape == Shape::mesh ? L.regions[rr][c] != 0 : inside_region(o.regions[rr], wp))
            g = region_groups[rr];
        const float mass = M.lattice_mass(static_cast<std::size_t>(g));
        // A jittered site (SolverDef::lattice_jitter) stays in its cell, and so does its contact sphere:
        // its radius is what is left of d / 2 after the largest move, so no two automata start in contact
        // and a link that breaks leaves its pair apart (regions and classes keep the cell's centre).
        Vec3d site = wp;
        float radius = contact;
        if (random) {
          // (Regions and classes keep the cell's centre, as for a jittered site.)
          const auto& s = rs.inside[M.size() - first];
          const Vec3d turned = R.apply({s[0], s[1], s[2]});
          site = {turned[0] + o.position[0], turned[1] + o.position[1], turned[2] + o.position[2]};
        } else if (jitter > 0) {
          Vec3d move{};
          double largest = 0;
          for (int a = 0; a < 3; ++a) {
            const double u = unit_from_hash(hash_keys(scene.solver.seed, oi, static_cast<std::uint64_t>(c), a, 0x6a6974ull));
            move[a] = jitter * d * (2.0 * u - 1.0);
            largest = std::max(largest, std::fabs(move[a]));
          }
          const Vec3d turned = R.apply(move);
          site = {wp[0] + turned[0], wp[1] + turned[1], wp[2] + turned[2]};
          radius = std::min(contact, static_cast<float>(0.5 * d - largest));
        }
        if (random || jitter > 0) {  // (the automata before it, of other objects, hold their own centres)
          M.cell0.insert(M.cell0.end(), M.position0.begin() + static_cast<std::ptrdiff_t>(M.cell0.size()), M.position0.end());
          M.cell0.push_back(to_dvec3(wp));
        }
        M.position0.push_back(to_dvec3(site));
        M.velocity0.push_back(to_dvec3(o.velocity));
        M.mass.push_back(mass);
        M.radius.push_back(radius);
        M.inertia.push_back(mass * fd * fd / 6.0f);  // cube of side d about a central axis
        M.volume.push_back(fd * fd * fd);
        M.group.push_back(static_cast<std::uint8_t>(g));
        M.object.push_back(static_cast<std::int32_t>(oi));
        M.grip.push_back(-1);
        local.push_back(to_vec3(lp));
      }
  if (M.size() == first) {
    throw Error(fmt::format("{}: {} '{}' holds no automaton at spacing {:.4g} m; make it larger than the spacing "
                            "or {}",
                            scene.source, okey, o.name, d,
                            scene.solver.target_automata > 0 ? "raise solver.target_automata" : "decrease solver.spacing"));
  }
  refuse_empty_regions(scene, M, oi, first, d);
  if (const MeshObject* mo = S.of(oi)) {
    bind_surface(M, *mo, L, index, R, o.position, d);
    MeshSummary ms = mesh_summary(*mo, oi, o.mesh, R, o.position);
    ms.fill_seconds = L.fill_seconds;
    ms.automata = M.size() - first;
    ms.dropped_automata = static_cast<std::size_t>(L.dropped);
    ms.dropped_pieces = static_cast<std::size_t>(L.dropped_pieces);
    // A few stray cells are left out; a fill that falls apart into large pieces is not the mesh's solid.
    if (static_cast<double>(L.dropped) > 0.01 * static_cast<double>(ms.automata + L.dropped)) {
      throw Error(fmt::format(
          "{}: {} '{}': the fill of the mesh {} at spacing {:.4g} m falls apart: {} of its {} cells ({:.3g} %, in {} "
          "piece{}, the largest {} cells) are inside it but no lattice link joins them to the body of their "
          "surface, since the mesh is thinner than a cell between them (they would fall off at t = 0; up to 1 % "
          "are left out, over that the scene is refused). Decrease solver.spacing{}, or thicken the mesh there",
          scene.source, okey, o.name, o.mesh, d, L.dropped, ms.automata + L.dropped,
          100.0 * static_cast<double>(L.dropped) / static_cast<double>(ms.automata + L.dropped), L.dropped_pieces,
          L.dropped_pieces == 1 ? "" : "s", L.largest_dropped,
          scene.solver.target_automata > 0 ? " (raise solver.target_automata)" : ""));
    }
    M.meshes.push_back(std::move(ms));
  }
  if (random) {
    link_random(M, scene, oi, first, rs, d);
    for (int a = 0; a < 3; ++a) {  // no lattice links
      nb.above[a].resize(M.size(), Model::kNoLink);
      nb.below[a].resize(M.size(), Model::kNoLink);
    }
    return;
  }
  // Face neighbours along +-x, +-y, +-z of each cell: the automata of one object link along its own
  // lattice (row-major order, so the one above has the larger index).
  const std::int64_t stride[3] = {1, L.n[0], L.n[0] * L.n[1]};
  c = 0;
  for (std::int64_t k = 0; k < L.n[2]; ++k)
    for (std::int64_t j = 0; j < L.n[1]; ++j)
      for (std::int64_t i = 0; i < L.n[0]; ++i, ++c) {
        if (index[c] < 0) continue;
        const std::int64_t cell[3] = {i, j, k};
        for (int a = 0; a < 3; ++a) {
          const bool up = cell[a] + 1 < L.n[a], down = cell[a] > 0;
          const std::int64_t nu = up ? index[c + stride[a]] : -1, nd = down ? index[c - stride[a]] : -1;
          nb.above[a].push_back(nu < 0 ? Model::kNoLink : static_cast<std::uint32_t>(nu));
          nb.below[a].push_back(nd < 0 ? Model::kNoLink : static_cast<std::uint32_t>(nd));
          M.links += nu >= 0;
        }
      }
}

// Grips (first grip wins) and loads of the automata whose initial centres lie in their boxes.
void add_boundaries(Model& M, const SceneDef& scene, double d) {
  const std::size_t n = M.size();
  // Grips: automata whose initial centre lies in the box (first grip wins).
  for (std::size_t g = 0; g < scene.grips.size(); ++g) {
    const GripDef& gd = scene.grips[g];
    if (g >= 32767) throw Error(fmt::format("{}: more than 32767 grips; merge grips that move alike", scene.source));
    M.grip_names.push_back(gd.name);
    M.grip_velocity.push_back(to_dvec3(gd.velocity));
    std::size_t held = 0;
    for (std::size_t a = 0; a < n; ++a) {
      if (M.grip[a] < 0 && inside_box(M.position0[a], gd.min, gd.max)) {
        M.grip[a] = static_cast<std::int16_t>(g);
        ++held;
      }
    }
    if (held == 0) {
      throw Error(fmt::format("{}: grip[{}] '{}' (min {}, max {}) holds no automaton; make its box contain the "
                              "centres of the automata to hold (spacing {:.4g} m)",
                              scene.source, g, gd.name, fmt_vec(gd.min), fmt_vec(gd.max), d));
    }
  }

  // Loads: constant forces on the automata whose initial centre lies in the box (they add up).
  for (std::size_t l = 0; l < scene.loads.size(); ++l) {
    const LoadDef& ld = scene.loads[l];
    if (M.load.empty()) M.load.assign(n, Vec3{});
    std::size_t held = 0;
    for (std::size_t a = 0; a < n; ++a) {
      if (inside_box(M.position0[a], ld.min, ld.max)) {
        M.load[a] += to_vec3(ld.force);
        ++held;
        const Vec3& f = M.load[a];
        if (!(std::isfinite(f.x) && std::isfinite(f.y) && std::isfinite(f.z))) {
          throw Error(fmt::format("{}: load[{}] '{}'.force = {}{} does not fit the float32 arithmetic of the "
                                  "solver (at most 3.4e38 N along an axis on an automaton); give a smaller force",
                                  scene.source, l, ld.name, fmt_vec(ld.force),
                                  l > 0 ? " (with the loads before it on the same automata)" : ""));
        }
      }
    }
    if (held == 0) {
      throw Error(fmt::format("{}: load[{}] '{}' (min {}, max {}) acts on no automaton; make its box contain the "
                              "centres of the automata to load (spacing {:.4g} m)",
                              scene.source, l, ld.name, fmt_vec(ld.min), fmt_vec(ld.max), d));
    }
  }

}

// The projectiles (rigid spheres) from `placed` on, each refused when it starts inside or touching an
// object or another projectile; those before `placed` are in flight (build_model).
void add_projectiles(Model& M, const SceneDef& scene, std::size_t placed, GroupTable& groups) {
  const std::size_t n = M.size();
  // Projectiles: rigid spheres; refuse one that starts inside or touching an object. The automata are
  // binned in a grid of cells as large as the largest reach, so that each ball looks at the automata
  // around it only (a loop over all of them for each ball made 1,000 balls on 100,000 automata 1e8 tests).
  BuildProgress::stage(fmt::format("placing {} projectiles", scene.projectiles.size()));
  {
    const double table = 8.0 * static_cast<double>(scene.projectiles.size()) * static_cast<double>(scene.projectiles.size());
    if (table > scene.solver.max_memory_gb * 1e9) {
      throw Error(fmt::format("{}: {} projectiles need {:.3g} GB for the damping of each pair of them, over "
                              "solver.max_memory_gb = {:g}; use fewer projectiles or raise solver.max_memory_gb",
                              scene.source, scene.projectiles.size(), table / 1e9, scene.solver.max_memory_gb));
    }
  }
  UniformGrid automata_grid;
  bool grid_built = false;
  const float largest_automaton = M.radius.empty() ? 0.0f : *std::max_element(M.radius.begin(), M.radius.end());
  double largest_ball = 0;
  for (std::size_t p = placed; p < scene.projectiles.size(); ++p)
    largest_ball = std::max(largest_ball, scene.projectiles[p].radius);
  // The cubic lattice's automata are spheres of radius d/2 to the contacts, on a square grid: between four
  // of them runs a straight channel along each axis, d/sqrt(2) - d/2 = 0.207 d from their centres, and a
  // ball that fits in it crosses a body untouched (a hostile review: a 5 mm ball at 50 m/s through an
  // intact wall of d = 5 cm, 0 links broken, while one of 10.5 mm was stopped). The random lattice has
  // no such channels (its sites lie anywhere in their cells), nor do the shells (their own limit).
  const bool cubic_volume = scene.solver.lattice == SolverDef::Lattice::cubic &&
                            std::any_of(M.object_surface.begin(), M.object_surface.end(), [](auto s) { return s == 0; });
  const double channel = (std::numbers::sqrt2 / 2 - 0.5) * M.spacing;
  for (std::size_t p = 0; p < scene.projectiles.size(); ++p) {
    const ProjectileDef& pd = scene.projectiles[p];
    const std::string key = fmt::format("projectile[{}]", p);
    ProjectileParams pp;
    pp.name = pd.name;
    pp.group = groups.of(pd.material, key + ".material", false);
    const double rho = pd.density > 0 ? pd.density : M.groups[pp.group].density;
    pp.radius = float_at_most(pd.radius);  // (touching as placed: the checks below take the radius as given)
    const double mass = rho * 4.0 / 3.0 * std::numbers::pi * pd.radius * pd.radius * pd.radius;
    const std::string fix = fmt::format("check its radius (m) and density (kg/m^3); the automata here weigh {:.3g} kg",
                                        M.mass.empty() ? 0.0 : M.mass[0]);
    pp.mass = as_float32(scene, key + " mass", mass, fix);
    pp.inertia = as_float32(scene, key + " moment of inertia", 0.4 * mass * pd.radius * pd.radius, fix);
    as_float32(scene, key + ".radius", pd.radius, fix);
    if (cubic_volume && pd.radius < channel) {
      throw Error(fmt::format("{}: {} '{}' has a radius of {} m, less than the {} m (0.207 of the spacing {:g} m) "
                              "of the channels between the cubic lattice's automata: it would pass through a body "
                              "without touching it; give it a radius of at least {} m, or {}, or solver.lattice = "
                              "\"random\"",
                              scene.source, key, pd.name, text::distinct(pd.radius, channel).a,
                              text::distinct(pd.radius, channel).b, static_cast<double>(M.spacing),
                              text::at_least(channel, 4),
                              scene.solver.target_automata > 0
                                  ? std::string("more solver.target_automata (a finer spacing)")
                                  : fmt::format("a spacing of at most {} m",
                                                text::at_most(pd.radius / (std::numbers::sqrt2 / 2 - 0.5), 4))));
    }
    pp.kinematic = pd.kinematic;
    pp.rolling = static_cast<float>(pd.rolling_friction);
    pp.twisting = static_cast<float>(pd.twisting_friction);
    pp.position = to_dvec3(pd.position);
    pp.velocity = to_dvec3(pd.velocity);
    pp.angular_velocity = to_dvec3(pd.angular_velocity);
    if (p >= placed && n > 0) {
      if (!grid_built) {
        automata_grid.build(M.position0.data(), n, largest_ball + largest_automaton);
        grid_built = true;
      }
      // The automaton it overlaps most deeply; and the advice: how far back along its path (against its
      // velocity) the ball is clear of every automaton, found by sweeping that line through all of them (the
      // depth of the first one found was too little: three refusals in a row moved the cow's ball 2 cm).
      std::size_t a = n;
      double deepest = 0;
      automata_grid.for_each_candidate(pp.position, [&](std::uint32_t c) {
        const DVec3 dd = ddelta(pp.position, M.position0[c]);
        const double reach = pd.radius + M.radius[c];
        if (!(dot(dd, dd) < reach * reach)) return;
        const double gap = reach - std::sqrt(dot(dd, dd));
        if (a == n || gap > deepest || (gap == deepest && c < a)) {
          a = c;
          deepest = gap;
        }
      });
      if (a < n) {
        // The first distance s >= 0 along `u` (a unit vector) at which the ball is clear of every automaton:
        // each one it would overlap takes an interval of s out (|x_c - p - s u| < reach).
        const auto clear_along = [&](const DVec3& u) {
          std::vector<std::pair<double, double>> taken;
          for (std::size_t c = 0; c < n; ++c) {
            const DVec3 dd = ddelta(pp.position, M.position0[c]);
            const double reach = pd.radius + M.radius[c], du = dot(dd, u);
            const double disc = du * du - dot(dd, dd) + reach * reach;
            if (disc > 0) taken.emplace_back(du - std::sqrt(disc), du + std::sqrt(disc));
          }
          std::sort(taken.begin(), taken.end());
          double s = 0;
          for (const auto& [lo, hi] : taken) {
            if (lo >= s) break;
            s = std::max(s, hi);
          }
          return s;
        };
        const auto clear_at = [&](const DVec3& q) {
          for (std::size_t c = 0; c < n; ++c) {
            const DVec3 dd = ddelta(q, M.position0[c]);
            const double reach = pd.radius + M.radius[c];
            if (dot(dd, dd) < reach * reach) return false;
          }
          return true;
        };
        // Straight out: along the line from the automaton it overlaps most to its centre, as a displacement
        // whose printed digits are checked to clear it.
        DVec3 w = ddelta(M.position0[a], pp.position);
        const double len = std::sqrt(dot(w, w));
        w = len > 0 ? w * (1.0 / len) : DVec3{0, 0, 1};
        const double out = clear_along(w);
        std::string straight;
        for (double move = out, tries = 0; tries < 20; move *= 1.01, ++tries) {
          const std::string text = fmt::format("[{:.4g}, {:.4g}, {:.4g}] m", w.x * move, w.y * move, w.z * move);
          DVec3 moved{};
          if (std::sscanf(text.c_str(), "[%lf, %lf, %lf]", &moved.x, &moved.y, &moved.z) != 3) break;
          straight = text;
          if (clear_at(pp.position + moved)) break;
        }
        const double speed = std::sqrt(dot(pp.velocity, pp.velocity));
        std::string advice;
        if (speed > 0) {
          const DVec3 u = pp.velocity * (1.0 / speed);
          const double behind = clear_along(u * -1.0), ahead = clear_along(u);
          // (rounded up as printed: following the advice clears it)
          advice = fmt::format("{} m further back along its path clears it{}{}", text::at_least(behind, 3),
                               out < 0.5 * behind ? fmt::format(", as does a move by {} (straight out)", straight)
                                                  : std::string(),
                               ahead < 0.999 * behind ? "; its velocity leads out of the object: check its direction"
                                                      : std::string());
        } else {
          advice = fmt::format("it is at rest: a move by {} (straight out) clears it", straight);
        }
        throw Error(fmt::format(
            "{}: {}.position = {} puts '{}' (radius {:g} m) inside object '{}': it overlaps the automaton at "
            "[{:.4g}, {:.4g}, {:.4g}] by {:.3g} m; move the projectile clear of the object ({})",
            scene.source, key, fmt_vec(pd.position), pd.name, pd.radius, M.object_names[M.object[a]],
            M.position0[a].x, M.position0[a].y, M.position0[a].z, deepest, advice));
      }
    }
    M.projectiles.push_back(pp);
  }

  // Projectiles may touch each other but not overlap (they would start pressed into each other).
  for (std::size_t p = placed; p < M.projectiles.size(); ++p)
    for (std::size_t q = 0; q < p; ++q) {
      const ProjectileParams &A = M.projectiles[q], &B = M.projectiles[p];
      const DVec3 dd = ddelta(A.position, B.position);
      const double reach = static_cast<double>(A.radius) + B.radius, dist = std::sqrt(dot(dd, dd));
      if (dist < reach * (1 - 1e-6)) {
        throw Error(fmt::format("{}: projectile[{}] '{}' overlaps projectile[{}] '{}' by {:.3g} m (centres {:.4g} m "
                                "apart, radii {:g} and {:g} m); move them apart",
                                scene.source, p, B.name, q, A.name, reach - dist, dist, A.radius, B.radius));
      }
    }

}

// Contact materials of every pair of groups and of every group with the ground.
void set_contact_materials(Model& M, const SceneDef& scene) {
  // Contact materials of every pair of groups and of every group with the ground (contact_law.hpp): the
  // moduli in series, the pair's mean friction, rolling and twisting coefficients and restitution; the
  // ground brings its own coefficients and is rigid.
  const std::size_t ng = M.groups.size();
  M.contact.resize(ng * ng);
  M.ground_contact.resize(ng);
  for (std::size_t a = 0; a < ng; ++a) {
    const GroupParams& A = M.groups[a];
    for (std::size_t b = 0; b < ng; ++b) {
      const GroupParams& B = M.groups[b];
      ContactMaterial& c = M.contact[a * ng + b];
      c.youngs = harmonic(A.youngs, B.youngs);
      c.shear = harmonic(A.shear_modulus, B.shear_modulus);
      c.restitution = 0.5f * (A.restitution + B.restitution);
      c.zeta = restitution_damping_ratio(c.restitution);
      c.friction = 0.5f * (A.friction + B.friction);
      c.rolling = 0.5f * (A.rolling_friction + B.rolling_friction);
      c.twisting = 0.5f * (A.twisting_friction + B.twisting_friction);
    }
    ContactMaterial& g = M.ground_contact[a];
    g.youngs = harmonic(A.youngs, INFINITY);
    g.shear = harmonic(A.shear_modulus, INFINITY);
    g.restitution = static_cast<float>(scene.ground.restitution);
    g.zeta = restitution_damping_ratio(g.restitution);
    g.friction = static_cast<float>(scene.ground.friction);
    g.rolling = static_cast<float>(scene.ground.rolling_friction);
    g.twisting = static_cast<float>(scene.ground.twisting_friction);
  }
}

// The time step: solver.time_step as given (refused above the critical step), else solver.safety x the
// critical step.
// Model::face: the free sides of the automata's cells. The cubic lattice's from its links (a missing one
// is a side outside the object); the random lattice's from its cells (Model::cell0), numbered along the
// object's axes from its first automaton's cell. Not the jittered lattice nor surface-mode shells.
void mark_faces(Model& M, double d) {
  const std::size_t n = M.size();
  std::vector<std::uint8_t> face(n, 0);
  const auto bit = [](int axis, bool below) { return static_cast<std::uint8_t>(1u << (2 * axis + (below ? 1 : 0))); };
  std::vector<std::vector<std::uint32_t>> random_automata(M.object_axes.size());
  const bool jittered = !M.link_rest.empty();
  for (std::size_t a = 0; a < n; ++a) {
    const auto o = static_cast<std::size_t>(M.object[a]);
    if (M.object_surface[o]) continue;
    if (M.random_automaton(a)) {
      random_automata[o].push_back(static_cast<std::uint32_t>(a));
      continue;
    }
    if (jittered) continue;
    for (int axis = 0; axis < 3; ++axis) {
      const std::size_t slot = static_cast<std::size_t>(axis) * n + a;
      if (M.neighbour[slot] == Model::kNoLink) face[a] |= bit(axis, false);
      if (M.neighbour_below[slot] == Model::kNoLink) face[a] |= bit(axis, true);
    }
  }
  // The random lattice's cells per object, their numbers packed 21 bits each.
  constexpr std::int64_t kHalf = std::int64_t{1} << 20;
  for (std::size_t o = 0; o < random_automata.size(); ++o) {
    const auto& list = random_automata[o];
    if (list.empty()) continue;
    const DVec3 ref = M.cell0[list.front()];
    std::vector<std::array<std::int64_t, 3>> cell(list.size());
    std::unordered_set<std::uint64_t> present;
    present.reserve(2 * list.size());
    const auto key = [](const std::array<std::int64_t, 3>& c) {
      std::uint64_t k = 0;
      for (std::int64_t v : c) k = (k << 21) | static_cast<std::uint64_t>(v + kHalf);
      return k;
    };
    bool fits = true;
    for (std::size_t k = 0; k < list.size() && fits; ++k) {
      const DVec3 r = M.cell0[list[k]] - ref;
      for (std::size_t axis = 0; axis < 3; ++axis) {
        const double v = std::round(dot(r, to_dvec3(M.object_axes[o][axis])) / d);
        fits = fits && std::fabs(v) < static_cast<double>(kHalf - 1);
        cell[k][axis] = fits ? static_cast<std::int64_t>(v) : 0;
      }
      present.insert(key(cell[k]));
    }
    if (!fits) continue;  // (a million cells along an axis: no faces)
    for (std::size_t k = 0; k < list.size(); ++k)
      for (int axis = 0; axis < 3; ++axis)
        for (const bool below : {false, true}) {
          auto c = cell[k];
          c[static_cast<std::size_t>(axis)] += below ? -1 : 1;
          if (!present.count(key(c))) face[list[k]] |= bit(axis, below);
        }
  }
  if (std::any_of(face.begin(), face.end(), [](std::uint8_t f) { return f != 0; })) M.face.swap(face);
}

void choose_time_step(Model& M, const SceneDef& scene) {
  const TimeStepBound critical = critical_time_step(M);
  M.critical_dt = critical.dt;
  M.dt_limited_by = critical.limited_by;
  M.objects_critical_dt = critical.objects_dt;
  if (scene.solver.time_step > 0) {
    if (scene.solver.time_step > critical.dt) {
      throw Error(fmt::format("{}: solver.time_step = {} s is above the critical step {} s of this scene (set by "
                              "{}), where the integration becomes unstable; remove solver.time_step to use "
                              "solver.safety x the critical step, or set it below {:.4g}",
                              scene.source, text::num(scene.solver.time_step),
                              text::distinct(scene.solver.time_step, critical.dt).b, critical.limited_by,
                              scene.solver.safety * critical.dt));
    }
    set_time_step(M, static_cast<float>(scene.solver.time_step));
  } else {
    // The step is kept in float32: a safety so small that it leaves float's normal range (1.2e-38 s) would
    // round it to 0 (a frame of NaN steps, taken as one step of a whole frame) or to a few bits.
    const double step = scene.solver.safety * critical.dt;
    if (!(static_cast<float>(step) >= std::numeric_limits<float>::min())) {
      throw Error(fmt::format("{}: solver.safety = {} makes the time step {:.3g} s ({} x the critical step {:.4g} s), "
                              "below the {:.2g} s a float32 step holds; raise solver.safety (0.5 is the default)",
                              scene.source, text::num(scene.solver.safety), step, text::num(scene.solver.safety),
                              critical.dt, static_cast<double>(std::numeric_limits<float>::min())));
    }
    set_time_step(M, static_cast<float>(step));
  }
}

}  // namespace

Model build_model(const SceneDef& scene, std::size_t placed) {
  validate_scene(scene);
  // The spacing is rounded to float once: the rest length r0 = d is stored in float32, and the centres
  // (double) are laid out with the same d, so an intact lattice starts with a strain of exactly zero (up
  // to the double rounding of the centres) instead of the 3e-8 of a float-rounded r0.
  BuildProgress::stage("reading the meshes");
  const Shapes S = prepare_shapes(scene);
  if (scene.solver.target_automata > 0) BuildProgress::stage("finding the spacing for solver.target_automata");
  const double given = S.any_lattice ? scene_spacing(scene, S) : surface_spacing(S);
  const double d = static_cast<double>(static_cast<float>(given));
  const float contact = lattice_contact_radius(scene, S, given, d);
  Model M;
  M.spacing = static_cast<float>(d);
  const std::int64_t n_est = checked_automata_count(scene, S, d);
  // Reserved at once: grown by push_back, the arrays would hold up to twice their size (measured: the
  // model of 400,000 automata took 85 MB instead of 57).
  const auto n_res = static_cast<std::size_t>(n_est);
  for (auto* v : {&M.mass, &M.radius, &M.inertia, &M.volume, &M.class_factor}) v->reserve(n_res);
  M.position0.reserve(n_res);
  M.velocity0.reserve(n_res);
  M.group.reserve(n_res);
  M.strength_class.reserve(n_res);
  M.object.reserve(n_res);
  M.grip.reserve(n_res);
  // Neighbours along each axis, per automaton; joined into Model::neighbour(_below) at the end.
  AxisNeighbours nb;
  for (auto* v : {&nb.above, &nb.below})
    for (auto& axis : *v) axis.reserve(n_res);

  GroupTable groups(scene, M, d);
  for (std::size_t oi = 0; oi < scene.objects.size(); ++oi) {
    const ObjectDef& o = scene.objects[oi];
    const std::string okey = fmt::format("object[{}]", oi);
    BuildProgress::stage(fmt::format("filling object '{}' ({} of {})", o.name, oi + 1, scene.objects.size()));
    M.object_names.push_back(o.name);
    // (The lattice's automata are checked per material; a surface object's per automaton, as it is built.)
    const bool lattice_automata = S.surface_of(oi) == nullptr;
    const int base_group = groups.of(o.material, okey + ".material", lattice_automata);
    std::vector<int> region_groups;
    for (std::size_t r = 0; r < o.regions.size(); ++r)
      region_groups.push_back(
          groups.of(o.regions[r].material, fmt::format("{}.region[{}].material", okey, r), lattice_automata));

    const Mat3 R = rotation_matrix(o.rotation);
    M.object_axes.push_back({to_vec3({R.m[0][0], R.m[1][0], R.m[2][0]}), to_vec3({R.m[0][1], R.m[1][1], R.m[2][1]}),
                             to_vec3({R.m[0][2], R.m[1][2], R.m[2][2]})});
    M.object_surface.push_back(S.surface_of(oi) ? 1 : 0);
    if (scene.solver.lattice == SolverDef::Lattice::random) M.object_random.push_back(S.surface_of(oi) ? 0 : 1);
    std::vector<Vec3> local;  // the automata's centres in the object's frame, for the strength classes
    if (S.surface_of(oi)) fill_surface(M, scene, S, oi, R, base_group, region_groups, local, nb, d);
    else fill_lattice(M, scene, S, oi, R, base_group, region_groups, local, nb, d, contact);
    const HeterogeneityDef& het = o.heterogeneity ? *o.heterogeneity : scene.heterogeneity;
    for (auto cl : assign_classes(local, het, scene.solver.seed, static_cast<std::uint32_t>(oi))) {
      M.strength_class.push_back(cl);
      M.class_factor.push_back(static_cast<float>(het.class_factors[cl - 1]));
    }
  }

  BuildProgress::stage("checking that the objects do not overlap");
  refuse_overlaps(scene, M);
  index_corners(M.surface);
  index_explicit_links(M);
  // (A scene of surface-mode objects only has no random lattice, whatever solver.lattice says.)
  if (std::none_of(M.object_random.begin(), M.object_random.end(), [](std::uint8_t r) { return r != 0; }))
    M.object_random.clear();
  // (The automata after the last random or jittered one, of other objects, hold their own centres.)
  if (!M.cell0.empty())
    M.cell0.insert(M.cell0.end(), M.position0.begin() + static_cast<std::ptrdiff_t>(M.cell0.size()), M.position0.end());
  if (!M.object_random.empty()) {
    M.boxed.resize(M.size(), 0);
    M.free_face.resize(M.size(), 0.0f);
    M.lattice_stiffness = kRandomStiffness;
    M.lattice_lambda = kRandomLambda;
    // (-0 from any front end is 0: no springs, and the model's fingerprint of 0.)
    M.lattice_bending = scene.solver.link_bending > 0 ? static_cast<float>(scene.solver.link_bending) : 0.0f;
    M.lattice_strength = M.lattice_bending > 0.0f ? kRandomStrength : kRandomStrengthUnbent;
  }

  const std::size_t n = M.size();
  M.neighbour.reserve(3 * n);
  M.neighbour_below.reserve(3 * n);
  for (int a = 0; a < 3; ++a) {
    M.neighbour.insert(M.neighbour.end(), nb.above[a].begin(), nb.above[a].end());
    M.neighbour_below.insert(M.neighbour_below.end(), nb.below[a].begin(), nb.below[a].end());
    std::vector<std::uint32_t>().swap(nb.above[a]);
    std::vector<std::uint32_t>().swap(nb.below[a]);
  }
  for (std::size_t a = 0; a < n; ++a) M.total_mass += M.mass[a];
  assign_link_strengths(M, scene.solver.seed);
  if (scene.solver.lattice_jitter > 0 && M.has_lattice_links()) {  // (a scene of surface-mode objects only has none)
    M.lattice_stiffness = jitter_stiffness(scene.solver.lattice_jitter);
    M.lattice_lambda = M.lattice_stiffness;
    // Each lattice link's rest length is the distance of its moved sites (in double: the strain at rest is
    // zero to 1e-16, as for the explicit links).
    M.link_rest.assign(3 * n, d);
    M.link_inv_rest.assign(3 * n, static_cast<float>(1.0 / d));
    for (std::size_t l = 0; l < 3 * n; ++l) {
      if (M.neighbour[l] == Model::kNoLink) continue;
      const DVec3 dd = ddelta(M.position0[l % n], M.position0[M.neighbour[l]]);
      M.link_rest[l] = std::sqrt(dot(dd, dd));
      M.link_inv_rest[l] = static_cast<float>(1.0 / M.link_rest[l]);
    }
  }

  mark_faces(M, d);
  add_boundaries(M, scene, d);
  add_projectiles(M, scene, placed, groups);

  M.gravity = to_vec3(scene.solver.gravity);
  const float gl = length(M.gravity);
  M.up = gl > 0 ? M.gravity * (-1.0f / gl) : Vec3{0, 0, 1};
  M.ground = scene.ground.enabled;
  // The plane x . up = h |up|: up is a float unit vector, whose length differs from 1 by up to 1e-7 off the
  // axes (gravity (-1, 0, -1): 1.7e-8), which put a ground at 999,000 m 1.7 cm off where the scene says.
  // Along an axis |up| is 1 and the height as given.
  M.ground_height = scene.ground.height * length(to_dvec3(M.up));
  if (M.ground) settle_on_the_ground(scene, S, M, placed);
  set_contact_materials(M, scene);
  // The contact skin, a share of the finest spacing: a surface-mode shell's mean link where it is finer than
  // the lattice's (a bunny's shell of 4 mm triangles beside a box at 0.1 m took the box's skin, and every one
  // of its automata listed hundreds of candidates: 2 GB for a model priced at 150 MB).
  double finest = d;
  for (const auto& sc : S.surface)
    if (sc && sc->mean_link > 0) finest = std::min(finest, sc->mean_link);
  M.skin = static_cast<float>(scene.solver.skin * finest);
  M.link_damping = static_cast<float>(scene.solver.link_damping);
  M.local_damping = static_cast<float>(scene.solver.local_damping);
  M.stress_coefficient = static_cast<float>(scene.solver.stress_coefficient);

  scale_surface_masses(M, scene.solver.mass_scaling);
  BuildProgress::stage("the time step");
  choose_time_step(M, scene);
  return M;
}

}  // namespace mca::lattice
