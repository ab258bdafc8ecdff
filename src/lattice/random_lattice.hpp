#pragma once
// The random lattice (SolverDef::Lattice::random, docs/model-notes.md "The random lattice"): a site at a
// random point of each cell an object fills, linked to its Voronoi neighbours, each link's cross-section
// the Voronoi face the two sites share and each automaton's volume its Voronoi cell. A layer of ghost
// sites, drawn the same way in the empty cells around the object, bounds the cells of the sites on its
// surface (as the cubic lattice's automata are whole cubes); ghosts become no automata.
#include <array>
#include <cstdint>
#include <vector>

namespace mca::lattice {

// The sites of an object's cells, n[0] x n[1] x n[2] of them (row-major, x fastest; `inside` flags the
// filled ones), in the object's frame with cell (0, 0, 0) centred at `origin`: a site per inside cell (in
// cell order) and a ghost per empty cell that touches one (also across an edge or a corner, and in the
// layer just outside the frame). Each is a uniform random point of its cell (from seed, object and cell),
// drawn again, up to 8 times, while it lies closer than kMinSiteDistance d to a site already drawn in a
// neighbouring cell (the farthest of the 8 draws otherwise): a link far shorter than d would set the
// time step. Along an axis where the next cell is of the other kind (a surface cell and the ghost beyond
// it), a site lies at its cell's centre: the object's faces are the cubic lattice's (its contact spheres
// reach them, nothing starts in the ground or in an object placed against it), and the Voronoi cells
// fill the object's cells.
inline constexpr double kMinSiteDistance = 0.6;
struct RandomSites {
  std::vector<std::array<double, 3>> inside;  // per inside cell, in cell order
  std::vector<std::array<double, 3>> ghosts;
  std::vector<std::uint8_t> deep;              // per inside cell: 1 when its 26 neighbours are all inside
};
RandomSites random_sites(const std::int64_t n[3], const double origin[3], double d, const std::vector<std::uint8_t>& inside,
                         std::uint64_t seed, std::uint64_t object);

// The Voronoi neighbours among `sites` (the object's, then `ghosts`), by CGAL's Delaunay triangulation.
struct VoronoiLinks {
  std::vector<std::array<std::uint32_t, 2>> link;  // site pairs i < j (both the object's), sorted
  std::vector<double> area;                       // per link: the shared Voronoi face's area [m^2]
  std::vector<double> volume;                     // per site: its Voronoi cell's volume [m^3]
  std::vector<std::uint8_t> interior;             // per site: 1 when no ghost is among its neighbours
};
// The factor on the random lattice's moduli (Model::lattice_stiffness) that returns the input E: its
// automata relax off the affine displacement. A 20^3 block under uniaxial stress (the affine fit of its
// middle half, the end faces loaded free of moment; RandomLattice.ABlockReturnsTheInputModulusAndPoissonRatio)
// measured 0.9901 of the input modulus with the factor 1.02, 0.9998 with 1.03 (Poisson's ratio 0.2000 /
// 0.2009 for 0.2 with either).
inline constexpr float kRandomStiffness = 1.03f;

// The factor on the random lattice's strengths and breaking strains (Model::lattice_strength): a block of it
// pulled apart peaks at 0.915 of the tensile strength with the factor 1.28, against the cubic lattice's
// 0.913 (RandomLattice.TensileStrengthOfABlockAsMeasured; its links' own criterion, random_link_effort in
// physics/fracture.hpp). Under the lattice's equivalent stress it took 1.31 (0.713 with 1).
inline constexpr float kRandomStrength = 1.28f;

// Links stored per automaton, for the memory check before a build: 6.3 on the default wall, 7.1-7.45 on
// larger bodies (fewer of their automata at a surface).
inline constexpr double kRandomLinksPerAutomaton = 7.5;

// Faces smaller than min_area are left out (a near-degenerate pair of cells that touch at a point).
VoronoiLinks voronoi_links(const std::vector<std::array<double, 3>>& sites,
                           const std::vector<std::array<double, 3>>& ghosts, double min_area);

}  // namespace mca::lattice
