#include "mesh/mesh_write.hpp"

#include <algorithm>
#include <bit>
#include <fmt/format.h>

namespace mca::mesh {
namespace {
static_assert(std::endian::native == std::endian::little, "the PLY writer writes the machine's byte order");

template <class T>
void put(std::ostream& out, T v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof v);
}
}  // namespace

FloatMesh to_float(const TriMesh& m) {
  FloatMesh f;
  f.vertices.reserve(m.vertices.size());
  for (const auto& v : m.vertices)
    f.vertices.push_back({static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])});
  f.faces = m.faces;
  return f;
}

namespace {
// A binary PLY of the vertices' type (float or double) and int32 triangles, with the optional face values.
template <class Coordinate>
void write_ply_of(std::ostream& out, const std::vector<std::array<Coordinate, 3>>& vertices,
                  const std::vector<std::array<std::uint32_t, 3>>& faces, const std::vector<std::int32_t>& face_values,
                  const std::string& face_value_name) {
  static_assert(sizeof(std::array<Coordinate, 3>) == 3 * sizeof(Coordinate));
  const char* type = sizeof(Coordinate) == 4 ? "float" : "double";
  const bool values = !face_values.empty();
  out << "ply\nformat binary_little_endian 1.0\ncomment written by mca\n";
  out << fmt::format("element vertex {}\nproperty {} x\nproperty {} y\nproperty {} z\n", vertices.size(), type, type, type);
  out << fmt::format("element face {}\nproperty list uchar int vertex_indices\n", faces.size());
  if (values) out << fmt::format("property int {}\n", face_value_name);
  out << "end_header\n";
  std::string buf;
  buf.reserve(vertices.size() * 3 * sizeof(Coordinate));
  for (const auto& v : vertices) buf.append(reinterpret_cast<const char*>(v.data()), 3 * sizeof(Coordinate));
  out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  buf.clear();
  for (std::size_t f = 0; f < faces.size(); ++f) {
    buf.push_back(3);
    for (auto i : faces[f]) {
      const auto s = static_cast<std::int32_t>(i);
      buf.append(reinterpret_cast<const char*>(&s), 4);
    }
    if (values) buf.append(reinterpret_cast<const char*>(&face_values[f]), 4);
  }
  out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}
}  // namespace

void write_ply(std::ostream& out, const FloatMesh& m) {
  write_ply_of(out, m.vertices, m.faces, m.face_values, m.face_value_name);
}

void write_ply(std::ostream& out, const TriMesh& m) { write_ply_of(out, m.vertices, m.faces, {}, ""); }

void write_obj(std::ostream& out, const FloatMesh& m) {
  out << "# written by mca\n";
  fmt::memory_buffer b;
  for (const auto& v : m.vertices) fmt::format_to(std::back_inserter(b), "v {} {} {}\n", v[0], v[1], v[2]);
  // One group per face value (fragments become separate objects in Blender's importer): the faces in
  // order of value, each value's in their own order.
  std::vector<std::uint32_t> order(m.faces.size());
  for (std::size_t f = 0; f < order.size(); ++f) order[f] = static_cast<std::uint32_t>(f);
  if (!m.face_values.empty())
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return m.face_values[a] < m.face_values[b]; });
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::uint32_t f = order[k];
    if (!m.face_values.empty() && (k == 0 || m.face_values[f] != m.face_values[order[k - 1]]))
      fmt::format_to(std::back_inserter(b), "g {}_{}\n", m.face_value_name, m.face_values[f]);
    const auto& t = m.faces[f];
    fmt::format_to(std::back_inserter(b), "f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
  }
  out.write(b.data(), static_cast<std::streamsize>(b.size()));
}

}  // namespace mca::mesh
