#include "mesh/simplify.hpp"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Edge_collapse_visitor_base.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <optional>

namespace mca::mesh {
namespace {

using Tri = std::array<Point, 3>;

Point minus(const Point& a, const Point& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Point& a, const Point& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Point cross(const Point& a, const Point& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

// The planes through p of the triangles around it (its star), each triangle's corners within tol of one:
// how many (1 or 2, their unit normals in n), or 0 where there are more or a triangle has no normal.
int star_planes(const Point& p, const std::vector<Tri>& star, double tol, Point n[2]) {
  int planes = 0;
  for (const Tri& t : star) {
    bool fits = false;
    for (int i = 0; i < planes && !fits; ++i) {
      fits = true;
      for (const Point& q : t) fits = fits && std::fabs(dot(minus(q, p), n[i])) <= tol;
    }
    if (fits) continue;
    if (planes == 2) return 0;
    const Point c = cross(minus(t[1], t[0]), minus(t[2], t[0]));
    const double len = std::sqrt(dot(c, c));
    if (!(len > 0)) return 0;
    n[planes++] = {c[0] / len, c[1] / len, c[2] / len};
  }
  return planes;
}

// Whether p, whose star lies in `planes` planes of normals n (star_planes), may be moved onto its neighbour q
// without the surface moving by more than tol: its triangles in one plane, or in two with q on both (along
// the straight edge between them).
bool moves_within(const Point& p, int planes, const Point n[2], const Point& q, double tol) {
  if (planes == 0) return false;
  for (int i = 0; i < planes; ++i)
    if (std::fabs(dot(minus(q, p), n[i])) > tol) return false;
  return true;
}

using Kernel = CGAL::Simple_cartesian<double>;
using SurfaceMesh = CGAL::Surface_mesh<Kernel::Point_3>;
using VertexIndex = SurfaceMesh::Vertex_index;

Point point_of(const Kernel::Point_3& p) { return {p.x(), p.y(), p.z()}; }

namespace SMS = CGAL::Surface_mesh_simplification;

// What the collapses ask of each vertex: the planes of its star, kept until a collapse changes its
// triangles (each edge is tested again whenever a collapse near it happens: without it, the stars were
// most of the time).
class Flatness {
 public:
  Flatness(const SurfaceMesh& sm, double tol, double min_height)
      : sm_(sm), tol_(tol), min_height_(min_height), cache_(sm.number_of_vertices()) {}

  // Whether v0 may be moved onto its neighbour v1 without the surface moving by more than tol.
  bool movable(VertexIndex v0, VertexIndex v1) {
    const Entry& e = planes(v0);
    return moves_within(point_of(sm_.point(v0)), e.planes, e.n, point_of(sm_.point(v1)), tol_);
  }
  // Whether the triangles around v0 that stay when it is moved onto v1 are neither turned over nor lower than
  // min_height across their longest edge (or, one that was lower already, lower than it was).
  bool leaves_good_triangles(VertexIndex v0, VertexIndex v1) const {
    const Point p1 = point_of(sm_.point(v1));
    for (const auto f : CGAL::faces_around_target(sm_.halfedge(v0), sm_)) {
      Tri before, after;
      int k = 0;
      bool on_edge = false;
      for (const auto v : CGAL::vertices_around_face(sm_.halfedge(f), sm_)) {
        before[k] = point_of(sm_.point(v));
        after[k] = v == v0 ? p1 : before[k];
        on_edge = on_edge || v == v1;
        ++k;
      }
      if (on_edge) continue;  // (the two triangles on the edge go)
      const Point a = cross(minus(before[1], before[0]), minus(before[2], before[0]));
      const Point b = cross(minus(after[1], after[0]), minus(after[2], after[0]));
      if (!(dot(a, b) > 0)) return false;
      // (|b| is the height times the longest edge)
      const auto longest = [](const Tri& t) {
        double l = 0;
        for (int c = 0; c < 3; ++c) l = std::max(l, dot(minus(t[(c + 1) % 3], t[c]), minus(t[(c + 1) % 3], t[c])));
        return l;
      };
      const double height2 = dot(b, b) / longest(after);
      if (height2 < min_height_ * min_height_ && height2 < dot(a, a) / longest(before)) return false;
    }
    return true;
  }
  // After a collapse that kept v: its triangles and its neighbours' changed.
  void collapsed(VertexIndex v) {
    cache_[v.idx()].planes = kUnknown;
    for (const auto h : CGAL::halfedges_around_target(sm_.halfedge(v), sm_)) cache_[sm_.source(h).idx()].planes = kUnknown;
  }

 private:
  static constexpr int kUnknown = -1;
  struct Entry {
    int planes = kUnknown;
    Point n[2];
  };
  const Entry& planes(VertexIndex v) {
    Entry& e = cache_[v.idx()];
    if (e.planes != kUnknown) return e;
    star_.clear();
    e.planes = 0;
    for (const auto f : CGAL::faces_around_target(sm_.halfedge(v), sm_)) {
      if (f == SurfaceMesh::null_face()) return e;
      Tri t;
      int k = 0;
      for (const auto u : CGAL::vertices_around_face(sm_.halfedge(f), sm_)) t[k++] = point_of(sm_.point(u));
      star_.push_back(t);
    }
    e.planes = star_planes(point_of(sm_.point(v)), star_, tol_, e.n);
    return e;
  }
  const SurfaceMesh& sm_;
  double tol_, min_height_;
  std::vector<Entry> cache_;
  std::vector<Tri> star_;
};

// CGAL's policies: the kept end's point where a collapse is allowed one way or the other (none where
// neither), costed by the edge's squared length; no stop but the end of allowed collapses. The visitor
// tells the flatness what changed, and polls the caller's stop as each edge is costed at the start, then
// as each is taken.
struct Placement {
  Flatness* flat;
  template <class Profile>
  boost::optional<typename Profile::Point> operator()(const Profile& pr) const {
    if (flat->movable(pr.v0(), pr.v1())) return pr.p1();
    if (flat->movable(pr.v1(), pr.v0())) return pr.p0();
    return boost::none;
  }
};
// (The triangles left are checked once an edge is taken, not each time it is costed again.)
struct Filter {
  Flatness* flat;
  template <class Profile>
  boost::optional<typename Profile::Point> operator()(const Profile& pr, const boost::optional<typename Profile::Point>& at) const {
    if (!at) return at;
    const bool onto_v1 = *at == pr.p1();
    if (onto_v1 ? flat->leaves_good_triangles(pr.v0(), pr.v1()) : flat->leaves_good_triangles(pr.v1(), pr.v0())) return at;
    return boost::none;
  }
};
struct Cost {
  template <class Profile, class P>
  boost::optional<double> operator()(const Profile& pr, const P& placement) const {
    if (!placement) return boost::none;
    return CGAL::squared_distance(pr.p0(), pr.p1());
  }
};
struct Visitor : SMS::Edge_collapse_visitor_base<SurfaceMesh> {
  Flatness* flat;
  const std::function<void()>* poll;
  std::size_t calls = 0;
  void tick() {
    if (*poll && ++calls % 4096 == 0) (*poll)();
  }
  template <class Profile, class Cost>
  void OnCollected(const Profile&, const Cost&) {
    tick();
  }
  template <class Profile, class Cost, class Size>
  void OnSelected(const Profile&, const Cost&, Size, Size) {
    tick();
  }
  template <class Profile>
  void OnCollapsed(const Profile&, VertexIndex kept) {
    flat->collapsed(kept);
  }
};
struct NoStop {
  template <class Profile>
  bool operator()(const double&, const Profile&, std::size_t, std::size_t) const {
    return false;
  }
};

}  // namespace

double flat_vertex_share(const TriMesh& m, double tol) {
  if (m.vertices.empty()) return 0;
  // Each vertex's triangles, in CSR.
  std::vector<std::uint32_t> start(m.vertices.size() + 1, 0), around(3 * m.faces.size());
  for (const Triangle& f : m.faces)
    for (const auto v : f) ++start[v + 1];
  for (std::size_t v = 0; v < m.vertices.size(); ++v) start[v + 1] += start[v];
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (std::size_t f = 0; f < m.faces.size(); ++f)
    for (const auto v : m.faces[f]) around[fill[v]++] = static_cast<std::uint32_t>(f);
  std::size_t flat = 0;
  std::vector<Tri> star;
  for (std::size_t v = 0; v < m.vertices.size(); ++v) {
    star.clear();
    for (std::uint32_t k = start[v]; k < start[v + 1]; ++k) {
      const Triangle& f = m.faces[around[k]];
      star.push_back({m.vertices[f[0]], m.vertices[f[1]], m.vertices[f[2]]});
    }
    if (star.empty()) continue;
    Point n[2];
    const int planes = star_planes(m.vertices[v], star, tol, n);
    bool movable = false;
    for (std::uint32_t k = start[v]; k < start[v + 1] && !movable; ++k)
      for (const auto u : m.faces[around[k]])
        if (u != v && moves_within(m.vertices[v], planes, n, m.vertices[u], tol)) {
          movable = true;
          break;
        }
    flat += movable;
  }
  return static_cast<double>(flat) / static_cast<double>(m.vertices.size());
}

FlatSimplified simplify_flat(TriMesh& m, double tol, double min_height, const std::function<void()>& poll) {
  FlatSimplified r;
  r.faces_before = r.faces_after = m.faces.size();
  SurfaceMesh sm;
  sm.reserve(static_cast<SurfaceMesh::size_type>(m.vertices.size()), static_cast<SurfaceMesh::size_type>(3 * m.faces.size() / 2),
             static_cast<SurfaceMesh::size_type>(m.faces.size()));
  for (const Point& p : m.vertices) sm.add_vertex(Kernel::Point_3(p[0], p[1], p[2]));
  for (const Triangle& f : m.faces)
    if (sm.add_face(VertexIndex(f[0]), VertexIndex(f[1]), VertexIndex(f[2])) == SurfaceMesh::null_face()) return r;
  if (!CGAL::is_closed(sm)) return r;
  Flatness flat(sm, tol, min_height);
  Visitor visitor;
  visitor.flat = &flat;
  visitor.poll = &poll;
  SMS::edge_collapse(sm, NoStop{}, CGAL::parameters::get_cost(Cost{}).get_placement(Placement{&flat}).filter(Filter{&flat}).visitor(visitor));
  sm.collect_garbage();
  TriMesh out;
  out.vertices.reserve(sm.number_of_vertices());
  for (const auto v : sm.vertices()) out.vertices.push_back(point_of(sm.point(v)));
  out.faces.reserve(sm.number_of_faces());
  for (const auto f : sm.faces()) {
    Triangle t{};
    int k = 0;
    for (const auto v : CGAL::vertices_around_face(sm.halfedge(f), sm)) t[k++] = static_cast<std::uint32_t>(v.idx());
    out.faces.push_back(t);
  }
  m = std::move(out);
  r.faces_after = m.faces.size();
  r.done = true;
  return r;
}

}  // namespace mca::mesh
