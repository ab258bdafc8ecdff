#include "render/snapshot.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "analysis/surface.hpp"

namespace mca::render {
namespace {

constexpr std::array<const char*, 6> kColourNames = {"fragment", "damage", "class", "group", "stress", "speed"};
constexpr std::array<const char*, 4> kDrawNames = {"cubes", "spheres", "surface", "links"};

// What a snapshot takes from the model: the frame, the ground, the sizes.
Snapshot snapshot_frame(const Model& model, const std::array<double, 3>& origin) {
  Snapshot s;
  s.origin = origin;
  s.cube_size = model.spacing;
  s.automata_total = model.size();
  s.up = {model.up.x, model.up.y, model.up.z};
  s.ground = model.ground;
  const double up_origin = origin[0] * model.up.x + origin[1] * model.up.y + origin[2] * model.up.z;
  s.ground_height = static_cast<float>(model.ground_height - up_origin);
  return s;
}

// The projectiles at their world positions.
void add_projectiles(Snapshot& s, const Model& model, const std::vector<DVec3>& position) {
  for (std::size_t p = 0; p < position.size(); ++p) {
    const DVec3& c = position[p];
    const float radius = p < model.projectiles.size() ? model.projectiles[p].radius : 0.0f;
    s.projectiles.push_back({local(c.x, s.origin[0]), local(c.y, s.origin[1]), local(c.z, s.origin[2]), radius});
  }
}

}  // namespace

const char* name(ColourMode m) { return kColourNames[static_cast<std::size_t>(m)]; }
const char* name(DrawMode m) { return kDrawNames[static_cast<std::size_t>(m)]; }

std::optional<ColourMode> parse_colour_mode(const std::string& text) {
  for (std::size_t k = 0; k < kColourNames.size(); ++k)
    if (text == kColourNames[k]) return static_cast<ColourMode>(k);
  return std::nullopt;
}
std::optional<DrawMode> parse_draw_mode(const std::string& text) {
  for (std::size_t k = 0; k < kDrawNames.size(); ++k)
    if (text == kDrawNames[k]) return static_cast<DrawMode>(k);
  return std::nullopt;
}
std::string colour_mode_names() {
  std::string s;
  for (const char* n : kColourNames) s += (s.empty() ? "" : ", ") + std::string(n);
  return s;
}
std::string draw_mode_names() {
  std::string s;
  for (const char* n : kDrawNames) s += (s.empty() ? "" : ", ") + std::string(n);
  return s;
}

std::vector<Rgba> fragment_colours(const Model& model, const analysis::Fragments& fragments) {
  const std::size_t n = model.size();
  // Per fragment: its smallest automaton index and its automata; per object: its automata.
  std::vector<std::uint32_t> first(static_cast<std::size_t>(fragments.count), UINT32_MAX);
  std::vector<std::size_t> size(static_cast<std::size_t>(fragments.count), 0);
  const std::vector<std::uint32_t> whole = object_sizes(model);
  for (std::size_t a = 0; a < n; ++a) {
    const auto f = static_cast<std::size_t>(fragments.id[a]);
    first[f] = std::min(first[f], static_cast<std::uint32_t>(a));
    ++size[f];
  }
  std::vector<Rgba> by_fragment(first.size());
  for (std::size_t f = 0; f < first.size(); ++f)
    by_fragment[f] = fragment_colour(first[f], size[f], whole[static_cast<std::size_t>(model.object[first[f]])]);
  std::vector<Rgba> colour(n);
  for (std::size_t a = 0; a < n; ++a) colour[a] = by_fragment[static_cast<std::size_t>(fragments.id[a])];
  return colour;
}

std::vector<std::uint8_t> exposed_automata(const Model& model, const State& state) {
  const std::size_t n = model.size();
  const AutomatonLinks links = model.automaton_links();
  const std::uint8_t* boxed = model.boxed.empty() ? nullptr : model.boxed.data();
  std::vector<std::uint8_t> out(n);
  for (std::size_t a = 0; a < n; ++a) out[a] = automaton_exposed(links, a, state.intact.data(), boxed);
  return out;
}

Legend make_legend(const Model& model, const SnapshotOptions& o, bool softening, double largest) {
  Legend L;
  switch (o.colour) {
    case ColourMode::fragment:
      L.title = "fragments";
      L.swatches = {{"main body", main_body_colour()}, {"pieces", piece_colour(0)}};
      break;
    case ColourMode::damage:
      // (With softening links an intact link counts by its damage: the legend says so.)
      L = {softening ? "damage (broken and softened links)" : "damage (broken links)", true, 0, 100, "%", {}, ramp_damage};
      break;
    case ColourMode::strength_class:
      L.title = "strength class";
      for (int c = 1; c <= 4; ++c) L.swatches.push_back({std::to_string(c) + (c == 1 ? " weakest" : c == 4 ? " strongest" : ""), class_colour(c)});
      break;
    case ColourMode::group: {
      L.title = "material";
      // Only the groups the automata use (projectile materials have groups too).
      std::vector<std::uint8_t> used(model.groups.size());
      for (const std::uint8_t g : model.group) used[g] = 1;
      for (std::size_t k = 0; k < model.group_names.size(); ++k)
        if (used[k]) L.swatches.push_back({model.group_names[k], group_colour(k)});
      break;
    }
    case ColourMode::stress:
    case ColourMode::speed: {
      const double top = colour_scale(o, largest);
      if (o.colour == ColourMode::stress) L = {"equivalent stress", true, 0, top / 1e6, "MPa", {}, ramp_viridis};
      else L = {"speed", true, 0, top, "m/s", {}, ramp_viridis};
      break;
    }
  }
  return L;
}

Snapshot make_snapshot(const Model& model, const State& state, const analysis::Fragments& fragments,
                       const SnapshotOptions& o, const std::array<double, 3>& origin) {
  Snapshot s = snapshot_frame(model, origin);
  s.time = state.time;
  s.step = state.step;
  s.broken_links = state.broken_by[0] + state.broken_by[1];
  s.fragments = fragments.count;
  auto local = [&](const DVec3& p) {
    return std::array<float, 3>{render::local(p.x, origin[0]), render::local(p.y, origin[1]), render::local(p.z, origin[2])};
  };

  // Per-automaton colour and the legend of the mode.
  const std::size_t n = model.size();
  std::vector<Rgba> colour(n);
  float largest = 0;
  switch (o.colour) {
    case ColourMode::fragment: colour = fragment_colours(model, fragments); break;
    case ColourMode::damage: {
      const AutomatonLinks links = model.automaton_links();
      const float* damage = state.link_damage.empty() ? nullptr : state.link_damage.data();
      for (std::size_t a = 0; a < n; ++a) colour[a] = ramp_damage(automaton_damage_of(links, a, state.intact.data(), damage));
      break;
    }
    case ColourMode::strength_class:
      for (std::size_t a = 0; a < n; ++a) colour[a] = class_colour(model.strength_class[a]);
      break;
    case ColourMode::group:
      for (std::size_t a = 0; a < n; ++a) colour[a] = group_colour(model.group[a]);
      break;
    case ColourMode::stress:
    case ColourMode::speed: {
      const bool stress = o.colour == ColourMode::stress;
      std::vector<float> v(n);
      for (std::size_t a = 0; a < n; ++a) {
        v[a] = stress ? von_mises(state.s[a]) : speed_of(state.v[a].x, state.v[a].y, state.v[a].z);
        largest = std::max(largest, finite_or_zero(v[a]));
      }
      const double top = colour_scale(o, largest);
      for (std::size_t a = 0; a < n; ++a) colour[a] = scaled_colour(v[a], top);
      break;
    }
  }
  s.legend = make_legend(model, o, !state.link_damage.empty(), largest);

  // Automata: every one, or the exposed ones (drawing those enclosed on all six sides changes no pixel).
  const std::vector<std::uint8_t> exposed = o.all_automata ? std::vector<std::uint8_t>(n, 1) : exposed_automata(model, state);
  const bool surface = o.draw == DrawMode::surface && model.surface.faces() > 0;
  if (o.draw != DrawMode::links) {
    // With the surface drawn, automata of mesh objects are shown by their triangles; only automata that
    // carry none (the inner faces of cracks show through the split surface) are drawn as cubes.
    const std::vector<std::uint8_t> carries = surface ? carrying_automata(model) : std::vector<std::uint8_t>{};
    s.automata.reserve(n / 4);
    for (std::size_t a = 0; a < n; ++a) {
      if (!exposed[a] || (surface && carries[a])) continue;
      const auto p = local(state.x[a]);
      const Quat& q = state.q[a];
      s.automata.push_back({p[0], p[1], p[2], q.x, q.y, q.z, q.w, colour[a]});
      s.radius.push_back(model.radius[a]);
    }
  }
  if (surface) {
    // Each corner where posed_surface puts its vertex, but rounded to float only in the drawing frame (a
    // mesh far from the world origin keeps its detail).
    s.surface.resize(model.surface.corner.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, s.surface.size(), 4096), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t c = r.begin(); c < r.end(); ++c) {
        const auto p = local(analysis::posed_corner(model, state, fragments.id.data(), static_cast<std::uint32_t>(c)));
        s.surface[c] = {p[0], p[1], p[2], colour[model.surface.automaton[c / 3]]};
      }
    });
  }
  if (o.draw == DrawMode::links) {
    model.for_each_link([&](std::size_t l, std::uint32_t i, std::uint32_t j, int) {
      if (!state.intact[l]) return;
      const auto a = local(state.x[i]), b = local(state.x[j]);
      s.links.push_back({a[0], a[1], a[2], colour[i]});
      s.links.push_back({b[0], b[1], b[2], colour[j]});
    });
    // A piece of one automaton has no link to draw: its cube, so that the debris stays in the picture.
    for (std::size_t a = 0; a < n; ++a) {
      bool linked = false;
      model.for_each_link_of(a, [&](std::size_t l) { linked = linked || state.intact[l] != 0; });
      if (linked) continue;
      const auto p = local(state.x[a]);
      const Quat& q = state.q[a];
      s.automata.push_back({p[0], p[1], p[2], q.x, q.y, q.z, q.w, colour[a]});
      s.radius.push_back(model.radius[a]);
    }
  }
  std::vector<DVec3> balls;
  for (const ProjectileState& p : state.projectiles) balls.push_back(p.position);
  add_projectiles(s, model, balls);
  return s;
}

Snapshot make_snapshot(const Model& model, const Backend& backend, const SnapshotOptions& o,
                       const std::array<double, 3>& origin, DrawTarget* target, std::string* why_not) {
  DrawList list;
  if (!backend.draw_list(o, origin, list, target)) {
    if (why_not && target)
      *why_not = fmt::format("the {} backend's {} mode is drawn from its state", backend.name(), name(o.draw));
    const State& state = backend.state();
    return make_snapshot(model, state, analysis::label_model_fragments(model, state.intact.data()), o, origin);
  }
  if (why_not) *why_not = list.shared_why;
  Snapshot s = snapshot_frame(model, origin);
  s.time = backend.current_time();
  s.step = backend.current_step();
  s.broken_links = backend.broken_links();
  s.fragments = list.fragments;
  s.legend = make_legend(model, o, list.softening, list.largest);
  s.automata = std::move(list.automata);
  s.radius = std::move(list.radius);
  s.surface = std::move(list.surface);
  s.shared_automata = list.shared_automata;
  s.shared_corners = list.shared_corners;
  if (target && s.shared_automata) s.shared_automata_buffer = target->buffer(DrawTarget::automata);
  if (target && s.shared_corners) s.shared_surface_buffer = target->buffer(DrawTarget::surface);
  add_projectiles(s, model, list.projectiles);
  return s;
}

}  // namespace mca::render
