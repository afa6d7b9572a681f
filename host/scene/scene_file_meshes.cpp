// Scene files: "meshes" entries (a mesh file or a generator, with a transform and a material), the mesh files'
// own materials and textures, and the files kept two-level. scene_file.cpp reads the rest.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "host/io/error.h"
#include "host/scene/curves.h"
#include "host/scene/generators.h"
#include "host/scene/scene.h"
#include "host/scene/scene_file_reader.h"

namespace rtu::host::scene_file_detail {
namespace {

// A "generate" entry: the generator and the keys it accepts.
IndexedMesh generate(const Reader& r, const Json& j, const std::string& path, std::vector<std::string> keys) {
  const std::string kind = r.string(j["generate"], join(path, "generate"));
  auto param = [&](const char* key) -> const Json* { return j.contains(key) ? &j[key] : nullptr; };
  IndexedMesh mesh;
  if (kind == "icosphere") {
    keys.insert(keys.end(), {"subdiv", "radius"});
    r.check_keys(j, path, keys);
    const int subdiv = param("subdiv") ? r.integer(j["subdiv"], join(path, "subdiv"), 0, kMaxIcosphereSubdiv) : 4;
    const float radius = param("radius") ? r.positive(j["radius"], join(path, "radius")) : 1.0f;
    mesh = make_icosphere(subdiv, radius);
  } else if (kind == "torus") {
    keys.insert(keys.end(), {"major_radius", "minor_radius", "major_segments", "minor_segments"});
    r.check_keys(j, path, keys);
    const float major = param("major_radius") ? r.positive(j["major_radius"], join(path, "major_radius")) : 1.0f;
    const float minor = param("minor_radius") ? r.positive(j["minor_radius"], join(path, "minor_radius")) : 0.25f;
    auto segments = [&](const char* key, int def) {
      return param(key) ? r.integer(j[key], join(path, key), kMinTorusSegments, kMaxTorusSegments) : def;
    };
    mesh = make_torus(major, minor, segments("major_segments", 48), segments("minor_segments", 24));
  } else if (kind == "box") {
    keys.push_back("size");
    r.check_keys(j, path, keys);
    mesh = make_box(param("size") ? r.size(j["size"], join(path, "size"), 3) : Vec3(1.0f));
  } else if (kind == "quad") {
    keys.push_back("size");
    r.check_keys(j, path, keys);
    const Vec3 s = param("size") ? r.size(j["size"], join(path, "size"), 2) : Vec3(1.0f);
    mesh = make_quad(s.x, s.y);
  } else {
    r.fail(join(path, "generate"), "unknown generator '" + kind + "' (valid: icosphere, torus, box, quad)");
  }
  return mesh;
}

// A mesh file's own materials and textures join the scene's, named "FILE/NAME"; returns the scene's material of
// each of the file's triangles.
std::vector<uint32_t> join_file_materials(Builder& b, const std::filesystem::path& file, ImportedModel& model) {
  const uint32_t mat_base = uint32_t(b.scene.materials.size());
  const int tex_base = int(b.scene.textures.size());
  for (Material& mat : model.materials) {
    mat.name = file.filename().string() + "/" + mat.name;
    if (mat.texture >= 0) mat.texture += tex_base;
    b.scene.materials.push_back(std::move(mat));
  }
  for (Texture& t : model.textures) b.scene.textures.push_back(std::move(t));
  std::vector<uint32_t> out;
  out.reserve(model.tri_material.size());
  for (const uint32_t k : model.tri_material) out.push_back(mat_base + k);
  return out;
}

// A mesh file entry kept two-level: its meshes' materials (the entry's "material", or the file's own, joining the
// scene's as read_mesh_entries names them) and texture coordinates per mesh, from the first instance placing each.
void keep_file_instances(Builder& b, const Json& m, const std::string& path, const std::filesystem::path& file,
                         const Transform& t, uint32_t material, ImportedModel& model) {
  Builder::InstancedFile f;
  f.path = path;
  f.transform = t;
  std::vector<uint32_t> tri_material(model.triangles.size(), material);
  if (!m.contains("material") && !model.materials.empty()) {
    tri_material = join_file_materials(b, file, model);
  } else {
    model.tri_uv.clear();  // one material for all: the file's coordinates are not needed
  }
  hw::InstanceSet& set = model.instances;
  f.mesh_material.resize(set.meshes.size());
  f.mesh_uv.resize(set.meshes.size());
  std::vector<bool> seen(set.meshes.size(), false);
  for (const hw::Instance& in : set.instances) {
    if (seen[in.mesh]) continue;
    seen[in.mesh] = true;
    const size_t n = set.meshes[in.mesh].triangles.size();
    f.mesh_material[in.mesh].assign(tri_material.begin() + in.tri_base, tri_material.begin() + in.tri_base + n);
    if (!model.tri_uv.empty())
      f.mesh_uv[in.mesh].assign(model.tri_uv.begin() + in.tri_base, model.tri_uv.begin() + in.tri_base + n);
  }
  f.set = std::move(set);
  b.instanced_files.push_back(std::move(f));
}

}  // namespace

Transform read_transform(const Reader& r, const Json& j, const std::string& path) {
  r.object(j, path);
  r.check_keys(j, path, {"scale", "rotate", "translate", "matrix"});
  Transform t;
  if (j.contains("matrix")) {
    // Three rows (L | t) of an affine map, as Embree's FLOAT3X4_ROW_MAJOR; no other key beside it.
    const std::string key = join(path, "matrix");
    if (j.size() != 1) r.fail(path, "'matrix' excludes scale, rotate and translate");
    const Json& rows = r.array(j["matrix"], key);
    if (rows.size() != 3) r.fail(key, "expected 3 rows of 4 numbers");
    for (int row = 0; row < 3; ++row) {
      const std::vector<float> v = r.numbers(rows[size_t(row)], join(key, size_t(row)), 4);
      for (int c = 0; c < 3; ++c) t.linear[c][row] = v[size_t(c)];
      t.translate[row] = v[3];
    }
    if (glm::determinant(t.linear) == 0.0) r.fail(key, "singular (its 3x3 part has determinant 0)");
    t.identity = t.linear == glm::dmat3(1.0) && t.translate == DVec3(0.0);
    return t;
  }
  glm::dmat3 scale(1.0), rotate(1.0);
  if (j.contains("scale")) {
    const std::string key = join(path, "scale");
    const Vec3 s = j["scale"].is_number() ? Vec3(r.number(j["scale"], key)) : r.vec3(j["scale"], key);
    if (s.x == 0.0f || s.y == 0.0f || s.z == 0.0f) r.fail(key, "scale factors must be non-zero");
    scale = glm::dmat3(glm::dvec3(s.x, 0, 0), glm::dvec3(0, s.y, 0), glm::dvec3(0, 0, s.z));
  }
  if (j.contains("rotate")) {
    const std::string key = join(path, "rotate");
    const std::vector<float> a = r.numbers(j["rotate"], key, 4);
    const DVec3 axis(a[0], a[1], a[2]);
    if (axis == DVec3(0.0)) r.fail(key, "rotation axis must not be the zero vector");
    rotate = glm::dmat3(glm::rotate(glm::dmat4(1.0), glm::radians(double(a[3])), glm::normalize(axis)));
  }
  if (j.contains("translate")) t.translate = DVec3(r.vec3(j["translate"], join(path, "translate")));
  t.linear = rotate * scale;
  t.identity = t.linear == glm::dmat3(1.0) && t.translate == DVec3(0.0);
  return t;
}

// Mesh entries at `where` into tris, with their materials in tri_material.
// With `keep_instances` (the scene's own "meshes"), a mesh file whose node tree places a mesh more than once is
// kept two-level (Builder::instanced_files) instead of flattened into tris.
void read_mesh_entries(Builder& b, const Json& j, const std::string& where, const std::filesystem::path& base_dir,
                       hw::Geometry& g, std::vector<uint32_t>& tri_material, std::vector<TriangleUv>& tri_uv,
                       std::vector<uint32_t>& curve_material, bool keep_instances) {
  std::vector<hw::Triangle>& tris = g.triangles;
  const Reader& r = b.reader;
  r.array(j, where);
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string path = join(where, i);
    const Json& m = r.object(j[i], path);
    const bool has_file = m.contains("file"), has_generate = m.contains("generate");
    std::vector<uint32_t> file_materials;  // per triangle of a file entry: the file's own materials
    if (has_file == has_generate) r.fail(path, "needs exactly one of 'file' and 'generate'");
    const uint32_t material = b.material(m, path);
    const std::vector<std::string> common = {has_file ? "file" : "generate", "material", "transform"};
    const size_t first = tris.size();

    if (has_file) {
      std::vector<std::string> keys = common;
      keys.push_back("curve_radius");
      r.check_keys(m, path, keys);
      const Transform t =
          m.contains("transform") ? read_transform(r, m["transform"], join(path, "transform")) : Transform{};
      std::filesystem::path file(r.string(m["file"], join(path, "file")));
      if (file.is_relative()) file = base_dir / file;
      ImportedModel model;
      try {
        // The file's textures are held to the budget beside those the scene holds already (its own, and earlier
        // files'): each file's alone may fit where all of them do not.
        uint64_t held = 0;
        for (const Texture& tex : b.scene.textures) held += tex.rgba.size();
        model = import_model(file.string(), held);
      } catch (const Error& e) {
        r.fail(join(path, "file"), e.what());
      }
      std::vector<hw::Triangle>& imported = model.triangles;
      if (imported.empty() && model.lines.empty())
        r.fail(join(path, "file"), file.string() + ": no triangles or lines");
      if (m.contains("curve_radius") && model.lines.empty())
        r.fail(join(path, "curve_radius"), file.string() + " has no lines");
      if (!model.lines.empty()) {
        // Its lines (in the file's world space, every placement of a line mesh flattened): strands of curve
        // segments, after the triangles in the primitive order, of the entry's material (not the file's).
        const Transform t =
            m.contains("transform") ? read_transform(r, m["transform"], join(path, "transform")) : Transform{};
        hw::Aabb bounds;
        for (const ImportedLine& l : model.lines) {
          bounds.extend(t.apply(l.p0));
          bounds.extend(t.apply(l.p1));
        }
        for (const hw::Triangle& tri : imported)
          for (const Vec3& v : {tri.v0, tri.v1, tri.v2}) bounds.extend(t.apply(v));
        const float radius = m.contains("curve_radius") ? r.positive(m["curve_radius"], join(path, "curve_radius"))
                                                        : default_line_radius(bounds);
        try {
          add_lines(
              g, model.lines, radius, [&](const Vec3& v) { return t.apply(v); }, "lines");
        } catch (const Error& e) {
          r.fail(join(path, "file"), e.what());
        }
        curve_material.insert(curve_material.end(), model.lines.size(), material);
        if (imported.empty()) continue;
      }
      if (keep_instances && !model.instances.instances.empty()) {
        keep_file_instances(b, m, path, file, t, material, model);
        continue;
      }
      // Without a "material" key, the file's own materials (when it has any) join the scene's, named
      // "FILE/NAME", with their textures and the triangles' texture coordinates.
      if (!m.contains("material") && !model.materials.empty()) {
        file_materials = join_file_materials(b, file, model);
        if (!model.tri_uv.empty()) {
          tri_uv.resize(first);
          tri_uv.insert(tri_uv.end(), model.tri_uv.begin(), model.tri_uv.end());
        }
      }
      // Per vertex, deterministic: shared vertices stay bit-identical.
      for (hw::Triangle& tri : imported) tri = {t.apply(tri.v0), t.apply(tri.v1), t.apply(tri.v2)};
      if (tris.empty()) {
        tris = std::move(imported);  // the common case of one large mesh: no copy
      } else {
        tris.insert(tris.end(), imported.begin(), imported.end());
      }
    } else {
      IndexedMesh mesh = generate(r, m, path, common);
      if (m.contains("transform")) {
        const Transform t = read_transform(r, m["transform"], join(path, "transform"));
        for (Vec3& v : mesh.vertices) v = t.apply(v);  // once per vertex, before expanding
      }
      append_triangles(mesh, tris);
      if (!mesh.uvs.empty()) {
        tri_uv.resize(first);  // entries before without coordinates: 0
        for (const auto& f : mesh.faces) {
          TriangleUv uv;
          for (int k = 0; k < 3; ++k) {
            uv.s[k] = mesh.uvs[f[size_t(k)]][0];
            uv.t[k] = mesh.uvs[f[size_t(k)]][1];
          }
          tri_uv.push_back(uv);
        }
      }
    }
    if (!file_materials.empty()) {
      tri_material.insert(tri_material.end(), file_materials.begin(), file_materials.end());
    } else {
      tri_material.insert(tri_material.end(), tris.size() - first, material);
    }
  }
}

void read_meshes(Builder& b, const Json& j, const std::filesystem::path& base_dir) {
  read_mesh_entries(b, j, "meshes", base_dir, b.scene.geometry, b.tri_material, b.tri_uv, b.curve_material, true);
}

}  // namespace rtu::host::scene_file_detail
