#pragma once
// Strength classes (paper sec. 5.1, physics.md sec. 5): drawn from P(c) per automaton, or per grain.
#include <array>
#include <cstdint>
#include <vector>

#include "core/math.hpp"
#include "core/model.hpp"
#include "mca/scene.hpp"

namespace mca::lattice {

// Class 1..4 for u uniform in [0, 1) under the shares P(c).
int class_from_uniform(double u, const std::array<double, 4>& shares);

// Classes for points given in an object's own frame (lattice coordinates, metres). Independent draws
// are keyed by (seed, object, point index); grains are Voronoi cells around one jittered seed point per
// cube of side grain_size, each grain drawing its class once, keyed by (seed, object, cube).
std::vector<std::uint8_t> assign_classes(const std::vector<Vec3>& local_points, const HeterogeneityDef& het,
                                         std::uint64_t seed, std::uint32_t object_index);

// The factor of a link's strength for u uniform in [0, 1): Weibull of modulus m and mean 1,
// (-ln(1 - u))^(1/m) / Gamma(1 + 1/m), raised to kMinLinkStrength where it falls below.
inline constexpr double kMinLinkStrength = 0.05;
float weibull_factor(double u, double m);

// Model::link_strength: per link slot (lattice links and the random lattice's explicit links),
// weibull_factor of (seed, slot) with the smaller weibull_modulus of its ends' materials that is not 0
// (the wider spread); 1 where both are 0 and on a surface-mode object's links. Left empty when no such
// link has an end of a material with a spread.
void assign_link_strengths(Model& M, std::uint64_t seed);

}  // namespace mca::lattice
