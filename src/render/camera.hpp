#pragma once
// The camera of the renderer: the scene's [camera] (position, target, fov; each optional) completed by an
// automatic framing of the objects at frame 0, fixed for the whole run so that a video does not jump.
#include <array>
#include <vector>
#include <string>

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "core/model.hpp"
#include "core/state.hpp"
#include "mca/scene.hpp"

namespace mca::render {

// Positions are relative to `origin` (Snapshot::origin): the frame-0 centre of the objects' box.
struct Camera {
  glm::vec3 eye{0, -5, 0}, target{0, 0, 0}, up{0, 0, 1};
  float fov = 40;        // vertical field of view [degrees]
  float near = 0.01f, far = 1000;
  // A word for the user about the view the automatic camera chose ("" where none): an object it shows as a
  // speck (objects far apart framed together).
  std::string note;
  glm::mat4 view() const;
  glm::mat4 projection(float aspect) const;
};

struct Framing {
  std::array<double, 3> origin{};     // world centre of the objects' box at frame 0
  glm::vec3 box_lo{0}, box_hi{0};     // the box, relative to origin
  std::vector<std::array<glm::vec3, 2>> object_box;  // per object: its own box (low, high), relative to origin
  std::vector<std::string> object_name;              // the name of each of object_box's objects
};

// The box of the automata centres (grown by half a spacing) in `state`.
Framing objects_box(const Model& model, const State& state);

// The camera for `def`: position and target given are used as they are (world coordinates); the target
// defaults to the box's centre, the position to a 3/4 view from the side the projectiles come from (the
// -y side without projectiles), 25 degrees above the horizon, far enough that the whole box fits the view
// of the given aspect. Throws mca::Error naming `source`, the key, the value and a fix when the camera is
// inside the box or sees none of it.
Camera make_camera(const CameraDef& def, const Model& model, const Framing& framing, float aspect,
                   const std::string& source);

}  // namespace mca::render
