#include "analysis/surface.hpp"

#include <algorithm>
#include <array>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace mca::analysis {
mesh::FloatMesh posed_surface(const Model& model, const State& state, const std::vector<std::int32_t>& fragment) {
  const BoundSurface& S = model.surface;
  const std::size_t nf = S.faces(), nv = S.vertices;
  mesh::FloatMesh out;
  out.face_value_name = "fragment";
  out.faces.resize(nf);
  out.face_values.resize(nf);
  for (std::size_t f = 0; f < nf; ++f) out.face_values[f] = fragment[S.automaton[f]];
  // Per mesh vertex, one output vertex per fragment among its corners (in order of first corner), at the
  // mean of the positions those corners are carried to. Two passes over ranges of vertices (in parallel,
  // the same result for any thread count): count them, then place them at the counts' running sums.
  auto fragments_of = [&](std::size_t v, std::int32_t* seen) {
    std::size_t n = 0;
    for (std::uint32_t k = S.first_corner[v]; k < S.first_corner[v + 1]; ++k) {
      const std::int32_t frag = out.face_values[S.corners_of[k] / 3];
      std::size_t e = 0;
      while (e < n && seen[e] != frag) ++e;
      if (e == n) seen[n++] = frag;
    }
    return n;
  };
  std::size_t max_corners = 0;
  for (std::size_t v = 0; v < nv; ++v) max_corners = std::max<std::size_t>(max_corners, S.first_corner[v + 1] - S.first_corner[v]);
  std::vector<std::uint32_t> first_out(nv + 1, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<std::int32_t> seen(max_corners);
    for (std::size_t v = r.begin(); v < r.end(); ++v) first_out[v + 1] = static_cast<std::uint32_t>(fragments_of(v, seen.data()));
  });
  for (std::size_t v = 0; v < nv; ++v) first_out[v + 1] += first_out[v];
  out.vertices.resize(first_out[nv]);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<std::int32_t> seen(max_corners);
    std::vector<std::uint8_t> placed(max_corners);  // per fragment of the vertex: its position is set
    for (std::size_t v = r.begin(); v < r.end(); ++v) {
      const std::size_t n = fragments_of(v, seen.data());
      std::fill(placed.begin(), placed.begin() + static_cast<std::ptrdiff_t>(n), std::uint8_t{0});
      for (std::uint32_t k = S.first_corner[v]; k < S.first_corner[v + 1]; ++k) {
        const std::uint32_t c = S.corners_of[k];
        const std::size_t f = c / 3;
        std::size_t e = 0;
        while (seen[e] != out.face_values[f]) ++e;
        out.faces[f][c % 3] = first_out[v] + static_cast<std::uint32_t>(e);
        if (placed[e]) continue;
        placed[e] = 1;
        const DVec3 p = posed_corner(model, state, fragment.data(), c);
        out.vertices[first_out[v] + e] = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
      }
    }
  });
  return out;
}

}  // namespace mca::analysis
