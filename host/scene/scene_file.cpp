// Scene description files (JSON). The schema is documented in scenes/README.md; keep the two in step.
//
// Strict by design: unknown or duplicate keys, wrong types or array lengths, non-finite numbers and unknown
// names are errors that name the file and the key path (e.g. "meshes[2].transform.scale"). The JSON itself is read
// by host/io/json_io.h, which also refuses nesting deeper than kMaxJsonDepth levels.
//
// This file reads the camera, textures, materials, spheres, curves, planes and lights, and puts the scene
// together (load_scene_json); scene_file_meshes.cpp reads "meshes", scene_file_instances.cpp "prototypes" and
// "instances"; scene_file_reader.h holds the typed reads and the scene being built that they share.
#include <algorithm>
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
#include "host/io/image.h"
#include "host/io/json_io.h"
#include "host/io/limits.h"
#include "host/scene/curves.h"
#include "host/scene/scene.h"
#include "host/scene/scene_file_reader.h"

namespace rtu::host {

using namespace scene_file_detail;

namespace {

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

}  // namespace

namespace scene_file_detail {

void read_spheres(Builder& b, const Json& j, const std::string& where, hw::Geometry& g,
                  std::vector<uint32_t>& material) {
  const Reader& r = b.reader;
  r.each_object(j, where, [&](const Json& s, const std::string& path) {
    r.check_keys(s, path, {"center", "radius", "material"});
    if (!s.contains("center")) r.fail(path, "missing key 'center'");
    if (!s.contains("radius")) r.fail(path, "missing key 'radius'");
    const Vec3 center = r.vec3(s["center"], join(path, "center"));
    const float radius = r.positive(s["radius"], join(path, "radius"));
    material.push_back(b.material(s, path));
    g.spheres.push_back({center, radius});
  });
}

// A curve set: points, a radius per point (or one for all) and segment starts (default: one strand through every
// point), as Embree's round linear curves take them (curves.h).
void read_curves(Builder& b, const Json& j, const std::string& where, hw::Geometry& g,
                 std::vector<uint32_t>& material) {
  const Reader& r = b.reader;
  r.each_object(j, where, [&](const Json& c, const std::string& path) {
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
    const uint32_t mat = b.material(c, path);
    try {
      add_curve_set(g, points, radii, starts, "curve");
    } catch (const Error& e) {
      r.fail(path, e.what());
    }
    material.insert(material.end(), starts.size(), mat);
  });
}

}  // namespace scene_file_detail

namespace {

void read_planes(Builder& b, const Json& j) {
  const Reader& r = b.reader;
  r.each_object(j, "planes", [&](const Json& p, const std::string& path) {
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
  });
}

// Point lights, and area lights with their two emissive triangles each (after every mesh triangle).
void read_lights(Builder& b, const Json& j) {
  const Reader& r = b.reader;
  r.each_object(j, "lights", [&](const Json& l, const std::string& path) {
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
  });
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

  Builder b{r,  {}, {}, {}, {}, {}, {}, {}, std::vector<std::vector<uint32_t>>(1), {}, {}, {},
            {}, {}, 0,  {}, {}, {}, {}, {}};
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
    if (root.contains("spheres")) read_spheres(b, root["spheres"], "spheres", b.scene.geometry, b.sphere_material);
    if (root.contains("curves")) read_curves(b, root["curves"], "curves", b.scene.geometry, b.curve_material);
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
    // Two levels: the loose triangles, spheres and curves become mesh 0 under the identity, instance 0; the
    // geometry is the flattened scene (loose triangles, instance triangles, spheres, curves, planes).
    hw::InstanceSet& set = scene.instances;
    set.meshes[0].triangles = std::move(scene.geometry.triangles);
    set.meshes[0].spheres = std::move(scene.geometry.spheres);
    set.meshes[0].curves = std::move(scene.geometry.curves);
    set.instances.insert(set.instances.begin(), hw::Instance{});
    set.finish();
    scene.geometry = set.flatten(scene.geometry.planes);
    b.tri_material.insert(b.tri_material.end(), b.instance_tri_material.begin(), b.instance_tri_material.end());
    b.sphere_material.insert(b.sphere_material.end(), b.instance_sphere_material.begin(),
                             b.instance_sphere_material.end());
    b.curve_material.insert(b.curve_material.end(), b.instance_curve_material.begin(),
                            b.instance_curve_material.end());
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
