#pragma once
// VTK XML writers written by hand (the VTK library would add about 1 GB of packages). Files follow
// the VTK XML format version 1.0 with raw appended binary data and UInt64 block headers, which
// ParaView 5.x and VTK 9 read directly. All files are written atomically (io/output_files.hpp).
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace mca::io {

// One per-point data array. Exactly one of f32 / i32 is set; it holds n_points * components values,
// components interleaved (x0 y0 z0 x1 ...). The writer does not copy or keep the pointer.
struct PointField {
  std::string name;
  int components = 1;
  const float* f32 = nullptr;
  const std::int32_t* i32 = nullptr;
};

// Writes an UnstructuredGrid with one VTK_VERTEX cell per point, so the points render in ParaView
// without a Glyph filter, plus one VTK_LINE cell per entry of `lines` (point index pairs) when given.
// `xyz` holds n_points * 3 floats. Throws std::invalid_argument for an inconsistent field or line
// index and mca::Error when the file cannot be written.
void write_vtu(const std::filesystem::path& path, std::size_t n_points, const float* xyz,
               const std::vector<PointField>& fields,
               const std::vector<std::array<std::uint32_t, 2>>* lines = nullptr);

// Writes a PolyData (.vtp) of triangles: `xyz` n_points * 3 floats, `triangles` point indices, and one Int32
// value per triangle as the cell array `cell_name` (none where `cell_values` is empty). Throws
// std::invalid_argument for an index past the points or a count of values that is not the triangles', and
// mca::Error when the file cannot be written.
void write_vtp(const std::filesystem::path& path, std::size_t n_points, const float* xyz,
               const std::vector<std::array<std::uint32_t, 3>>& triangles, const std::string& cell_name,
               const std::vector<std::int32_t>& cell_values);

// Writes a ParaView Collection (.pvd) listing (time, file) pairs; file names are written as given,
// normally relative to the .pvd's own folder.
void write_pvd(const std::filesystem::path& path,
               const std::vector<std::pair<double, std::string>>& time_and_relative_file);

}  // namespace mca::io
