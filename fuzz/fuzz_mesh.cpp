// libFuzzer target: the mesh loader, mca::mesh::read_mesh_memory (bytes -> TriMesh, through assimp),
// then what is computed from a loaded mesh (bounds, topology, signed_volume, shells).
//
// Input layout: byte 0 picks the format, (byte 0 % 6) indexes kExtensions below; the rest of the input is
// the file. The seeds in fuzz/seeds/mesh/ start with the ASCII digits '0'..'5' (0x30..0x35, which are
// 0..5 mod 6), so "3OFF\n..." is an OFF file.
//
// Bad input must end in mca::Error; anything else (another exception, a crash, a hang, a leak,
// undefined behaviour) is a finding. assimp itself is Debian's uninstrumented libassimp.so: memory errors
// inside it are seen only where they crash or touch memory our code allocated.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <mca/error.hpp>

#include "mesh/mesh.hpp"

namespace {

const char* const kExtensions[6] = {"obj", "ply", "stl", "off", "gltf", "glb"};

[[noreturn]] void die(const char* what) {
  std::fprintf(stderr, "fuzz_mesh: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string extension = kExtensions[data[0] % 6];
  mca::mesh::TriMesh mesh;
  try {
    mesh = mca::mesh::read_mesh_memory(data + 1, size - 1, extension, "fuzz." + extension);
  } catch (const mca::Error&) {
    return 0;  // refused with a message: the expected outcome for bad input
  }
  // What read_mesh_memory promises about an accepted mesh.
  if (mesh.vertices.empty() || mesh.faces.empty()) die("an accepted mesh has no vertices or no triangles");
  for (const auto& p : mesh.vertices) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) die("an accepted vertex is not finite");
  }
  for (const auto& f : mesh.faces) {
    for (const auto v : f) {
      if (v >= mesh.vertices.size()) die("a triangle uses a vertex index past the vertices");
    }
  }
  // The functions run on every loaded mesh (no finite check: a mesh spanning +-1e308 may overflow them).
  const mca::mesh::Bounds b = mca::mesh::bounds(mesh);
  (void)b.largest_extent();
  const mca::mesh::Topology t = mca::mesh::topology(mesh);
  if (t.degenerate_faces > mesh.faces.size() || t.boundary_edges > t.edges || t.non_manifold_edges > t.edges) {
    die("topology counts are inconsistent");
  }
  (void)t.closed();
  (void)mca::mesh::signed_volume(mesh);
  std::size_t shell_faces = 0;
  for (const mca::mesh::Shell& sh : mca::mesh::shells(mesh)) {
    for (const auto f : sh.faces) {
      if (f >= mesh.faces.size()) die("a shell lists a triangle past the triangles");
    }
    shell_faces += sh.faces.size();
  }
  if (shell_faces != mesh.faces.size()) die("the shells do not hold every triangle once");
  return 0;
}
