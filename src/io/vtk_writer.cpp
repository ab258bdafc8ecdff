#include "io/vtk_writer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <limits>
#include <ostream>
#include <stdexcept>

#include "io/output_files.hpp"

namespace mca::io {

// The raw appended blocks are the in-memory bytes, declared byte_order="LittleEndian".
static_assert(std::endian::native == std::endian::little, "vtk_writer assumes a little-endian host");

namespace {

constexpr std::uint8_t kVtkVertex = 1;
constexpr std::uint8_t kVtkLine = 3;

std::string xml_escape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

// One appended block: where it starts (relative to the byte after '_') and what it holds.
struct Block {
  const void* data;
  std::uint64_t bytes;
};

class Appended {
 public:
  // Returns the offset attribute for a block about to be added.
  std::uint64_t add(const void* data, std::uint64_t bytes) {
    const std::uint64_t offset = end_;
    blocks_.push_back({data, bytes});
    end_ += sizeof(std::uint64_t) + bytes;
    return offset;
  }
  void write(std::ostream& out) const {
    for (const Block& b : blocks_) {
      out.write(reinterpret_cast<const char*>(&b.bytes), sizeof b.bytes);
      if (b.bytes > 0) out.write(static_cast<const char*>(b.data), static_cast<std::streamsize>(b.bytes));
    }
  }

 private:
  std::vector<Block> blocks_;
  std::uint64_t end_ = 0;
};

// Writes `xml` (a file's head up to its piece's last element) closed as a `type` file, then the appended
// blocks, through a temporary name.
void write_appended_file(const std::filesystem::path& path, std::string xml, const char* type,
                         const Appended& appended) {
  xml += "    </Piece>\n";
  xml += fmt::format("  </{}>\n", type);
  xml += "  <AppendedData encoding=\"raw\">\n   _";
  write_file_atomic(path, [&](std::ostream& out) {
    out.write(xml.data(), static_cast<std::streamsize>(xml.size()));
    appended.write(out);
    out << "\n  </AppendedData>\n</VTKFile>\n";
  });
}

// Connectivity, offsets and cell types of the vertex cells followed by the line cells.
template <class Index>
struct Cells {
  std::vector<Index> connectivity, offsets;
  std::vector<std::uint8_t> types;

  Cells(std::size_t n_points, const std::vector<std::array<std::uint32_t, 2>>* lines) {
    const std::size_t n_lines = lines ? lines->size() : 0;
    connectivity.resize(n_points + 2 * n_lines);
    offsets.resize(n_points + n_lines);
    types.resize(n_points + n_lines);
    for (std::size_t i = 0; i < n_points; ++i) {
      connectivity[i] = static_cast<Index>(i);
      offsets[i] = static_cast<Index>(i + 1);  // VTK XML offsets are end positions, no leading 0
    }
    std::fill(types.begin(), types.begin() + static_cast<std::ptrdiff_t>(n_points), kVtkVertex);
    for (std::size_t k = 0; k < n_lines; ++k) {
      const auto& l = (*lines)[k];
      connectivity[n_points + 2 * k] = static_cast<Index>(l[0]);
      connectivity[n_points + 2 * k + 1] = static_cast<Index>(l[1]);
      offsets[n_points + k] = static_cast<Index>(n_points + 2 * k + 2);
    }
    std::fill(types.begin() + static_cast<std::ptrdiff_t>(n_points), types.end(), kVtkLine);
  }
};

template <class Index>
void write_vtu_impl(const std::filesystem::path& path, std::size_t n_points, const float* xyz,
                    const std::vector<PointField>& fields,
                    const std::vector<std::array<std::uint32_t, 2>>* lines, const char* index_type) {
  const Cells<Index> cells(n_points, lines);
  Appended appended;
  std::string xml;
  xml.reserve(2048);
  xml += "<?xml version=\"1.0\"?>\n";
  xml += "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\">\n";
  xml += "  <UnstructuredGrid>\n";
  xml += fmt::format("    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n", n_points,
                     cells.types.size());
  xml += "      <PointData>\n";
  for (const PointField& f : fields) {
    const auto count = static_cast<std::uint64_t>(n_points) * static_cast<std::uint64_t>(f.components);
    const bool is_float = f.f32 != nullptr;
    const std::uint64_t offset =
        is_float ? appended.add(f.f32, count * sizeof(float)) : appended.add(f.i32, count * sizeof(std::int32_t));
    xml += fmt::format(
        "        <DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\" format=\"appended\" "
        "offset=\"{}\"/>\n",
        is_float ? "Float32" : "Int32", xml_escape(f.name), f.components, offset);
  }
  xml += "      </PointData>\n";
  xml += "      <Points>\n";
  xml += fmt::format(
      "        <DataArray type=\"Float32\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" "
      "offset=\"{}\"/>\n",
      appended.add(xyz, static_cast<std::uint64_t>(n_points) * 3 * sizeof(float)));
  xml += "      </Points>\n";
  xml += "      <Cells>\n";
  const auto cell_array = [&](const char* type, const char* name, const void* data, std::uint64_t bytes) {
    xml += fmt::format(
        "        <DataArray type=\"{}\" Name=\"{}\" format=\"appended\" offset=\"{}\"/>\n", type, name,
        appended.add(data, bytes));
  };
  cell_array(index_type, "connectivity", cells.connectivity.data(), cells.connectivity.size() * sizeof(Index));
  cell_array(index_type, "offsets", cells.offsets.data(), cells.offsets.size() * sizeof(Index));
  cell_array("UInt8", "types", cells.types.data(), cells.types.size());
  xml += "      </Cells>\n";
  write_appended_file(path, xml, "UnstructuredGrid", appended);
}

}  // namespace

void write_vtu(const std::filesystem::path& path, std::size_t n_points, const float* xyz,
               const std::vector<PointField>& fields,
               const std::vector<std::array<std::uint32_t, 2>>* lines) {
  if (n_points > 0 && xyz == nullptr) throw std::invalid_argument("write_vtu: xyz is null");
  for (const PointField& f : fields) {
    if (f.name.empty()) throw std::invalid_argument("write_vtu: a point field has no name");
    if ((f.f32 == nullptr) == (f.i32 == nullptr) && n_points > 0)
      throw std::invalid_argument(
          fmt::format("write_vtu: field '{}' must set exactly one of f32 and i32", f.name));
    if (f.components < 1)
      throw std::invalid_argument(fmt::format("write_vtu: field '{}' has {} components", f.name, f.components));
  }
  // A bad index would make ParaView read past its point array, so catch it here.
  if (lines)
    for (const auto& l : *lines)
      if (l[0] >= n_points || l[1] >= n_points)
        throw std::invalid_argument(
            fmt::format("write_vtu: line ({}, {}) refers past {} points", l[0], l[1], n_points));

  // Int32 indices halve the cell arrays; Int64 only when the connectivity could overflow them.
  const std::size_t n_conn = n_points + 2 * (lines ? lines->size() : 0);
  if (n_conn <= static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
    write_vtu_impl<std::int32_t>(path, n_points, xyz, fields, lines, "Int32");
  else
    write_vtu_impl<std::int64_t>(path, n_points, xyz, fields, lines, "Int64");
}

void write_vtp(const std::filesystem::path& path, std::size_t n_points, const float* xyz,
               const std::vector<std::array<std::uint32_t, 3>>& triangles, const std::string& cell_name,
               const std::vector<std::int32_t>& cell_values) {
  if (n_points > 0 && xyz == nullptr) throw std::invalid_argument("write_vtp: xyz is null");
  if (!cell_values.empty() && cell_values.size() != triangles.size())
    throw std::invalid_argument(fmt::format("write_vtp: {} values for {} triangles", cell_values.size(), triangles.size()));
  for (const auto& t : triangles)
    if (t[0] >= n_points || t[1] >= n_points || t[2] >= n_points)
      throw std::invalid_argument(fmt::format("write_vtp: triangle ({}, {}, {}) refers past {} points", t[0], t[1], t[2],
                                              n_points));
  // (Int64 connectivity: three indices a triangle, beyond Int32 only in meshes no one writes, and one type.)
  std::vector<std::int64_t> connectivity(3 * triangles.size()), offsets(triangles.size());
  for (std::size_t k = 0; k < triangles.size(); ++k) {
    for (int c = 0; c < 3; ++c) connectivity[3 * k + c] = triangles[k][c];
    offsets[k] = static_cast<std::int64_t>(3 * k + 3);
  }
  Appended appended;
  std::string xml;
  xml += "<?xml version=\"1.0\"?>\n";
  xml += "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n";
  xml += "  <PolyData>\n";
  xml += fmt::format("    <Piece NumberOfPoints=\"{}\" NumberOfVerts=\"0\" NumberOfLines=\"0\" NumberOfStrips=\"0\" "
                     "NumberOfPolys=\"{}\">\n",
                     n_points, triangles.size());
  if (!cell_values.empty()) {
    xml += "      <CellData>\n";
    xml += fmt::format("        <DataArray type=\"Int32\" Name=\"{}\" format=\"appended\" offset=\"{}\"/>\n",
                       xml_escape(cell_name), appended.add(cell_values.data(), cell_values.size() * sizeof(std::int32_t)));
    xml += "      </CellData>\n";
  }
  xml += "      <Points>\n";
  xml += fmt::format("        <DataArray type=\"Float32\" Name=\"Points\" NumberOfComponents=\"3\" format=\"appended\" "
                     "offset=\"{}\"/>\n",
                     appended.add(xyz, static_cast<std::uint64_t>(n_points) * 3 * sizeof(float)));
  xml += "      </Points>\n";
  xml += "      <Polys>\n";
  xml += fmt::format("        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" offset=\"{}\"/>\n",
                     appended.add(connectivity.data(), connectivity.size() * sizeof(std::int64_t)));
  xml += fmt::format("        <DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"{}\"/>\n",
                     appended.add(offsets.data(), offsets.size() * sizeof(std::int64_t)));
  xml += "      </Polys>\n";
  write_appended_file(path, xml, "PolyData", appended);
}

void write_pvd(const std::filesystem::path& path,
               const std::vector<std::pair<double, std::string>>& time_and_relative_file) {
  std::string xml;
  xml += "<?xml version=\"1.0\"?>\n";
  xml += "<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n";
  xml += "  <Collection>\n";
  for (const auto& [time, file] : time_and_relative_file)
    // {} prints the shortest form that reads back to the same double.
    xml += fmt::format("    <DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{}\"/>\n", time,
                       xml_escape(file));
  xml += "  </Collection>\n";
  xml += "</VTKFile>\n";
  write_file_atomic(path, [&](std::ostream& out) { out.write(xml.data(), static_cast<std::streamsize>(xml.size())); },
                    false);
}

}  // namespace mca::io
