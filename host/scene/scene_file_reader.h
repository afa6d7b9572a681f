// What the files of the scene file reader share (scene_file.cpp, scene_file_meshes.cpp,
// scene_file_instances.cpp): the typed reads that name the file and key path in every error, the scene being
// built, and the readers one file calls in another. Only those files include it.
#pragma once

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "host/io/error.h"
#include "host/scene/scene.h"

namespace rtu::host::scene_file_detail {

using Json = nlohmann::ordered_json;  // keeps file order: materials and error reports follow the file
using hw::DVec3;

inline std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}
inline std::string join(const std::string& path, size_t index) {
  return path + "[" + std::to_string(index) + "]";
}

// scale, then rotate, then translate; applied in double, rounded to float once per vertex.
struct Transform {
  glm::dmat3 linear{1.0};
  DVec3 translate{0.0};
  bool identity = true;  // leave vertices bit-exact
  Vec3 apply(const Vec3& p) const { return identity ? p : Vec3(linear * DVec3(p) + translate); }
};

// Reads typed values out of the parsed document; every failure names the file and the key path.
class Reader {
 public:
  explicit Reader(std::string file) : m_file(std::move(file)) {}

  const std::string& file() const { return m_file; }

  [[noreturn]] void fail(const std::string& path, const std::string& problem) const {
    throw Error(m_file + ": " + (path.empty() ? "" : path + ": ") + problem);
  }

  void check_keys(const Json& j, const std::string& path, const std::vector<std::string>& allowed) const {
    for (const auto& item : j.items()) {
      bool ok = false;
      for (const std::string& a : allowed) ok = ok || item.key() == a;
      if (ok) continue;
      std::string list;
      for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw Error(m_file + ": unknown key '" + join(path, item.key()) + "' (allowed here: " + list + ")");
    }
  }

  const Json& object(const Json& j, const std::string& path) const {
    if (!j.is_object()) fail(path, std::string("expected an object, got ") + j.type_name());
    return j;
  }
  // Calls f(entry, path) for each entry of the array j at `where`, an object named by its key path.
  template <class F>
  void each_object(const Json& j, const std::string& where, F&& f) const {
    array(j, where);
    for (size_t i = 0; i < j.size(); ++i) {
      const std::string path = join(where, i);
      f(object(j[i], path), path);
    }
  }
  const Json& array(const Json& j, const std::string& path) const {
    if (!j.is_array()) fail(path, std::string("expected an array, got ") + j.type_name());
    return j;
  }
  std::string string(const Json& j, const std::string& path) const {
    if (!j.is_string()) fail(path, std::string("expected a string, got ") + j.type_name());
    return j.get<std::string>();
  }
  float number(const Json& j, const std::string& path) const {
    if (!j.is_number()) fail(path, std::string("expected a number, got ") + j.type_name());
    const double d = j.get<double>();
    if (!std::isfinite(d)) fail(path, "not a finite number (NaN/Inf)");
    if (std::fabs(d) > double(FLT_MAX)) fail(path, "out of float range (NaN/Inf as float)");
    return float(d);
  }
  float positive(const Json& j, const std::string& path) const {
    const float f = number(j, path);
    if (!(f > 0.0f)) fail(path, "must be > 0, got " + j.dump());
    return f;
  }
  int integer(const Json& j, const std::string& path, int lo, int hi) const {
    const std::string range = " in " + std::to_string(lo) + ".." + std::to_string(hi);
    if (!j.is_number_integer()) fail(path, "expected an integer" + range + ", got " + j.dump());
    const bool in_range = j.is_number_unsigned()
                              ? (lo <= 0 || j.get<uint64_t>() >= uint64_t(lo)) && j.get<uint64_t>() <= uint64_t(hi)
                              : j.get<int64_t>() >= lo && j.get<int64_t>() <= hi;
    if (!in_range) fail(path, "expected an integer" + range + ", got " + j.dump());
    return int(j.get<int64_t>());
  }
  std::vector<float> numbers(const Json& j, const std::string& path, size_t n) const {
    if (!j.is_array() || j.size() != n) {
      fail(path, "expected an array of " + std::to_string(n) + " numbers, got " +
                     (j.is_array() ? "an array of " + std::to_string(j.size()) : std::string(j.type_name())));
    }
    std::vector<float> out;
    for (size_t i = 0; i < n; ++i) out.push_back(number(j[i], join(path, i)));
    return out;
  }
  Vec3 vec3(const Json& j, const std::string& path) const {
    const std::vector<float> v = numbers(j, path, 3);
    return Vec3(v[0], v[1], v[2]);
  }
  Vec3 nonzero_vec3(const Json& j, const std::string& path) const {
    const Vec3 v = vec3(j, path);
    if (v == Vec3(0.0f)) fail(path, "must not be the zero vector");
    return v;
  }
  Vec3 color(const Json& j, const std::string& path) const {
    const Vec3 c = vec3(j, path);
    if (c.x < 0.0f || c.y < 0.0f || c.z < 0.0f) fail(path, "color components must be >= 0");
    return c;
  }
  // A number s (-> s in every component) or an array of n positive numbers (n = 2 or 3; z = 0 for n = 2).
  Vec3 size(const Json& j, const std::string& path, size_t n) const {
    if (j.is_number()) return Vec3(positive(j, path));
    if (!j.is_array() || j.size() != n) {
      fail(path, "expected a number or an array of " + std::to_string(n) + " numbers");
    }
    Vec3 s(0.0f);
    for (size_t i = 0; i < n; ++i) s[int(i)] = positive(j[i], join(path, i));
    return s;
  }

 private:
  std::string m_file;
};

// Everything being built, with the per-kind material lists merged into prim_material at the end.
struct Builder {
  const Reader& reader;
  Scene scene;
  std::map<std::string, uint32_t> material_index;
  std::vector<uint32_t> tri_material, sphere_material, curve_material, plane_material;
  // Instancing: prototypes by name (their meshes are InstanceSet meshes 1.., mesh 0 is the loose geometry), the
  // per-triangle materials of every mesh, and the materials of instance triangles in instance order.
  struct Prototype {
    const Json* json = nullptr;
    std::string path;
    uint32_t mesh = UINT32_MAX;  // none when it has no meshes of its own
    bool visiting = false;       // on the current expansion path (a loop when met again)
    bool empty = false;          // expanded once and placed nothing: later entries naming it are not walked
  };
  std::map<std::string, Prototype> prototypes;
  std::vector<std::vector<uint32_t>> mesh_tri_material;
  std::vector<uint32_t> instance_tri_material;
  // The curve segments' materials of prototype meshes with strands (by mesh), and of instance curves in instance
  // order (after the loose curves' curve_material in the flattened scene); the same for spheres.
  std::map<uint32_t, std::vector<uint32_t>> mesh_curve_material;
  std::vector<uint32_t> instance_curve_material;
  std::map<uint32_t, std::vector<uint32_t>> mesh_sphere_material;
  std::vector<uint32_t> instance_sphere_material;
  uint64_t instance_prims = 0;
  // Texture coordinates, as the materials: loose mesh triangles, per instance mesh, instance triangles.
  std::vector<TriangleUv> tri_uv;
  std::vector<std::vector<TriangleUv>> mesh_tri_uv;
  std::vector<TriangleUv> instance_tri_uv;
  std::map<std::string, int> texture_index;
  // Mesh files of the top-level "meshes" whose node tree places a mesh more than once: added as instances (their
  // meshes after mesh 0) once the loose geometry is read, with the entry's transform and per-mesh materials.
  struct InstancedFile {
    std::string path;  // the entry's key path, for messages
    hw::InstanceSet set;
    Transform transform;
    std::vector<std::vector<uint32_t>> mesh_material;  // per mesh, per triangle
    std::vector<std::vector<TriangleUv>> mesh_uv;      // per mesh, per triangle (empty: none)
  };
  std::vector<InstancedFile> instanced_files;

  uint32_t material(const Json& parent, const std::string& path) const {
    if (!parent.contains("material")) return material_index.at("default");
    const std::string key = join(path, "material");
    const std::string name = reader.string(parent["material"], key);
    auto it = material_index.find(name);
    if (it == material_index.end()) {
      std::string known;
      for (const auto& [n, i] : material_index) known += (known.empty() ? "" : ", ") + n;
      reader.fail(key, "unknown material '" + name + "' (known: " + known + ")");
    }
    return it->second;
  }
};

// scene_file_meshes.cpp: a "transform" entry; "meshes" entries at `where` into g's triangles, with their
// materials in tri_material and texture coordinates in tri_uv; a mesh file's lines into g's curve segments, their
// materials in curve_material. With `keep_instances` (the scene's own "meshes"), a mesh file whose node tree
// places a mesh more than once is kept two-level (Builder::instanced_files) instead of flattened into g.
Transform read_transform(const Reader& r, const Json& j, const std::string& path);
void read_mesh_entries(Builder& b, const Json& j, const std::string& where, const std::filesystem::path& base_dir,
                       hw::Geometry& g, std::vector<uint32_t>& tri_material, std::vector<TriangleUv>& tri_uv,
                       std::vector<uint32_t>& curve_material, bool keep_instances = false);
void read_meshes(Builder& b, const Json& j, const std::filesystem::path& base_dir);
// scene_file.cpp: "spheres" and "curves" entries at `where` into g, their materials appended to `material`.
void read_spheres(Builder& b, const Json& j, const std::string& where, hw::Geometry& g,
                  std::vector<uint32_t>& material);
void read_curves(Builder& b, const Json& j, const std::string& where, hw::Geometry& g,
                 std::vector<uint32_t>& material);

// scene_file_instances.cpp: instancing (scenes/README.md, "prototypes" and "instances"), and the mesh files kept
// two-level, added as instances once the loose geometry is read.
void read_prototypes(Builder& b, const Json& j, const std::filesystem::path& base_dir);
void add_file_instances(Builder& b);
void read_instances(Builder& b, const Json& j);

}  // namespace rtu::host::scene_file_detail
