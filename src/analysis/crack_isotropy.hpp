#pragma once
// The crack isotropy measure of issue 21 (summary.json's crack_isotropy), as tools/fracture_metrics.py
// computes it: around the impact point, in the plane normal to the projectile's path, the share of
// damaged automata in eight 45-degree sectors, and the ratio of the sectors on the lattice axes to those on
// the diagonals. A cubic lattice steers cracks along its planes (ratio well above 1); an isotropic material
// gives about 1.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/math.hpp"

namespace mca {
struct Model;
struct SceneDef;
}  // namespace mca

namespace mca::analysis {

// The radii the issue measured the default wall with, in metres.
constexpr double kAnnulusInner = 0.25, kAnnulusOuter = 0.7;
// Automata with at least this damage (share of their links broken) count as damaged.
constexpr double kDamagedThreshold = 0.5;
// A sector of fewer automata gives no share (its share would move in steps of more than a fifth).
constexpr std::int64_t kMinSectorAutomata = 5;
// Every sector's share at least this: the annulus is damaged all round, and the ratio says little.
constexpr double kSaturated = 0.95;

// The plane of the measure: normal to world axis `normal` (0, 1, 2 = x, y, z), through `centre`. Angles are
// measured from the first in-plane axis towards the second, the two in increasing order (x then z for a
// y normal, y then z for x, x then y for z); sector s is centred on s * 45 degrees and spans +-22.5.
struct ImpactPlane {
  int normal = 1;
  std::array<double, 3> centre{};
  std::array<int, 2> axes() const {
    return normal == 0 ? std::array<int, 2>{1, 2} : normal == 1 ? std::array<int, 2>{0, 2} : std::array<int, 2>{0, 1};
  }
};

struct SectorShares {
  double r_in = 0, r_out = 0, threshold = kDamagedThreshold;
  std::int64_t in_annulus = 0;             // automata with r_in <= r <= r_out
  std::array<std::int64_t, 8> automata{};  // per sector
  std::array<std::int64_t, 8> damaged{};   // per sector, damage >= threshold
  std::array<std::optional<double>, 8> share;  // damaged / automata; unset for an empty sector
  // Means of the four axis sectors (0, 90, 180, 270 degrees) and the four diagonal ones, and their ratio;
  // unset, with `reason`, when a sector is empty or holds fewer than kMinSectorAutomata (the ratio also
  // when no diagonal automaton is damaged).
  std::optional<double> axis_mean, diagonal_mean, ratio;
  std::string reason;
};

// The sector shares of the automata at `initial` (their positions at rest) with `damage`, over those with
// r_in <= r <= r_out in `plane` (r measured in the plane from its centre, the normal component ignored).
// `only` (when not empty) has one entry per automaton: only those with a non-zero entry are counted.
SectorShares sector_shares(const std::vector<DVec3>& initial, const std::vector<float>& damage,
                           const ImpactPlane& plane, double r_in, double r_out,
                           const std::vector<std::uint8_t>& only = {}, double threshold = kDamagedThreshold);

// The measure on a run's state, the geometry taken from the scene and the model as fracture_metrics.py
// takes it from scene.toml: the normal is the axis of the first projectile's largest velocity component,
// the centre where that projectile's initial path crosses the plane through the first object's centre
// (its `position`), and the automata counted are the first object's, at their rest positions
// (Model::position0: what a frame's point minus its `displacement` gives), with the damage of the VTK
// frames' `damage` field (automaton_damage, with the softening links' damage).
//
// The radii: the 0.25 m and 0.7 m when the impact point lies at least 0.7 m from every in-plane edge
// of the first object (its automata's box, each automaton's centre +- its radius), so that the annulus
// lies inside it (the default wall, struck at 0.75 m from its top and bottom edges, is measured as in the
// issue and docs/fracture-study.md); on a smaller object 0.25 and 0.7 of that distance, the half-width
// for an object struck at its centre (a 0.4 m plate: 0.05 to 0.14 m), which keeps the annulus clear of the
// edges, where automata with fewer links break differently. `radii_scaled` says which.
struct CrackIsotropy {
  std::string reason;      // set when the measure could not be placed (then nothing below is set)
  ImpactPlane plane;
  double half_width = 0;   // distance from the impact point to the first object's nearest in-plane edge [m]
  bool radii_scaled = false;
  bool object_rotated = false;  // the first object's lattice axes are not the world's (the sectors use the world's)
  bool no_link_broken = false;  // no link of the first object has broken: its damage is softening only
  bool saturated = false;       // every sector's share is at least kSaturated
  SectorShares sectors;
};
CrackIsotropy crack_isotropy(const Model& model, const SceneDef& scene, const std::uint8_t* intact,
                             const float* link_damage = nullptr);

}  // namespace mca::analysis
