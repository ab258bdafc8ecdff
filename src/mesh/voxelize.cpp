#include "mesh/voxelize.hpp"

#include <cmath>
#include <mutex>
#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace mca::mesh {
namespace {

// The mesh as OpenVDB reads it: triangles, corners in the index space of the cell box.
struct Adapter {
  const TriMesh* m;
  const CellBox* box;
  const std::vector<std::uint32_t>* faces = nullptr;  // a subset of m's triangles, or all
  std::size_t polygonCount() const { return faces ? faces->size() : m->faces.size(); }
  std::size_t pointCount() const { return m->vertices.size(); }
  std::size_t vertexCount(std::size_t) const { return 3; }
  void getIndexSpacePoint(std::size_t n, std::size_t v, openvdb::Vec3d& pos) const {
    const Point& p = m->vertices[m->faces[faces ? (*faces)[n] : n][v]];
    for (int a = 0; a < 3; ++a) {
      pos[a] = (p[a] - box->origin[a]) / box->d;
      if (std::fabs(pos[a] - std::nearbyint(pos[a])) < 1e-6) pos[a] = std::nearbyint(pos[a]) - kTieShift;
    }
  }
  // A cell centre on a face is inside on the face's low side along each axis and outside on its high side,
  // as a box's cells are [min, max): a corner on a plane of cell centres is moved down by this share of a
  // cell (float's rounding of index coordinates is under a tenth of it below 8,000 cells; a corner off those
  // planes, every one of a curved mesh, stays). The distance of a centre on the face came out of OpenVDB's
  // float arithmetic as either sign: a cube of 0.5 m beside one of 0.6 m in one file, at a spacing of 0.1,
  // took 6 x 6 x 5 cells (a hostile review, 2026-12-07).
  static constexpr double kTieShift = 1e-3;
};

// The grid's voxel size: the cell's, or 1 (distances in cells) for cells under 0.1 mm, which OpenVDB cannot
// take (it refuses a voxel whose volume is under 3e-15: "ArithmeticError: Non-zero scale values required",
// every volume fill at a spacing of 1e-5 m and below). The points are given in cells either way (Adapter).
double grid_scale(const CellBox& box) { return box.d >= 1e-4 ? box.d : 1.0; }

openvdb::FloatGrid::Ptr distance_grid(const TriMesh& m, const CellBox& box, float band,
                                      const std::vector<std::uint32_t>* faces = nullptr) {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
  const auto xform = openvdb::math::Transform::createLinearTransform(grid_scale(box));
  // Each triangle once: the same three vertices give the same distances, and OpenVDB voxelizes every copy
  // (a cube of 12 triangles each given 300,000 times took 201 s to fill, against 0.9 s for a sphere of
  // 359,000 triangles).
  const std::vector<std::uint32_t> unique = unique_triangles(m, faces);
  // The sign is flood-filled from the band through the rest of the grid.
  return openvdb::tools::meshToVolume<openvdb::FloatGrid>(Adapter{&m, &box, &unique}, *xform, band, band);
}

}  // namespace

struct SignedDistance::Grid {
  openvdb::FloatGrid::Ptr grid;
  float unit;  // the mesh's units per unit of the grid's values (grid_scale)
};

SignedDistance::SignedDistance(const TriMesh& m, const CellBox& box, float band)
    : grid_(std::make_unique<Grid>(
          Grid{distance_grid(m, box, band), grid_scale(box) == 1.0 ? static_cast<float>(box.d) : 1.0f})) {}

SignedDistance::~SignedDistance() = default;

float SignedDistance::at(std::int64_t i, std::int64_t j, std::int64_t k) const {
  // The tree's own lookup (a ValueAccessor would be faster but is not safe to share between threads).
  const float v =
      grid_->grid->tree().getValue(openvdb::Coord(static_cast<int>(i), static_cast<int>(j), static_cast<int>(k)));
  return grid_->unit == 1.0f ? v : v * grid_->unit;
}

TriMesh polygonize(const CellBox& box, const std::function<void(std::int64_t k, float* values)>& plane) {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
  // The field is in cells, clamped to +-2: 2 outside (the background), -2 deep inside. Stored are the voxels
  // between, and those at +-2 beside a voxel of another value (a field that jumps from -2 to 2 between two
  // voxels keeps both); the sign flood fill then makes the rest of the inside tiles of -2. The grid holds
  // the values a grid of every inside voxel holds, in memory that grows with the surface, not the volume.
  // The planes are made a chunk at a time, with the plane on either side (made twice: the same values).
  auto grid = openvdb::FloatGrid::create(2.0f);
  {
    const std::int64_t nx = box.n[0], ny = box.n[1], nz = box.n[2];
    constexpr std::int64_t kChunk = 32;
    const auto per_plane = static_cast<std::size_t>(nx * ny);
    std::vector<float> slab((kChunk + 2) * per_plane);
    auto acc = grid->getAccessor();
    for (std::int64_t k0 = 0; k0 < nz; k0 += kChunk) {
      const std::int64_t k1 = std::min(nz, k0 + kChunk);
      const std::int64_t lo = std::max<std::int64_t>(0, k0 - 1), hi = std::min(nz, k1 + 1);  // planes held
      tbb::parallel_for(lo, hi, [&](std::int64_t k) { plane(k, slab.data() + static_cast<std::size_t>(k - lo) * per_plane); });
      const auto side = [&](std::int64_t i, std::int64_t j, std::int64_t k) {  // -1 inside, 1 outside, 0 between
        if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return 1;  // beyond the box: outside
        const float f = slab[static_cast<std::size_t>(k - lo) * per_plane + static_cast<std::size_t>(j * nx + i)];
        return f <= -2.0f ? -1 : f >= 2.0f ? 1 : 0;
      };
      for (std::int64_t k = k0; k < k1; ++k)
        for (std::int64_t j = 0; j < ny; ++j)
          for (std::int64_t i = 0; i < nx; ++i) {
            const int own = side(i, j, k);
            if (own == 0 || side(i - 1, j, k) != own || side(i + 1, j, k) != own || side(i, j - 1, k) != own ||
                side(i, j + 1, k) != own || side(i, j, k - 1) != own || side(i, j, k + 1) != own)
              acc.setValue(openvdb::Coord(static_cast<int>(i), static_cast<int>(j), static_cast<int>(k)),
                           slab[static_cast<std::size_t>(k - lo) * per_plane + static_cast<std::size_t>(j * nx + i)]);
            // A field not outside on the box's outer voxels (a shell piece reaching past its box) is closed
            // by the background beyond: those voxels are stored at 2, so that the fill does not carry the
            // inside's sign past the box (it opened shell pieces there).
            if (own == 1 || (i > 0 && j > 0 && k > 0 && i < nx - 1 && j < ny - 1 && k < nz - 1)) continue;
            for (std::int64_t dk = -1; dk <= 1; ++dk)
              for (std::int64_t dj = -1; dj <= 1; ++dj)
                for (std::int64_t di = -1; di <= 1; ++di) {
                  const std::int64_t a = i + di, b = j + dj, c = k + dk;
                  if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz)
                    acc.setValue(openvdb::Coord(static_cast<int>(a), static_cast<int>(b), static_cast<int>(c)), 2.0f);
                }
          }
    }
  }
  openvdb::tools::signedFloodFill(grid->tree());
  std::vector<openvdb::Vec3s> points;
  std::vector<openvdb::Vec3I> triangles;
  std::vector<openvdb::Vec4I> quads;
  openvdb::tools::volumeToMesh(*grid, points, triangles, quads, 0.0, 0.0);
  TriMesh out;
  out.vertices.reserve(points.size());
  for (const auto& p : points)
    out.vertices.push_back({box.origin[0] + p[0] * box.d, box.origin[1] + p[1] * box.d, box.origin[2] + p[2] * box.d});
  for (const auto& t : triangles) out.faces.push_back({t[0], t[1], t[2]});
  for (const auto& q : quads) {  // split along the shorter diagonal
    auto dist2 = [&](unsigned a, unsigned b) {
      double s = 0;
      for (int x = 0; x < 3; ++x) s += (out.vertices[a][x] - out.vertices[b][x]) * (out.vertices[a][x] - out.vertices[b][x]);
      return s;
    };
    if (dist2(q[0], q[2]) <= dist2(q[1], q[3])) {
      out.faces.push_back({q[0], q[1], q[2]});
      out.faces.push_back({q[0], q[2], q[3]});
    } else {
      out.faces.push_back({q[0], q[1], q[3]});
      out.faces.push_back({q[1], q[2], q[3]});
    }
  }
  if (signed_volume(out) < 0)
    for (auto& f : out.faces) std::swap(f[1], f[2]);
  return out;
}

bool feature_point(const Point* at, const Point* normal, int n, double flat, const Point& lo, const Point& hi, Point& x) {
  Point mean{0, 0, 0};
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) mean[c] += at[i][c] / n;
  // A x = b about the mean: A = sum n n^T, b = sum n (n . (p - mean)).
  openvdb::math::Mat3d A = openvdb::math::Mat3d::zero();
  openvdb::math::Vec3d b(0, 0, 0);
  for (int i = 0; i < n; ++i) {
    const openvdb::math::Vec3d nn(normal[i][0], normal[i][1], normal[i][2]);
    const double along = nn[0] * (at[i][0] - mean[0]) + nn[1] * (at[i][1] - mean[1]) + nn[2] * (at[i][2] - mean[2]);
    for (int r = 0; r < 3; ++r) {
      b[r] += nn[r] * along;
      for (int c = 0; c < 3; ++c) A(r, c) += nn[r] * nn[c];
    }
  }
  openvdb::math::Mat3d Q;  // its columns the eigenvectors
  openvdb::math::Vec3d D;
  if (n == 0 || !openvdb::math::diagonalizeSymmetricMatrix(A, Q, D)) return false;
  const double strongest = std::max({D[0], D[1], D[2]});
  if (!(strongest > 0)) return false;
  bool held[3];
  int free = 0;
  for (int e = 0; e < 3; ++e) free += !(held[e] = D[e] >= flat * strongest);
  x = mean;
  for (int e = 0; e < 3; ++e) {
    if (!held[e]) continue;
    const double k = (Q(0, e) * b[0] + Q(1, e) * b[1] + Q(2, e) * b[2]) / D[e];
    for (int c = 0; c < 3; ++c) x[c] += k * Q(c, e);
  }
  const auto in_box = [&] {
    for (int c = 0; c < 3; ++c)
      if (!(x[c] >= lo[c] && x[c] <= hi[c])) return false;
    return true;
  };
  if (in_box()) return true;
  if (free != 1) return false;  // a corner or a plane's point beyond the box
  // Along the line (the free direction u) to the part of it in the box nearest the mean, if it crosses it.
  int e = 0;
  while (held[e]) ++e;
  double s_lo = -INFINITY, s_hi = INFINITY;
  for (int c = 0; c < 3; ++c) {
    const double u = Q(c, e);
    if (u == 0) {
      if (!(x[c] >= lo[c] && x[c] <= hi[c])) return false;
      continue;
    }
    const double s0 = (lo[c] - x[c]) / u, s1 = (hi[c] - x[c]) / u;
    s_lo = std::max(s_lo, std::min(s0, s1));
    s_hi = std::min(s_hi, std::max(s0, s1));
  }
  if (!(s_lo <= s_hi)) return false;
  const double s = std::clamp(0.0, s_lo, s_hi);
  for (int c = 0; c < 3; ++c) x[c] = std::clamp(x[c] + s * Q(c, e), lo[c], hi[c]);  // (the clamp: rounding)
  return true;
}

std::vector<std::uint8_t> interior_cells(const TriMesh& m, const CellBox& box, const std::vector<std::uint32_t>* faces) {
  // A band of 3 cells each side.
  const auto grid = distance_grid(m, box, 3.0f, faces);
  std::vector<std::uint8_t> inside(static_cast<std::size_t>(box.cells()), 0);
  const std::int64_t nx = box.n[0], ny = box.n[1];
  tbb::parallel_for(tbb::blocked_range<std::int64_t>(0, box.n[2]), [&](const tbb::blocked_range<std::int64_t>& r) {
    auto acc = grid->getConstAccessor();
    for (std::int64_t k = r.begin(); k < r.end(); ++k)
      for (std::int64_t j = 0; j < ny; ++j) {
        std::uint8_t* row = inside.data() + (k * ny + j) * nx;
        for (std::int64_t i = 0; i < nx; ++i)
          row[i] = acc.getValue(openvdb::Coord(static_cast<int>(i), static_cast<int>(j), static_cast<int>(k))) < 0.0f;
      }
  });
  return inside;
}

}  // namespace mca::mesh
