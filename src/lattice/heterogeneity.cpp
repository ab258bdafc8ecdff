#include "lattice/heterogeneity.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/rng.hpp"

namespace mca::lattice {

int class_from_uniform(double u, const std::array<double, 4>& shares) {
  double acc = 0.0;
  int last = 1;
  for (int c = 0; c < 4; ++c) {
    if (shares[c] <= 0.0) continue;
    last = c + 1;
    acc += shares[c];
    if (u < acc) return c + 1;
  }
  return last;  // u beyond the rounded sum: the last class with a share
}

std::vector<std::uint8_t> assign_classes(const std::vector<Vec3>& pts, const HeterogeneityDef& het,
                                         std::uint64_t seed, std::uint32_t object_index) {
  std::vector<std::uint8_t> out(pts.size());
  if (het.grain_size <= 0.0) {
    for (std::size_t k = 0; k < pts.size(); ++k)
      out[k] = static_cast<std::uint8_t>(
          class_from_uniform(unit_from_hash(hash_keys(seed, object_index, k, 0x636c617373ull)), het.shares));
    return out;
  }
  const double g = het.grain_size;
  auto key = [](std::int64_t v) { return static_cast<std::uint64_t>(v); };
  for (std::size_t k = 0; k < pts.size(); ++k) {
    const double p[3] = {pts[k].x / g, pts[k].y / g, pts[k].z / g};
    const std::int64_t c[3] = {static_cast<std::int64_t>(std::floor(p[0])),
                               static_cast<std::int64_t>(std::floor(p[1])),
                               static_cast<std::int64_t>(std::floor(p[2]))};
    double best = std::numeric_limits<double>::max();
    std::uint64_t best_cell = 0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const std::int64_t n[3] = {c[0] + dx, c[1] + dy, c[2] + dz};
          const std::uint64_t h = hash_keys(seed, object_index, key(n[0]), key(n[1]), key(n[2]));
          // Seed point of the grain: jittered inside its cube (three independent coordinates).
          const double s[3] = {n[0] + unit_from_hash(splitmix64(h ^ 1)), n[1] + unit_from_hash(splitmix64(h ^ 2)),
                               n[2] + unit_from_hash(splitmix64(h ^ 3))};
          const double d2 = (p[0] - s[0]) * (p[0] - s[0]) + (p[1] - s[1]) * (p[1] - s[1]) +
                            (p[2] - s[2]) * (p[2] - s[2]);
          if (d2 < best) {
            best = d2;
            best_cell = h;
          }
        }
    out[k] = static_cast<std::uint8_t>(class_from_uniform(unit_from_hash(splitmix64(best_cell ^ 4)), het.shares));
  }
  return out;
}

float weibull_factor(double u, double m) {
  const double w = std::pow(-std::log1p(-u), 1.0 / m) / std::tgamma(1.0 + 1.0 / m);
  return static_cast<float>(std::max(w, kMinLinkStrength));
}

void assign_link_strengths(Model& M, std::uint64_t seed) {
  // The links that take a spread: every lattice link, and the random lattice's explicit links (a
  // surface-mode object's have none; neither has a projectile's material, which has no links).
  const auto spreads = [&](std::size_t l) {
    return M.link_exists(l) && (!M.is_explicit(l) || M.random_automaton(M.link_i(l)));
  };
  const auto modulus = [&](std::size_t l) {
    const float mi = M.groups[M.group[M.link_i(l)]].weibull_modulus, mj = M.groups[M.group[M.link_j(l)]].weibull_modulus;
    return mi <= 0 ? mj : mj <= 0 ? mi : std::min(mi, mj);
  };
  bool any = false;
  for (std::size_t l = 0; l < M.link_slots() && !any; ++l) any = spreads(l) && modulus(l) > 0;
  M.link_strength.clear();
  if (!any) return;
  M.link_strength.assign(M.link_slots(), 1.0f);
  for (std::size_t l = 0; l < M.link_slots(); ++l) {
    if (!spreads(l)) continue;
    const float m = modulus(l);
    if (m > 0) M.link_strength[l] = weibull_factor(unit_from_hash(hash_keys(seed, l, 0x77656962756c6cull)), m);
  }
}

}  // namespace mca::lattice
