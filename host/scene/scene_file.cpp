// Scene description files (JSON). The schema is documented in scenes/README.md; keep the two in step.
//
// Strict by design: unknown or duplicate keys, wrong types or array lengths, non-finite numbers and unknown
// names are errors that name the file and the key path (e.g. "meshes[2].transform.scale"). The JSON itself is read
// by host/io/json_io.h, which also refuses nesting deeper than kMaxJsonDepth levels.
#include <cfloat>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "host/io/error.h"
#include "host/io/image.h"
#include "host/io/json_io.h"
#include "host/io/limits.h"
#include "host/scene/curves.h"
#include "host/scene/generators.h"
#include "host/scene/scene.h"

namespace rtu::host {
namespace {

using Json = nlohmann::ordered_json;  // keeps file order: materials and error reports follow the file
using hw::DVec3;

std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}
std::string join(const std::string& path, size_t index) {
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

void read_camera(const Reader& r, const Json& j, Camera& cam) {
  const std::string path = "camera";
  r.object(j, path);
  r.check_keys(j, path, {"position", "look_at", "up", "fov_y", "width", "height"});
  if (j.contains("position")) cam.position = r.vec3(j["position"], join(path, "position"));
  if (j.contains("look_at")) cam.look_at = r.vec3(j["look_at"], join(path, "look_at"));
  if (j.contains("up")) cam.up = r.nonzero_vec3(j["up"], join(path, "up"));
  if (j.contains("fov_y")) {
    cam.fov_y_deg = r.number(j["fov_y"], join(path, "fov_y"));
    if (!(cam.fov_y_deg > 0.0f && cam.fov_y_deg < 180.0f))
      r.fail(join(path, "fov_y"), "must be in (0, 180) degrees");
  }
  if (j.contains("width")) cam.width = r.integer(j["width"], join(path, "width"), 1, 65536);
  if (j.contains("height")) cam.height = r.integer(j["height"], join(path, "height"), 1, 65536);
  const DVec3 view = DVec3(cam.look_at) - DVec3(cam.position);
  if (view == DVec3(0.0)) r.fail(path, "position and look_at are the same point");
  if (glm::cross(view, DVec3(cam.up)) == DVec3(0.0)) r.fail(join(path, "up"), "parallel to the view direction");
}

// Textures by name: an image file (PNG or JPEG; relative to the scene file) or inline texels.
void read_textures(Builder& b, const Json& j, const std::filesystem::path& base_dir) {
  const Reader& r = b.reader;
  r.object(j, "textures");
  uint64_t held = 0;  // texel bytes of the textures read so far
  for (const auto& item : j.items()) {
    const std::string path = join("textures", item.key());
    const Json& t = r.object(item.value(), path);
    if (item.key().empty()) r.fail(path, "texture names must not be empty");
    Texture tex;
    if (t.contains("file")) {
      r.check_keys(t, path, {"file"});
      std::filesystem::path file(r.string(t["file"], join(path, "file")));
      if (file.is_relative()) file = base_dir / file;
      try {
        // Each texture is held to the budget when decoded (read_texture); their sum is held here, from the
        // size the header declares, before decoding: those read so far, and this one twice while it decodes.
        const uint64_t next = texture_header_bytes(file.string());
        check_memory(std::to_string(b.scene.textures.size() + 1) + " textures so far", held + 2 * next);
        tex = read_texture(file.string());
      } catch (const Error& e) {
        r.fail(join(path, "file"), e.what());
      }
    } else {
      // Inline: "width", "height" and "texels", width * height [r, g, b, a] of integers 0..255, row 0 on top.
      r.check_keys(t, path, {"width", "height", "texels"});
      for (const char* key : {"width", "height", "texels"})
        if (!t.contains(key))
          r.fail(path, std::string("needs 'file', or 'width', 'height' and 'texels' (missing '") + key + "')");
      tex.width = uint32_t(r.integer(t["width"], join(path, "width"), 1, 256));
      tex.height = uint32_t(r.integer(t["height"], join(path, "height"), 1, 256));
      const std::string key = join(path, "texels");
      const Json& texels = r.array(t["texels"], key);
      if (texels.size() != size_t(tex.width) * tex.height)
        r.fail(key, "has " + std::to_string(texels.size()) + " texels for " + std::to_string(tex.width) + " x " +
                        std::to_string(tex.height));
      for (size_t i = 0; i < texels.size(); ++i) {
        const Json& px = r.array(texels[i], join(key, i));
        if (px.size() != 4) r.fail(join(key, i), "a texel is [r, g, b, a]");
        for (size_t c = 0; c < 4; ++c)
          tex.rgba.push_back(uint8_t(r.integer(px[c], join(join(key, i), c), 0, 255)));
      }
    }
    tex.name = item.key();
    held += tex.rgba.size();
    b.texture_index[item.key()] = int(b.scene.textures.size());
    b.scene.textures.push_back(std::move(tex));
  }
}

void read_materials(Builder& b, const Json& j) {
  const Reader& r = b.reader;
  r.object(j, "materials");
  if (!j.contains("default")) {
    b.scene.materials.push_back({.name = "default",
                                 .type = MaterialType::kDiffuse,
                                 .color = Vec3(0.8f),
                                 .ior = 1.5f,
                                 .emission = Vec3(0.0f)});
    b.material_index["default"] = 0;
  }
  for (const auto& item : j.items()) {
    const std::string path = join("materials", item.key());
    const Json& m = r.object(item.value(), path);
    if (item.key().empty()) r.fail(path, "material names must not be empty");
    r.check_keys(m, path, {"type", "color", "ior", "emission", "texture", "alpha_mode", "alpha", "alpha_cutoff"});
    Material mat;
    mat.name = item.key();
    const std::string type = m.contains("type") ? r.string(m["type"], join(path, "type")) : "diffuse";
    static const std::map<std::string, MaterialType> kTypes = {{"diffuse", MaterialType::kDiffuse},
                                                               {"mirror", MaterialType::kMirror},
                                                               {"glass", MaterialType::kGlass},
                                                               {"emissive", MaterialType::kEmissive}};
    auto type_it = kTypes.find(type);
    if (type_it == kTypes.end()) {
      r.fail(join(path, "type"), "unknown material type '" + type + "' (valid: diffuse, mirror, glass, emissive)");
    }
    mat.type = type_it->second;

    if (mat.type == MaterialType::kEmissive) {
      if (m.contains("color")) r.fail(join(path, "color"), "emissive materials have no color; use 'emission'");
      mat.emission = m.contains("emission") ? r.color(m["emission"], join(path, "emission")) : Vec3(1.0f);
    } else {
      if (m.contains("emission")) r.fail(join(path, "emission"), "only emissive materials have an emission");
      if (m.contains("color")) mat.color = r.color(m["color"], join(path, "color"));
    }
    if (m.contains("ior")) {
      if (mat.type != MaterialType::kGlass) r.fail(join(path, "ior"), "only glass materials have an ior");
      mat.ior = r.positive(m["ior"], join(path, "ior"));
    }
    if (m.contains("texture")) {
      const std::string key = join(path, "texture");
      const std::string name = r.string(m["texture"], key);
      auto it = b.texture_index.find(name);
      if (it == b.texture_index.end()) {
        std::string known;
        for (const auto& [n, i] : b.texture_index) known += (known.empty() ? "" : ", ") + n;
        r.fail(key, "unknown texture '" + name + "' (known: " + (known.empty() ? "none" : known) + ")");
      }
      mat.texture = it->second;
    }
    if (m.contains("alpha_mode")) {
      const std::string key = join(path, "alpha_mode");
      const std::string mode = r.string(m["alpha_mode"], key);
      if (mode == "mask")
        mat.alpha_mode = AlphaMode::kMask;
      else if (mode != "opaque")
        r.fail(key, "unknown alpha mode '" + mode + "' (valid: opaque, mask)");
    }
    auto unit = [&](const char* key) {
      const float v = r.number(m[key], join(path, key));
      if (!(v >= 0.0f && v <= 1.0f)) r.fail(join(path, key), "must be in [0, 1]");
      return v;
    };
    if (m.contains("alpha")) mat.alpha = unit("alpha");
    if (m.contains("alpha_cutoff")) mat.alpha_cutoff = unit("alpha_cutoff");
    b.material_index[mat.name] = uint32_t(b.scene.materials.size());
    b.scene.materials.push_back(mat);
  }
}

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

// Mesh entries at `where` into tris, with their materials in tri_material.
// A mesh file entry kept two-level: its meshes' materials (the entry's "material", or the file's own, joining the
// scene's as read_mesh_entries names them) and texture coordinates per mesh, from the first instance placing each.
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

// With `keep_instances` (the scene's own "meshes"), a mesh file whose node tree places a mesh more than once is
// kept two-level (Builder::instanced_files) instead of flattened into tris.
void read_mesh_entries(Builder& b, const Json& j, const std::string& where, const std::filesystem::path& base_dir,
                       std::vector<hw::Triangle>& tris, std::vector<uint32_t>& tri_material,
                       std::vector<TriangleUv>& tri_uv, bool keep_instances = false) {
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
        // Its lines: strands of curve segments, after the triangles in the primitive order, of the entry's
        // material (not the file's).
        if (!model.instances.instances.empty())
          r.fail(join(path, "file"),
                 file.string() + ": lines in a file whose node tree places a mesh more than once");
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
              b.scene.geometry, model.lines, radius, [&](const Vec3& v) { return t.apply(v); }, "lines");
        } catch (const Error& e) {
          r.fail(join(path, "file"), e.what());
        }
        b.curve_material.insert(b.curve_material.end(), model.lines.size(), material);
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
  read_mesh_entries(b, j, "meshes", base_dir, b.scene.geometry.triangles, b.tri_material, b.tri_uv, true);
}

// Instancing (scenes/README.md, "prototypes" and "instances"). A transform as an affine map in double.
struct Xform {
  glm::dmat3 linear{1.0};
  DVec3 translate{0.0};
  Xform then(const Transform& t) const {  // this map applied after t: x -> this(t(x))
    return Xform{linear * t.linear, linear * t.translate + translate};
  }
};

constexpr size_t kMaxInstances = size_t(1) << 20;

void read_prototypes(Builder& b, const Json& j, const std::filesystem::path& base_dir) {
  const Reader& r = b.reader;
  r.object(j, "prototypes");
  for (const auto& item : j.items()) {
    const std::string path = join("prototypes", item.key());
    const Json& p = r.object(item.value(), path);
    if (item.key().empty()) r.fail(path, "prototype names must not be empty");
    r.check_keys(p, path, {"meshes", "instances"});
    if (!p.contains("meshes") && !p.contains("instances")) r.fail(path, "needs 'meshes' or 'instances'");
    Builder::Prototype proto;
    proto.json = &item.value();
    proto.path = path;
    if (p.contains("meshes")) {
      hw::Geometry g;
      std::vector<uint32_t> mats;
      std::vector<TriangleUv> uvs;
      read_mesh_entries(b, p["meshes"], join(path, "meshes"), base_dir, g.triangles, mats, uvs);
      uvs.resize(g.triangles.size());
      proto.mesh = uint32_t(b.scene.instances.meshes.size());
      b.scene.instances.meshes.push_back(std::move(g));
      b.mesh_tri_material.push_back(std::move(mats));
      b.mesh_tri_uv.push_back(std::move(uvs));
    }
    if (p.contains("instances")) r.array(p["instances"], join(path, "instances"));
    b.prototypes[item.key()] = proto;
  }
}

// An instance of mesh `mesh` placed by x, with its mesh's materials and texture coordinates.
void add_instance(Builder& b, uint32_t mesh, const Xform& x, const std::string& path) {
  const Reader& r = b.reader;
  hw::InstanceSet& set = b.scene.instances;
  if (set.instances.size() >= kMaxInstances)
    r.fail(path, "more than " + std::to_string(kMaxInstances) + " instances");
  hw::Instance in;
  in.mesh = mesh;
  for (int row = 0; row < 3; ++row) {
    for (int c = 0; c < 3; ++c) in.to_world.m[row][c] = float(x.linear[c][row]);
    in.to_world.m[row][3] = float(x.translate[row]);
  }
  hw::AffineD inv;
  if (!hw::invert(in.to_world, inv))
    r.fail(path, "the composed transform is not finite or is singular (in float)");
  const uint64_t before = b.instance_prims;
  b.instance_prims += set.meshes[mesh].triangles.size();
  if (b.instance_prims >= hw::kMaxBvhPrims) r.fail(path, "instances hold more than 2^27 - 1 triangles in all");
  // Each instance triangle takes its material and texture coordinates here and its world-space copy when the
  // scene is flattened: the flattened scene's budget (check_scene_size) is applied as the count grows, each time
  // it passes a multiple of 2^16 triangles (reading the limit is a file read), before that memory is taken.
  if ((before >> 16) != (b.instance_prims >> 16)) {
    try {
      check_scene_size("the instances so far", b.instance_prims);
    } catch (const Error& e) {
      r.fail(path, e.what());
    }
  }
  set.instances.push_back(in);
  const std::vector<uint32_t>& mats = b.mesh_tri_material[mesh];
  b.instance_tri_material.insert(b.instance_tri_material.end(), mats.begin(), mats.end());
  const std::vector<TriangleUv>& uvs = b.mesh_tri_uv[mesh];
  b.instance_tri_uv.insert(b.instance_tri_uv.end(), uvs.begin(), uvs.end());
}

// The mesh files kept two-level (Builder::instanced_files): their meshes after mesh 0, an instance per placement,
// its node transform composed after the entry's.
void add_file_instances(Builder& b) {
  for (Builder::InstancedFile& f : b.instanced_files) {
    const uint32_t base = uint32_t(b.scene.instances.meshes.size());
    for (size_t m = 0; m < f.set.meshes.size(); ++m) {
      b.mesh_tri_uv.push_back(std::move(f.mesh_uv[m]));
      b.mesh_tri_uv.back().resize(f.set.meshes[m].triangles.size());
      b.mesh_tri_material.push_back(std::move(f.mesh_material[m]));
      b.scene.instances.meshes.push_back(std::move(f.set.meshes[m]));
    }
    const Xform entry{f.transform.linear, f.transform.translate};
    for (const hw::Instance& in : f.set.instances) {
      Transform node;
      node.identity = false;
      for (int row = 0; row < 3; ++row) {
        for (int c = 0; c < 3; ++c) node.linear[c][row] = double(in.to_world.m[row][c]);
        node.translate[row] = double(in.to_world.m[row][3]);
      }
      add_instance(b, base + in.mesh, entry.then(node), f.path);
    }
  }
  b.instanced_files.clear();
}

// One instance entry at `path` under the transform `parent`, at nesting depth `depth` (1 at the top level).
void expand_instance(Builder& b, const Json& e, const std::string& path, const Xform& parent, int depth) {
  const Reader& r = b.reader;
  r.object(e, path);
  r.check_keys(e, path, {"prototype", "transform"});
  if (!e.contains("prototype")) r.fail(path, "missing key 'prototype'");
  const std::string name = r.string(e["prototype"], join(path, "prototype"));
  auto it = b.prototypes.find(name);
  if (it == b.prototypes.end()) {
    std::string known;
    for (const auto& [n, p] : b.prototypes) known += (known.empty() ? "" : ", ") + n;
    r.fail(join(path, "prototype"),
           "unknown prototype '" + name + "' (known: " + (known.empty() ? "none" : known) + ")");
  }
  Builder::Prototype& proto = it->second;
  if (proto.visiting) r.fail(join(path, "prototype"), "instance loop: '" + name + "' contains itself");
  if (depth > hw::kMaxInstanceNesting)
    r.fail(path, "instances nested deeper than " + std::to_string(hw::kMaxInstanceNesting) + " levels");
  const Xform x =
      e.contains("transform") ? parent.then(read_transform(r, e["transform"], join(path, "transform"))) : parent;
  if (proto.empty) return;  // its one full walk checked its entries and placed nothing
  const size_t placed = b.scene.instances.instances.size();
  if (proto.mesh != UINT32_MAX) add_instance(b, proto.mesh, x, path);
  if (proto.json->contains("instances")) {
    const Json& subs = (*proto.json)["instances"];
    proto.visiting = true;
    for (size_t i = 0; i < subs.size(); ++i)
      expand_instance(b, subs[i], join(join(proto.path, "instances"), i), x, depth + 1);
    proto.visiting = false;
  }
  proto.empty = b.scene.instances.instances.size() == placed;
}

void read_instances(Builder& b, const Json& j) {
  b.reader.array(j, "instances");
  for (size_t i = 0; i < j.size(); ++i) expand_instance(b, j[i], join("instances", i), Xform{}, 1);
}

void read_spheres(Builder& b, const Json& j) {
  const Reader& r = b.reader;
  r.array(j, "spheres");
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string path = join("spheres", i);
    const Json& s = r.object(j[i], path);
    r.check_keys(s, path, {"center", "radius", "material"});
    if (!s.contains("center")) r.fail(path, "missing key 'center'");
    if (!s.contains("radius")) r.fail(path, "missing key 'radius'");
    const Vec3 center = r.vec3(s["center"], join(path, "center"));
    const float radius = r.positive(s["radius"], join(path, "radius"));
    b.sphere_material.push_back(b.material(s, path));
    b.scene.geometry.spheres.push_back({center, radius});
  }
}

// A curve set: points, a radius per point (or one for all) and segment starts (default: one strand through every
// point), as Embree's round linear curves take them (curves.h).
void read_curves(Builder& b, const Json& j) {
  const Reader& r = b.reader;
  r.array(j, "curves");
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string path = join("curves", i);
    const Json& c = r.object(j[i], path);
    r.check_keys(c, path, {"points", "radius", "radii", "segments", "material"});
    if (!c.contains("points")) r.fail(path, "missing key 'points'");
    if (c.contains("radius") == c.contains("radii")) r.fail(path, "give either 'radius' or 'radii'");
    const Json& pj = r.array(c["points"], join(path, "points"));
    if (pj.size() < 2) r.fail(join(path, "points"), "a curve needs at least 2 points");
    std::vector<Vec3> points;
    for (size_t k = 0; k < pj.size(); ++k) points.push_back(r.vec3(pj[k], join(join(path, "points"), k)));
    std::vector<float> radii;
    if (c.contains("radius")) {
      radii.assign(points.size(), r.positive(c["radius"], join(path, "radius")));
    } else {
      const Json& rj = r.array(c["radii"], join(path, "radii"));
      if (rj.size() != points.size())
        r.fail(join(path, "radii"), "expected one radius per point (" + std::to_string(points.size()) + ")");
      for (size_t k = 0; k < rj.size(); ++k) {
        const float v = r.number(rj[k], join(join(path, "radii"), k));
        if (!(v >= 0.0f)) r.fail(join(join(path, "radii"), k), "must be >= 0");
        radii.push_back(v);
      }
    }
    std::vector<uint32_t> starts;
    if (c.contains("segments")) {
      const Json& sj = r.array(c["segments"], join(path, "segments"));
      const int last = int(std::min<size_t>(points.size(), size_t(INT32_MAX))) - 2;
      for (size_t k = 0; k < sj.size(); ++k)
        starts.push_back(uint32_t(r.integer(sj[k], join(join(path, "segments"), k), 0, last)));
    } else {
      for (uint32_t k = 0; k + 1 < points.size(); ++k) starts.push_back(k);
    }
    const uint32_t material = b.material(c, path);
    try {
      add_curve_set(b.scene.geometry, points, radii, starts, "curve");
    } catch (const Error& e) {
      r.fail(path, e.what());
    }
    b.curve_material.insert(b.curve_material.end(), starts.size(), material);
  }
}

void read_planes(Builder& b, const Json& j) {
  const Reader& r = b.reader;
  r.array(j, "planes");
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string path = join("planes", i);
    const Json& p = r.object(j[i], path);
    r.check_keys(p, path, {"normal", "offset", "point", "material"});
    if (!p.contains("normal")) r.fail(path, "missing key 'normal'");
    const Vec3 normal = r.nonzero_vec3(p["normal"], join(path, "normal"));
    if (p.contains("offset") && p.contains("point")) r.fail(path, "give either 'offset' or 'point', not both");
    float offset = 0.0f;
    if (p.contains("offset")) offset = r.number(p["offset"], join(path, "offset"));
    if (p.contains("point")) {
      const double c = glm::dot(DVec3(r.vec3(p["point"], join(path, "point"))), DVec3(normal));
      if (!(std::fabs(c) <= double(FLT_MAX))) r.fail(join(path, "point"), "dot(point, normal) out of float range");
      offset = float(c);
    }
    b.plane_material.push_back(b.material(p, path));
    b.scene.geometry.planes.push_back({normal, offset});
  }
}

// Point lights, and area lights with their two emissive triangles each (after every mesh triangle).
void read_lights(Builder& b, const Json& j) {
  const Reader& r = b.reader;
  r.array(j, "lights");
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string path = join("lights", i);
    const Json& l = r.object(j[i], path);
    if (!l.contains("type")) r.fail(path, "missing key 'type' (point or area)");
    const std::string type = r.string(l["type"], join(path, "type"));
    Light light;
    if (type == "point") {
      r.check_keys(l, path, {"type", "position", "intensity"});
      if (!l.contains("position")) r.fail(path, "missing key 'position'");
      light.type = LightType::kPoint;
      light.position = r.vec3(l["position"], join(path, "position"));
      if (l.contains("intensity")) light.intensity = r.color(l["intensity"], join(path, "intensity"));
    } else if (type == "area") {
      r.check_keys(l, path, {"type", "corner", "edge_u", "edge_v", "emission"});
      for (const char* key : {"corner", "edge_u", "edge_v"}) {
        if (!l.contains(key)) r.fail(path, std::string("missing key '") + key + "'");
      }
      light.type = LightType::kArea;
      light.position = r.vec3(l["corner"], join(path, "corner"));
      light.edge_u = r.nonzero_vec3(l["edge_u"], join(path, "edge_u"));
      light.edge_v = r.nonzero_vec3(l["edge_v"], join(path, "edge_v"));
      if (glm::cross(DVec3(light.edge_u), DVec3(light.edge_v)) == DVec3(0.0)) {
        r.fail(path, "edge_u and edge_v are parallel");
      }
      light.intensity = l.contains("emission") ? r.color(l["emission"], join(path, "emission")) : Vec3(1.0f);

      // Its own emissive material, then the triangles (corner, +u, +u+v) and (corner, +u+v, +v).
      const uint32_t m = uint32_t(b.scene.materials.size());
      b.scene.materials.push_back({.name = path,
                                   .type = MaterialType::kEmissive,
                                   .color = Vec3(1.0f),
                                   .ior = 1.5f,
                                   .emission = light.intensity});
      std::vector<hw::Triangle>& tris = b.scene.geometry.triangles;
      light.first_prim = uint32_t(tris.size());
      const Vec3 c = light.position, pu = c + light.edge_u, puv = pu + light.edge_v, pv = c + light.edge_v;
      tris.push_back({c, pu, puv});
      tris.push_back({c, puv, pv});
      b.tri_material.insert(b.tri_material.end(), 2, m);
    } else {
      r.fail(join(path, "type"), "unknown light type '" + type + "' (valid: point, area)");
    }
    b.scene.lights.push_back(light);
  }
}

}  // namespace

Scene load_scene_file(const std::string& path) {
  // Depth-bounded (json_io.h): the reads below copy values and name them in messages, both recursive.
  return load_scene_json(read_json_file(path), path, std::filesystem::path(path).parent_path().string());
}

Scene load_scene_json(const nlohmann::ordered_json& root, const std::string& path, const std::string& base) {
  const Reader r(path);
  if (!root.is_object())
    r.fail("", std::string("expected a JSON object at the top level, got ") + root.type_name());
  r.check_keys(root, "",
               {"description", "camera", "textures", "materials", "meshes", "spheres", "curves", "planes",
                "lights", "prototypes", "instances"});

  Builder b{r, {}, {}, {}, {}, {}, {}, {}, std::vector<std::vector<uint32_t>>(1), {}, 0, {}, {}, {}, {}, {}};
  b.mesh_tri_uv.resize(1);
  b.scene.name = path;
  try {
    if (root.contains("description")) r.string(root["description"], "description");
    if (root.contains("textures")) read_textures(b, root["textures"], std::filesystem::path(path).parent_path());
    read_materials(b, root.contains("materials") ? root["materials"] : Json::object());
    // Triangle order: meshes, then area lights (scene.h). Lights are read after the meshes for that reason.
    const std::filesystem::path base_dir(base);
    if (root.contains("meshes")) read_meshes(b, root["meshes"], base_dir);
    if (root.contains("lights")) read_lights(b, root["lights"]);
    if (root.contains("spheres")) read_spheres(b, root["spheres"]);
    if (root.contains("curves")) read_curves(b, root["curves"]);
    if (root.contains("planes")) read_planes(b, root["planes"]);
    b.scene.instances.meshes.emplace_back();  // mesh 0: the loose geometry, if instances follow
    add_file_instances(b);
    if (root.contains("prototypes")) read_prototypes(b, root["prototypes"], base_dir);
    if (root.contains("instances")) read_instances(b, root["instances"]);
    if (root.contains("camera")) {
      read_camera(r, root["camera"], b.scene.camera);
      b.scene.has_camera = true;
    }
  } catch (const nlohmann::json::exception& e) {  // not expected: every access is type-checked first
    r.fail("", e.what());
  }

  Scene& scene = b.scene;
  b.tri_uv.resize(scene.geometry.triangles.size());  // the loose triangles: meshes, then area lights (none)
  if (scene.instances.instances.empty()) {
    if (root.contains("instances") && !root["instances"].empty())
      r.fail("instances", "no instance has triangles (its prototypes have no meshes)");
    scene.instances = {};
  } else {
    if (!scene.geometry.curves.empty()) r.fail("curves", "curves in a scene with instances are not supported");
    // Two levels: the loose triangles and spheres become mesh 0 under the identity, instance 0; the geometry is
    // the flattened scene (loose triangles, instance triangles, spheres, planes).
    hw::InstanceSet& set = scene.instances;
    set.meshes[0].triangles = std::move(scene.geometry.triangles);
    set.meshes[0].spheres = std::move(scene.geometry.spheres);
    set.instances.insert(set.instances.begin(), hw::Instance{});
    set.finish();
    scene.geometry = set.flatten(scene.geometry.planes);
    b.tri_material.insert(b.tri_material.end(), b.instance_tri_material.begin(), b.instance_tri_material.end());
    b.tri_uv.insert(b.tri_uv.end(), b.instance_tri_uv.begin(), b.instance_tri_uv.end());
  }
  // Texture coordinates only matter to textured materials.
  if (!scene.textures.empty()) scene.triangle_uv = std::move(b.tri_uv);
  scene.prim_material = b.tri_material;
  scene.prim_material.insert(scene.prim_material.end(), b.sphere_material.begin(), b.sphere_material.end());
  scene.prim_material.insert(scene.prim_material.end(), b.curve_material.begin(), b.curve_material.end());
  scene.prim_material.insert(scene.prim_material.end(), b.plane_material.begin(), b.plane_material.end());
  if (!scene.has_camera) scene.camera = frame_camera(scene.geometry.bounds());
  return std::move(b.scene);
}

}  // namespace rtu::host
