// Mesh import with Assimp, in the primitive order documented in scene.h.
//
// Only aiProcess_Triangulate and aiProcess_ValidateDataStructure are requested: steps such as
// PreTransformVertices or SortByPType reorder meshes or faces and would break the documented order. The node
// tree is walked here instead, accumulating node transforms (parent * child) into world space.
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "host/error.h"
#include "host/limits.h"
#include "host/scene.h"

namespace rtu::host {
namespace {

// One instance of a node in the depth-first walk, with its world transform.
struct NodeVisit {
  const aiNode* node;
  aiMatrix4x4 world;
};

std::string format_vec(const aiVector3D& v) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "(%g, %g, %g)", double(v.x), double(v.y), double(v.z));
  return buf;
}

std::string mesh_label(const aiScene& scene, unsigned mesh_index) {
  std::string label = "mesh " + std::to_string(mesh_index);
  const aiString& name = scene.mMeshes[mesh_index]->mName;
  if (name.length > 0) label += " ('" + std::string(name.C_Str()) + "')";
  return label;
}

// Calls visit(mesh_index, world) for every mesh instance: a node's meshes in order, then its children in order.
// An explicit stack, so deep node trees cannot overflow the call stack.
template <typename Visit>
void walk_nodes(const aiScene& scene, Visit&& visit) {
  if (!scene.mRootNode) return;
  std::vector<NodeVisit> stack{{scene.mRootNode, scene.mRootNode->mTransformation}};
  while (!stack.empty()) {
    NodeVisit cur = stack.back();
    stack.pop_back();
    for (unsigned i = 0; i < cur.node->mNumMeshes; ++i) visit(cur.node->mMeshes[i], cur.world);
    // Children pushed in reverse so the first child is visited first.
    for (unsigned i = cur.node->mNumChildren; i-- > 0;) {
      const aiNode* child = cur.node->mChildren[i];
      stack.push_back({child, cur.world * child->mTransformation});
    }
  }
}

}  // namespace

std::vector<hw::Triangle> import_mesh(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(path + ": file not found");
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(path + ": not a regular file");
  // Assimp holds the file and its parsed meshes at once (several times the file's bytes for text formats), then
  // the triangles are copied out: refuse a file that cannot fit before reading it.
  const uint64_t file_bytes = std::filesystem::file_size(path, ec);
  if (!ec)
    check_memory(path + ": importing a " + std::to_string(file_bytes >> 20) + " MiB mesh file", 8 * file_bytes);

  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_ValidateDataStructure);
  if (!scene && std::string(importer.GetErrorString()).find("contains no faces") != std::string::npos) {
    // Validation rejects a mesh without faces (e.g. an OBJ of bare vertices: a point cloud). Such a mesh just
    // has no triangles; read again without validation, the checks below cover what this code relies on.
    scene = importer.ReadFile(path, aiProcess_Triangulate);
  }
  if (!scene) throw Error(path + ": " + importer.GetErrorString());

  // First pass: count triangles, so a large mesh is allocated once.
  size_t count = 0;
  walk_nodes(*scene, [&](unsigned mesh_index, const aiMatrix4x4&) {
    if (mesh_index >= scene->mNumMeshes)
      throw Error(path + ": node refers to missing mesh " + std::to_string(mesh_index));
    const aiMesh* mesh = scene->mMeshes[mesh_index];
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) count += mesh->mFaces[f].mNumIndices == 3;
  });

  std::vector<hw::Triangle> triangles;
  triangles.reserve(count);
  const aiMatrix4x4 identity;
  walk_nodes(*scene, [&](unsigned mesh_index, const aiMatrix4x4& world) {
    const aiMesh* mesh = scene->mMeshes[mesh_index];
    const bool transform = !(world == identity);  // exact: an identity node keeps the file's bits
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines
      hw::Vec3 v[3];
      for (int k = 0; k < 3; ++k) {
        const unsigned index = face.mIndices[k];
        if (index >= mesh->mNumVertices) {
          throw Error(path + ": " + mesh_label(*scene, mesh_index) + ", face " + std::to_string(f) +
                      ": index out of range (" + std::to_string(index) +
                      " >= " + std::to_string(mesh->mNumVertices) + " vertices)");
        }
        aiVector3D p = mesh->mVertices[index];
        if (transform) p = world * p;
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
          throw Error(path + ": " + mesh_label(*scene, mesh_index) + ", face " + std::to_string(f) + ", vertex " +
                      std::to_string(index) + ": NaN/Inf coordinate " + format_vec(p));
        }
        v[k] = hw::Vec3(p.x, p.y, p.z);
      }
      triangles.push_back({v[0], v[1], v[2]});
    }
  });
  importer.FreeScene();
  return triangles;
}

}  // namespace rtu::host
