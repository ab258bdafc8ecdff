#pragma once
// The random lattice (SolverDef::Lattice::random, docs/model-notes.md "The random lattice"): a site at a
// random point of each cell an object fills, linked to its Voronoi neighbours, each link's cross-section
// the Voronoi face the two sites share and each automaton's volume its Voronoi cell. A layer of ghost
// sites in the empty cells around the object, mirror images of its surface sites, bounds the cells of
// those sites by the object's faces (as the cubic lattice's automata are whole cubes); ghosts become no
// automata.
#include <array>
#include <cstdint>
#include <vector>

namespace mca::lattice {

// The sites of an object's cells, n[0] x n[1] x n[2] of them (row-major, x fastest; `inside` flags the
// filled ones), in the object's frame with cell (0, 0, 0) centred at `origin`: a site per inside cell (in
// cell order) and a ghost per empty cell that touches one (also across an edge or a corner, and in the
// layer just outside the frame). A site is a uniform random point of its cell (from seed, object and
// cell), drawn again, up to 8 times, while it lies closer than kMinSiteDistance d to a site already drawn
// in a neighbouring cell (the farthest of the 8 draws otherwise): a link far shorter than d would set the
// time step. Along an axis where the next cell is of the other kind (a surface cell and the ghost beyond
// it), a site lies at its cell's centre: the object's faces are the cubic lattice's (its contact spheres
// reach them, nothing starts in the ground or in an object placed against it). A ghost is the mirror
// image of the one site it touches across a face (else across an edge, else a corner), so the Voronoi
// faces toward the ghosts lie in the object's faces and the cells fill the object's cells; one that
// touches several at that level (a concave corner of a mesh), or whose image comes too close to another
// site, is drawn at random as a site is.
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
  std::vector<double> free_face;                  // per site: sum of A r over its faces toward ghosts [m^3]
};
// The factors on the random lattice's G (Model::lattice_stiffness: its pair springs) and lambda
// (Model::lattice_lambda: its many-body term) that return the input E and Poisson's ratio: its automata
// relax off the affine displacement. A 20^3 block under uniaxial stress (the affine fit of its middle
// half, the end faces loaded free of moment; RandomLattice.ABlockReturnsTheInputModulusAndPoissonRatio),
// with the ghosts mirrored and the free faces' many-body term (random_many_body): 1.03 on both gave
// 0.9989 E and nu 0.2043 / 0.2042 for 0.2; lambda at 0.96 of that, 0.9951 E and nu 0.1995 / 0.1994; 1.035
// on G and 1 on lambda, 1.0006 E and nu 0.2002 / 0.2001; with the links' bending springs
// (SolverDef::link_bending = 0.1: the automata's rotations relax off the affine ones less freely), 1.0030 E
// and nu 0.1994 / 0.1993 (at link_bending = 1, 1.0148 E and nu 0.1957 / 0.1953). (With ghosts drawn at
// random, 1.03 on both gave 0.9998 E, nu 0.2000 / 0.2009, with its soft faces: see random_sites.)
inline constexpr float kRandomStiffness = 1.035f;
inline constexpr float kRandomLambda = 1.0f;

// The factor on the random lattice's strengths and breaking strains (Model::lattice_strength): a block of it
// pulled apart peaks at 0.924 of the tensile strength with the factor 1.10, against the cubic lattice's
// 0.913 (RandomLattice.TensileStrengthOfABlockAsMeasured; its links' own criterion, random_link_effort in
// physics/fracture.hpp, which sees the bending springs' fibre stresses, SolverDef::link_bending = 0.1);
// pressed, at 0.652 of the compressive strength (the cubic lattice's 0.620). Without the bending springs
// the factor was 1.078 (0.915 and 0.597). With the springs' square sections of before (afc609c): 0.917
// and 0.660 at 1.10; 0.898 and 0.650 at 1.078; at link_bending = 1, 0.666 in tension (1.48 returned
// 0.908, but 0.963 in compression). With
// the ghosts drawn at random (before 2026-12-03) it took 1.28: their leaning faces left the block's
// surface soft (random_sites), and 1.28 with the mirrored ghosts gave 1.086 and 0.686. Under the
// lattice's equivalent stress it took 1.31 (0.713 with 1).
inline constexpr float kRandomStrength = 1.10f;
// The factor without the bending springs (SolverDef::link_bending = 0): the lattice of before them, bit for bit.
inline constexpr float kRandomStrengthUnbent = 1.078f;

// Links stored per automaton, for the memory check before a build: 6.3 on the default wall, 7.1-7.45 on
// larger bodies (fewer of their automata at a surface).
inline constexpr double kRandomLinksPerAutomaton = 7.5;

// Faces smaller than min_area are left out (a near-degenerate pair of cells that touch at a point).
VoronoiLinks voronoi_links(const std::vector<std::array<double, 3>>& sites,
                           const std::vector<std::array<double, 3>>& ghosts, double min_area);

}  // namespace mca::lattice
