#include "mesh/voxelize.hpp"

#include <mutex>
#include <openvdb/openvdb.h>
#include <openvdb/tools/MeshToVolume.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace mca::mesh {
namespace {

// The mesh as OpenVDB reads it: triangles, corners in the index space of the cell box.
struct Adapter {
  const TriMesh* m;
  const CellBox* box;
  std::size_t polygonCount() const { return m->faces.size(); }
  std::size_t pointCount() const { return m->vertices.size(); }
  std::size_t vertexCount(std::size_t) const { return 3; }
  void getIndexSpacePoint(std::size_t n, std::size_t v, openvdb::Vec3d& pos) const {
    const Point& p = m->vertices[m->faces[n][v]];
    for (int a = 0; a < 3; ++a) pos[a] = (p[a] - box->origin[a]) / box->d;
  }
};

}  // namespace

std::vector<std::uint8_t> interior_cells(const TriMesh& m, const CellBox& box) {
  static std::once_flag once;
  std::call_once(once, [] { openvdb::initialize(); });
  const auto xform = openvdb::math::Transform::createLinearTransform(box.d);
  // A band of 3 cells each side: the sign is flood-filled from there through the rest of the grid.
  const auto grid = openvdb::tools::meshToVolume<openvdb::FloatGrid>(Adapter{&m, &box}, *xform, 3.0f, 3.0f);
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
