#pragma once
// Semi-implicit (symplectic) Euler for translation and rotation (physics.md sec. 7), with Cundall's
// local damping: each force component is reduced by alpha |f| against the direction of motion.
#include "core/math.hpp"

namespace mca {

MCA_HD float local_damped(float f, float v, float alpha) {
  const float d = alpha * std::fabs(f);
  return v > 0.0f ? f - d : (v < 0.0f ? f + d : f);
}

MCA_HD Vec3 local_damped(Vec3 f, Vec3 v, float alpha) {
  return {local_damped(f.x, v.x, alpha), local_damped(f.y, v.y, alpha), local_damped(f.z, v.z, alpha)};
}

struct Body {
  DVec3 x;
  Vec3 v, w;
  Quat q;
};

// f and t come back as applied (after local damping).
MCA_HD void integrate_body(Body& b, Vec3& f, Vec3& t, float inv_m, float inv_j, float dt, float alpha) {
  if (alpha > 0.0f) {
    f = local_damped(f, b.v, alpha);
    t = local_damped(t, b.w, alpha);
  }
  b.v += f * (inv_m * dt);
  b.x += b.v * dt;
  b.w += t * (inv_j * dt);
  b.q = integrate_orientation(b.q, b.w, dt);
}

}  // namespace mca
