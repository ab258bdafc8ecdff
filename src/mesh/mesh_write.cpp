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

void write_ply(std::ostream& out, const FloatMesh& m) {
  const bool values = !m.face_values.empty();
  out << "ply\nformat binary_little_endian 1.0\ncomment written by mca\n";
  out << fmt::format("element vertex {}\nproperty float x\nproperty float y\nproperty float z\n", m.vertices.size());
  out << fmt::format("element face {}\nproperty list uchar int vertex_indices\n", m.faces.size());
  if (values) out << fmt::format("property int {}\n", m.face_value_name);
  out << "end_header\n";
  std::string buf;
  buf.reserve(m.vertices.size() * 12);
  for (const auto& v : m.vertices) buf.append(reinterpret_cast<const char*>(v.data()), 12);
  out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  buf.clear();
  for (std::size_t f = 0; f < m.faces.size(); ++f) {
    buf.push_back(3);
    for (auto i : m.faces[f]) {
      const auto s = static_cast<std::int32_t>(i);
      buf.append(reinterpret_cast<const char*>(&s), 4);
    }
    if (values) buf.append(reinterpret_cast<const char*>(&m.face_values[f]), 4);
  }
  out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
}

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
