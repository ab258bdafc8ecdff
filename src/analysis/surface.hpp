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

}  // namespace mca::analysis
