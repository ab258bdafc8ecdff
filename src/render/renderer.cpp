#include "render/renderer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstring>

#include <epoxy/gl.h>
#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "core/text.hpp"
#include "mca/error.hpp"
#include "render/font.hpp"

namespace mca::render {
namespace {

// Lighting shared by the lit shaders: a directional key light from above and behind the camera, a
// hemisphere fill from the up axis.
constexpr const char* kShade = R"(
uniform vec3 u_light;
uniform vec3 u_up;
vec3 shade(vec3 base, vec3 n) {
  n = normalize(n);
  float key = max(dot(n, u_light), 0.0);
  float hemi = 0.5 + 0.5 * dot(n, u_up);
  return base * (0.22 + 0.28 * hemi + 0.62 * key);
}
)";

constexpr const char* kCubeVs = R"(#version 450 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 i_centre;
layout(location = 3) in vec4 i_quat;
layout(location = 4) in vec4 i_colour;
uniform mat4 u_view_proj;
uniform float u_size;
out vec3 v_normal;
out vec3 v_local;
out vec4 v_colour;
vec3 rotate(vec4 q, vec3 v) { vec3 t = 2.0 * cross(q.xyz, v); return v + q.w * t + cross(q.xyz, t); }
void main() {
  v_local = a_pos;
  v_normal = rotate(i_quat, a_normal);
  v_colour = i_colour;
  gl_Position = u_view_proj * vec4(i_centre + rotate(i_quat, a_pos * u_size), 1.0);
}
)";

constexpr const char* kCubeFs = R"(
in vec3 v_normal;
in vec3 v_local;
in vec4 v_colour;
out vec4 o_colour;
void main() {
  // Darken the rim of each face a little, so the lattice of cubes reads as cells.
  vec3 a = abs(v_local) * 2.0;
  float m = max(max(min(a.x, a.y), min(a.y, a.z)), min(a.x, a.z));
  float rim = smoothstep(0.80, 0.97, m);
  o_colour = vec4(shade(v_colour.rgb, v_normal) * (1.0 - 0.25 * rim), 1.0);
}
)";

constexpr const char* kSphereVs = R"(#version 450 core
layout(location = 0) in vec2 a_corner;
layout(location = 1) in vec4 i_sphere;
layout(location = 2) in vec4 i_colour;
uniform mat4 u_view;
uniform mat4 u_proj;
out vec3 v_pos;
flat out vec3 v_centre;
flat out float v_radius;
flat out vec4 v_colour;
void main() {
  vec3 c = (u_view * vec4(i_sphere.xyz, 1.0)).xyz;
  // A quad facing the eye, moved to the sphere's front and widened so it covers the sphere's outline.
  float r = i_sphere.w;
  float grow = 1.0 / max(0.3, sqrt(max(1.0 - r * r / dot(c, c), 0.0)));
  vec3 p = c + vec3(a_corner * r * grow, 0.0) + normalize(-c) * r;
  v_pos = p;
  v_centre = c;
  v_radius = r;
  v_colour = i_colour;
  gl_Position = u_proj * vec4(p, 1.0);
}
)";

constexpr const char* kSphereFs = R"(
in vec3 v_pos;
flat in vec3 v_centre;
flat in float v_radius;
flat in vec4 v_colour;
uniform mat4 u_proj;
uniform mat3 u_view_rot;
out vec4 o_colour;
void main() {
  // The eye ray through this fragment against the sphere (view space, eye at the origin).
  vec3 d = normalize(v_pos);
  float b = dot(d, v_centre);
  float h = b * b - dot(v_centre, v_centre) + v_radius * v_radius;
  if (h < 0.0) discard;
  vec3 hit = d * (b - sqrt(h));
  vec3 n = (hit - v_centre) / v_radius;
  vec4 clip = u_proj * vec4(hit, 1.0);
  gl_FragDepth = 0.5 * clip.z / clip.w + 0.5;
  // Lighting is in world space: n back through the view's rotation.
  vec3 c = shade(v_colour.rgb, transpose(u_view_rot) * n);
  // A highlight on the projectiles (and spheres) so they read as balls.
  vec3 world_n = normalize(transpose(u_view_rot) * n);
  vec3 eye_dir = normalize(transpose(u_view_rot) * -hit);
  float spec = pow(max(dot(reflect(-u_light, world_n), eye_dir), 0.0), 24.0);
  o_colour = vec4(c + 0.35 * spec, 1.0);
}
)";

constexpr const char* kFlatVs = R"(#version 450 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec4 a_colour;
uniform mat4 u_view_proj;
out vec3 v_world;
out vec4 v_colour;
void main() {
  v_world = a_pos;
  v_colour = a_colour;
  gl_Position = u_view_proj * vec4(a_pos, 1.0);
}
)";

// Triangles flat-shaded by the screen-space derivatives of their position (no normals needed); lines
// unlit.
constexpr const char* kFlatFs = R"(
in vec3 v_world;
in vec4 v_colour;
uniform int u_lit;
uniform vec3 u_eye;
out vec4 o_colour;
void main() {
  if (u_lit == 0) { o_colour = v_colour; return; }
  vec3 n = normalize(cross(dFdx(v_world), dFdy(v_world)));
  if (dot(n, u_eye - v_world) < 0.0) n = -n;
  o_colour = vec4(shade(v_colour.rgb, n), 1.0);
}
)";

constexpr const char* kGroundVs = R"(#version 450 core
layout(location = 0) in vec3 a_pos;
uniform mat4 u_view_proj;
out vec3 v_world;
void main() { v_world = a_pos; gl_Position = u_view_proj * vec4(a_pos, 1.0); }
)";

constexpr const char* kGroundFs = R"(
in vec3 v_world;
uniform vec3 u_eye;
uniform vec3 u_axis_a;
uniform vec3 u_axis_b;
uniform float u_tile;
uniform float u_fade;
uniform vec3 u_background;
out vec4 o_colour;
void main() {
  vec2 uv = vec2(dot(v_world, u_axis_a), dot(v_world, u_axis_b)) / u_tile;
  float checker = mod(floor(uv.x) + floor(uv.y), 2.0);
  // Thin lines at the tile edges, widened with distance (one pixel's worth) against aliasing.
  vec2 w = fwidth(uv);
  vec2 g = abs(fract(uv - 0.5) - 0.5) / max(w, vec2(1e-6));
  float line = 1.0 - min(min(g.x, g.y), 1.0);
  vec3 base = mix(vec3(0.36, 0.355, 0.34), vec3(0.41, 0.405, 0.39), checker);
  base = mix(base, vec3(0.28, 0.28, 0.27), 0.6 * line);
  vec3 c = shade(base, u_up);
  float fog = smoothstep(0.35 * u_fade, u_fade, length(v_world - u_eye));
  o_colour = vec4(mix(c, u_background, fog), 1.0);
}
)";

constexpr const char* kOverlayVs = R"(#version 450 core
layout(location = 0) in vec2 a_pos;
layout(location = 1) in vec4 a_colour;
uniform vec2 u_size;
out vec4 v_colour;
void main() {
  v_colour = a_colour;
  gl_Position = vec4(2.0 * a_pos.x / u_size.x - 1.0, 1.0 - 2.0 * a_pos.y / u_size.y, 0.0, 1.0);
}
)";

constexpr const char* kOverlayFs = R"(#version 450 core
in vec4 v_colour;
out vec4 o_colour;
void main() { o_colour = v_colour; }
)";

unsigned compile(GLenum type, const std::string& text, const char* what) {
  const unsigned s = glCreateShader(type);
  const char* src = text.c_str();
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  int ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    std::string log(4096, '\0');
    glGetShaderInfoLog(s, static_cast<int>(log.size()), nullptr, log.data());
    throw Error(fmt::format("the renderer's {} shader does not compile on this OpenGL ({}): {}", what,
                            Renderer::gl_description(), log.c_str()));
  }
  return s;
}

unsigned program(const char* vs, const std::string& fs, const char* what, bool lit = true) {
  const std::string fs_text = lit ? std::string("#version 450 core\n") + kShade + fs : fs;
  const unsigned p = glCreateProgram();
  const unsigned v = compile(GL_VERTEX_SHADER, vs, what), f = compile(GL_FRAGMENT_SHADER, fs_text, what);
  glAttachShader(p, v);
  glAttachShader(p, f);
  glLinkProgram(p);
  glDeleteShader(v);
  glDeleteShader(f);
  int ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    std::string log(4096, '\0');
    glGetProgramInfoLog(p, static_cast<int>(log.size()), nullptr, log.data());
    throw Error(fmt::format("the renderer's {} shaders do not link: {}", what, log.c_str()));
  }
  return p;
}

int loc(unsigned prog, const char* name) { return glGetUniformLocation(prog, name); }

// A unit cube centred at the origin: 36 vertices of position and normal.
std::vector<float> cube_vertices() {
  std::vector<float> v;
  for (int axis = 0; axis < 3; ++axis)
    for (int sign = -1; sign <= 1; sign += 2) {
      glm::vec3 n(0);
      n[axis] = static_cast<float>(sign);
      const glm::vec3 u = axis == 0 ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
      glm::vec3 w = glm::cross(n, u);
      const glm::vec3 c = 0.5f * n;
      const glm::vec3 p[4] = {c - 0.5f * u - 0.5f * w, c + 0.5f * u - 0.5f * w, c + 0.5f * u + 0.5f * w,
                              c - 0.5f * u + 0.5f * w};
      for (int k : {0, 1, 2, 0, 2, 3}) {
        v.insert(v.end(), {p[k].x, p[k].y, p[k].z, n.x, n.y, n.z});
      }
    }
  return v;
}

struct Rect {
  float x0, y0, x1, y1;
  Rgba colour;
};

// Overlay rectangles in pixels (y down), two triangles each.
struct OverlayBuilder {
  std::vector<float> data;  // x, y, then the colour as 4 bytes in a float's place
  void rect(float x0, float y0, float x1, float y1, Rgba c) {
    float packed;
    static_assert(sizeof(packed) == sizeof(c));
    std::memcpy(&packed, c.data(), sizeof(c));
    const float xy[6][2] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y0}, {x1, y1}, {x0, y1}};
    for (const auto& p : xy) data.insert(data.end(), {p[0], p[1], packed});
  }
  // Text with a one-pixel dark shadow; returns the width in pixels.
  float text(float x, float y, std::string_view s, int scale, Rgba c = {240, 240, 240, 255}) {
    for (int pass = 0; pass < 2; ++pass) {
      const float off = pass == 0 ? static_cast<float>(scale) * 0.5f + 0.5f : 0.0f;
      const Rgba col = pass == 0 ? Rgba{0, 0, 0, 200} : c;
      float cx = x + off;
      for (char ch : s) {
        const std::uint8_t* g = glyph(ch);
        for (int r = 0; r < kGlyphRows; ++r)
          for (int b = 0; b < kGlyphWidth; ++b)
            if (g[r] & (1 << (kGlyphWidth - 1 - b)))
              rect(cx + b * scale, y + off + r * scale, cx + (b + 1) * scale, y + off + (r + 1) * scale, col);
        cx += kGlyphAdvance * scale;
      }
    }
    return static_cast<float>(text_width(s) * scale);
  }
};

std::string short_number(double v) {
  if (v == 0) return "0";
  const double a = std::abs(v);
  if (a >= 1e4 || a < 1e-2) return fmt::format("{:.2g}", v);
  if (a >= 100) return fmt::format("{:.0f}", v);
  if (a >= 10) return fmt::format("{:.1f}", v);
  return fmt::format("{:.2f}", v);
}

}  // namespace

constexpr float kBackground[3] = {34 / 255.0f, 37 / 255.0f, 43 / 255.0f};

SharedBuffers::~SharedBuffers() {
  for (int w = 0; w < 2; ++w) {
    shared_[w].reset();  // released before the buffer goes
    if (name_[w]) glDeleteBuffers(1, &name_[w]);
  }
}

std::size_t SharedBuffers::reserve(Which w, std::size_t bytes) {
  if (size_[w] >= bytes) return size_[w];
  const std::size_t size = std::max(bytes, size_[w] + size_[w] / 2);
  shared_[w].reset();
  if (name_[w]) glDeleteBuffers(1, &name_[w]);
  while (glGetError() != GL_NO_ERROR) {
  }  // earlier errors are not this buffer's
  glCreateBuffers(1, &name_[w]);
  glNamedBufferStorage(name_[w], static_cast<GLsizeiptr>(size), nullptr, GL_MAP_WRITE_BIT);
  if (const GLenum e = glGetError(); e != GL_NO_ERROR)
    throw Error(fmt::format("OpenGL could not make a buffer of {} bytes for the draw list (error 0x{:x})", size, e));
  size_[w] = size;
  return size;
}

void* SharedBuffers::map(Which w, std::size_t bytes) {
  void* p = glMapNamedBufferRange(name_[w], 0, static_cast<GLsizeiptr>(bytes), GL_MAP_WRITE_BIT | GL_MAP_INVALIDATE_BUFFER_BIT);
  if (!p) throw Error(fmt::format("OpenGL could not map the draw list's buffer of {} bytes (error 0x{:x})", bytes, glGetError()));
  return p;
}

void SharedBuffers::unmap(Which w) { glUnmapNamedBuffer(name_[w]); }

struct Renderer::Impl {
  unsigned cube_prog, sphere_prog, flat_prog, ground_prog, overlay_prog;
  unsigned cube_vao, cube_vbo, inst_vbo;
  unsigned sphere_vao, quad_vbo, sphere_vbo;
  unsigned flat_vao, flat_vbo;
  unsigned ground_vao, ground_vbo;
  unsigned overlay_vao, overlay_vbo;
  SharedBuffers shared;
};

namespace {
// The cube VAO's per-instance attributes (Instance records) from buffer vbo (the VAO bound).
void instance_attributes(unsigned vbo) {
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, sizeof(Instance), reinterpret_cast<void*>(offsetof(Instance, x)));
  glVertexAttribPointer(3, 4, GL_FLOAT, GL_FALSE, sizeof(Instance), reinterpret_cast<void*>(offsetof(Instance, qx)));
  glVertexAttribPointer(4, 4, GL_UNSIGNED_BYTE, GL_TRUE, sizeof(Instance), reinterpret_cast<void*>(offsetof(Instance, colour)));
}
// The flat VAO's per-vertex attributes (SurfaceVertex records) from buffer vbo (the VAO bound).
void vertex_attributes(unsigned vbo) {
  glBindBuffer(GL_ARRAY_BUFFER, vbo);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(SurfaceVertex), nullptr);
  glVertexAttribPointer(1, 4, GL_UNSIGNED_BYTE, GL_TRUE, sizeof(SurfaceVertex),
                        reinterpret_cast<void*>(offsetof(SurfaceVertex, colour)));
}
}  // namespace

DrawTarget& Renderer::draw_target() { return impl_->shared; }

std::string Renderer::gl_description() {
  const auto str = [](GLenum e) {
    const auto* s = glGetString(e);
    return s ? std::string(reinterpret_cast<const char*>(s)) : std::string("?");
  };
  return fmt::format("OpenGL {} on {}", str(GL_VERSION), str(GL_RENDERER));
}

Renderer::Renderer() : impl_(new Impl) {
  if (epoxy_gl_version() < 45) {
    const std::string d = gl_description();
    delete impl_;
    throw Error(fmt::format("the renderer needs OpenGL 4.5 core; this context gives {} (Mesa's llvmpipe gives 4.5: "
                            "install libgl1-mesa-dri, scripts/setup.sh)",
                            d));
  }
  Impl& I = *impl_;
  I.cube_prog = program(kCubeVs, kCubeFs, "cube");
  I.sphere_prog = program(kSphereVs, kSphereFs, "sphere");
  I.flat_prog = program(kFlatVs, kFlatFs, "surface");
  I.ground_prog = program(kGroundVs, kGroundFs, "ground");
  I.overlay_prog = program(kOverlayVs, kOverlayFs, "overlay", false);

  // Cubes: a shared cube and one instance record (Instance) per automaton.
  glGenVertexArrays(1, &I.cube_vao);
  glBindVertexArray(I.cube_vao);
  const std::vector<float> cube = cube_vertices();
  glGenBuffers(1, &I.cube_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, I.cube_vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(cube.size() * sizeof(float)), cube.data(), GL_STATIC_DRAW);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), reinterpret_cast<void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(0);
  glEnableVertexAttribArray(1);
  glGenBuffers(1, &I.inst_vbo);
  instance_attributes(I.inst_vbo);
  for (int a = 2; a <= 4; ++a) {
    glEnableVertexAttribArray(a);
    glVertexAttribDivisor(a, 1);
  }

  // Spheres: a quad and one (centre, radius, colour) per sphere.
  glGenVertexArrays(1, &I.sphere_vao);
  glBindVertexArray(I.sphere_vao);
  const float quad[12] = {-1, -1, 1, -1, 1, 1, -1, -1, 1, 1, -1, 1};
  glGenBuffers(1, &I.quad_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, I.quad_vbo);
  glBufferData(GL_ARRAY_BUFFER, sizeof(quad), quad, GL_STATIC_DRAW);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 0, nullptr);
  glEnableVertexAttribArray(0);
  glGenBuffers(1, &I.sphere_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, I.sphere_vbo);
  glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, 5 * sizeof(float), nullptr);
  glVertexAttribPointer(2, 4, GL_UNSIGNED_BYTE, GL_TRUE, 5 * sizeof(float), reinterpret_cast<void*>(4 * sizeof(float)));
  for (int a = 1; a <= 2; ++a) {
    glEnableVertexAttribArray(a);
    glVertexAttribDivisor(a, 1);
  }

  // Triangles and lines: position and colour per vertex (SurfaceVertex).
  glGenVertexArrays(1, &I.flat_vao);
  glBindVertexArray(I.flat_vao);
  glGenBuffers(1, &I.flat_vbo);
  vertex_attributes(I.flat_vbo);
  glEnableVertexAttribArray(0);
  glEnableVertexAttribArray(1);

  glGenVertexArrays(1, &I.ground_vao);
  glBindVertexArray(I.ground_vao);
  glGenBuffers(1, &I.ground_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, I.ground_vbo);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  glEnableVertexAttribArray(0);

  glGenVertexArrays(1, &I.overlay_vao);
  glBindVertexArray(I.overlay_vao);
  glGenBuffers(1, &I.overlay_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, I.overlay_vbo);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  glVertexAttribPointer(1, 4, GL_UNSIGNED_BYTE, GL_TRUE, 3 * sizeof(float), reinterpret_cast<void*>(2 * sizeof(float)));
  glEnableVertexAttribArray(0);
  glEnableVertexAttribArray(1);
  glBindVertexArray(0);
}

Renderer::~Renderer() {
  Impl& I = *impl_;
  for (unsigned p : {I.cube_prog, I.sphere_prog, I.flat_prog, I.ground_prog, I.overlay_prog}) glDeleteProgram(p);
  const unsigned buffers[] = {I.cube_vbo, I.inst_vbo, I.quad_vbo, I.sphere_vbo, I.flat_vbo, I.ground_vbo, I.overlay_vbo};
  glDeleteBuffers(7, buffers);
  const unsigned arrays[] = {I.cube_vao, I.sphere_vao, I.flat_vao, I.ground_vao, I.overlay_vao};
  glDeleteVertexArrays(5, arrays);
  delete impl_;
}

void Renderer::draw(const Snapshot& s, DrawMode mode, const Camera& cam, int width, int height, const Overlay& overlay) {
  Impl& I = *impl_;
  glViewport(0, 0, width, height);
  glClearColor(kBackground[0], kBackground[1], kBackground[2], 1);
  glClearDepth(1);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);

  const float aspect = static_cast<float>(width) / static_cast<float>(std::max(height, 1));
  const glm::mat4 view = cam.view(), proj = cam.projection(aspect), vp = proj * view;
  const glm::vec3 up = glm::normalize(glm::vec3(s.up[0], s.up[1], s.up[2]));
  // The key light: from above, over the camera's left shoulder.
  const glm::vec3 fwd = glm::normalize(cam.target - cam.eye);
  // (A view along the up axis has no side from it: the camera's own up, which make_camera turns off the axis
  // for such a view, gives one; the light's right was NaN and the picture unlit.)
  glm::vec3 side = glm::cross(fwd, up);
  if (glm::length(side) < 1e-3f) side = glm::cross(fwd, cam.up);
  if (glm::length(side) < 1e-3f) side = glm::cross(fwd, std::abs(fwd.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0));
  const glm::vec3 right = glm::normalize(side);
  const glm::vec3 light = glm::normalize(-0.8f * fwd - 0.4f * right + 0.8f * up);
  auto common = [&](unsigned prog) {
    glUseProgram(prog);
    glUniform3fv(loc(prog, "u_light"), 1, glm::value_ptr(light));
    glUniform3fv(loc(prog, "u_up"), 1, glm::value_ptr(up));
    glUniformMatrix4fv(loc(prog, "u_view_proj"), 1, GL_FALSE, glm::value_ptr(vp));
  };

  // Ground: a square around the point under the target, large enough to reach the horizon's fog.
  if (s.ground) {
    const float reach = 12.0f * glm::length(cam.target - cam.eye) + 10.0f * s.cube_size;
    const glm::vec3 a = glm::normalize(glm::abs(up.x) < 0.9f ? glm::cross(up, glm::vec3(1, 0, 0)) : glm::cross(up, glm::vec3(0, 1, 0)));
    const glm::vec3 b = glm::cross(up, a);
    const glm::vec3 c = cam.target - glm::dot(cam.target, up) * up + s.ground_height * up;
    const glm::vec3 q[6] = {c - reach * a - reach * b, c + reach * a - reach * b, c + reach * a + reach * b,
                            c - reach * a - reach * b, c + reach * a + reach * b, c - reach * a + reach * b};
    common(I.ground_prog);
    // Tiles of a round size near a tenth of the viewing distance.
    const float tile = std::pow(10.0f, std::round(std::log10(0.15f * glm::length(cam.target - cam.eye))));
    glUniform3fv(loc(I.ground_prog, "u_eye"), 1, glm::value_ptr(cam.eye));
    glUniform3fv(loc(I.ground_prog, "u_axis_a"), 1, glm::value_ptr(a));
    glUniform3fv(loc(I.ground_prog, "u_axis_b"), 1, glm::value_ptr(b));
    glUniform1f(loc(I.ground_prog, "u_tile"), tile);
    glUniform1f(loc(I.ground_prog, "u_fade"), 6.0f * glm::length(cam.target - cam.eye));
    glUniform3fv(loc(I.ground_prog, "u_background"), 1, kBackground);
    glBindVertexArray(I.ground_vao);
    glBindBuffer(GL_ARRAY_BUFFER, I.ground_vbo);
    glBufferData(GL_ARRAY_BUFFER, sizeof(q), q, GL_STREAM_DRAW);
    // Behind everything standing on it: a small offset keeps faces resting on the plane in front.
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1, 4);
    glDrawArrays(GL_TRIANGLES, 0, 6);
    glDisable(GL_POLYGON_OFFSET_FILL);
  }

  auto draw_spheres = [&](const std::vector<float>& data) {
    if (data.empty()) return;
    glUseProgram(I.sphere_prog);
    glUniform3fv(loc(I.sphere_prog, "u_light"), 1, glm::value_ptr(light));
    glUniform3fv(loc(I.sphere_prog, "u_up"), 1, glm::value_ptr(up));
    glUniformMatrix4fv(loc(I.sphere_prog, "u_view"), 1, GL_FALSE, glm::value_ptr(view));
    glUniformMatrix4fv(loc(I.sphere_prog, "u_proj"), 1, GL_FALSE, glm::value_ptr(proj));
    const glm::mat3 rot(view);
    glUniformMatrix3fv(loc(I.sphere_prog, "u_view_rot"), 1, GL_FALSE, glm::value_ptr(rot));
    glBindVertexArray(I.sphere_vao);
    glBindBuffer(GL_ARRAY_BUFFER, I.sphere_vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(data.size() * sizeof(float)), data.data(), GL_STREAM_DRAW);
    glDrawArraysInstanced(GL_TRIANGLES, 0, 6, static_cast<int>(data.size() / 5));
  };
  auto sphere_record = [](std::vector<float>& out, float x, float y, float z, float r, Rgba c) {
    float packed;
    std::memcpy(&packed, c.data(), sizeof(c));
    out.insert(out.end(), {x, y, z, r, packed});
  };

  if (s.shared_automata) {  // written into the shared buffer by the backend
    common(I.cube_prog);
    glUniform1f(loc(I.cube_prog, "u_size"), s.cube_size);
    glBindVertexArray(I.cube_vao);
    instance_attributes(s.shared_automata_buffer);
    glDrawArraysInstanced(GL_TRIANGLES, 0, 36, static_cast<int>(s.shared_automata));
    instance_attributes(I.inst_vbo);
  } else if (!s.automata.empty()) {
    if (mode == DrawMode::spheres) {
      std::vector<float> data;
      data.reserve(5 * s.automata.size());
      for (std::size_t k = 0; k < s.automata.size(); ++k) {
        const Instance& a = s.automata[k];
        sphere_record(data, a.x, a.y, a.z, s.radius[k], a.colour);
      }
      draw_spheres(data);
    } else {
      common(I.cube_prog);
      glUniform1f(loc(I.cube_prog, "u_size"), s.cube_size);
      glBindVertexArray(I.cube_vao);
      glBindBuffer(GL_ARRAY_BUFFER, I.inst_vbo);
      glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(s.automata.size() * sizeof(Instance)), s.automata.data(),
                   GL_STREAM_DRAW);
      glDrawArraysInstanced(GL_TRIANGLES, 0, 36, static_cast<int>(s.automata.size()));
    }
  }
  for (const auto* verts : {&s.surface, &s.links}) {
    const bool lines = verts == &s.links;
    const bool shared = !lines && s.shared_corners;  // written into the shared buffer by the backend
    if (verts->empty() && !shared) continue;
    common(I.flat_prog);
    glUniform1i(loc(I.flat_prog, "u_lit"), lines ? 0 : 1);
    glUniform3fv(loc(I.flat_prog, "u_eye"), 1, glm::value_ptr(cam.eye));
    glBindVertexArray(I.flat_vao);
    if (shared) {
      vertex_attributes(s.shared_surface_buffer);
      glDrawArrays(GL_TRIANGLES, 0, static_cast<int>(s.shared_corners));
      vertex_attributes(I.flat_vbo);
      continue;
    }
    glBindBuffer(GL_ARRAY_BUFFER, I.flat_vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(verts->size() * sizeof(SurfaceVertex)), verts->data(),
                 GL_STREAM_DRAW);
    glDrawArrays(lines ? GL_LINES : GL_TRIANGLES, 0, static_cast<int>(verts->size()));
  }
  // The projectiles: red balls, as the paper's.
  std::vector<float> balls;
  for (const auto& b : s.projectiles) sphere_record(balls, b.x, b.y, b.z, b.radius, Rgba{205, 30, 30, 255});
  draw_spheres(balls);

  // Overlay.
  OverlayBuilder o;
  // (By the narrower side of a 16:9 picture: a tall narrow one, 100x4000, took the scale of its height and
  // showed a glyph of each line.)
  const int scale = std::max(1, static_cast<int>(std::lround(std::min(height / 360.0, width / 640.0))));
  const float line_h = (kGlyphHeight + 4) * scale;
  const float margin = 8.0f * scale;
  float text_end = 0;  // where the lines at the top end
  if (overlay.counters || !overlay.lines.empty()) {
    float y = margin;
    std::vector<std::string> lines;
    if (overlay.counters) {
      lines.push_back("t = " + text::sim_time(s.time, overlay.time_resolution));
      lines.push_back(fmt::format("broken links {}   fragments {}", s.broken_links, s.fragments));
    }
    for (const std::string& l : overlay.lines) lines.push_back(one_glyph_per_character(l));
    // A line wider than the window goes on over as many as it takes, broken at spaces (a long message ran
    // off a 640-pixel window, and a small window cut "fragments 327" to read 32); the lines stop at half
    // the picture's height, the first one drawn whatever it takes (a viewer of 120x60 was text all over).
    const auto fits = static_cast<std::size_t>(
        std::max(8.0f, (static_cast<float>(width) - 2 * margin) / static_cast<float>(kGlyphAdvance * scale)));
    const float bottom = 0.5f * static_cast<float>(height);
    for (const std::string& l : lines)
      for (const std::string_view part : wrap_text(l, fits)) {
        if (y != margin && y + line_h > bottom) break;
        o.text(margin, y, part, scale);
        y += line_h;
      }
    text_end = y;
  }
  const Legend& L = s.legend;
  const bool bar = L.continuous && L.ramp;
  const float bar_h = 8.0f * scale;
  // The swatches in lines that fit the picture's width (twelve materials with long names ran off its edge); a
  // label wider than the picture goes on over the lines below it, under its start, broken at spaces (cut at
  // the edge, five read "MATERIAL_NUMBE"). Each item: its swatch (or none, for a label's continuation) and its text.
  const float box_w = static_cast<float>((kGlyphHeight + 4) * scale), gap = 12.0f * scale;
  struct Item {
    const Rgba* colour;
    std::string text;
  };
  std::vector<std::vector<Item>> legend_lines;
  // A label's line that ends where more of it is left out: "..." within the room.
  const auto cut_short = [](std::string& t, std::size_t room) {
    if (t.size() + 3 > room) t.resize(room > 3 ? room - 3 : 0);
    t += "...";
  };
  if (!bar) {
    const float right = static_cast<float>(width) - margin;
    const auto room = static_cast<std::size_t>(
        std::max(1.0f, (right - margin - box_w) / static_cast<float>(kGlyphAdvance * scale)));
    float x = right;  // (a new line at the first swatch)
    for (const auto& [name, colour] : L.swatches) {
      const std::string label = one_glyph_per_character(name);
      const float w = box_w + static_cast<float>(text_width(label) * scale);
      if (legend_lines.empty() || x + w > right) {
        legend_lines.emplace_back();
        x = margin;
      }
      if (label.size() <= room) {
        legend_lines.back().push_back({&colour, label});
        x += w + gap;
        continue;
      }
      // (Broken at spaces: cut at the width, "piggy" read "pi" over "ggy"; two lines at most, the second
      // ending in "..." where more is left: a name of 159 characters covered a picture of 320x180.)
      constexpr std::size_t kLabelLines = 2;
      const auto parts = wrap_text(label, room);
      for (std::size_t k = 0; k < std::min(parts.size(), kLabelLines); ++k) {
        std::string part(parts[k]);
        if (k + 1 == kLabelLines && parts.size() > kLabelLines) cut_short(part, room);
        if (k == 0)
          legend_lines.back().push_back({&colour, std::move(part)});
        else
          legend_lines.push_back({{nullptr, std::move(part)}});
      }
      x = right;  // (the next swatch on a line of its own)
    }
    if (legend_lines.empty()) legend_lines.emplace_back();
    // At most a third of the picture's height with its title (two lines at least): the lines beyond give way
    // to one that counts the swatches left out (many long names filled the picture, over the objects). A
    // label's continuation goes with its first line, but for the first swatch's, which is cut short (at
    // 160x90 the legend named none).
    const auto fit = static_cast<std::size_t>(std::max(2.0f, (static_cast<float>(height) / 3 - margin) / line_h - 1));
    if (legend_lines.size() > fit) {
      std::size_t cut = fit - 1;
      while (cut > 1 && legend_lines[cut].front().colour == nullptr) --cut;
      if (legend_lines[cut].front().colour == nullptr) cut_short(legend_lines[0].back().text, room);
      std::size_t left_out = 0;
      for (std::size_t r = cut; r < legend_lines.size(); ++r)
        for (const Item& item : legend_lines[r]) left_out += item.colour != nullptr;
      legend_lines.resize(cut);
      legend_lines.push_back({{nullptr, fmt::format("and {} more", left_out)}});
    }
  }
  const float legend_h = bar ? 2 * line_h + bar_h + 3.0f * scale : static_cast<float>(legend_lines.size() + 1) * line_h;
  // The legend only where it fits below the lines at the top (in a small window they would overlap).
  if (overlay.legend && static_cast<float>(height) - margin - legend_h >= text_end) {
    float y = static_cast<float>(height) - margin;
    // A translucent panel of the background's colour behind it: its text stays readable over the objects,
    // which show through.
    const float bar_w = 160.0f * scale;
    float legend_w = static_cast<float>(text_width(L.title) * scale);
    if (bar) legend_w = std::max(legend_w, bar_w);
    for (const auto& line : legend_lines) {
      float w = 0;
      for (const Item& item : line) w += (w > 0 ? gap : 0.0f) + box_w + static_cast<float>(text_width(item.text) * scale);
      legend_w = std::max(legend_w, w);
    }
    const float pad = 4.0f * scale;
    o.rect(margin - pad, y - legend_h - pad, margin + legend_w + pad, y + pad, Rgba{34, 37, 43, 170});
    if (bar) {
      y -= line_h;
      const std::string lo = short_number(L.min), hi = short_number(L.max) + " " + L.unit;
      o.text(margin, y, lo, scale);
      o.text(margin + bar_w - text_width(hi) * scale, y, hi, scale);
      y -= bar_h + 3.0f * scale;
      constexpr int steps = 64;
      for (int k = 0; k < steps; ++k) {
        const float x0 = margin + bar_w * k / steps, x1 = margin + bar_w * (k + 1) / steps;
        o.rect(x0, y, x1 + 0.5f, y + bar_h, L.ramp((k + 0.5f) / steps));
      }
      y -= line_h;
      o.text(margin, y, L.title, scale);
    } else {
      // The last line lowest.
      for (std::size_t r = legend_lines.size(); r-- > 0;) {
        float x = margin;
        y -= line_h;
        for (const Item& item : legend_lines[r]) {
          if (item.colour) o.rect(x, y - scale, x + kGlyphHeight * scale, y + (kGlyphHeight - 1) * scale, *item.colour);
          x += box_w;
          x += o.text(x, y, item.text, scale) + gap;
        }
      }
      y -= line_h;
      o.text(margin, y, L.title, scale);
    }
  }
  if (!o.data.empty()) {
    glDisable(GL_DEPTH_TEST);
    glEnable(GL_BLEND);
    glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(I.overlay_prog);
    glUniform2f(loc(I.overlay_prog, "u_size"), static_cast<float>(width), static_cast<float>(height));
    glBindVertexArray(I.overlay_vao);
    glBindBuffer(GL_ARRAY_BUFFER, I.overlay_vbo);
    glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(o.data.size() * sizeof(float)), o.data.data(), GL_STREAM_DRAW);
    glDrawArrays(GL_TRIANGLES, 0, static_cast<int>(o.data.size() / 3));
    glDisable(GL_BLEND);
    glEnable(GL_DEPTH_TEST);
  }
  glBindVertexArray(0);
}

OffscreenTarget::OffscreenTarget(int width, int height) : width_(width), height_(height) {
  glGenFramebuffers(1, &fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glGenRenderbuffers(1, &colour_);
  glBindRenderbuffer(GL_RENDERBUFFER, colour_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour_);
  glGenRenderbuffers(1, &depth_);
  glBindRenderbuffer(GL_RENDERBUFFER, depth_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_);
  const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE)
    throw Error(fmt::format("cannot make an offscreen image of {}x{} pixels (framebuffer status 0x{:x}); give a "
                            "smaller --render-size",
                            width, height, status));
}

OffscreenTarget::~OffscreenTarget() {
  glDeleteFramebuffers(1, &fbo_);
  glDeleteRenderbuffers(1, &colour_);
  glDeleteRenderbuffers(1, &depth_);
}

void OffscreenTarget::bind() const { glBindFramebuffer(GL_FRAMEBUFFER, fbo_); }

void read_pixels(int width, int height, std::vector<std::uint8_t>& out) {
  const std::size_t row = 4 * static_cast<std::size_t>(width);
  out.resize(row * static_cast<std::size_t>(height));
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, out.data());
  std::vector<std::uint8_t> tmp(row);
  for (int y = 0; y < height / 2; ++y) {
    auto* a = out.data() + row * static_cast<std::size_t>(y);
    auto* b = out.data() + row * static_cast<std::size_t>(height - 1 - y);
    std::memcpy(tmp.data(), a, row);
    std::memcpy(a, b, row);
    std::memcpy(b, tmp.data(), row);
  }
}

void OffscreenTarget::read_rgba(std::vector<std::uint8_t>& out) const {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  read_pixels(width_, height_, out);
}

}  // namespace mca::render
