#include "analysis/surface.hpp"

#include <unordered_map>

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
  const std::size_t nf = S.faces();
  mesh::FloatMesh out;
  out.face_value_name = "fragment";
  out.faces.resize(nf);
  out.face_values.resize(nf);
  // (mesh vertex, fragment) -> output vertex; positions summed in double, then averaged.
  std::unordered_map<std::uint64_t, std::uint32_t> slot;
  slot.reserve(S.vertices + S.vertices / 4);
  std::vector<DVec3> sum;
  std::vector<std::uint32_t> uses;
  for (std::size_t f = 0; f < nf; ++f) {
    const std::uint32_t a = S.automaton[f];
    const std::int32_t frag = fragment[a];
    out.face_values[f] = frag;
    const DVec3 centre = state.x[a];
    for (int c = 0; c < 3; ++c) {
      const std::uint64_t key = std::uint64_t{S.corner[3 * f + c]} << 32 | static_cast<std::uint32_t>(frag);
      const auto [it, fresh] = slot.try_emplace(key, static_cast<std::uint32_t>(sum.size()));
      if (fresh) {
        sum.push_back({0, 0, 0});
        uses.push_back(0);
      }
      const DVec3 p = rotate(state.q[a], S.offset[3 * f + c]);
      DVec3& acc = sum[it->second];
      acc.x += centre.x + p.x;
      acc.y += centre.y + p.y;
      acc.z += centre.z + p.z;
      uses[it->second] += 1;
      out.faces[f][c] = it->second;
    }
  }
  out.vertices.resize(sum.size());
  for (std::size_t v = 0; v < sum.size(); ++v) {
    const double k = 1.0 / uses[v];
    out.vertices[v] = {static_cast<float>(sum[v].x * k), static_cast<float>(sum[v].y * k), static_cast<float>(sum[v].z * k)};
  }
  return out;
}

}  // namespace mca::analysis
