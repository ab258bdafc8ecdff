#include "render/camera.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/trigonometric.hpp>

#include "mca/error.hpp"

namespace mca::render {
namespace {

std::string shown(const glm::dvec3& v) { return fmt::format("[{:.6g}, {:.6g}, {:.6g}]", v.x, v.y, v.z); }

// A unit vector perpendicular to `up`, near `hint`.
glm::vec3 horizontal(glm::vec3 hint, glm::vec3 up) {
  glm::vec3 h = hint - glm::dot(hint, up) * up;
  if (glm::length(h) < 1e-4f) {
    h = glm::abs(up.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    h -= glm::dot(h, up) * up;
  }
  return glm::normalize(h);
}

}  // namespace

glm::mat4 Camera::view() const { return glm::lookAt(eye, target, up); }
glm::mat4 Camera::projection(float aspect) const { return glm::perspective(glm::radians(fov), aspect, near, far); }

Framing objects_box(const Model& model, const State& state) {
  Framing f;
  if (state.x.empty()) return f;
  glm::dvec3 lo(state.x[0].x, state.x[0].y, state.x[0].z), hi = lo;
  for (const DVec3& p : state.x) {
    lo = glm::min(lo, glm::dvec3(p.x, p.y, p.z));
    hi = glm::max(hi, glm::dvec3(p.x, p.y, p.z));
  }
  const glm::dvec3 c = 0.5 * (lo + hi);
  f.origin = {c.x, c.y, c.z};
  const double h = 0.5 * model.spacing;
  f.box_lo = glm::vec3(lo - c - h);
  f.box_hi = glm::vec3(hi - c + h);
  const std::size_t objects = model.object_names.size();
  std::vector<glm::dvec3> olo(objects, glm::dvec3(INFINITY)), ohi(objects, glm::dvec3(-INFINITY));
  for (std::size_t a = 0; a < state.x.size() && a < model.object.size(); ++a) {
    const auto o = static_cast<std::size_t>(model.object[a]);
    if (o >= objects) continue;
    const glm::dvec3 p(state.x[a].x, state.x[a].y, state.x[a].z);
    olo[o] = glm::min(olo[o], p);
    ohi[o] = glm::max(ohi[o], p);
  }
  for (std::size_t o = 0; o < objects; ++o)
    if (olo[o].x <= ohi[o].x) {
      f.object_box.push_back({glm::vec3(olo[o] - c - h), glm::vec3(ohi[o] - c + h)});
      f.object_name.push_back(model.object_names[o]);
    }
  return f;
}

Camera make_camera(const CameraDef& def, const Model& model, const Framing& fr, float aspect, const std::string& source) {
  Camera cam;
  const glm::dvec3 origin(fr.origin[0], fr.origin[1], fr.origin[2]);
  cam.up = glm::normalize(glm::vec3(model.up.x, model.up.y, model.up.z));
  cam.fov = static_cast<float>(def.fov);
  const glm::vec3 centre = 0.5f * (fr.box_lo + fr.box_hi);
  cam.target = def.target ? glm::vec3(glm::dvec3((*def.target)[0], (*def.target)[1], (*def.target)[2]) - origin) : centre;
  const std::array<glm::vec3, 8> corners = [&] {
    std::array<glm::vec3, 8> c;
    for (int k = 0; k < 8; ++k)
      c[k] = {k & 1 ? fr.box_hi.x : fr.box_lo.x, k & 2 ? fr.box_hi.y : fr.box_lo.y, k & 4 ? fr.box_hi.z : fr.box_lo.z};
    return c;
  }();
  const float radius = 0.5f * glm::length(fr.box_hi - fr.box_lo);
  const float tan_v = std::tan(glm::radians(cam.fov) / 2), tan_h = tan_v * aspect;
  // A projectile's centre at frame 0, in the drawing frame (relative to the framing's origin).
  const auto ball_centre = [&](const ProjectileParams& p) {
    return glm::vec3(glm::dvec3(p.position.x, p.position.y, p.position.z) - origin);
  };

  bool drawn_back = false;  // the automatic camera in a ball in every view, drawn back to frame it
  if (def.position) {
    cam.eye = glm::vec3(glm::dvec3((*def.position)[0], (*def.position)[1], (*def.position)[2]) - origin);
  } else {
    // Towards the side the projectiles come from, turned 35 degrees about the up axis (a 3/4 view of the
    // struck face), 25 degrees above the horizon.
    glm::vec3 front(0, -1, 0);
    if (!model.projectiles.empty()) {
      glm::vec3 mean(0);
      for (const auto& p : model.projectiles) mean += ball_centre(p);
      front = mean / static_cast<float>(model.projectiles.size()) - cam.target;
      // Balls on every side (one before the wall, one behind) leave no side: the first ball's (their mean's,
      // near the target, gave the x axis, side on to the wall).
      const glm::vec3 level = front - glm::dot(front, cam.up) * cam.up;
      if (glm::length(level) < 0.1f * radius) front = ball_centre(model.projectiles[0]) - cam.target;
    }
    front = horizontal(front, cam.up);
    const glm::vec3 side = glm::normalize(glm::cross(cam.up, front));
    // The eye looking from azimuth `az_deg` (about the up axis, from `front`) and elevation `el_deg`, as near
    // as the objects' box fits the picture with a margin; with `frame_balls`, the balls it would be in or
    // next to are framed too.
    const auto place = [&](float az_deg, float el_deg, bool frame_balls) {
      const float az = glm::radians(az_deg), el = glm::radians(el_deg);
      const glm::vec3 back = std::cos(el) * (std::cos(az) * front + std::sin(az) * side) + std::sin(el) * cam.up;
      const glm::vec3 f = -back, r = glm::normalize(glm::cross(f, cam.up)), u = glm::cross(r, f);
      constexpr float margin = 1.12f;
      float dist = 0;
      const auto frame = [&](const glm::vec3& c) {
        const glm::vec3 d = c - cam.target;
        const float x = glm::dot(d, r), y = glm::dot(d, u), z = glm::dot(d, f);
        dist = std::max({dist, margin * std::abs(x) / tan_h - z, margin * std::abs(y) / tan_v - z});
      };
      for (const glm::vec3& c : corners) frame(c);
      dist = std::max(dist, 1e-3f);
      std::vector<bool> framed(model.projectiles.size(), false);
      for (bool more = frame_balls; more;) {
        more = false;
        for (std::size_t k = 0; k < model.projectiles.size(); ++k) {
          const auto& p = model.projectiles[k];
          const glm::vec3 c = ball_centre(p);
          if (framed[k] || glm::length(cam.target + back * dist - c) >= 1.5f * p.radius) continue;
          framed[k] = more = true;
          for (int q = 0; q < 8; ++q)
            frame(c + p.radius * glm::vec3(q & 1 ? 1 : -1, q & 2 ? 1 : -1, q & 4 ? 1 : -1));
        }
      }
      return cam.target + back * dist;
    };
    // In a ball or at its surface (within a twentieth of the distance to the target): the ball is not drawn
    // from inside. (A ball near the camera that hides the objects is counted by `hidden`; a margin of a tenth
    // of the radius put every view of a cube under a ball of 2 m in it.)
    const auto by_a_ball = [&](const glm::vec3& eye) {
      const float margin = 0.05f * glm::length(eye - cam.target);
      return std::any_of(model.projectiles.begin(), model.projectiles.end(), [&](const ProjectileParams& p) {
        return glm::length(eye - ball_centre(p)) < p.radius + margin;
      });
    };
    // The objects' points a ball stands in front of, seen from `eye`: of each object's box, 27 (its corners,
    // the middles of its edges and faces, its centre: the corners alone passed a view of a face mostly hidden).
    constexpr int kPoints = 27;
    const auto hidden = [&](const glm::vec3& eye) {
      int n = 0;
      for (const auto& [lo, hi] : fr.object_box)
        for (int k = 0; k < kPoints; ++k) {
          const glm::vec3 w(static_cast<float>(k % 3), static_cast<float>(k / 3 % 3), static_cast<float>(k / 9));
          const glm::vec3 sight = lo + 0.5f * w * (hi - lo) - eye;
          const float length2 = glm::dot(sight, sight);
          for (const auto& p : model.projectiles) {
            const glm::vec3 c = ball_centre(p);
            const float t = length2 > 0 ? std::clamp(glm::dot(c - eye, sight) / length2, 0.0f, 1.0f) : 0.0f;
            if (glm::length(eye + t * sight - c) < p.radius) {
              ++n;
              break;
            }
          }
        }
      return n;
    };
    // The 3/4 view, unless the camera would stand in a ball, or balls stand before half or more of those
    // points (a ball of 3 m before the wall hid all of it; beside a cube of 0.2 m it held the camera, which
    // drew back to frame it until the cube was a speck; a ball touching the face hides less): then the first
    // of the other views (the other side, higher, from behind, side on, from above, then near the horizon,
    // under a ball above the objects) clear of the balls that hides none, else the one in no ball that hides
    // fewest; in a ball in every one, the 3/4 view framing that ball.
    constexpr std::array<std::array<float, 2>, 18> views = {
        {{35, 25}, {-35, 25}, {35, 50}, {-35, 50}, {145, 25}, {-145, 25}, {60, 40}, {-60, 40}, {90, 25},
         {-90, 25}, {180, 25}, {0, 75}, {35, 5}, {-35, 5}, {145, 5}, {-145, 5}, {90, 5}, {-90, 5}}};
    const int half = (kPoints * static_cast<int>(fr.object_box.size()) + 1) / 2;
    int fewest = std::numeric_limits<int>::max();
    for (std::size_t k = 0; k < views.size(); ++k) {
      const glm::vec3 eye = place(views[k][0], views[k][1], false);
      if (by_a_ball(eye)) continue;
      const int n = hidden(eye);
      if (n < fewest) {
        fewest = n;
        cam.eye = eye;
      }
      if (n == 0 || (k == 0 && n < half)) break;
    }
    drawn_back = fewest == std::numeric_limits<int>::max();
    if (drawn_back) cam.eye = place(views[0][0], views[0][1], true);
  }
  // Inside a ball at frame 0: the ball is not drawn from inside, and the view is of its inner side.
  if (def.position)
    for (const auto& p : model.projectiles) {
      const glm::dvec3 c(p.position.x, p.position.y, p.position.z), eye = glm::dvec3(cam.eye) + origin;
      if (glm::length(eye - c) < p.radius)
        throw Error(fmt::format("{}: [camera] position = {} is inside projectile '{}' (radius {:.3g} m at {}, frame "
                                "0): the ball would not be seen; move the camera outside it, or leave out position for "
                                "an automatic view",
                                source, shown(eye), p.name, p.radius, shown(c)));
    }
  // Inside an object's own box (not the box around all of them: a camera between two walls is fine).
  for (const auto& [lo, hi] : fr.object_box)
    if (glm::all(glm::greaterThan(cam.eye, lo)) && glm::all(glm::lessThan(cam.eye, hi)))
      throw Error(fmt::format("{}: [camera] position = {} is inside an object's bounding box {} .. {} (frame 0): the "
                              "view would be filled by the inside of the object; move the camera outside the box, "
                              "or leave out position for an automatic view",
                              source, shown(glm::dvec3(cam.eye) + origin), shown(glm::dvec3(lo) + origin),
                              shown(glm::dvec3(hi) + origin)));
  const float dist = glm::length(cam.target - cam.eye);
  if (!(dist > 1e-6f))
    throw Error(fmt::format("{}: [camera] position = target = {}: the camera needs a direction to look in; move the "
                            "position away from the target (or leave out position for an automatic view)",
                            source, shown(glm::dvec3(cam.eye) + origin)));
  // Who chose the view, for the messages below: a scene's [camera], or the automatic framing.
  const std::string camera_name =
      def.position || def.target ? "the [camera]" : "the automatic camera (the scene has no [camera] position or target)";
  const glm::vec3 f = (cam.target - cam.eye) / dist;
  const glm::vec3 world_up = cam.up;
  // A camera looking along the up axis: another up for lookAt.
  if (std::abs(glm::dot(f, cam.up)) > 0.999f) cam.up = horizontal(glm::vec3(0, 1, 0), cam.up);
  const glm::vec3 to_c = centre - cam.eye;
  const float dc = glm::length(to_c);
  // The angle a sphere of radius r about c spans from the eye (a full turn from inside it).
  const auto span = [&](const glm::vec3& c, float r) {
    const float d = glm::length(c - cam.eye);
    return d > r ? 2 * std::asin(r / d) : 6.2832f;
  };
  const float spread = 0.5f * span(centre, radius);
  // Sees none of the box: all its corners lie outside the same side of the view's pyramid (behind the
  // camera, or left, right, below or above the field of view).
  {
    const glm::mat4 V = cam.view();
    std::array<int, 5> outside{};  // behind, left, right, below, above
    for (const glm::vec3& c : corners) {
      const glm::vec4 v = V * glm::vec4(c, 1);
      const float depth = -v.z;
      outside[0] += depth <= 0;
      outside[1] += v.x < -depth * tan_h;
      outside[2] += v.x > depth * tan_h;
      outside[3] += v.y < -depth * tan_v;
      outside[4] += v.y > depth * tan_v;
    }
    const float angle = std::acos(std::clamp(glm::dot(f, to_c / dc), -1.0f, 1.0f));
    if (std::any_of(outside.begin(), outside.end(), [](int k) { return k == 8; }))
      throw Error(fmt::format("{}: {} at {} looking at {} sees none of the objects (their box {} .. {} lies "
                              "{:.0f} degrees off the view's axis; the field of view is fov = {:g} degrees); point "
                              "target at the objects, or leave out target to look at their centre",
                              source, camera_name, shown(glm::dvec3(cam.eye) + origin), shown(glm::dvec3(cam.target) + origin),
                              shown(glm::dvec3(fr.box_lo) + origin), shown(glm::dvec3(fr.box_hi) + origin),
                              glm::degrees(angle), def.fov));
  }
  // So far that the objects are a speck (a target far from them, the position left automatic, frames them
  // from a distance where they span a few pixels): under a twentieth of the field of view, as good as none.
  // The narrower field counts: a tall, narrow picture (16x512) frames the objects across its width, and
  // they span little of its height, which is no speck.
  // (The automatic camera's own choice never refuses a scene: where every view of the objects is in a ball,
  // it frames that ball from afar, and a speck is the picture it can give.)
  const float fov_narrow = std::min(glm::radians(cam.fov), 2 * std::atan(tan_h));
  if ((def.position || def.target) && 2 * spread < fov_narrow / 20)
    throw Error(fmt::format("{}: {} at {} looking at {} sees the objects only as a speck: their box {} .. {} "
                            "spans {:.2g} degrees of the view's {:.3g} (the narrower of its height and width) at {:.3g} "
                            "m; point target at the objects (or leave it out to look at their centre), or give a "
                            "position nearer to them",
                            source, camera_name, shown(glm::dvec3(cam.eye) + origin),
                            shown(glm::dvec3(cam.target) + origin), shown(glm::dvec3(fr.box_lo) + origin),
                            shown(glm::dvec3(fr.box_hi) + origin), glm::degrees(2 * spread),
                            glm::degrees(fov_narrow), dc));
  // The automatic camera's speck: the object it shows smallest under a twentieth of the field (two cubes of
  // 0.2 m 100 m apart were two dots, without a word; or every view was in a ball).
  if (!def.position && !def.target && !fr.object_box.empty()) {
    std::vector<float> spans;
    for (const auto& [lo, hi] : fr.object_box) spans.push_back(span(0.5f * (lo + hi), 0.5f * glm::length(hi - lo)));
    const auto smallest = static_cast<std::size_t>(std::min_element(spans.begin(), spans.end()) - spans.begin());
    if (spans[smallest] < fov_narrow / 20)
      cam.note = fmt::format(
          "the automatic camera at {} sees object '{}' as a speck ({:.2g} degrees of the view's {:.3g}: {}); give the "
          "scene a [camera] target (and position) to look at it",
          shown(glm::dvec3(cam.eye) + origin), fr.object_name[smallest], glm::degrees(spans[smallest]),
          glm::degrees(fov_narrow),
          drawn_back ? "every view of the objects is in a ball, and it is drawn back to frame the ball"
                     : fmt::format("the objects' box is {:.3g} m across", 2 * radius));
  }
  // Under the ground the view is of the ground's underside: refused.
  if (def.position && model.ground) {
    const glm::dvec3 eye = glm::dvec3(cam.eye) + origin;
    // (The world's up: a view along the up axis has another up of its own, and one from under the ground
    // looking straight up was taken as above it.)
    const double height = glm::dot(eye, glm::dvec3(world_up)) - model.ground_height;
    if (height < 0)
      throw Error(fmt::format("{}: [camera] position = {} is {:.3g} m below the ground (ground.height = {:g} along the "
                              "up direction): the view would be of the ground's underside; raise the position above "
                              "the ground",
                              source, shown(eye), -height, model.ground_height + model.ground_lowered));
  }
  // Depth range: from just short of the box (or of the target) to far behind it, the ground included.
  const float depth = std::max(dc, dist);
  cam.near = std::max(1e-3f, std::min(0.5f * (dc - radius), 0.05f * depth));
  // Nearer still where a ball is nearer (it was cut away by the near plane).
  for (const auto& p : model.projectiles) {
    const float gap = glm::length(ball_centre(p) - cam.eye) - p.radius;
    if (gap > 0) cam.near = std::max(1e-3f, std::min(cam.near, 0.5f * gap));
  }
  cam.far = 40.0f * (depth + radius);
  return cam;
}

}  // namespace mca::render
