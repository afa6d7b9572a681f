// Mesh files through the importer rtu owns (host/scene/mesh_import.cpp over Assimp): the first byte picks the
// format (byte % 8: OBJ, PLY, OFF, STL, glTF, Collada, DirectX .x, AC3D), the rest is the file. The flat formats
// first; the last four nest (JSON arrays and node trees, XML elements, frames, kids) and reach Assimp's recursive
// parsers, whose stack overflow on deep input mesh_import_process.cpp must report as an Error. Accepted meshes
// give finite triangles; everything else an Error.
#include <cmath>

#include "host/io/error.h"
#include "host/scene/scene.h"
#include "tests/fuzz/fuzz.h"

namespace rtu::fuzz {

int mesh_import(const uint8_t* data, size_t size) {
  init();
  if (size < 1) return 0;
  static const char* const kExt[] = {"obj", "ply", "off", "stl", "gltf", "dae", "x", "ac"};
  const std::string path = scratch_file(std::string("mesh.") + kExt[data[0] % 8], data + 1, size - 1);
  std::vector<hw::Triangle> tris;
  try {
    tris = host::import_mesh(path);
  } catch (const host::Error&) {
    return 0;
  }
  for (const hw::Triangle& t : tris)
    for (const hw::Vec3& v : {t.v0, t.v1, t.v2})
      RTU_FUZZ_CHECK(std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z));
  return 0;
}

}  // namespace rtu::fuzz

RTU_FUZZ_ENTRY(mesh_import)
