#pragma once
// The bound surface of the mesh objects (Model::surface) in the pose of a state: each triangle carried by
// its automaton (centre and rotation), its vertices split where their triangles belong to different
// fragments, so cracks open between the pieces. What [output] surface writes per frame.
#include <cstdint>
#include <vector>

#include "core/model.hpp"
#include "core/state.hpp"
#include "mesh/mesh_write.hpp"

namespace mca::analysis {

// `fragment`: per automaton (Fragments::id). A mesh vertex becomes one vertex per fragment among its
// triangles, at the mean of the positions its triangles of that fragment give it (within a fragment the
// automata move almost rigidly, so the mean closes the hairline gaps of their elastic strain). Output
// vertices are numbered by mesh vertex, then by fragment in order of its first triangle; the face values
// are the fragments.
mesh::FloatMesh posed_surface(const Model& model, const State& state, const std::vector<std::int32_t>& fragment);

// Corner c of the bound surface in the pose of a state (posed_corner, core/model.hpp), `fragment` per
// automaton: where posed_surface puts its vertex, in double.
inline DVec3 posed_corner(const Model& model, const State& state, const std::int32_t* fragment, std::uint32_t c) {
  const BoundSurface& S = model.surface;
  const auto same = [&](std::uint32_t f, std::uint32_t g) { return fragment[S.automaton[f]] == fragment[S.automaton[g]]; };
  const auto pose = [&](std::uint32_t a, DVec3& x, Quat& q) {
    x = state.x[a];
    q = state.q[a];
  };
  return posed_corner(S.corners(), c, same, pose);
}

}  // namespace mca::analysis
