// What the files of the mesh importer share (mesh_import.cpp and its parts): the child's answer, one blob, and
// the steps import_model runs. Only those files include it.
//   mesh_import.cpp          import_model; the child's side: Assimp's scene into the blob (import_with_assimp)
//   mesh_import_checks.cpp   PLY, OFF and glTF headers checked before Assimp reads the file
//   mesh_import_process.cpp  Assimp in a child process on its own stack (import_isolated)
//   mesh_import_decode.cpp   the parent's side: the blob into an ImportedModel, materials and textures
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "host/io/error.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/instancing.h"

namespace rtu::host::mesh_detail {

// The child's answer is one blob: the triangles, each triangle's material (the file's material index), texture
// coordinates when a material is textured, the materials' raw properties and their textures (a file path, the
// encoded bytes of an embedded image, or embedded texels). Decoding images and mapping materials happen in the
// parent (decode_model), so the child runs nothing but Assimp.
class BlobWriter {
 public:
  template <typename T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    m_out.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <typename T>
  void put_array(const std::vector<T>& v) {
    put(uint64_t(v.size()));
    m_out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void put_string(const std::string& str) {
    put(uint64_t(str.size()));
    m_out.append(str);
  }
  std::string take() { return std::move(m_out); }

 private:
  std::string m_out;
};

class BlobReader {
 public:
  BlobReader(const std::string& blob, const std::string& path) : m_blob(blob), m_path(path) {}
  template <typename T>
  T get() {
    T v;
    std::memcpy(&v, need(sizeof v), sizeof v);
    return v;
  }
  template <typename T>
  std::vector<T> get_array() {
    const uint64_t n = get<uint64_t>();
    if (n > (m_blob.size() - m_at) / sizeof(T)) truncated();
    std::vector<T> v(n);
    if (n) std::memcpy(v.data(), need(n * sizeof(T)), n * sizeof(T));
    return v;
  }
  std::string get_string() {
    const uint64_t n = get<uint64_t>();
    if (n > m_blob.size() - m_at) truncated();
    return std::string(need(n), n);
  }
  bool done() const { return m_at == m_blob.size(); }
  [[noreturn]] void truncated() const {
    throw Error(m_path + ": the mesh importer (Assimp) sent a truncated answer");
  }

 private:
  const char* need(size_t n) {
    if (n > m_blob.size() - m_at) truncated();
    const char* p = m_blob.data() + m_at;
    m_at += n;
    return p;
  }
  const std::string& m_blob;
  const std::string& m_path;
  size_t m_at = 0;
};

// A material's properties as the file states them (glTF's metallic-roughness model; other formats' diffuse
// colour and opacity stand in for the base colour and alpha).
struct RawMaterial {
  float base[4] = {0.8f, 0.8f, 0.8f, 1.0f};
  float metallic = 0.0f, roughness = 1.0f;
  float emission[3] = {0.0f, 0.0f, 0.0f};
  float transmission = 0.0f, ior = 1.5f, alpha_cutoff = 0.5f;
  uint8_t alpha_mode = 0;  // 0 opaque, 1 mask, 2 blend (glTF alphaMode)
  int32_t texture = -1;    // index into the textures sent, or -1
};

// Where the node tree places a mesh: the object mesh (meshes in the order of their first placement) and the
// node's world transform.
struct Placement {
  uint32_t mesh = 0;
  hw::Affine to_world;
};

enum TextureKind : uint8_t { kTextureFile = 0, kTextureEncoded = 1, kTextureTexels = 2 };

// Refuse, naming the file, a header whose counts the file or the memory limit cannot hold
// (mesh_import_checks.cpp).
void check_ply_header(const std::string& path);
void check_off_header(const std::string& path);
void check_gltf_accessors(const std::string& path);

// Runs import_with_assimp(path) in a child process and returns its blob; throws Error for what the child reports,
// a crash, a hang or a truncated answer (mesh_import_process.cpp).
std::string import_isolated(const std::string& path);
// The import proper, in the child (mesh_import.cpp).
std::string import_with_assimp(const std::string& path);
// The child's blob into the model; `held`: the texels the caller already holds (mesh_import_decode.cpp).
ImportedModel decode_model(const std::string& blob, const std::string& path, uint64_t held);

}  // namespace rtu::host::mesh_detail
