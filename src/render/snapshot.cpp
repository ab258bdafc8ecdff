#include "render/snapshot.hpp"

#include <algorithm>
#include <cmath>

#include "analysis/surface.hpp"

namespace mca::render {
namespace {

constexpr std::array<const char*, 6> kColourNames = {"fragment", "damage", "class", "group", "stress", "speed"};
constexpr std::array<const char*, 4> kDrawNames = {"cubes", "spheres", "surface", "links"};

Rgba rgb(float r, float g, float b) {
  auto c = [](float v) { return static_cast<std::uint8_t>(std::lround(255.0f * std::clamp(v, 0.0f, 1.0f))); };
  return {c(r), c(g), c(b), 255};
}

// Piecewise-linear interpolation between equally spaced stops.
template <std::size_t N>
Rgba ramp(const std::array<std::array<float, 3>, N>& stops, float t) {
  t = std::isfinite(t) ? std::clamp(t, 0.0f, 1.0f) : 0.0f;
  const float x = t * (N - 1);
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(x), N - 2);
  const float f = x - static_cast<float>(k);
  const auto& a = stops[k];
  const auto& b = stops[k + 1];
  return rgb(a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]));
}

// A categorical palette (well separated hues, readable on the dark background).
constexpr std::array<std::array<float, 3>, 10> kCategorical = {{{0.30f, 0.55f, 0.85f}, {0.95f, 0.55f, 0.15f},
                                                                  {0.35f, 0.75f, 0.35f}, {0.85f, 0.25f, 0.25f},
                                                                  {0.65f, 0.45f, 0.80f}, {0.60f, 0.40f, 0.30f},
                                                                  {0.90f, 0.50f, 0.75f}, {0.75f, 0.75f, 0.20f},
                                                                  {0.20f, 0.75f, 0.80f}, {0.55f, 0.55f, 0.55f}}};

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

// Concrete grey for intact, through orange to deep red where every link has broken.
Rgba ramp_damage(float t) {
  static constexpr std::array<std::array<float, 3>, 4> stops = {
      {{0.72f, 0.71f, 0.68f}, {0.98f, 0.80f, 0.25f}, {0.95f, 0.40f, 0.10f}, {0.65f, 0.05f, 0.05f}}};
  return ramp(stops, t);
}

// Matplotlib's viridis at nine stops.
Rgba ramp_viridis(float t) {
  static constexpr std::array<std::array<float, 3>, 9> stops = {
      {{0.267f, 0.005f, 0.329f}, {0.283f, 0.141f, 0.458f}, {0.254f, 0.265f, 0.530f}, {0.207f, 0.372f, 0.553f},
       {0.164f, 0.471f, 0.558f}, {0.128f, 0.567f, 0.551f}, {0.135f, 0.659f, 0.518f}, {0.267f, 0.749f, 0.441f},
       {0.993f, 0.906f, 0.144f}}};
  return ramp(stops, t);
}

// The paper colours automata by strength class (its Figs. 5-8): the weaker class blue against red
// (Venus, sec. 6), three classes yellow, green and red in the medium-heterogeneity bunny.
Rgba class_colour(int c) {
  switch (c) {
    case 1: return rgb(0.20f, 0.40f, 0.95f);
    case 2: return rgb(0.95f, 0.85f, 0.15f);
    case 3: return rgb(0.25f, 0.75f, 0.25f);
    default: return rgb(0.85f, 0.15f, 0.15f);
  }
}

Rgba main_body_colour() { return rgb(0.72f, 0.71f, 0.68f); }

Rgba piece_colour(std::uint32_t first_automaton) {
  // A well-mixed hash of the index (murmur3's finaliser): pieces that split from neighbouring automata get
  // far-apart hues; saturation and value vary a little so that close hues still differ.
  std::uint32_t x = first_automaton + 0x9e3779b9u;
  x ^= x >> 16;
  x *= 0x85ebca6bu;
  x ^= x >> 13;
  x *= 0xc2b2ae35u;
  x ^= x >> 16;
  const float h = static_cast<float>(x & 0xffffu) / 65536.0f * 6.0f;
  const float s = 0.55f + 0.25f * static_cast<float>((x >> 16) & 0xffu) / 255.0f;
  const float v = 0.80f + 0.15f * static_cast<float>(x >> 24) / 255.0f;
  const int k = static_cast<int>(h);
  const float f = h - static_cast<float>(k), p = v * (1 - s), q = v * (1 - s * f), u = v * (1 - s * (1 - f));
  switch (k % 6) {
    case 0: return rgb(v, u, p);
    case 1: return rgb(q, v, p);
    case 2: return rgb(p, v, u);
    case 3: return rgb(p, q, v);
    case 4: return rgb(u, p, v);
    default: return rgb(v, p, q);
  }
}

std::vector<Rgba> fragment_colours(const Model& model, const analysis::Fragments& fragments) {
  const std::size_t n = model.size();
  // Per fragment: its smallest automaton index and its automata; per object: its automata.
  std::vector<std::uint32_t> first(static_cast<std::size_t>(fragments.count), UINT32_MAX);
  std::vector<std::size_t> size(static_cast<std::size_t>(fragments.count), 0);
  std::vector<std::size_t> object_size(model.object_names.size() + 1, 0);
  for (std::size_t a = 0; a < n; ++a) {
    const auto f = static_cast<std::size_t>(fragments.id[a]);
    first[f] = std::min(first[f], static_cast<std::uint32_t>(a));
    ++size[f];
    ++object_size[static_cast<std::size_t>(model.object[a])];
  }
  std::vector<Rgba> by_fragment(first.size());
  for (std::size_t f = 0; f < first.size(); ++f) {
    const std::size_t whole = object_size[static_cast<std::size_t>(model.object[first[f]])];
    by_fragment[f] = 2 * size[f] > whole ? main_body_colour() : piece_colour(first[f]);
  }
  std::vector<Rgba> colour(n);
  for (std::size_t a = 0; a < n; ++a) colour[a] = by_fragment[static_cast<std::size_t>(fragments.id[a])];
  return colour;
}

std::vector<std::uint8_t> exposed_automata(const Model& model, const State& state) {
  const std::size_t n = model.size();
  std::vector<std::uint8_t> out(n);
  for (std::size_t a = 0; a < n; ++a) {
    int intact = 0, all = 0;
    model.for_each_link_of(a, [&](std::size_t l) {
      intact += state.intact[l] != 0;
      ++all;
    });
    // Enclosed: a cubic automaton with its six links, one of the random lattice boxed in with all of its.
    out[a] = model.boxed.empty() ? intact < 6 : !model.boxed[a] || intact < all;
  }
  return out;
}

Snapshot make_snapshot(const Model& model, const State& state, const analysis::Fragments& fragments,
                       const SnapshotOptions& o, const std::array<double, 3>& origin) {
  Snapshot s;
  s.origin = origin;
  s.cube_size = model.spacing;
  s.automata_total = model.size();
  s.time = state.time;
  s.step = state.step;
  s.broken_links = state.broken_by[0] + state.broken_by[1];
  s.fragments = fragments.count;
  s.up = {model.up.x, model.up.y, model.up.z};
  s.ground = model.ground;
  const double up_origin = origin[0] * model.up.x + origin[1] * model.up.y + origin[2] * model.up.z;
  s.ground_height = static_cast<float>(model.ground_height - up_origin);
  auto local = [&](const DVec3& p) {
    return std::array<float, 3>{static_cast<float>(p.x - origin[0]), static_cast<float>(p.y - origin[1]),
                                static_cast<float>(p.z - origin[2])};
  };

  // Per-automaton colour and the legend of the mode.
  const std::size_t n = model.size();
  std::vector<Rgba> colour(n);
  Legend& L = s.legend;
  switch (o.colour) {
    case ColourMode::fragment: {
      colour = fragment_colours(model, fragments);
      L.title = "fragments";
      L.swatches = {{"main body", main_body_colour()}, {"pieces", piece_colour(0)}};
      break;
    }
    case ColourMode::damage: {
      std::vector<float> d(n);
      automaton_damage(model, state.intact.data(), state.link_damage.empty() ? nullptr : state.link_damage.data(),
                       d.data());
      for (std::size_t a = 0; a < n; ++a) colour[a] = ramp_damage(d[a]);
      // (With softening links an intact link counts by its damage: the legend says so.)
      L = {state.link_damage.empty() ? "damage (broken links)" : "damage (broken and softened links)", true, 0, 100, "%",
           {}, ramp_damage};
      break;
    }
    case ColourMode::strength_class: {
      for (std::size_t a = 0; a < n; ++a) colour[a] = class_colour(model.strength_class[a]);
      L.title = "strength class";
      for (int c = 1; c <= 4; ++c) L.swatches.push_back({std::to_string(c) + (c == 1 ? " weakest" : c == 4 ? " strongest" : ""), class_colour(c)});
      break;
    }
    case ColourMode::group: {
      auto g = [](std::size_t k) {
        const auto& c = kCategorical[k % kCategorical.size()];
        return rgb(c[0], c[1], c[2]);
      };
      for (std::size_t a = 0; a < n; ++a) colour[a] = g(model.group[a]);
      L.title = "material";
      // Only the groups the automata use (projectile materials have groups too).
      std::vector<std::uint8_t> used(model.groups.size());
      for (std::size_t a = 0; a < n; ++a) used[model.group[a]] = 1;
      for (std::size_t k = 0; k < model.group_names.size(); ++k)
        if (used[k]) L.swatches.push_back({model.group_names[k], g(k)});
      break;
    }
    case ColourMode::stress:
    case ColourMode::speed: {
      const bool stress = o.colour == ColourMode::stress;
      std::vector<float> v(n);
      float largest = 0;
      for (std::size_t a = 0; a < n; ++a) {
        v[a] = stress ? von_mises(state.s[a]) : static_cast<float>(length(state.v[a]));
        if (std::isfinite(v[a])) largest = std::max(largest, v[a]);
      }
      const double top = o.scale_max > 0 ? o.scale_max : std::max<double>(largest, stress ? 1e3 : 1e-3);
      for (std::size_t a = 0; a < n; ++a) colour[a] = ramp_viridis(static_cast<float>(v[a] / top));
      if (stress) L = {"equivalent stress", true, 0, top / 1e6, "MPa", {}, ramp_viridis};
      else L = {"speed", true, 0, top, "m/s", {}, ramp_viridis};
      break;
    }
  }

  // Automata: every one, or the exposed ones (drawing those enclosed on all six sides changes no pixel).
  const std::vector<std::uint8_t> exposed = o.all_automata ? std::vector<std::uint8_t>(n, 1) : exposed_automata(model, state);
  const bool surface = o.draw == DrawMode::surface && model.surface.faces() > 0;
  if (o.draw != DrawMode::links) {
    // With the surface drawn, automata of mesh objects are shown by their triangles; only automata that
    // carry none (the inner faces of cracks show through the split surface) are drawn as cubes.
    std::vector<std::uint8_t> carries;
    if (surface) {
      carries.assign(n, 0);
      for (std::uint32_t a : model.surface.automaton) carries[a] = 1;
    }
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
    const mesh::FloatMesh m = analysis::posed_surface(model, state, fragments.id);
    s.surface.reserve(3 * m.faces.size());
    const auto shift = [&](const std::array<float, 3>& v) {
      return std::array<float, 3>{static_cast<float>(v[0] - origin[0]), static_cast<float>(v[1] - origin[1]),
                                  static_cast<float>(v[2] - origin[2])};
    };
    for (std::size_t f = 0; f < m.faces.size(); ++f) {
      const Rgba c = colour[model.surface.automaton[f]];
      for (std::uint32_t v : m.faces[f]) {
        const auto p = shift(m.vertices[v]);
        s.surface.push_back({p[0], p[1], p[2], c});
      }
    }
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
  for (const ProjectileState& p : state.projectiles) {
    const auto c = local(p.position);
    s.projectiles.push_back({c[0], c[1], c[2], 0});
  }
  for (std::size_t p = 0; p < s.projectiles.size() && p < model.projectiles.size(); ++p)
    s.projectiles[p].radius = model.projectiles[p].radius;
  return s;
}

}  // namespace mca::render
