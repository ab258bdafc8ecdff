#include "analysis/crack_isotropy.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "core/model.hpp"
#include "mca/scene.hpp"

namespace mca::analysis {

namespace {
double component(const DVec3& v, int axis) { return axis == 0 ? v.x : axis == 1 ? v.y : v.z; }
constexpr const char* kAxisName[] = {"x", "y", "z"};
}  // namespace

SectorShares sector_shares(const std::vector<DVec3>& initial, const std::vector<float>& damage,
                           const ImpactPlane& plane, double r_in, double r_out, const std::vector<std::uint8_t>& only,
                           double threshold) {
  if (damage.size() != initial.size() || (!only.empty() && only.size() != initial.size()))
    throw std::invalid_argument(fmt::format("sector_shares: {} positions, {} damage values, {} filter entries",
                                            initial.size(), damage.size(), only.size()));
  SectorShares s;
  s.r_in = r_in;
  s.r_out = r_out;
  s.threshold = threshold;
  const auto [a, b] = plane.axes();
  for (std::size_t i = 0; i < initial.size(); ++i) {
    if (!only.empty() && !only[i]) continue;
    const double da = component(initial[i], a) - plane.centre[static_cast<std::size_t>(a)];
    const double db = component(initial[i], b) - plane.centre[static_cast<std::size_t>(b)];
    const double r = std::hypot(da, db);
    if (!(r >= r_in && r <= r_out)) continue;
    // Degrees in [0, 360), then the sector whose centre (k * 45) is within 22.5 degrees: as numpy's
    // floor((degrees(arctan2(db, da)) % 360 + 22.5) / 45) % 8.
    double angle = std::fmod(std::atan2(db, da) * (180.0 / std::numbers::pi), 360.0);
    if (angle < 0) angle += 360.0;
    const auto sector = static_cast<std::size_t>(static_cast<int>(std::floor((angle + 22.5) / 45.0)) % 8);
    ++s.in_annulus;
    ++s.automata[sector];
    if (damage[i] >= threshold) ++s.damaged[sector];
  }
  std::string empty;
  for (std::size_t k = 0; k < 8; ++k) {
    if (s.automata[k] > 0)
      s.share[k] = static_cast<double>(s.damaged[k]) / static_cast<double>(s.automata[k]);
    else
      empty += fmt::format("{}{}", empty.empty() ? "" : ", ", 45 * k);
  }
  if (!empty.empty()) {
    s.reason = fmt::format("no automaton of the annulus {:g}-{:g} m lies in the sector{} at {} degrees", r_in, r_out,
                           empty.find(',') == std::string::npos ? "" : "s", empty);
    return s;
  }
  // A share of fewer automata than this moves in steps of a fifth or more: too coarse to compare sectors.
  std::string sparse;
  for (std::size_t k = 0; k < 8; ++k)
    if (s.automata[k] < kMinSectorAutomata) sparse += fmt::format("{}{} ({})", sparse.empty() ? "" : ", ", 45 * k, s.automata[k]);
  if (!sparse.empty()) {
    s.reason = fmt::format("the annulus {:g}-{:g} m holds fewer than {} automata in the sectors at {} degrees (the "
                           "counts in brackets): too few for a share; the measure needs the impact point farther from "
                           "the object's edges, or a finer spacing",
                           r_in, r_out, kMinSectorAutomata, sparse);
    return s;
  }
  double axes = 0, diagonals = 0;
  for (std::size_t k = 0; k < 8; k += 2) {
    axes += *s.share[k];
    diagonals += *s.share[k + 1];
  }
  s.axis_mean = axes / 4;
  s.diagonal_mean = diagonals / 4;
  if (*s.diagonal_mean > 0)
    s.ratio = *s.axis_mean / *s.diagonal_mean;
  else if (*s.axis_mean > 0)
    s.reason = "no automaton of the diagonal sectors is damaged: the axis/diagonal ratio is unbounded";
  else
    s.reason = "no automaton of the annulus is damaged: there is no crack to measure";
  return s;
}

CrackIsotropy crack_isotropy(const Model& model, const SceneDef& scene, const std::uint8_t* intact,
                             const float* link_damage) {
  CrackIsotropy c;
  if (scene.projectiles.empty()) {
    c.reason = "the scene has no projectile to place the impact";
    return c;
  }
  if (scene.objects.empty() || model.size() == 0) {
    c.reason = "the scene has no object";
    return c;
  }
  const ProjectileDef& p = scene.projectiles.front();
  int normal = 0;  // the largest component; the first of equal ones, as numpy.argmax
  for (int k = 1; k < 3; ++k)
    if (std::fabs(p.velocity[static_cast<std::size_t>(k)]) > std::fabs(p.velocity[static_cast<std::size_t>(normal)]))
      normal = k;
  const auto n = static_cast<std::size_t>(normal);
  if (p.velocity[n] == 0) {
    c.reason = fmt::format("the first projectile, '{}', does not move", p.name);
    return c;
  }
  const double plane_at = scene.objects.front().position[n];
  const double t = (plane_at - p.position[n]) / p.velocity[n];
  if (t < 0) {
    c.reason = fmt::format("the first projectile, '{}', moves away from the plane {} = {:g} m through the first "
                           "object's centre",
                           p.name, kAxisName[normal], plane_at);
    return c;
  }
  c.plane.normal = normal;
  for (std::size_t k = 0; k < 3; ++k) c.plane.centre[k] = p.position[k] + t * p.velocity[k];

  // The first object's automata, and their box in the plane.
  std::vector<std::uint8_t> first(model.size(), 0);
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::array<double, 3> lo{kInf, kInf, kInf}, hi{-kInf, -kInf, -kInf};
  for (std::size_t i = 0; i < model.size(); ++i) {
    if (model.object[i] != 0) continue;
    first[i] = 1;
    for (int k = 0; k < 3; ++k) {
      const double x = component(model.position0[i], k);
      lo[static_cast<std::size_t>(k)] = std::min(lo[static_cast<std::size_t>(k)], x - model.radius[i]);
      hi[static_cast<std::size_t>(k)] = std::max(hi[static_cast<std::size_t>(k)], x + model.radius[i]);
    }
  }
  c.half_width = kInf;
  for (const int k : c.plane.axes()) {
    const auto u = static_cast<std::size_t>(k);
    c.half_width = std::min({c.half_width, c.plane.centre[u] - lo[u], hi[u] - c.plane.centre[u]});
  }
  if (!(c.half_width > 0)) {
    c.reason = fmt::format("the first projectile's path crosses the plane {} = {:g} m at [{:g}, {:g}, {:g}], outside "
                           "the first object ('{}')",
                           kAxisName[normal], plane_at, c.plane.centre[0], c.plane.centre[1], c.plane.centre[2],
                           scene.objects.front().name);
    c.half_width = 0;
    return c;
  }
  // Struck at (or within an automaton of) its edge, the annulus scaled to the half-width would be thinner
  // than an automaton.
  if (c.half_width < static_cast<double>(model.spacing) / (kAnnulusOuter - kAnnulusInner)) {
    c.reason = fmt::format("the first projectile's path crosses the plane {} = {:g} m {:g} m from the first object's "
                           "('{}') nearest edge in the plane: an annulus that fits would be thinner than an automaton "
                           "({:g} m)",
                           kAxisName[normal], plane_at, c.half_width, scene.objects.front().name, model.spacing);
    return c;
  }
  if (!model.object_axes.empty())
    for (int k = 0; k < 3; ++k) {
      // Rotated off the world's axes: a lattice axis along none of them (a turn by 90 or 180 degrees
      // maps the lattice's axes onto the world's, and the sectors stay centred on its axes).
      const DVec3 axis = to_dvec3(model.object_axes.front()[static_cast<std::size_t>(k)]);
      const double largest = std::max({std::fabs(axis.x), std::fabs(axis.y), std::fabs(axis.z)});
      if (std::fabs(largest - 1.0) > 1e-6) c.object_rotated = true;
    }

  c.radii_scaled = c.half_width < kAnnulusOuter;
  const double scale = c.radii_scaled ? c.half_width : 1.0;
  std::vector<float> damage(model.size());
  automaton_damage(model, intact, link_damage, damage.data());
  c.sectors = sector_shares(model.position0, damage, c.plane, kAnnulusInner * scale, kAnnulusOuter * scale, first);
  // What the damage counted is: with softening links it counts softened links too (automaton_damage).
  std::size_t broken = 0;
  for (std::size_t l = 0; l < model.link_slots(); ++l) broken += model.link_exists(l) && !intact[l] && first[model.link_i(l)];
  c.no_link_broken = broken == 0;
  c.saturated = c.sectors.ratio && std::all_of(c.sectors.share.begin(), c.sectors.share.end(),
                                               [](const std::optional<double>& v) { return v && *v >= kSaturated; });
  return c;
}

}  // namespace mca::analysis
