#include "mesh/readers.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <vector>

#include <fmt/format.h>

#include "core/text.hpp"
#include "mca/error.hpp"

namespace mca::mesh::detail {
namespace {

// A line, or a corner's index, longer than any mesh writes: garbage, refused before it is looked at.
constexpr std::size_t kMaxLine = 1 << 20;
constexpr std::uint64_t kMaxCount = 0xfffffff0ull;  // vertices and faces are addressed with 32 bits

// Lines of a text buffer with their numbers; comments (from `comment`) cut off, blank lines skipped.
class Lines {
 public:
  Lines(std::string_view b, const std::string& name, char comment) : b_(b), name_(name), comment_(comment) {}

  // The next line that has a word; false at the end.
  bool next() {
    while (at_ < b_.size()) {
      const std::size_t nl = std::min(b_.find('\n', at_), b_.size());
      ++number_;
      if (nl - at_ > kMaxLine) {
        throw Error(fmt::format("{}: line {} is longer than {} MB: the file is damaged or not a mesh file", name_,
                                number_, kMaxLine >> 20));
      }
      std::string_view line = b_.substr(at_, nl - at_);
      at_ = nl + 1;
      // A UTF-8 byte order mark, which some Windows editors write before text, at the start of a line (files
      // joined end to end carry one each): skipped (after it the line read as an unknown keyword).
      while (line.substr(0, kBom.size()) == kBom) line.remove_prefix(kBom.size());
      if (const std::size_t c = line.find(comment_); c != std::string_view::npos) line = line.substr(0, c);
      words_.clear();
      std::size_t i = 0;
      while (i < line.size()) {
        while (i < line.size() && is_space(line[i])) ++i;
        const std::size_t start = i;
        while (i < line.size() && !is_space(line[i])) ++i;
        if (i > start) words_.push_back(line.substr(start, i - start));
      }
      if (!words_.empty()) {
        text_ = line;
        return true;
      }
    }
    return false;
  }
  const std::vector<std::string_view>& words() const { return words_; }
  std::size_t number() const { return number_; }
  std::string_view text() const { return text_.size() > 80 ? text_.substr(0, 80) : text_; }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }
  std::string_view b_;
  const std::string& name_;
  char comment_;
  std::size_t at_ = 0, number_ = 0;
  std::vector<std::string_view> words_;
  std::string_view text_;
};

// A decimal number as C's strtod reads it ("1", "-2.5e3", ".3", "+4."), else false.
bool to_double(std::string_view w, double& out) {
  if (!w.empty() && w[0] == '+') w.remove_prefix(1);
  const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), out);
  return ec == std::errc() && end == w.data() + w.size();
}

bool to_integer(std::string_view w, std::int64_t& out) {
  if (!w.empty() && w[0] == '+') w.remove_prefix(1);
  const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), out);
  return ec == std::errc() && end == w.data() + w.size();
}

std::uint64_t header_count(std::string_view w, const std::string& name, const char* what) {
  std::int64_t v = 0;
  const std::string_view d = !w.empty() && w[0] == '+' ? w.substr(1) : w;
  const bool digits = !d.empty() && d.find_first_not_of("0123456789") == std::string_view::npos;
  if (digits && (w.size() > 12 || !to_integer(w, v))) {
    throw Error(fmt::format("{}: the header's {} count is {}, more than mca reads (4e9); the file is damaged or not "
                            "one mesh",
                            name, what, w));
  }
  if (!digits || !to_integer(w, v) || v < 0) {
    throw Error(fmt::format("{}: the header's {} count '{}' is not {}; the file is damaged", name, what, w,
                            !w.empty() && w[0] == '-' && to_integer(w, v) ? "0 or more" : "a whole number"));
  }
  if (static_cast<std::uint64_t>(v) > kMaxCount)
    throw Error(fmt::format("{}: the header declares {} {}, more than mca reads (4e9)", name, v, what));
  return static_cast<std::uint64_t>(v);
}

// Splits the polygon `corners` into triangles of its winding: a fan from its first corner where it is convex
// (a triangle, most quads), else by ear clipping in its plane. Blender's OBJ and PLY exporters write
// n-gons as they are, concave ones too (an extruded star): the fan filled their notches. A polygon the
// clipping cannot take (its corners not yet read, a plane of no area, one that crosses itself, more than
// 4,096 corners) is fanned as before.
void add_polygon(TriMesh& m, const std::vector<std::uint32_t>& corners) {
  const std::size_t n = corners.size();
  const auto fan = [&] {
    for (std::size_t k = 1; k + 1 < n; ++k) m.faces.push_back({corners[0], corners[k], corners[k + 1]});
  };
  if (n <= 3 || n > 4096 ||
      std::any_of(corners.begin(), corners.end(), [&](std::uint32_t c) { return c >= m.vertices.size(); })) {
    fan();
    return;
  }
  // Newell's normal, then the corners in the plane of its largest component, turned so the polygon winds
  // counter-clockwise there.
  double nn[3] = {0, 0, 0};
  for (std::size_t k = 0; k < n; ++k) {
    const Point& a = m.vertices[corners[k]];
    const Point& b = m.vertices[corners[(k + 1) % n]];
    nn[0] += (a[1] - b[1]) * (a[2] + b[2]);
    nn[1] += (a[2] - b[2]) * (a[0] + b[0]);
    nn[2] += (a[0] - b[0]) * (a[1] + b[1]);
  }
  const int axis = std::fabs(nn[0]) >= std::fabs(nn[1]) && std::fabs(nn[0]) >= std::fabs(nn[2]) ? 0
                   : std::fabs(nn[1]) >= std::fabs(nn[2])                                       ? 1
                                                                                                : 2;
  if (!(std::fabs(nn[axis]) > 0)) {
    fan();
    return;
  }
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const double turn = nn[axis] > 0 ? 1.0 : -1.0;
  // A corner at the point of the one before (written twice) turns by nothing, and hid a reflex turn from the
  // convexity test (an L fanned across its notch): it is left out, the polygon being the same without it.
  std::vector<std::uint32_t> kept;
  std::vector<std::array<double, 2>> q;
  for (std::size_t k = 0; k < n; ++k) {
    const std::array<double, 2> p = {m.vertices[corners[k]][u], turn * m.vertices[corners[k]][v]};
    if (!q.empty() && p == q.back()) continue;
    kept.push_back(corners[k]);
    q.push_back(p);
  }
  while (q.size() > 1 && q.back() == q.front()) {
    q.pop_back();
    kept.pop_back();
  }
  if (q.size() < 3) {
    fan();
    return;
  }
  const std::size_t n2 = q.size();
  const auto cross = [&](std::size_t a, std::size_t b, std::size_t c) {
    return (q[b][0] - q[a][0]) * (q[c][1] - q[a][1]) - (q[b][1] - q[a][1]) * (q[c][0] - q[a][0]);
  };
  bool convex = true;
  for (std::size_t k = 0; k < n2 && convex; ++k) convex = cross(k, (k + 1) % n2, (k + 2) % n2) >= 0;
  if (convex) {
    fan();
    return;
  }
  std::vector<std::size_t> left(n2);
  for (std::size_t k = 0; k < n2; ++k) left[k] = k;
  std::vector<Triangle> ears;
  while (left.size() > 3) {
    const std::size_t r = left.size();
    // An ear: a convex corner whose triangle holds no other corner (inside, or on the diagonal it cuts);
    // failing one, a corner in line with its neighbours (its triangle of no area keeps the edges joined).
    std::size_t cut = r;
    for (int pass = 0; pass < 2 && cut == r; ++pass)
      for (std::size_t k = 0; k < r && cut == r; ++k) {
        const std::size_t a = left[(k + r - 1) % r], b = left[k], c = left[(k + 1) % r];
        const double area = cross(a, b, c);
        if (pass == 1) {
          if (area == 0) cut = k;
          continue;
        }
        if (!(area > 0)) continue;
        bool empty = true;
        for (std::size_t j = 0; j < r && empty; ++j) {
          const std::size_t p = left[j];
          if (p == a || p == b || p == c) continue;
          empty = !(cross(a, b, p) > 0 && cross(b, c, p) > 0 && cross(c, a, p) >= 0);
        }
        if (empty) cut = k;
      }
    if (cut == r) {  // it crosses itself: as before
      fan();
      return;
    }
    ears.push_back({kept[left[(cut + r - 1) % r]], kept[left[cut]], kept[left[(cut + 1) % r]]});
    left.erase(left.begin() + static_cast<std::ptrdiff_t>(cut));
  }
  m.faces.insert(m.faces.end(), ears.begin(), ears.end());
  m.faces.push_back({kept[left[0]], kept[left[1]], kept[left[2]]});
}

}  // namespace

ReadResult read_off(std::string_view bytes, const std::string& name,
                    const std::function<void(double vertices, double faces)>& check) {
  // "[ST][C][N]OFF", the counts "vertices faces [edges]" (on the same line or the next), then a line per
  // vertex "x y z [...]" and a line per face "k i1 ... ik [colour]"; '#' starts a comment.
  Lines in(bytes, name, '#');
  if (!in.next()) throw Error(fmt::format("{}: does not start with OFF: not an OFF file", name));
  const std::string_view key = in.words()[0];
  if (key.size() < 3 || key.substr(key.size() - 3) != "OFF") {
    throw Error(fmt::format("{}: does not start with OFF: not an OFF file", name));
  }
  const std::string_view prefix = key.substr(0, key.size() - 3);
  if (prefix.find_first_not_of("STCN") != std::string_view::npos) {
    throw Error(fmt::format("{}: is a '{}' file (vertices of 4 or n dimensions, or binary); mca reads OFF, COFF, NOFF, "
                            "CNOFF and STOFF with three coordinates per vertex: convert it (e.g. with MeshLab)",
                            name, text::utf8_shown(key)));
  }
  std::vector<std::string_view> counts(in.words().begin() + 1, in.words().end());
  if (counts.size() < 2) {
    if (!in.next()) throw Error(fmt::format("{}: the OFF header has no vertex and face counts: the file is cut short", name));
    counts = in.words();
  }
  if (counts.size() < 2) throw Error(fmt::format("{}: the OFF header has no face count: the file is damaged", name));
  const std::uint64_t nv = header_count(counts[0], name, "vertex"), nf = header_count(counts[1], name, "face");
  // The shortest vertex line is "0 0 0\n" (6 bytes), the shortest face "3 0 0 0\n" (8): counts the bytes
  // cannot hold are refused before anything is allocated for them.
  const std::uint64_t least = 6 * nv + 8 * nf;
  if (least > bytes.size()) {
    throw Error(fmt::format("{}: the header declares {} vertices and {} faces, which take at least {} bytes, but the "
                            "file has {}: its counts are wrong or it is cut short",
                            name, nv, nf, least, bytes.size()));
  }
  check(static_cast<double>(nv), static_cast<double>(nf));
  ReadResult r;
  TriMesh& m = r.mesh;
  m.vertices.reserve(nv);
  m.faces.reserve(nf);
  for (std::uint64_t v = 0; v < nv; ++v) {
    if (!in.next()) {
      throw Error(fmt::format("{}: declares {} vertices and {} faces but ends after {} vertices: it is cut short", name,
                              nv, nf, v));
    }
    const auto& w = in.words();
    Point p{};
    for (int a = 0; a < 3; ++a) {
      if (static_cast<std::size_t>(a) >= w.size() || !to_double(w[a], p[a])) {
        throw Error(fmt::format("{}: line {} ('{}'), vertex {} of {}, does not start with three numbers x y z; the "
                                "file is damaged",
                                name, in.number(), in.text(), v, nv));
      }
    }
    m.vertices.push_back(p);
  }
  std::vector<std::uint32_t> corners;
  for (std::uint64_t f = 0; f < nf; ++f) {
    if (!in.next()) throw Error(fmt::format("{}: declares {} faces but ends after {}: it is cut short", name, nf, f));
    const auto& w = in.words();
    std::int64_t k = 0;
    if (!to_integer(w[0], k) || k < 0 || static_cast<std::uint64_t>(k) >= w.size()) {
      throw Error(fmt::format("{}: face {} ('{}') does not list its vertex count and that many vertices; the file is "
                              "damaged",
                              name, f, in.text()));
    }
    corners.clear();
    for (std::int64_t i = 1; i <= k; ++i) {
      std::int64_t idx = 0;
      if (!to_integer(w[i], idx) || idx < 0 || static_cast<std::uint64_t>(idx) >= nv) {
        throw Error(fmt::format("{}: face {} uses vertex '{}', but the file has {} vertices (0 to {}); the file is "
                                "damaged",
                                name, f, w[i], nv, nv == 0 ? 0 : nv - 1));
      }
      corners.push_back(static_cast<std::uint32_t>(idx));
    }
    if (k < 3) ++r.points_and_lines;
    add_polygon(m, corners);
  }
  if (in.next()) {
    throw Error(fmt::format("{}: declares {} faces but has more lines after them ('{}'): its header's counts are "
                            "wrong or the file is damaged",
                            name, nf, in.text()));
  }
  return r;
}

ReadResult read_obj(std::string_view bytes, const std::string& name) {
  Lines in(bytes, name, '#');
  ReadResult r;
  TriMesh& m = r.mesh;
  // Faces are kept as read (indices may point at vertices defined later) and checked at the end.
  std::vector<std::int64_t> face_corners;  // every face's corners, each face ended by 0 (OBJ counts from 1)
  std::vector<std::size_t> face_line;       // the line of each face, for messages
  std::vector<std::uint32_t> corners;
  std::size_t faces = 0;
  while (in.next()) {
    const auto& w = in.words();
    if (w[0] == "v") {
      Point p{};
      for (int a = 0; a < 3; ++a) {
        if (static_cast<std::size_t>(a + 1) >= w.size() || !to_double(w[a + 1], p[a])) {
          throw Error(fmt::format("{}: line {} ('{}'): a vertex needs three numbers, 'v x y z'; the file is damaged",
                                  name, in.number(), in.text()));
        }
      }
      if (m.vertices.size() >= kMaxCount) throw Error(fmt::format("{}: more than 4e9 vertices", name));
      m.vertices.push_back(p);
    } else if (w[0] == "f" || w[0] == "fo") {
      if (w.size() < 4) {
        ++r.points_and_lines;
        continue;
      }
      for (std::size_t k = 1; k < w.size(); ++k) {
        // "v", "v/t", "v//n", "v/t/n": the vertex is the first number.
        const std::string_view c = w[k].substr(0, w[k].find('/'));
        std::int64_t idx = 0;
        if (!to_integer(c, idx)) {
          throw Error(fmt::format("{}: line {} ('{}'): corner '{}' is not a vertex number (1 is the first, -1 the "
                                  "last so far); the file is damaged",
                                  name, in.number(), in.text(), w[k]));
        }
        if (idx == 0) {  // numbered from 0, as some hand-written exporters do
          throw Error(fmt::format("{}: line {} ('{}'): corner '{}' is vertex 0, but an OBJ numbers its vertices from "
                                  "1 (-1 is the last so far): the program that wrote it counted from 0; export it "
                                  "again, or add 1 to every face's vertex numbers",
                                  name, in.number(), in.text(), w[k]));
        }
        if (idx < 0) {  // from the end of the vertices read so far
          idx += static_cast<std::int64_t>(m.vertices.size()) + 1;
          if (idx <= 0) {
            throw Error(fmt::format("{}: line {} ('{}'): corner '{}' counts back past the first vertex ({} read so "
                                    "far); the file is damaged",
                                    name, in.number(), in.text(), w[k], m.vertices.size()));
          }
        }
        face_corners.push_back(idx);
      }
      face_corners.push_back(0);
      face_line.push_back(in.number());
      ++faces;
    } else if (w[0] == "l" || w[0] == "p") {
      ++r.points_and_lines;
    }
  }
  m.faces.reserve(faces);
  std::size_t f = 0;
  for (std::size_t k = 0; k < face_corners.size(); ++k) {
    const std::int64_t idx = face_corners[k];
    if (idx == 0) {
      add_polygon(m, corners);
      corners.clear();
      ++f;
      continue;
    }
    if (static_cast<std::uint64_t>(idx) > m.vertices.size()) {
      throw Error(fmt::format("{}: line {}: a face uses vertex {}, but the file has {} vertices; the file is damaged",
                              name, face_line[f], idx, m.vertices.size()));
    }
    corners.push_back(static_cast<std::uint32_t>(idx - 1));
  }
  return r;
}

namespace {

enum class Type { i8, u8, i16, u16, i32, u32, f32, f64 };

bool type_of(std::string_view t, Type& out) {
  static const std::pair<const char*, Type> names[] = {
      {"char", Type::i8},    {"int8", Type::i8},     {"uchar", Type::u8},   {"uint8", Type::u8},
      {"short", Type::i16},  {"int16", Type::i16},   {"ushort", Type::u16}, {"uint16", Type::u16},
      {"int", Type::i32},    {"int32", Type::i32},   {"uint", Type::u32},   {"uint32", Type::u32},
      {"float", Type::f32},  {"float32", Type::f32}, {"double", Type::f64}, {"float64", Type::f64}};
  for (const auto& [n, ty] : names)
    if (t == n) {
      out = ty;
      return true;
    }
  return false;
}

std::size_t size_of(Type t) {
  switch (t) {
    case Type::i8: case Type::u8: return 1;
    case Type::i16: case Type::u16: return 2;
    case Type::i32: case Type::u32: case Type::f32: return 4;
    case Type::f64: return 8;
  }
  return 1;
}

struct Property {
  std::string name;
  bool list = false;
  Type count{}, item{};  // a list's count and item types; a scalar's type in item
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

// Reads binary values of a PLY body.
class Binary {
 public:
  Binary(std::string_view b, std::size_t at, bool big, const std::string& name) : b_(b), at_(at), big_(big), name_(name) {}
  double value(Type t, const Element& e, std::uint64_t i) {
    const std::size_t n = size_of(t);
    if (at_ + n > b_.size()) {
      throw Error(fmt::format("{}: the data ends inside {} {} of {}: the file is cut short", name_, e.name, i, e.count));
    }
    unsigned char raw[8];
    for (std::size_t k = 0; k < n; ++k) raw[k] = static_cast<unsigned char>(b_[at_ + (big_ ? n - 1 - k : k)]);
    at_ += n;
    switch (t) {
      case Type::i8: { std::int8_t v; std::memcpy(&v, raw, 1); return v; }
      case Type::u8: return raw[0];
      case Type::i16: { std::int16_t v; std::memcpy(&v, raw, 2); return v; }
      case Type::u16: { std::uint16_t v; std::memcpy(&v, raw, 2); return v; }
      case Type::i32: { std::int32_t v; std::memcpy(&v, raw, 4); return v; }
      case Type::u32: { std::uint32_t v; std::memcpy(&v, raw, 4); return v; }
      case Type::f32: { float v; std::memcpy(&v, raw, 4); return v; }
      case Type::f64: { double v; std::memcpy(&v, raw, 8); return v; }
    }
    return 0;
  }
  void skip(std::uint64_t bytes, const Element& e, std::uint64_t i) {
    if (bytes > b_.size() - std::min(at_, b_.size())) {
      throw Error(fmt::format("{}: the data ends inside {} {} of {}: the file is cut short", name_, e.name, i, e.count));
    }
    at_ += bytes;
  }

 private:
  std::string_view b_;
  std::size_t at_;
  bool big_;
  const std::string& name_;
};

}  // namespace

ReadResult read_ply(std::string_view bytes, const std::string& name) {
  // The header (mesh.cpp's check_ply has checked its form and that the body holds what it declares).
  const std::size_t end = bytes.find("\nend_header");
  if (bytes.substr(0, 3) != "ply" || end == std::string_view::npos)
    throw Error(fmt::format("{}: not a PLY file (no 'ply' line or no end_header)", name));
  std::size_t body = bytes.find('\n', end + 1);
  body = body == std::string_view::npos ? bytes.size() : body + 1;
  Lines header(bytes.substr(0, end + 1), name, '\0');
  std::string format;
  std::vector<Element> elements;
  while (header.next()) {
    const auto& w = header.words();
    if (w[0] == "format" && w.size() > 1) {
      format = std::string(w[1]);
    } else if (w[0] == "element" && w.size() > 2) {
      Element e;
      e.name = std::string(w[1]);
      e.count = header_count(w[2], name, e.name.c_str());
      elements.push_back(std::move(e));
    } else if (w[0] == "property" && !elements.empty()) {
      Property p;
      bool ok = false;
      if (w.size() > 4 && w[1] == "list") {
        p.list = true;
        ok = type_of(w[2], p.count) && type_of(w[3], p.item);
        p.name = std::string(w[4]);
      } else if (w.size() > 2) {
        ok = type_of(w[1], p.item);
        p.name = std::string(w[2]);
      }
      if (!ok) throw Error(fmt::format("{}: the PLY header's line '{}' is not a property this reader knows", name, header.text()));
      elements.back().properties.push_back(std::move(p));
    }
  }
  const bool ascii = format == "ascii";
  if (!ascii && format != "binary_little_endian" && format != "binary_big_endian") {
    throw Error(fmt::format("{}: the PLY header's format '{}' is not ascii, binary_little_endian or binary_big_endian",
                            name, format));
  }
  ReadResult r;
  TriMesh& m = r.mesh;
  Lines rows(bytes.substr(body), name, '\0');
  Binary bin(bytes, body, format == "binary_big_endian", name);
  std::vector<std::uint32_t> corners;
  std::vector<double> values;
  for (const Element& e : elements) {
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    int axis[3] = {-1, -1, -1}, list = -1;
    for (std::size_t k = 0; k < e.properties.size(); ++k) {
      const Property& p = e.properties[k];
      if (is_vertex && !p.list && (p.name == "x" || p.name == "y" || p.name == "z")) axis[p.name[0] - 'x'] = static_cast<int>(k);
      if (is_face && p.list && (p.name == "vertex_indices" || p.name == "vertex_index")) list = static_cast<int>(k);
    }
    if (is_vertex && (axis[0] < 0 || axis[1] < 0 || axis[2] < 0)) {
      throw Error(fmt::format("{}: the PLY vertex element has no x, y and z properties", name));
    }
    if (is_vertex) {
      r.float32 = std::any_of(axis, axis + 3,
                              [&](int a) { return e.properties[static_cast<std::size_t>(a)].item == Type::f32; });
      m.vertices.reserve(e.count);
    }
    if (is_face) m.faces.reserve(e.count);
    for (std::uint64_t i = 0; i < e.count; ++i) {
      Point p{};
      corners.clear();
      if (ascii) {
        if (!rows.next()) {
          throw Error(fmt::format("{}: the data ends inside {} {} of {}: the file is cut short", name, e.name, i, e.count));
        }
        const auto& w = rows.words();
        std::size_t at = 0;
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
          const Property& prop = e.properties[k];
          std::int64_t n = 1;
          if (prop.list) {
            if (at >= w.size() || !to_integer(w[at], n) || n < 0 || n > (1 << 20)) {
              throw Error(fmt::format("{}: {} {} has a bad list length; the file is damaged", name, e.name, i));
            }
            ++at;
          }
          for (std::int64_t j = 0; j < n; ++j, ++at) {
            double v = 0;
            if (at >= w.size() || !to_double(w[at], v)) {
              throw Error(fmt::format("{}: {} {} (line '{}') has fewer values than the header declares, or one that is "
                                      "not a number; the file is damaged",
                                      name, e.name, i, rows.text()));
            }
            if (static_cast<int>(k) == list) {
              if (!(v >= 0 && v < static_cast<double>(kMaxCount)) || v != static_cast<double>(static_cast<std::uint32_t>(v))) {
                throw Error(fmt::format("{}: face {} uses vertex '{}'; the file is damaged", name, i, w[at]));
              }
              corners.push_back(static_cast<std::uint32_t>(v));
            }
            for (int a = 0; a < 3; ++a)
              if (static_cast<int>(k) == axis[a]) p[a] = v;
          }
        }
      } else {
        for (std::size_t k = 0; k < e.properties.size(); ++k) {
          const Property& prop = e.properties[k];
          const bool wanted = static_cast<int>(k) == list || static_cast<int>(k) == axis[0] ||
                              static_cast<int>(k) == axis[1] || static_cast<int>(k) == axis[2];
          if (!prop.list) {
            if (!wanted) {
              bin.skip(size_of(prop.item), e, i);
              continue;
            }
            const double v = bin.value(prop.item, e, i);
            for (int a = 0; a < 3; ++a)
              if (static_cast<int>(k) == axis[a]) p[a] = v;
            continue;
          }
          const double n = bin.value(prop.count, e, i);
          if (!(n >= 0 && n <= (1 << 20))) throw Error(fmt::format("{}: {} {} has a bad list length; the file is damaged", name, e.name, i));
          if (!wanted) {
            bin.skip(static_cast<std::uint64_t>(n) * size_of(prop.item), e, i);
            continue;
          }
          for (std::uint64_t j = 0; j < static_cast<std::uint64_t>(n); ++j) {
            const double v = bin.value(prop.item, e, i);
            if (!(v >= 0 && v < static_cast<double>(kMaxCount))) {
              throw Error(fmt::format("{}: face {} uses vertex {}; the file is damaged", name, i, v));
            }
            corners.push_back(static_cast<std::uint32_t>(v));
          }
        }
      }
      if (is_vertex) m.vertices.push_back(p);
      if (is_face) {
        if (corners.size() < 3) ++r.points_and_lines;
        add_polygon(m, corners);
      }
    }
  }
  for (std::size_t f = 0; f < m.faces.size(); ++f)
    for (auto v : m.faces[f])
      if (v >= m.vertices.size()) {
        throw Error(fmt::format("{}: a face uses vertex {}, but the file has {} vertices (0 to {}); the file is damaged",
                                name, v, m.vertices.size(), m.vertices.empty() ? 0 : m.vertices.size() - 1));
      }
  return r;
}

}  // namespace mca::mesh::detail
