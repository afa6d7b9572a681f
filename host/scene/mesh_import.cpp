// Mesh import with Assimp, in the primitive order documented in scene.h.
//
// Only aiProcess_Triangulate and aiProcess_ValidateDataStructure are requested: steps such as
// PreTransformVertices or SortByPType reorder meshes or faces and would break the documented order. The node
// tree is walked here instead, accumulating node transforms (parent * child) into world space.
//
// Hardening (docs/guide/hardening.md): files beyond the memory budget are refused before reading; PLY, OFF and
// glTF headers are checked first (mesh_import_checks.cpp; Assimp 5.2 loops for ever on some PLY headers); Assimp
// itself runs in a child process (mesh_import_process.cpp), so a file on which it aborts, hangs
// (RTU_IMPORT_TIMEOUT) or leaks costs an Error, never rtusim. In the child it runs on a stack of known size, so
// that a file nested too deeply for Assimp's recursive parsers is named as such (import_on_stack). This file holds
// the child's side, the Assimp scene into a blob; mesh_import_decode.cpp the parent's, the blob into the model.
#include <assimp/GltfMaterial.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Importer.hpp>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <new>
#include <string>
#include <vector>

#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/limits.h"
#include "host/scene/mesh_import_internal.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/instancing.h"

namespace rtu::host {
namespace mesh_detail {
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

RawMaterial raw_material(const aiMaterial& m) {
  RawMaterial r;
  aiColor4D c;
  if (m.Get(AI_MATKEY_BASE_COLOR, c) == AI_SUCCESS) {
    r.base[0] = c.r, r.base[1] = c.g, r.base[2] = c.b, r.base[3] = c.a;
  } else if (m.Get(AI_MATKEY_COLOR_DIFFUSE, c) == AI_SUCCESS) {
    r.base[0] = c.r, r.base[1] = c.g, r.base[2] = c.b;
    float opacity = 1.0f;
    if (m.Get(AI_MATKEY_OPACITY, opacity) == AI_SUCCESS) r.base[3] = opacity;
  }
  m.Get(AI_MATKEY_METALLIC_FACTOR, r.metallic);
  m.Get(AI_MATKEY_ROUGHNESS_FACTOR, r.roughness);
  aiColor3D e;
  if (m.Get(AI_MATKEY_COLOR_EMISSIVE, e) == AI_SUCCESS) {
    float strength = 1.0f;
    m.Get(AI_MATKEY_EMISSIVE_INTENSITY, strength);
    r.emission[0] = e.r * strength, r.emission[1] = e.g * strength, r.emission[2] = e.b * strength;
  }
  m.Get(AI_MATKEY_TRANSMISSION_FACTOR, r.transmission);
  m.Get(AI_MATKEY_REFRACTI, r.ior);
  aiString mode;
  if (m.Get(AI_MATKEY_GLTF_ALPHAMODE, mode) == AI_SUCCESS) {
    const std::string s = mode.C_Str();
    r.alpha_mode = s == "MASK" ? 1 : s == "BLEND" ? 2 : 0;
  }
  m.Get(AI_MATKEY_GLTF_ALPHACUTOFF, r.alpha_cutoff);
  return r;
}

// Reads the file with Assimp, triangulated and validated. Throws Error when Assimp cannot read it.
const aiScene* read_with_assimp(Assimp::Importer& importer, const std::string& path) {
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_ValidateDataStructure);
  if (!scene && std::string(importer.GetErrorString()).find("contains no faces") != std::string::npos) {
    // Validation rejects a mesh without faces (e.g. an OBJ of bare vertices: a point cloud). Such a mesh just
    // has no triangles; read again without validation, the checks below cover what this code relies on.
    scene = importer.ReadFile(path, aiProcess_Triangulate);
  }
  if (!scene) {
    // Assimp reports what it caught as its error string: a std::bad_alloc as that bare name.
    const std::string why = importer.GetErrorString();
    if (why == std::bad_alloc().what()) throw Error(out_of_memory_message(path + ": importing the mesh"));
    throw Error(path + ": " + why);
  }
  return scene;
}

// An embedded texture into the blob: compressed (mWidth bytes of a PNG, JPEG, ...) as it is, or mWidth x mHeight
// aiTexels (BGRA) as RGBA.
void put_embedded_texture(BlobWriter& textures, const aiTexture& t, const std::string& label) {
  if (t.mHeight == 0) {
    textures.put(kTextureEncoded);
    textures.put_string(label);
    textures.put_string(std::string(reinterpret_cast<const char*>(t.pcData), t.mWidth));
    return;
  }
  textures.put(kTextureTexels);
  textures.put_string(label);
  textures.put(uint32_t(t.mWidth));
  textures.put(uint32_t(t.mHeight));
  std::string rgba(size_t(t.mWidth) * t.mHeight * 4, '\0');
  for (size_t k = 0; k < size_t(t.mWidth) * t.mHeight; ++k) {
    const aiTexel& x = t.pcData[k];
    rgba[4 * k] = char(x.r), rgba[4 * k + 1] = char(x.g), rgba[4 * k + 2] = char(x.b);
    rgba[4 * k + 3] = char(x.a);
  }
  textures.put_string(rgba);
}

// The file's materials and their base-colour textures (each texture once, by its path).
struct ImportedMaterials {
  std::vector<RawMaterial> materials;
  std::vector<std::string> names;
  BlobWriter textures;
  size_t texture_count = 0;
};

ImportedMaterials import_materials(const aiScene& scene, const std::string& path) {
  ImportedMaterials out;
  out.materials.resize(scene.mNumMaterials);
  out.names.resize(scene.mNumMaterials);
  std::map<std::string, int32_t> texture_index;
  for (unsigned i = 0; i < scene.mNumMaterials; ++i) {
    const aiMaterial* m = scene.mMaterials[i];
    if (!m) continue;
    out.materials[i] = raw_material(*m);
    aiString name;
    if (m->Get(AI_MATKEY_NAME, name) == AI_SUCCESS) out.names[i] = name.C_Str();
    aiString tex;
    if (m->GetTexture(aiTextureType_BASE_COLOR, 0, &tex) != AI_SUCCESS &&
        m->GetTexture(aiTextureType_DIFFUSE, 0, &tex) != AI_SUCCESS)
      continue;
    const std::string key = tex.C_Str();
    if (key.empty()) continue;
    auto it = texture_index.find(key);
    if (it == texture_index.end()) {
      it = texture_index.emplace(key, int32_t(texture_index.size())).first;
      if (const aiTexture* t = scene.GetEmbeddedTexture(key.c_str())) {
        put_embedded_texture(out.textures, *t, path + " (embedded texture " + key + ")");
      } else {
        out.textures.put(kTextureFile);
        out.textures.put_string(key);
      }
    }
    out.materials[i].texture = it->second;
  }
  out.texture_count = texture_index.size();
  return out;
}

// Where the node tree places each mesh, and how many triangles that makes.
struct MeshPlacements {
  size_t count = 0;                   // triangles placed (world space, every placement)
  bool textured = false;              // a placed mesh has texture coordinates and a textured material
  std::vector<uint32_t> placed;       // per Assimp mesh: the nodes that place it
  std::vector<Placement> placements;  // every placement, in node order
  std::vector<uint32_t> object_mesh;  // Assimp mesh -> object mesh
  std::vector<uint32_t> object_tris;  // per object mesh
  bool invertible = true;             // every placement's transform can be inverted
};

// First pass: count triangles, so a large mesh is allocated once, and note where each mesh is placed.
MeshPlacements place_meshes(const aiScene& scene, const std::string& path,
                            const std::vector<RawMaterial>& materials) {
  MeshPlacements mp;
  mp.placed.assign(scene.mNumMeshes, 0);
  mp.object_mesh.assign(scene.mNumMeshes, UINT32_MAX);
  walk_nodes(scene, [&](unsigned mesh_index, const aiMatrix4x4& world) {
    if (mesh_index >= scene.mNumMeshes)
      throw Error(path + ": node refers to missing mesh " + std::to_string(mesh_index));
    if (mp.object_mesh[mesh_index] == UINT32_MAX) {
      mp.object_mesh[mesh_index] = uint32_t(mp.object_tris.size());
      uint32_t n = 0;
      for (unsigned f = 0; f < scene.mMeshes[mesh_index]->mNumFaces; ++f)
        n += scene.mMeshes[mesh_index]->mFaces[f].mNumIndices == 3;
      mp.object_tris.push_back(n);
    }
    ++mp.placed[mesh_index];
    Placement pl{mp.object_mesh[mesh_index], {}};
    for (int c = 0; c < 4; ++c) {
      pl.to_world.m[0][c] = world[0][c];
      pl.to_world.m[1][c] = world[1][c];
      pl.to_world.m[2][c] = world[2][c];
    }
    hw::AffineD inverse;
    mp.invertible = mp.invertible && hw::invert(pl.to_world, inverse);
    mp.placements.push_back(pl);
    const aiMesh* mesh = scene.mMeshes[mesh_index];
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) mp.count += mesh->mFaces[f].mNumIndices == 3;
    if (mesh->mMaterialIndex < materials.size() && materials[mesh->mMaterialIndex].texture >= 0 &&
        mesh->HasTextureCoords(0))
      mp.textured = true;
  });
  return mp;
}

// The triangles as sent to the parent, their materials and (textured files) texture coordinates.
struct ImportedTriangles {
  std::vector<hw::Triangle> triangles;
  std::vector<uint32_t> tri_material;
  std::vector<TriangleUv> tri_uv;
};

// One face's vertices (world space when `transform`) and texture coordinates. Throws Error for an index out of
// range or a coordinate that is not finite.
void read_face(const aiScene& scene, const std::string& path, unsigned mesh_index, unsigned f,
               const aiMatrix4x4& world, bool transform, hw::Vec3 (&v)[3], TriangleUv& uv) {
  const aiMesh* mesh = scene.mMeshes[mesh_index];
  const aiFace& face = mesh->mFaces[f];
  const bool uvs = mesh->HasTextureCoords(0);
  for (int k = 0; k < 3; ++k) {
    const unsigned index = face.mIndices[k];
    if (index >= mesh->mNumVertices) {
      throw Error(path + ": " + mesh_label(scene, mesh_index) + ", face " + std::to_string(f) +
                  ": index out of range (" + std::to_string(index) + " >= " + std::to_string(mesh->mNumVertices) +
                  " vertices)");
    }
    aiVector3D p = mesh->mVertices[index];
    if (transform) p = world * p;
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      throw Error(path + ": " + mesh_label(scene, mesh_index) + ", face " + std::to_string(f) + ", vertex " +
                  std::to_string(index) + ": NaN/Inf coordinate " + format_vec(p));
    }
    v[k] = hw::Vec3(p.x, p.y, p.z);
    if (uvs) {
      // Assimp's texture coordinates have their origin at the image's bottom left (it flips glTF's); rtu's
      // textures have row 0 on top (scene.h), so t is flipped back.
      uv.s[k] = mesh->mTextureCoords[0][index].x;
      uv.t[k] = 1.0f - mesh->mTextureCoords[0][index].y;
    }
  }
}

// Second pass: the triangles. Two-level: object space, each mesh's triangles once. Otherwise world space; an
// identity node keeps the file's bits (the comparison is exact). Materials and texture coordinates are per
// placed triangle either way.
ImportedTriangles read_triangles(const aiScene& scene, const std::string& path, size_t num_materials,
                                 bool instanced, bool textured, size_t count, size_t flat_count) {
  ImportedTriangles out;
  out.triangles.reserve(count);
  out.tri_material.reserve(flat_count);
  if (textured) out.tri_uv.reserve(flat_count);
  std::vector<bool> sent(scene.mNumMeshes, false);
  const aiMatrix4x4 identity;
  walk_nodes(scene, [&](unsigned mesh_index, const aiMatrix4x4& world) {
    const aiMesh* mesh = scene.mMeshes[mesh_index];
    const bool transform = !instanced && !(world == identity);
    const bool send = !instanced || !sent[mesh_index];
    sent[mesh_index] = true;
    const uint32_t material = mesh->mMaterialIndex < num_materials ? mesh->mMaterialIndex : UINT32_MAX;
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      if (mesh->mFaces[f].mNumIndices != 3) continue;  // points and lines
      hw::Vec3 v[3];
      TriangleUv uv;
      read_face(scene, path, mesh_index, f, world, transform, v, uv);
      if (send) out.triangles.push_back({v[0], v[1], v[2]});
      out.tri_material.push_back(material);
      if (textured) out.tri_uv.push_back(uv);
    }
  });
  return out;
}

// The lines (faces of two indices) in world space, in node order; a line joins the one before it in the same mesh
// placement when it starts where that one ends (the same point: importers such as OBJ's give every face its own
// vertices). Throws Error for an index out of range or a
// coordinate that is not finite.
std::vector<ImportedLine> read_lines(const aiScene& scene, const std::string& path, size_t num_materials) {
  std::vector<ImportedLine> out;
  walk_nodes(scene, [&](unsigned mesh_index, const aiMatrix4x4& world) {
    const aiMesh* mesh = scene.mMeshes[mesh_index];
    const uint32_t material = mesh->mMaterialIndex < num_materials ? mesh->mMaterialIndex : UINT32_MAX;
    bool any = false;
    hw::Vec3 last_end(0.0f);
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 2) continue;
      hw::Vec3 p[2];
      for (int k = 0; k < 2; ++k) {
        const unsigned index = face.mIndices[k];
        if (index >= mesh->mNumVertices)
          throw Error(path + ": " + mesh_label(scene, mesh_index) + ", line " + std::to_string(f) +
                      ": index out of range (" + std::to_string(index) +
                      " >= " + std::to_string(mesh->mNumVertices) + " vertices)");
        const aiVector3D v = world * mesh->mVertices[index];
        if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
          throw Error(path + ": " + mesh_label(scene, mesh_index) + ", line " + std::to_string(f) +
                      ": NaN/Inf coordinate " + format_vec(v));
        p[k] = hw::Vec3(v.x, v.y, v.z);
      }
      out.push_back({p[0], p[1], any && p[0] == last_end ? 1u : 0u, material});
      last_end = p[1];
      any = true;
    }
  });
  return out;
}

}  // namespace

// The import proper, in the child process of import_isolated().
std::string import_with_assimp(const std::string& path) {
  Assimp::Importer importer;
  const aiScene* scene = read_with_assimp(importer, path);
  ImportedMaterials mats = import_materials(*scene, path);
  MeshPlacements mp = place_meshes(*scene, path, mats.materials);

  // A mesh placed by more than one node makes the file two-level: its meshes are sent once each in object space
  // with every placement (instances), unless a transform cannot be inverted (a node scaled to zero): then, as
  // for files that place each mesh once, every triangle is sent in world space.
  bool instanced = false;
  for (const uint32_t n : mp.placed) instanced = instanced || n > 1;
  instanced = instanced && mp.invertible;
  const size_t flat_count = mp.count;
  // A node tree may place a mesh many times: the triangles it places, as the flattened scene will hold them, are
  // held to the scene's budget before anything per placed triangle is reserved (here, and where the parent
  // flattens two levels).
  check_scene_size(path, flat_count);
  size_t count = flat_count;
  if (instanced) {
    count = 0;
    for (const uint32_t n : mp.object_tris) count += n;
  } else {
    mp.placements.clear();
    mp.object_tris.clear();
  }
  const ImportedTriangles tris =
      read_triangles(*scene, path, mats.materials.size(), instanced, mp.textured, count, flat_count);

  BlobWriter out;
  out.put_array(tris.triangles);
  out.put_array(tris.tri_material);
  out.put_array(tris.tri_uv);
  out.put_array(mp.object_tris);
  out.put_array(mp.placements);
  out.put_array(read_lines(*scene, path, mats.materials.size()));
  out.put(uint64_t(mats.materials.size()));
  for (size_t i = 0; i < mats.materials.size(); ++i) {
    out.put_string(mats.names[i]);
    out.put(mats.materials[i]);
  }
  out.put(uint64_t(mats.texture_count));
  std::string blob = out.take();
  blob += mats.textures.take();
  importer.FreeScene();
  return blob;
}

}  // namespace mesh_detail

ImportedModel import_model(const std::string& path, uint64_t held) {
  check_input_file(path);
  std::error_code ec;
  // Assimp holds the file and its parsed meshes at once (several times the file's bytes for text formats), then
  // the triangles are copied out: refuse a file that cannot fit before reading it.
  const uint64_t file_bytes = std::filesystem::file_size(path, ec);
  if (!ec)
    check_memory(path + ": importing a " + std::to_string(file_bytes >> 20) + " MiB mesh file", 8 * file_bytes);

  mesh_detail::check_ply_header(path);
  mesh_detail::check_off_header(path);
  mesh_detail::check_gltf_accessors(path);
  return mesh_detail::decode_model(mesh_detail::import_isolated(path), path, held);
}

std::vector<hw::Triangle> import_mesh(const std::string& path) {
  return import_model(path).triangles;
}

}  // namespace rtu::host
