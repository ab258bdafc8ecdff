#include "analysis/surface.hpp"

#include <array>
#include <utility>

namespace mca::analysis {
namespace {

// q v q^-1 for a unit quaternion, in double (the centres are double).
DVec3 rotate(const Quat& q, const Vec3& v) {
  const double w = q.w, x = q.x, y = q.y, z = q.z;
  // t = 2 (u x v), v' = v + w t + u x t
  const double tx = 2 * (y * v.z - z * v.y), ty = 2 * (z * v.x - x * v.z), tz = 2 * (x * v.y - y * v.x);
  return {v.x + w * tx + (y * tz - z * ty), v.y + w * ty + (z * tx - x * tz), v.z + w * tz + (x * ty - y * tx)};
}

}  // namespace

mesh::FloatMesh posed_surface(const Model& model, const State& state, const std::vector<std::int32_t>& fragment) {
  const BoundSurface& S = model.surface;
  const std::size_t nf = S.faces(), nc = 3 * nf, nv = S.vertices;
  mesh::FloatMesh out;
  out.face_value_name = "fragment";
  out.faces.resize(nf);
  out.face_values.resize(nf);
  for (std::size_t f = 0; f < nf; ++f) out.face_values[f] = fragment[S.automaton[f]];
  // The corners of each mesh vertex (a counting sort: no hashing in a per-frame pass).
  std::vector<std::uint32_t> first(nv + 1, 0), corners(nc);
  for (std::size_t c = 0; c < nc; ++c) ++first[S.corner[c] + 1];
  for (std::size_t v = 0; v < nv; ++v) first[v + 1] += first[v];
  {
    std::vector<std::uint32_t> fill(first.begin(), first.end() - 1);
    for (std::size_t c = 0; c < nc; ++c) corners[fill[S.corner[c]]++] = static_cast<std::uint32_t>(c);
  }
  out.vertices.reserve(nv + nv / 8);
  // Per mesh vertex, one output vertex per fragment among its corners (in order of first corner), at the
  // mean of the positions those corners are carried to.
  std::vector<std::pair<std::int32_t, std::uint32_t>> seen;  // (fragment, output vertex) of this vertex
  std::vector<std::array<double, 4>> acc;                    // x, y, z sums and count, per entry of seen
  for (std::size_t v = 0; v < nv; ++v) {
    seen.clear();
    acc.clear();
    for (std::uint32_t k = first[v]; k < first[v + 1]; ++k) {
      const std::uint32_t c = corners[k];
      const std::size_t f = c / 3;
      const std::uint32_t a = S.automaton[f];
      const std::int32_t frag = out.face_values[f];
      std::size_t e = 0;
      while (e < seen.size() && seen[e].first != frag) ++e;
      if (e == seen.size()) {
        seen.push_back({frag, static_cast<std::uint32_t>(out.vertices.size() + e)});
        acc.push_back({0, 0, 0, 0});
      }
      const DVec3 p = rotate(state.q[a], S.offset[c]);
      acc[e][0] += state.x[a].x + p.x;
      acc[e][1] += state.x[a].y + p.y;
      acc[e][2] += state.x[a].z + p.z;
      acc[e][3] += 1;
      out.faces[f][c % 3] = seen[e].second;
    }
    for (const auto& s4 : acc)
      out.vertices.push_back({static_cast<float>(s4[0] / s4[3]), static_cast<float>(s4[1] / s4[3]),
                              static_cast<float>(s4[2] / s4[3])});
  }
  return out;
}

}  // namespace mca::analysis
