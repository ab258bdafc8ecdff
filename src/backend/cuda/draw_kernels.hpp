#pragma once
// The CUDA backend's draw list (Backend::draw_list): what render::make_snapshot builds from a State
// (render/snapshot.cpp), built on the device from the backend's own arrays, with the same per-thread
// functions (render/draw_list.hpp, core/model.hpp), so the same bytes. A frame then copies the drawn
// automata and triangles, not the state.
//
// Fragments are labelled by a union-find whose parents only ever point to smaller indices: a root is
// hooked under the smaller of two roots by compare-and-swap, so that each fragment's root is its smallest
// automaton whatever order the threads ran in. That is what the colours need (a piece's hue comes from
// its smallest automaton, the main body is the fragment with over half its object's automata), and the
// surface needs only which triangles share a fragment.
#include <cstddef>
#include <cstdint>

#include "backend/cuda/device_kernels.hpp"
#include "render/draw_list.hpp"

namespace mca::gpu {

// *p, read where other threads write it.
MCA_HD std::uint32_t load_shared(const std::uint32_t* p) {
#if defined(__CUDA_ARCH__)
  return *static_cast<const volatile std::uint32_t*>(p);
#else
  return *p;
#endif
}
MCA_HD void store_shared(std::uint32_t* p, std::uint32_t v) {
#if defined(__CUDA_ARCH__)
  *static_cast<volatile std::uint32_t*>(p) = v;
#else
  *p = v;
#endif
}
// *p = desired if it was expected; returns what it was.
MCA_HD std::uint32_t compare_swap(std::uint32_t* p, std::uint32_t expected, std::uint32_t desired) {
#if defined(__CUDA_ARCH__)
  return atomicCAS(p, expected, desired);
#else
  const std::uint32_t before = *p;
  if (before == expected) *p = desired;
  return before;
#endif
}

// The union-find of the fragments: parent[a] <= a, a root is its own parent.
struct FragmentRoots {
  std::uint32_t* parent;
  // a's root. Halves the path on the way: a non-root's parent only ever moves to another of its
  // ancestors, and roots are never written here (only hooked, by compare-and-swap).
  MCA_HD std::uint32_t find(std::uint32_t a) const {
    for (;;) {
      const std::uint32_t p = load_shared(parent + a);
      if (p == a) return a;
      const std::uint32_t up = load_shared(parent + p);
      if (up != p) store_shared(parent + a, up);
      a = p;
    }
  }
  // Joins the sets of a and b: the larger root under the smaller.
  MCA_HD void unite(std::uint32_t a, std::uint32_t b) const {
    a = find(a);
    b = find(b);
    while (a != b) {
      if (a > b) {
        const std::uint32_t t = a;
        a = b;
        b = t;
      }
      const std::uint32_t was = compare_swap(parent + b, b, a);
      if (was == b) return;
      b = find(was);  // b was hooked by another thread meanwhile
      a = find(a);
    }
  }
};
struct FragmentStartKernel {
  std::uint32_t *parent, *size;
  MCA_HD void operator()(std::size_t a) const {
    parent[a] = static_cast<std::uint32_t>(a);
    size[a] = 0;
  }
};
// Link slot l, where intact, joins its ends.
struct FragmentUniteKernel {
  FragmentRoots roots;
  LinkEnds ends;
  const std::uint8_t* intact;
  MCA_HD void operator()(std::size_t l) const {
    if (!intact[l]) return;
    const std::uint32_t j = ends.j(static_cast<std::uint32_t>(l));
    if (j != kNone) roots.unite(ends.i(static_cast<std::uint32_t>(l)), j);
  }
};
// Automaton a's fragment (its smallest automaton); counts the fragment's automata and the fragments.
struct FragmentLabelKernel {
  FragmentRoots roots;
  std::uint32_t *label, *size, *fragments;
  MCA_HD void operator()(std::size_t a) const {
    const std::uint32_t r = roots.find(static_cast<std::uint32_t>(a));
    label[a] = r;
    count_up(size + r);
    if (r == a) count_up(fragments);
  }
};

// What a draw reads back before it writes the list.
struct DrawStatus {
  float largest = 0;          // stress, speed: the largest finite value
  std::uint32_t fragments = 0;
};

// The stress or speed of automaton a (render::make_snapshot's values), kept for the colours; the largest
// finite one is reduced (Dev::launch_reduce).
struct DrawValueKernel {
  bool stress;
  const Sym3* s;
  const double *vx, *vy, *vz;
  float* value;
  MCA_HD Reduced operator()(std::size_t a) const {
    const float v = stress ? von_mises(s[a]) : render::speed_of(vx[a], vy[a], vz[a]);
    value[a] = v;
    Reduced r;
    r.max = render::finite_or_zero(v);
    return r;
  }
};
struct DrawColourKernel {
  render::ColourMode mode;
  AutomatonLinks links;
  const std::uint8_t* intact;
  const float* damage;  // null: no softening
  const std::uint8_t *strength_class, *group;
  const std::int32_t* object;
  const std::uint32_t *label, *size, *object_size;
  const float* value;
  double top;
  render::Rgba* colour;
  MCA_HD void operator()(std::size_t a) const {
    using render::ColourMode;
    switch (mode) {
      case ColourMode::fragment:
        colour[a] = render::fragment_colour(label[a], size[label[a]], object_size[object[label[a]]]);
        break;
      case ColourMode::damage: colour[a] = render::ramp_damage(automaton_damage_of(links, a, intact, damage)); break;
      case ColourMode::strength_class: colour[a] = render::class_colour(strength_class[a]); break;
      case ColourMode::group: colour[a] = render::group_colour(group[a]); break;
      case ColourMode::stress:
      case ColourMode::speed: colour[a] = render::scaled_colour(value[a], top); break;
    }
  }
};
// Whether automaton a is drawn: seen (or all asked for), and not carrying surface triangles where the
// surface is drawn (carries null: it is not).
struct DrawFlagKernel {
  AutomatonLinks links;
  const std::uint8_t *intact, *boxed, *carries;
  bool all;
  std::uint32_t* flag;
  MCA_HD void operator()(std::size_t a) const {
    const bool seen = all || render::automaton_exposed(links, a, intact, boxed);
    flag[a] = seen && !(carries && carries[a]) ? 1u : 0u;
  }
};
// The drawing frame's origin (world coordinates).
struct DrawOrigin {
  double x, y, z;
};
// A drawn automaton's instance at its place in the list (automaton order).
struct DrawAutomataKernel {
  const std::uint32_t *flag, *place;
  const double *px, *py, *pz;
  const float *qw, *qx, *qy, *qz, *radius;
  const render::Rgba* colour;
  DrawOrigin o;
  render::Instance* out;
  float* out_radius;  // null: not wanted
  MCA_HD void operator()(std::size_t a) const {
    if (!flag[a]) return;
    const std::uint32_t k = place[a];
    out[k] = {render::local(px[a], o.x), render::local(py[a], o.y), render::local(pz[a], o.z), qx[a], qy[a], qz[a], qw[a],
              colour[a]};
    if (out_radius) out_radius[k] = radius[a];
  }
};
// Corner c of the bound surface (3 per triangle, in triangle order): posed as analysis::posed_surface
// poses its vertex (but rounded to float only in the drawing frame), in the colour of the triangle's
// automaton.
struct DrawSurfaceKernel {
  SurfaceCorners surface;
  const std::uint32_t* label;
  const double *px, *py, *pz;
  const float *qw, *qx, *qy, *qz;
  const render::Rgba* colour;
  DrawOrigin o;
  render::SurfaceVertex* out;
  MCA_HD void operator()(std::size_t c) const {
    const SurfaceCorners& S = surface;
    const auto same = [&](std::uint32_t f, std::uint32_t g) { return label[S.automaton[f]] == label[S.automaton[g]]; };
    const auto pose = [&](std::uint32_t a, DVec3& x, Quat& q) {
      x = {px[a], py[a], pz[a]};
      q = {qw[a], qx[a], qy[a], qz[a]};
    };
    const DVec3 p = posed_corner(S, static_cast<std::uint32_t>(c), same, pose);
    out[c] = {render::local(p.x, o.x), render::local(p.y, o.y), render::local(p.z, o.z), colour[S.automaton[c / 3]]};
  }
};

}  // namespace mca::gpu
