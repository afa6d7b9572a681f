// load_scene: dispatch on the spec, then one validation for every kind of input. Also the automatic camera.
#include "host/scene/scene.h"

#include <algorithm>
#include <cctype>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <stdexcept>
#include <string>

#include "firmware/render_scene.h"
#include "host/io/error.h"
#include "host/io/limits.h"
#include "host/scene/curves.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::host {
namespace {

constexpr const char* kBuiltinPrefix = "builtin:";

bool finite(const Vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

std::string format_vec(const Vec3& v) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "(%g, %g, %g)", double(v.x), double(v.y), double(v.z));
  return buf;
}

bool has_json_extension(const std::string& spec) {
  std::string ext = std::filesystem::path(spec).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".json";
}

// A bare mesh file: one mesh entry with the file's materials (or the default material), an automatic camera, and a
// point light at the camera so a render is not black.
Scene load_mesh_scene(const std::string& path) {
  Scene scene;
  scene.name = path;
  ImportedModel model = import_model(path);
  scene.geometry.triangles = std::move(model.triangles);
  scene.instances = std::move(model.instances);  // a node tree that places meshes more than once: two levels
  // Its lines, as strands of curve segments a thousandth of the file's size thick (a scene file's mesh entry
  // names the radius: `curve_radius`).
  if (!model.lines.empty()) {
    hw::Aabb b = scene.geometry.bounds();
    for (const ImportedLine& l : model.lines) {
      b.extend(l.p0);
      b.extend(l.p1);
    }
    add_lines(
        scene.geometry, model.lines, default_line_radius(b), [](const Vec3& v) { return v; }, path);
    if (scene.instanced()) {  // two levels: the lines (world space) are one more mesh, under the identity
      hw::Geometry loose;
      loose.curves = scene.geometry.curves;
      scene.instances.meshes.push_back(std::move(loose));
      scene.instances.instances.push_back(hw::Instance{uint32_t(scene.instances.meshes.size() - 1), {}});
      scene.instances.finish();
    }
  }
  if (!model.materials.empty()) {  // the file's own materials
    scene.materials = std::move(model.materials);
    scene.prim_material = std::move(model.tri_material);
    for (const ImportedLine& l : model.lines)
      scene.prim_material.push_back(l.material == UINT32_MAX ? 0 : l.material);
    scene.textures = std::move(model.textures);
    if (!scene.textures.empty()) scene.triangle_uv = std::move(model.tri_uv);
  } else {
    scene.materials.push_back({.name = "default",
                               .type = MaterialType::kDiffuse,
                               .color = Vec3(0.8f),
                               .ior = 1.5f,
                               .emission = Vec3(0.0f)});
    scene.prim_material.assign(scene.geometry.num_prims(), 0);
  }
  scene.camera = frame_camera(scene.geometry.bounds());
  // Intensity = squared distance to the target: irradiance about 1 there.
  const double d = glm::length(hw::DVec3(scene.camera.look_at) - hw::DVec3(scene.camera.position));
  Light light;
  light.type = LightType::kPoint;
  light.position = scene.camera.position;
  light.intensity = Vec3(float(std::min(d * d, double(FLT_MAX))));
  scene.lights.push_back(light);
  return scene;
}

}  // namespace

Scene load_scene(const std::string& spec) {
  Scene scene;
  if (spec.rfind(kBuiltinPrefix, 0) == 0) {
    scene = load_builtin_scene(spec.substr(std::char_traits<char>::length(kBuiltinPrefix)));
  } else if (has_json_extension(spec)) {
    scene = load_scene_file(spec);
  } else {
    scene = load_mesh_scene(spec);
  }
  scene.name = spec;
  finish_scene(scene);
  return scene;
}

void finish_scene(Scene& scene) {
  validate_scene(scene);
  mark_non_opaque(scene);
}

void mark_non_opaque(Scene& scene) {
  hw::Geometry& g = scene.geometry;
  g.non_opaque.clear();
  for (hw::Geometry& m : scene.instances.meshes) m.non_opaque.clear();
  bool any = false;
  for (const Material& m : scene.materials) any |= m.alpha_mode == AlphaMode::kMask;
  if (!any) return;
  g.non_opaque.assign(g.triangles.size(), 0);
  for (size_t i = 0; i < g.triangles.size(); ++i)
    g.non_opaque[i] = scene.materials[scene.prim_material[i]].alpha_mode == AlphaMode::kMask ? 1 : 0;
  // Instance meshes: every placement of a mesh has its materials, so any placement gives its flags.
  hw::InstanceSet& set = scene.instances;
  std::vector<bool> done(set.meshes.size(), false);
  for (uint32_t i = 0; i < set.instances.size(); ++i) {
    const uint32_t mesh = set.instances[i].mesh;
    if (done[mesh]) continue;
    done[mesh] = true;
    hw::Geometry& m = set.meshes[mesh];
    m.non_opaque.resize(m.triangles.size());
    for (uint32_t j = 0; j < m.triangles.size(); ++j) m.non_opaque[j] = g.non_opaque[set.global_prim(i, j)];
  }
}

void check_scene_size(const std::string& name, uint64_t prims) {
  // The unit's primitive index (BVH leaves, device image records, float scene image) holds fewer than 2^27.
  if (prims >= hw::kMaxBvhPrims)
    throw Error(name + ": " + std::to_string(prims) +
                " primitives: more than the unit's primitive index holds (at most " +
                std::to_string(hw::kMaxBvhPrims - 1) + ")");
  // A trace keeps the geometry, the float BVH, its leaf-ordered copies and the device image: 256 bytes per
  // primitive is a floor (trace_bench's peaks are 87-136 MiB for 120k-250k triangles, import included).
  check_memory(name + ": " + std::to_string(prims) + " primitives", prims * 256);
}

void validate_scene(const Scene& scene) {
  auto fail = [&](const std::string& problem) { throw Error(scene.name + ": " + problem); };
  const hw::Geometry& g = scene.geometry;
  if (g.num_prims() == 0) fail("empty scene (no triangles, spheres, curves or planes)");
  check_scene_size(scene.name, g.num_prims());
  if (scene.instanced()) {
    try {
      scene.instances.validate();
    } catch (const std::invalid_argument& e) {
      fail(e.what());
    }
    if (scene.instances.num_triangles() != g.triangles.size() || scene.instances.num_spheres() != g.spheres.size())
      fail("the instances and the flattened geometry differ in their primitive counts");
  }

  for (size_t i = 0; i < g.triangles.size(); ++i) {
    const hw::Triangle& t = g.triangles[i];
    if (!finite(t.v0) || !finite(t.v1) || !finite(t.v2)) {
      fail("triangle " + std::to_string(i) + ": NaN/Inf coordinate " + format_vec(t.v0) + " " + format_vec(t.v1) +
           " " + format_vec(t.v2));
    }
  }
  for (size_t i = 0; i < g.spheres.size(); ++i) {
    const hw::Sphere& s = g.spheres[i];
    if (!finite(s.center)) fail("sphere " + std::to_string(i) + ": NaN/Inf center " + format_vec(s.center));
    if (!(s.radius > 0.0f) || !std::isfinite(s.radius)) {
      fail("sphere " + std::to_string(i) + ": radius must be finite and > 0, got " + std::to_string(s.radius));
    }
  }
  for (size_t i = 0; i < g.curves.size(); ++i)
    if (const std::string why = hw::check_curve_segment(g.curves[i]); !why.empty())
      fail("curve segment " + std::to_string(i) + ": " + why);
  for (size_t i = 0; i < g.planes.size(); ++i) {
    const hw::Plane& p = g.planes[i];
    if (!finite(p.normal) || !std::isfinite(p.offset)) fail("plane " + std::to_string(i) + ": NaN/Inf value");
    if (p.normal == Vec3(0.0f)) fail("plane " + std::to_string(i) + ": zero normal");
  }
  // Finite but huge: products of two values would overflow float (hw::kMaxCoordinate).
  auto big = [](const Vec3& v) {
    return std::fabs(v.x) > hw::kMaxCoordinate || std::fabs(v.y) > hw::kMaxCoordinate ||
           std::fabs(v.z) > hw::kMaxCoordinate;
  };
  const std::string too_big = ": a value beyond 2^62 (4.6e18), where float products overflow";
  for (size_t i = 0; i < g.triangles.size(); ++i)
    if (big(g.triangles[i].v0) || big(g.triangles[i].v1) || big(g.triangles[i].v2))
      fail("triangle " + std::to_string(i) + too_big);
  for (size_t i = 0; i < g.spheres.size(); ++i)
    if (big(g.spheres[i].center) || g.spheres[i].radius > hw::kMaxCoordinate)
      fail("sphere " + std::to_string(i) + too_big);
  for (size_t i = 0; i < g.planes.size(); ++i)
    if (big(g.planes[i].normal) || std::fabs(g.planes[i].offset) > hw::kMaxCoordinate)
      fail("plane " + std::to_string(i) + too_big);

  if (scene.materials.empty()) fail("no materials");
  if (scene.prim_material.size() != g.num_prims()) {
    fail("prim_material has " + std::to_string(scene.prim_material.size()) + " entries for " +
         std::to_string(g.num_prims()) + " primitives");
  }
  for (size_t i = 0; i < scene.prim_material.size(); ++i) {
    if (scene.prim_material[i] >= scene.materials.size()) {
      fail("primitive " + std::to_string(i) + ": material index out of range");
    }
  }
  for (const Material& m : scene.materials) {
    if (!finite(m.color) || !finite(m.emission) || !std::isfinite(m.ior) || !(m.ior > 0.0f)) {
      fail("material '" + m.name + "': NaN/Inf or non-positive ior");
    }
    if (!(m.alpha >= 0.0f && m.alpha <= 1.0f) || !(m.alpha_cutoff >= 0.0f && m.alpha_cutoff <= 1.0f))
      fail("material '" + m.name + "': alpha and alpha_cutoff must be in [0, 1]");
    if (m.texture < -1 || m.texture >= int(scene.textures.size()))
      fail("material '" + m.name + "': texture index out of range");
  }
  for (const Texture& t : scene.textures) {
    if (t.width < 1 || t.height < 1 || t.width > fw::kMaxTextureSide || t.height > fw::kMaxTextureSide)
      fail("texture '" + t.name + "': " + std::to_string(t.width) + " x " + std::to_string(t.height) +
           " texels (each side must be in [1, " + std::to_string(fw::kMaxTextureSide) + "])");
    if (t.rgba.size() != size_t(t.width) * t.height * 4) fail("texture '" + t.name + "': texel count mismatch");
  }
  if (!scene.triangle_uv.empty() && scene.triangle_uv.size() != g.triangles.size())
    fail("triangle_uv has " + std::to_string(scene.triangle_uv.size()) + " entries for " +
         std::to_string(g.triangles.size()) + " triangles");
  for (size_t i = 0; i < scene.triangle_uv.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(scene.triangle_uv[i].s[k]) || !std::isfinite(scene.triangle_uv[i].t[k]))
        fail("triangle " + std::to_string(i) + ": NaN/Inf texture coordinate");

  for (size_t i = 0; i < scene.lights.size(); ++i) {
    const Light& l = scene.lights[i];
    const std::string label = "light " + std::to_string(i);
    if (!finite(l.position) || !finite(l.edge_u) || !finite(l.edge_v) || !finite(l.intensity)) {
      fail(label + ": NaN/Inf value");
    }
    if (l.type == LightType::kArea && uint64_t(l.first_prim) + 2 > g.triangles.size()) {
      fail(label + ": area light triangles out of range");
    }
  }

  const Camera& c = scene.camera;
  if (!finite(c.position) || !finite(c.look_at) || !finite(c.up) || !std::isfinite(c.fov_y_deg)) {
    fail("camera: NaN/Inf value");
  }
  if (!(c.fov_y_deg > 0.0f && c.fov_y_deg < 180.0f)) fail("camera: fov_y must be in (0, 180) degrees");
  if (c.width <= 0 || c.height <= 0) fail("camera: width and height must be > 0");
  if (c.position == c.look_at) fail("camera: position and look_at are the same point");
}

Camera frame_camera(const hw::Aabb& bounds) {
  Camera cam;  // empty or non-finite bounds (e.g. only planes): the default camera
  if (bounds.empty() || !finite(bounds.lo) || !finite(bounds.hi)) return cam;

  const hw::DVec3 lo(bounds.lo), hi(bounds.hi);
  const hw::DVec3 center = 0.5 * (lo + hi);
  double radius = 0.5 * glm::length(hi - lo);  // bounding sphere of the box
  // A point or a tiny box far from the origin: keep the camera resolvably far from its target in float.
  const double magnitude = std::max({std::fabs(center.x), std::fabs(center.y), std::fabs(center.z)});
  if (!(radius > 0.0)) radius = 1.0;
  radius = std::max(radius, 1e-4 * magnitude);

  // Fit the bounding sphere in the vertical field of view (the horizontal one is wider at 4:3).
  const double half_fov = 0.5 * double(cam.fov_y_deg) * std::numbers::pi / 180.0;
  const double distance = radius / std::sin(half_fov);
  const hw::DVec3 dir = glm::normalize(hw::DVec3(1.0, 0.6, 1.4));
  cam.look_at = Vec3(center);
  cam.position = Vec3(center + distance * dir);
  cam.up = Vec3(0.0f, 1.0f, 0.0f);
  return cam;
}

}  // namespace rtu::host
