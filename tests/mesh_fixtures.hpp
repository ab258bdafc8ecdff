#pragma once
// Meshes the tests make themselves (a cube, a sphere, a torus) and write in every format the loader reads.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/fragment_meshes.hpp"
#include "core/model.hpp"
#include "mesh/mesh.hpp"
#include "mesh/mesh_write.hpp"

namespace mca::test {

// An axis-aligned cube [-h, h]^3 + c, triangles facing outward.
inline mesh::TriMesh cube_mesh(double h, mesh::Point c = {0, 0, 0}) {
  mesh::TriMesh m;
  for (int k = 0; k < 8; ++k) m.vertices.push_back({c[0] + (k & 1 ? h : -h), c[1] + (k & 2 ? h : -h), c[2] + (k & 4 ? h : -h)});
  const std::uint32_t q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q) {
    m.faces.push_back({f[0], f[1], f[2]});
    m.faces.push_back({f[0], f[2], f[3]});
  }
  return m;
}

// A sphere of radius r: an icosahedron subdivided `levels` times, its vertices pushed onto the sphere.
inline mesh::TriMesh sphere_mesh(double r, int levels, mesh::Point c = {0, 0, 0}) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<mesh::Point> v = {{-1, t, 0}, {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  std::vector<mesh::Triangle> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                   {11, 10, 2}, {10, 7, 6}, {7, 1, 8},   {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                                   {3, 8, 9},  {4, 9, 5},  {2, 4, 11},  {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mid;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back({(v[a][0] + v[b][0]) / 2, (v[a][1] + v[b][1]) / 2, (v[a][2] + v[b][2]) / 2});
      return mid[key] = static_cast<std::uint32_t>(v.size() - 1);
    };
    std::vector<mesh::Triangle> g;
    for (const auto& tri : f) {
      const auto a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), cc = midpoint(tri[2], tri[0]);
      g.push_back({tri[0], a, cc});
      g.push_back({tri[1], b, a});
      g.push_back({tri[2], cc, b});
      g.push_back({a, b, cc});
    }
    f = g;
  }
  mesh::TriMesh m;
  for (auto& p : v) {
    const double n = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    m.vertices.push_back({c[0] + r * p[0] / n, c[1] + r * p[1] / n, c[2] + r * p[2] / n});
  }
  m.faces = f;
  return m;
}

// The automata of m labelled piece(position0) in automaton order (0, 1, ...; each label used), as the
// fragments of a run label them.
template <class F>
analysis::Fragments label_pieces(const Model& m, F&& piece) {
  analysis::Fragments f;
  f.id.resize(m.size());
  f.count = 0;
  for (std::size_t a = 0; a < m.size(); ++a) {
    f.id[a] = piece(m.position0[a]);
    f.count = std::max(f.count, f.id[a] + 1);
  }
  return f;
}

// The automata of m labelled by the planes x = cuts[k] (increasing): piece k between cuts k - 1 and k.
inline analysis::Fragments cut_by_x(const Model& m, const std::vector<double>& cuts) {
  analysis::Fragments f = label_pieces(m, [&](const DVec3& p) {
    std::int32_t k = 0;
    while (k < static_cast<std::int32_t>(cuts.size()) && p.x > cuts[static_cast<std::size_t>(k)]) ++k;
    return k;
  });
  f.count = static_cast<std::int32_t>(cuts.size()) + 1;
  return f;
}

// Every automaton of m in one piece (the object whole, as a run's end meshes an unbroken one).
inline analysis::Fragments one_piece(const Model& m) { return cut_by_x(m, {}); }

// Checks that each fragment mesh is closed and manifold with a positive volume; returns their volumes' sum.
inline double closed_volume(const std::vector<analysis::FragmentMesh>& meshes) {
  double sum = 0;
  for (const auto& fm : meshes) {
    const mesh::Topology topo = mesh::topology(fm.mesh);
    EXPECT_EQ(topo.boundary_edges, 0u) << "fragment " << fm.fragment;
    EXPECT_EQ(topo.non_manifold_edges, 0u) << "fragment " << fm.fragment;
    EXPECT_GT(fm.volume, 0);
    sum += fm.volume;
  }
  return sum;
}

// A flat sheet in the plane z = 0 of n x m squares of side a (from the origin), each split into two
// right triangles on its diagonal: an open mesh.
inline mesh::TriMesh sheet_mesh(int n, int m, double a) {
  mesh::TriMesh sheet;
  for (int j = 0; j <= m; ++j)
    for (int i = 0; i <= n; ++i) sheet.vertices.push_back({a * i, a * j, 0.0});
  auto at = [&](int i, int j) { return static_cast<std::uint32_t>(j * (n + 1) + i); };
  for (int j = 0; j < m; ++j)
    for (int i = 0; i < n; ++i) {
      sheet.faces.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      sheet.faces.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  return sheet;
}

// A torus about the z axis: tube radius r, centre-line radius R.
inline mesh::TriMesh torus_mesh(double R, double r, int nu = 64, int nv = 32) {
  mesh::TriMesh m;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      const double u = 2 * std::numbers::pi * i / nu, w = 2 * std::numbers::pi * j / nv;
      m.vertices.push_back({(R + r * std::cos(w)) * std::cos(u), (R + r * std::cos(w)) * std::sin(u), r * std::sin(w)});
    }
  auto at = [&](int i, int j) { return static_cast<std::uint32_t>((i % nu) * nv + (j % nv)); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.faces.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      m.faces.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  return m;
}

// A binary glTF of `json` and, where given, a BIN chunk of `bin` (each padded to 4 bytes as the format asks).
inline std::string glb_of(std::string json, std::string bin = {}) {
  while (json.size() % 4) json += ' ';
  while (bin.size() % 4) bin += '\0';
  std::string b = "glTF";
  auto u32 = [&](std::uint32_t v) { b.append(reinterpret_cast<const char*>(&v), 4); };
  u32(2);
  u32(static_cast<std::uint32_t>(20 + json.size() + (bin.empty() ? 0 : 8 + bin.size())));
  u32(static_cast<std::uint32_t>(json.size()));
  u32(0x4E4F534A);  // "JSON"
  b += json;
  if (!bin.empty()) {
    u32(static_cast<std::uint32_t>(bin.size()));
    u32(0x004E4942);  // "BIN"
    b += bin;
  }
  return b;
}

// The JSON of a glTF of one primitive in one buffer: `vertices` float32 positions (within lo..hi), then
// `indices` uint32 indices; `uri`: the buffer's `, "uri": ...` (empty: a .glb's BIN chunk).
inline std::string gltf_json(std::size_t vertices, std::size_t indices, const mesh::Point& lo, const mesh::Point& hi,
                             const std::string& uri = {}) {
  const std::size_t vbytes = 12 * vertices, ibytes = 4 * indices;
  return fmt::format(
      R"({{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],)"
      R"( "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],)"
      R"( "buffers": [{{"byteLength": {}{}}}],)"
      R"( "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": {}}}, {{"buffer": 0, "byteOffset": {}, "byteLength": {}}}],)"
      R"( "accessors": [{{"bufferView": 0, "componentType": 5126, "count": {}, "type": "VEC3", "min": [{}, {}, {}], "max": [{}, {}, {}]}},)"
      R"( {{"bufferView": 1, "componentType": 5125, "count": {}, "type": "SCALAR"}}]}})",
      vbytes + ibytes, uri, vbytes, vbytes, ibytes, vertices, static_cast<float>(lo[0]), static_cast<float>(lo[1]),
      static_cast<float>(lo[2]), static_cast<float>(hi[0]), static_cast<float>(hi[1]), static_cast<float>(hi[2]),
      indices);
}

// Writes `m` as `path`; the format follows the extension (.off, .obj, .ply: binary; .ascii.ply, .stl:
// binary; .ascii.stl, .gltf, .glb).
inline void write_mesh_file(const std::filesystem::path& path, const mesh::TriMesh& m) {
  const std::string name = path.filename().string();
  auto ends = [&](const std::string& s) { return name.size() >= s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0; };
  std::ofstream out(path, std::ios::binary);
  if (ends(".off")) {
    out << fmt::format("OFF\n{} {} 0\n", m.vertices.size(), m.faces.size());
    for (const auto& v : m.vertices) out << fmt::format("{} {} {}\n", v[0], v[1], v[2]);
    for (const auto& f : m.faces) out << fmt::format("3 {} {} {}\n", f[0], f[1], f[2]);
  } else if (ends(".obj")) {
    mesh::write_obj(out, mesh::to_float(m));
  } else if (ends(".ascii.ply")) {
    out << fmt::format("ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n"
                       "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
                       m.vertices.size(), m.faces.size());
    for (const auto& v : m.vertices) out << fmt::format("{} {} {}\n", v[0], v[1], v[2]);
    for (const auto& f : m.faces) out << fmt::format("3 {} {} {}\n", f[0], f[1], f[2]);
  } else if (ends(".ply")) {
    mesh::write_ply(out, mesh::to_float(m));
  } else if (ends(".ascii.stl")) {
    out << "solid test\n";
    for (const auto& f : m.faces) {
      out << " facet normal 0 0 0\n  outer loop\n";
      for (auto i : f) out << fmt::format("   vertex {} {} {}\n", m.vertices[i][0], m.vertices[i][1], m.vertices[i][2]);
      out << "  endloop\n endfacet\n";
    }
    out << "endsolid test\n";
  } else if (ends(".stl")) {
    const char header[80] = "binary stl written by the mca tests";
    out.write(header, 80);
    const auto n = static_cast<std::uint32_t>(m.faces.size());
    out.write(reinterpret_cast<const char*>(&n), 4);
    for (const auto& f : m.faces) {
      float buf[12] = {0, 0, 0};
      for (int c = 0; c < 3; ++c)
        for (int a = 0; a < 3; ++a) buf[3 + 3 * c + a] = static_cast<float>(m.vertices[f[c]][a]);
      out.write(reinterpret_cast<const char*>(buf), 48);
      const std::uint16_t attr = 0;
      out.write(reinterpret_cast<const char*>(&attr), 2);
    }
  } else if (ends(".gltf") || ends(".glb")) {
    // One buffer: float32 positions, then uint32 indices; .gltf embeds it as base64, .glb as its BIN chunk.
    std::string bin;
    for (const auto& v : m.vertices)
      for (double x : v) {
        const float f = static_cast<float>(x);
        bin.append(reinterpret_cast<const char*>(&f), 4);
      }
    for (const auto& f : m.faces) bin.append(reinterpret_cast<const char*>(f.data()), 12);
    mesh::Bounds b = mesh::bounds(m);
    const bool glb = ends(".glb");
    std::string uri;
    if (!glb) {
      static const char* tbl = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
      std::string enc;
      for (std::size_t i = 0; i < bin.size(); i += 3) {
        const std::uint32_t x = (static_cast<std::uint8_t>(bin[i]) << 16) |
                                (i + 1 < bin.size() ? static_cast<std::uint8_t>(bin[i + 1]) << 8 : 0) |
                                (i + 2 < bin.size() ? static_cast<std::uint8_t>(bin[i + 2]) : 0);
        enc += tbl[(x >> 18) & 63];
        enc += tbl[(x >> 12) & 63];
        enc += i + 1 < bin.size() ? tbl[(x >> 6) & 63] : '=';
        enc += i + 2 < bin.size() ? tbl[x & 63] : '=';
      }
      uri = fmt::format(R"(, "uri": "data:application/octet-stream;base64,{}")", enc);
    }
    const std::string json = gltf_json(m.vertices.size(), 3 * m.faces.size(), b.lo, b.hi, uri);
    if (!glb) out << json;
    else out << glb_of(json, bin);
  }
}

}  // namespace mca::test
