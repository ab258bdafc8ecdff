#include "lattice/lattice.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <map>
#include <numbers>

#include "lattice/heterogeneity.hpp"
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
};

std::int64_t cells_along(double extent, double d) {
  return std::max<std::int64_t>(1, static_cast<std::int64_t>(std::llround(extent / d)));
}

// Cells per axis and the centre of cell (0,0,0) in the object frame.
void lattice_frame(const ObjectDef& o, double d, std::int64_t n[3], double origin[3]) {
  double ext[3] = {0, 0, 0};
  switch (o.shape) {
    case Shape::box: ext[0] = o.size[0]; ext[1] = o.size[1]; ext[2] = o.size[2]; break;
    case Shape::sphere: ext[0] = ext[1] = ext[2] = 2 * o.radius; break;
    case Shape::cylinder: ext[0] = ext[1] = 2 * o.radius; ext[2] = o.height; break;
  }
  for (int a = 0; a < 3; ++a) {
    n[a] = cells_along(ext[a], d);
    origin[a] = -0.5 * static_cast<double>(n[a] - 1) * d;
  }
}

// Whether the cell centre (x, y, z) of the object frame lies in the shape.
bool inside_shape(const ObjectDef& o, double x, double y, double z) {
  if (o.shape == Shape::sphere) return x * x + y * y + z * z <= o.radius * o.radius;
  if (o.shape == Shape::cylinder) return x * x + y * y <= o.radius * o.radius && std::fabs(z) <= 0.5 * o.height;
  return true;
}

ObjectLattice object_lattice(const ObjectDef& o, double d) {
  ObjectLattice L;
  lattice_frame(o, d, L.n, L.origin);
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
std::int64_t object_count(const ObjectDef& o, double d) {
  std::int64_t n[3];
  double origin[3];
  lattice_frame(o, d, n, origin);
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

GroupParams group_params(const MaterialDef& m) {
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
  g.strengthening = static_cast<int>(m.strengthening);
  g.strengthening_alpha = static_cast<float>(m.strengthening_alpha);
  return g;
}

// The automata of grips and loads: initial centre inside [lo, hi].
bool inside_box(Vec3 p, const Vec3d& lo, const Vec3d& hi) {
  return p.x >= lo[0] && p.x <= hi[0] && p.y >= lo[1] && p.y <= hi[1] && p.z >= lo[2] && p.z <= hi[2];
}

Vec3 to_vec3(const Vec3d& v) { return {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])}; }

std::string fmt_vec(const Vec3d& v) { return fmt::format("[{:g}, {:g}, {:g}]", v[0], v[1], v[2]); }

double shapes_volume(const SceneDef& scene) {
  double volume = 0;
  for (const auto& o : scene.objects) {
    if (o.shape == Shape::box) volume += o.size[0] * o.size[1] * o.size[2];
    else if (o.shape == Shape::sphere) volume += 4.0 / 3.0 * std::numbers::pi * std::pow(o.radius, 3);
    else volume += std::numbers::pi * o.radius * o.radius * o.height;
  }
  return volume;
}

void refuse_over_memory(const SceneDef& scene, double d, double automata, bool approximate) {
  const double bytes = static_cast<double>(estimate_memory_bytes(1, 3)) * automata;
  if (bytes <= scene.solver.max_memory_gb * 1e9) return;
  throw Error(fmt::format(
      "{}: the scene needs about {:.1f} GB for {}{:.4g} automata at spacing {:.4g} m, over solver.max_memory_gb = "
      "{:g}; increase solver.spacing (memory falls with its cube) or raise solver.max_memory_gb if the machine has it",
      scene.source, bytes / 1e9, approximate ? "about " : "", automata, d, scene.solver.max_memory_gb));
}

}  // namespace

std::int64_t count_automata(const SceneDef& scene, double spacing) {
  std::int64_t n = 0;
  for (const auto& o : scene.objects) n += object_count(o, spacing);
  return n;
}

double spacing_for_target(const SceneDef& scene, std::int64_t target) {
  const double volume = shapes_volume(scene);
  // The count falls as d grows; bisect on d between generous bounds, keep the closest count seen.
  double lo = std::cbrt(volume / target) * 0.25, hi = std::cbrt(volume / target) * 4.0;
  double best_d = lo;
  std::int64_t best_n = count_automata(scene, lo);
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    const std::int64_t n = count_automata(scene, mid);
    if (std::llabs(n - target) < std::llabs(best_n - target)) {
      best_n = n;
      best_d = mid;
    }
    if (std::llabs(n - target) <= target / 50) break;
    if (n > target) lo = mid;
    else hi = mid;
  }
  if (static_cast<double>(std::llabs(best_n - target)) > 0.02 * static_cast<double>(target)) {
    throw Error(fmt::format(
        "{}: solver.target_automata = {} cannot be met within 2 %: the closest count is {} (spacing {:.6g} m), "
        "since the lattice counts of these shapes jump in steps; set solver.target_automata = {} or give "
        "solver.spacing instead",
        scene.source, target, best_n, best_d, best_n));
  }
  return best_d;
}

double scene_spacing(const SceneDef& scene) {
  return scene.solver.target_automata > 0 ? spacing_for_target(scene, scene.solver.target_automata)
                                          : scene.solver.spacing;
}

double stable_time_step(const Model& model, double safety) {
  // Only the groups automata are made of: a projectile's material enters through its contact spring.
  std::vector<char> used(model.groups.size(), 0);
  double m_min = std::numeric_limits<double>::max();
  for (std::size_t a = 0; a < model.size(); ++a) {
    used[model.group[a]] = 1;
    m_min = std::min<double>(m_min, model.mass[a]);
  }
  double cp_max = 0, k_max = 0;
  const double d = model.spacing;
  for (std::size_t gi = 0; gi < model.groups.size(); ++gi) {
    if (!used[gi]) continue;
    const auto& g = model.groups[gi];
    const double m = 2.0 * g.shear_modulus + g.lame_lambda;  // P-wave modulus
    cp_max = std::max(cp_max, std::sqrt(m / g.density));
    // Stiffest spring an automaton feels: a link (2G + lambda of both ends) or a projectile contact.
    k_max = std::max(k_max, (2.0 * g.shear_modulus + 2.0 * g.lame_lambda) * d);
    for (const auto& p : model.projectiles) {
      const auto& pg = model.groups[p.group];
      k_max = std::max(k_max, 2.0 * g.youngs * pg.youngs / (g.youngs + pg.youngs) * d);
    }
  }
  if (cp_max == 0) return 0;
  return std::min(safety * d / cp_max, safety * std::sqrt(m_min / k_max));
}

Model build_model(const SceneDef& scene) {
  validate_scene(scene);
  const double d = scene_spacing(scene);
  Model M;
  M.spacing = static_cast<float>(d);

  // Memory check before allocating anything large: first from the shapes' volume (so an absurd spacing
  // is refused at once: a lattice fills a shape to within a few cells of its surface, so half the
  // volume estimate is a safe lower bound), then from the exact count.
  refuse_over_memory(scene, d, 0.5 * shapes_volume(scene) / (d * d * d), true);
  const std::int64_t n_est = count_automata(scene, d);
  refuse_over_memory(scene, d, static_cast<double>(n_est), false);
  // Links are addressed with 29 bits in the backends' adjacency (3 links per automaton).
  if (n_est > (std::int64_t{1} << 29) / 3) {
    throw Error(fmt::format("{}: {} automata are more than this build supports (about 1.8e8); increase solver.spacing",
                            scene.source, n_est));
  }

  std::map<std::string, int> group_index;
  auto group_of = [&](const std::string& name, const std::string& key) {
    auto it = group_index.find(name);
    if (it != group_index.end()) return it->second;
    if (group_index.size() >= 255) throw Error(fmt::format("{}: more than 255 materials in one scene", scene.source));
    const MaterialDef& m = resolve_material(scene, name, key);
    const int idx = static_cast<int>(M.groups.size());
    M.groups.push_back(group_params(m));
    M.group_names.push_back(name);
    group_index.emplace(name, idx);
    return idx;
  };

  const float fd = static_cast<float>(d);
  for (std::size_t oi = 0; oi < scene.objects.size(); ++oi) {
    const ObjectDef& o = scene.objects[oi];
    const std::string okey = fmt::format("object[{}]", oi);
    M.object_names.push_back(o.name);
    const int base_group = group_of(o.material, okey + ".material");
    std::vector<int> region_groups;
    for (std::size_t r = 0; r < o.regions.size(); ++r)
      region_groups.push_back(group_of(o.regions[r].material, fmt::format("{}.region[{}].material", okey, r)));

    const ObjectLattice L = object_lattice(o, d);
    const Mat3 R = rotation_matrix(o.rotation);
    const std::size_t first = M.size();
    std::vector<std::int64_t> index(L.inside.size(), -1);
    std::vector<Vec3> local;
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
            if (inside_region(o.regions[rr], wp)) g = region_groups[rr];
          const float mass = M.groups[g].density * fd * fd * fd;
          M.position0.push_back(to_vec3(wp));
          M.velocity0.push_back(to_vec3(o.velocity));
          M.mass.push_back(mass);
          M.radius.push_back(0.5f * fd);
          M.inertia.push_back(mass * fd * fd / 6.0f);  // cube of side d about a central axis
          M.volume.push_back(fd * fd * fd);
          M.group.push_back(static_cast<std::uint8_t>(g));
          M.object.push_back(static_cast<std::int16_t>(oi));
          M.grip.push_back(-1);
          local.push_back(to_vec3(lp));
        }
    if (M.size() == first) {
      throw Error(fmt::format("{}: {} '{}' holds no automaton at spacing {:.4g} m; make it larger than the spacing "
                              "or decrease solver.spacing",
                              scene.source, okey, o.name, d));
    }
    // Face-neighbour links in +x, +y, +z of each cell: i < j by construction (row-major order).
    c = 0;
    for (std::int64_t k = 0; k < L.n[2]; ++k)
      for (std::int64_t j = 0; j < L.n[1]; ++j)
        for (std::int64_t i = 0; i < L.n[0]; ++i, ++c) {
          if (index[c] < 0) continue;
          const std::int64_t nb[3] = {i + 1 < L.n[0] ? static_cast<std::int64_t>(c + 1) : -1,
                                      j + 1 < L.n[1] ? static_cast<std::int64_t>(c + L.n[0]) : -1,
                                      k + 1 < L.n[2] ? static_cast<std::int64_t>(c + L.n[0] * L.n[1]) : -1};
          for (int a = 0; a < 3; ++a) {
            if (nb[a] < 0 || index[nb[a]] < 0) continue;
            M.link_i.push_back(static_cast<std::uint32_t>(index[c]));
            M.link_j.push_back(static_cast<std::uint32_t>(index[nb[a]]));
            M.link_r0.push_back(fd);
            M.link_area.push_back(fd * fd);
            M.link_axis.push_back(static_cast<std::uint8_t>(a));
          }
        }
    const HeterogeneityDef& het = o.heterogeneity ? *o.heterogeneity : scene.heterogeneity;
    const auto classes = assign_classes(local, het, scene.solver.seed, static_cast<std::uint32_t>(oi));
    for (auto cl : classes) {
      M.strength_class.push_back(cl);
      M.class_factor.push_back(static_cast<float>(het.class_factors[cl - 1]));
    }
  }

  // Automaton -> links adjacency (CSR), each automaton's links in link order.
  const std::size_t n = M.size();
  M.adj_begin.assign(n + 1, 0);
  for (std::size_t l = 0; l < M.link_count(); ++l) {
    ++M.adj_begin[M.link_i[l] + 1];
    ++M.adj_begin[M.link_j[l] + 1];
  }
  for (std::size_t a = 0; a < n; ++a) M.adj_begin[a + 1] += M.adj_begin[a];
  M.adj_link.resize(M.adj_begin[n]);
  {
    std::vector<std::uint32_t> fill(M.adj_begin.begin(), M.adj_begin.end() - 1);
    for (std::size_t l = 0; l < M.link_count(); ++l) {
      M.adj_link[fill[M.link_i[l]]++] = static_cast<std::uint32_t>(l);
      M.adj_link[fill[M.link_j[l]]++] = static_cast<std::uint32_t>(l);
    }
  }
  for (std::size_t a = 0; a < n; ++a) M.total_mass += M.mass[a];

  // Grips: automata whose initial centre lies in the box (first grip wins).
  for (std::size_t g = 0; g < scene.grips.size(); ++g) {
    const GripDef& gd = scene.grips[g];
    M.grip_names.push_back(gd.name);
    M.grip_velocity.push_back(to_vec3(gd.velocity));
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
      }
    }
    if (held == 0) {
      throw Error(fmt::format("{}: load[{}] '{}' (min {}, max {}) acts on no automaton; make its box contain the "
                              "centres of the automata to load (spacing {:.4g} m)",
                              scene.source, l, ld.name, fmt_vec(ld.min), fmt_vec(ld.max), d));
    }
  }

  // Projectiles: rigid spheres; refuse one that starts inside or touching an object.
  for (std::size_t p = 0; p < scene.projectiles.size(); ++p) {
    const ProjectileDef& pd = scene.projectiles[p];
    const std::string key = fmt::format("projectile[{}]", p);
    ProjectileParams pp;
    pp.name = pd.name;
    pp.group = group_of(pd.material, key + ".material");
    const double rho = pd.density > 0 ? pd.density : M.groups[pp.group].density;
    pp.radius = static_cast<float>(pd.radius);
    const double mass = rho * 4.0 / 3.0 * std::numbers::pi * pd.radius * pd.radius * pd.radius;
    pp.mass = static_cast<float>(mass);
    pp.inertia = static_cast<float>(0.4 * mass * pd.radius * pd.radius);
    pp.kinematic = pd.kinematic;
    pp.position = to_vec3(pd.position);
    pp.velocity = to_vec3(pd.velocity);
    pp.angular_velocity = to_vec3(pd.angular_velocity);
    for (std::size_t a = 0; a < n; ++a) {
      const Vec3 dd = M.position0[a] - pp.position;
      const double reach = pd.radius + M.radius[a];
      if (dot(dd, dd) < reach * reach) {
        const double gap = reach - length(dd);
        throw Error(fmt::format(
            "{}: {}.position = {} puts '{}' (radius {:g} m) inside object '{}': it overlaps the automaton at "
            "[{:.4g}, {:.4g}, {:.4g}] by {:.3g} m; move the projectile clear of the object (at least {:.3g} m "
            "further away along its path)",
            scene.source, key, fmt_vec(pd.position), pd.name, pd.radius, M.object_names[M.object[a]],
            M.position0[a].x, M.position0[a].y, M.position0[a].z, gap, gap));
      }
    }
    M.projectiles.push_back(pp);
  }

  M.gravity = to_vec3(scene.solver.gravity);
  const float gl = length(M.gravity);
  M.up = gl > 0 ? M.gravity * (-1.0f / gl) : Vec3{0, 0, 1};
  M.ground = scene.ground.enabled;
  M.ground_height = static_cast<float>(scene.ground.height);
  M.ground_friction = static_cast<float>(scene.ground.friction);
  M.ground_restitution = static_cast<float>(scene.ground.restitution);
  M.skin = static_cast<float>(scene.solver.skin * d);
  M.link_damping = static_cast<float>(scene.solver.link_damping);
  M.local_damping = static_cast<float>(scene.solver.local_damping);
  M.stress_coefficient = static_cast<float>(scene.solver.stress_coefficient);

  const double stable = stable_time_step(M, scene.solver.safety);
  if (scene.solver.time_step > 0) {
    if (scene.solver.time_step > stable * (1 + 1e-9)) {
      throw Error(fmt::format("{}: solver.time_step = {:g} s is above the stable step {:.4g} s of this scene "
                              "(C = {:g}); remove solver.time_step to use the automatic step, or set it below {:.4g}",
                              scene.source, scene.solver.time_step, stable, scene.solver.safety, stable));
    }
    M.dt = static_cast<float>(scene.solver.time_step);
  } else {
    M.dt = static_cast<float>(stable);
  }
  return M;
}

}  // namespace mca::lattice
