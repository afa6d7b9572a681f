// Built-in scenes (builtin:NAME[?key=value&...]) and the mesh generators they and scene files use.
// Everything here is deterministic and needs no files.
#include <charconv>
#include <cmath>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "host/io/error.h"
#include "host/scene/generators.h"
#include "host/scene/scene.h"
#include "host/scene/suite_scenes.h"

namespace rtu::host {

using hw::Vec3;

// ---- Generators

IndexedMesh make_icosphere(int subdiv, float radius, Vec3 offset) {
  if (subdiv < 0 || subdiv > kMaxIcosphereSubdiv) throw Error("icosphere: subdiv out of range");
  if (!(radius > 0.0f) || !std::isfinite(radius)) throw Error("icosphere: radius must be > 0");
  // Refused before generating when the scene could not be traced (check_scene_size: index width, memory).
  check_scene_size("icosphere subdiv " + std::to_string(subdiv), uint64_t(20) << (2 * subdiv));

  // Unit-sphere directions in double; rounded to float once at the end.
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<hw::DVec3> dirs = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                                 {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (hw::DVec3& d : dirs) d = glm::normalize(d);
  std::vector<std::array<uint32_t, 3>> faces = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                                {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                                {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                                {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};

  for (int level = 0; level < subdiv; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoints;  // edge (lo, hi) -> vertex, computed once
    auto midpoint = [&](uint32_t a, uint32_t b) {
      auto key = std::minmax(a, b);
      auto it = midpoints.find(key);
      if (it != midpoints.end()) return it->second;
      dirs.push_back(glm::normalize(dirs[key.first] + dirs[key.second]));
      uint32_t index = uint32_t(dirs.size() - 1);
      midpoints.emplace(key, index);
      return index;
    };
    std::vector<std::array<uint32_t, 3>> finer;
    finer.reserve(faces.size() * 4);
    for (const auto& f : faces) {
      uint32_t ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      finer.push_back({f[0], ab, ca});
      finer.push_back({f[1], bc, ab});
      finer.push_back({f[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    faces = std::move(finer);
  }

  IndexedMesh mesh;
  mesh.vertices.reserve(dirs.size());
  for (const hw::DVec3& d : dirs) mesh.vertices.push_back(Vec3(d * double(radius)) + offset);
  mesh.faces = std::move(faces);
  return mesh;
}

IndexedMesh make_torus(float major_radius, float minor_radius, int major_segments, int minor_segments) {
  if (!(major_radius > 0.0f) || !(minor_radius > 0.0f) || !std::isfinite(major_radius) ||
      !std::isfinite(minor_radius)) {
    throw Error("torus: radii must be > 0");
  }
  for (int n : {major_segments, minor_segments}) {
    if (n < kMinTorusSegments || n > kMaxTorusSegments) throw Error("torus: segment count out of range");
  }
  check_scene_size("torus " + std::to_string(major_segments) + " x " + std::to_string(minor_segments),
                   2 * uint64_t(major_segments) * uint64_t(minor_segments));
  IndexedMesh mesh;
  const double two_pi = 2.0 * std::numbers::pi;
  for (int i = 0; i < major_segments; ++i) {
    const double phi = two_pi * i / major_segments;  // around the y axis
    for (int j = 0; j < minor_segments; ++j) {
      const double theta = two_pi * j / minor_segments;  // around the tube
      const double r = major_radius + minor_radius * std::cos(theta);
      mesh.vertices.push_back(
          Vec3(hw::DVec3(r * std::cos(phi), minor_radius * std::sin(theta), -r * std::sin(phi))));
    }
  }
  auto index = [&](int i, int j) {
    return uint32_t((i % major_segments) * minor_segments + (j % minor_segments));
  };
  for (int i = 0; i < major_segments; ++i) {
    for (int j = 0; j < minor_segments; ++j) {
      const uint32_t a = index(i, j), b = index(i + 1, j), c = index(i + 1, j + 1), d = index(i, j + 1);
      mesh.faces.push_back({a, b, c});
      mesh.faces.push_back({a, c, d});
    }
  }
  return mesh;
}

IndexedMesh make_box(Vec3 size) {
  if (!(size.x > 0.0f && size.y > 0.0f && size.z > 0.0f)) throw Error("box: size must be > 0");
  const Vec3 h = 0.5f * size;
  IndexedMesh mesh;
  for (int k = 0; k < 8; ++k) {  // bit 0: +x, bit 1: +y, bit 2: +z
    mesh.vertices.push_back(Vec3(k & 1 ? h.x : -h.x, k & 2 ? h.y : -h.y, k & 4 ? h.z : -h.z));
  }
  // Each side as a quad, counter-clockwise from outside, split along its first diagonal.
  const uint32_t quads[6][4] = {{1, 3, 7, 5}, {0, 4, 6, 2},   // +x, -x
                                {2, 6, 7, 3}, {0, 1, 5, 4},   // +y, -y
                                {4, 5, 7, 6}, {0, 2, 3, 1}};  // +z, -z
  for (const auto& q : quads) {
    mesh.faces.push_back({q[0], q[1], q[2]});
    mesh.faces.push_back({q[0], q[2], q[3]});
  }
  return mesh;
}

IndexedMesh make_quad(float size_x, float size_z) {
  if (!(size_x > 0.0f && size_z > 0.0f)) throw Error("quad: size must be > 0");
  const float hx = 0.5f * size_x, hz = 0.5f * size_z;
  IndexedMesh mesh;
  mesh.vertices = {{-hx, 0.0f, -hz}, {-hx, 0.0f, hz}, {hx, 0.0f, hz}, {hx, 0.0f, -hz}};
  mesh.faces = {{0, 1, 2}, {0, 2, 3}};  // counter-clockwise seen from +y
  mesh.uvs = {{0.0f, 0.0f}, {0.0f, 1.0f}, {1.0f, 1.0f}, {1.0f, 0.0f}};
  return mesh;
}

void append_triangles(const IndexedMesh& mesh, std::vector<hw::Triangle>& out) {
  out.reserve(out.size() + mesh.faces.size());
  for (const auto& f : mesh.faces) out.push_back({mesh.vertices[f[0]], mesh.vertices[f[1]], mesh.vertices[f[2]]});
}

// ---- Built-in scenes

namespace {

constexpr Vec3 kFarOffset(148376.0f, 1234.0f, -223423.0f);  // icosphere_far: far from the origin

using Params = std::map<std::string, std::string>;

// Appends a parallelogram light's two triangles (corner, +u, +u+v) and (corner, +u+v, +v) with its own emissive
// material, and its Light record. Call after all mesh triangles: they must follow them (scene.h).
void add_area_light(Scene& scene, std::vector<uint32_t>& tri_material, Vec3 corner, Vec3 edge_u, Vec3 edge_v,
                    Vec3 emission, const std::string& material_name) {
  const uint32_t m = add_material(scene, {.name = material_name,
                                          .type = MaterialType::kEmissive,
                                          .color = Vec3(1.0f),
                                          .ior = 1.5f,
                                          .emission = emission});
  Light light;
  light.type = LightType::kArea;
  light.position = corner;
  light.edge_u = edge_u;
  light.edge_v = edge_v;
  light.intensity = emission;
  light.first_prim = uint32_t(scene.geometry.triangles.size());
  const Vec3 pu = corner + edge_u, puv = pu + edge_v, pv = corner + edge_v;
  scene.geometry.triangles.push_back({corner, pu, puv});
  scene.geometry.triangles.push_back({corner, puv, pv});
  tri_material.insert(tri_material.end(), 2, m);
  scene.lights.push_back(light);
}

// prim_material from the per-kind lists, in primitive order.
void set_prim_material(Scene& scene, const std::vector<uint32_t>& tri, const std::vector<uint32_t>& sphere,
                       const std::vector<uint32_t>& plane) {
  scene.prim_material = tri;
  scene.prim_material.insert(scene.prim_material.end(), sphere.begin(), sphere.end());
  scene.prim_material.insert(scene.prim_material.end(), plane.begin(), plane.end());
}

// seed: the classic picture of the lecture outline: a mirror sphere, a glass sphere and a diffuse torus on a
// ground plane, one point light.
Scene make_seed() {
  Scene scene;
  const uint32_t ground = add_material(scene, diffuse_material("ground", Vec3(0.75f, 0.75f, 0.7f)));
  const uint32_t torus = add_material(scene, diffuse_material("torus", Vec3(0.85f, 0.45f, 0.15f)));
  const uint32_t mirror = add_material(scene, {"mirror", MaterialType::kMirror, Vec3(0.9f), 1.5f, {}});
  const uint32_t glass = add_material(scene, {"glass", MaterialType::kGlass, Vec3(1.0f), 1.5f, {}});

  // Torus (64 x 24 segments = 3072 triangles), stood up by a rotation of 75 degrees about x, behind the spheres.
  IndexedMesh mesh = make_torus(0.9f, 0.3f, 64, 24);
  const double angle = 75.0 * std::numbers::pi / 180.0;
  const double c = std::cos(angle), s = std::sin(angle);
  for (Vec3& v : mesh.vertices) {
    const hw::DVec3 p(v);
    v = Vec3(hw::DVec3(p.x, c * p.y - s * p.z, s * p.y + c * p.z) + hw::DVec3(0.0, 1.25, -1.6));
  }
  append_triangles(mesh, scene.geometry.triangles);
  std::vector<uint32_t> tri_material(scene.geometry.triangles.size(), torus);

  scene.geometry.spheres = {{Vec3(-1.3f, 0.8f, 0.2f), 0.8f}, {Vec3(1.3f, 0.8f, 0.5f), 0.8f}};
  scene.geometry.planes = {{Vec3(0.0f, 1.0f, 0.0f), 0.0f}};
  set_prim_material(scene, tri_material, {mirror, glass}, {ground});

  scene.lights.push_back(point_light(Vec3(4.0f, 7.0f, 5.0f), Vec3(90.0f)));
  scene.camera.position = Vec3(0.0f, 2.2f, 7.0f);
  scene.camera.look_at = Vec3(0.0f, 0.9f, -0.3f);
  scene.camera.fov_y_deg = 45.0f;
  scene.camera.width = 640;
  scene.camera.height = 480;
  scene.has_camera = true;
  return scene;
}

// cornell: the Cornell box as measured (www.graphics.cornell.edu/online/box/data.html), millimetres, open at
// z = 0. The light is lowered from the ceiling (548.8) to 548.7 so it does not share the ceiling's plane.
Scene make_cornell() {
  Scene scene;
  const uint32_t white = add_material(scene, diffuse_material("white", Vec3(0.73f, 0.73f, 0.73f)));
  const uint32_t red = add_material(scene, diffuse_material("red", Vec3(0.65f, 0.05f, 0.05f)));
  const uint32_t green = add_material(scene, diffuse_material("green", Vec3(0.12f, 0.45f, 0.15f)));

  struct Quad {
    Vec3 a, b, c, d;
    uint32_t material;
  };
  auto p = [](double x, double y, double z) { return Vec3(hw::DVec3(x, y, z)); };
  const Quad quads[] = {
      // floor, ceiling, back wall
      {p(552.8, 0, 0), p(0, 0, 0), p(0, 0, 559.2), p(549.6, 0, 559.2), white},
      {p(556, 548.8, 0), p(556, 548.8, 559.2), p(0, 548.8, 559.2), p(0, 548.8, 0), white},
      {p(549.6, 0, 559.2), p(0, 0, 559.2), p(0, 548.8, 559.2), p(556, 548.8, 559.2), white},
      // right wall (green, x = 0), left wall (red, x ~ 550)
      {p(0, 0, 559.2), p(0, 0, 0), p(0, 548.8, 0), p(0, 548.8, 559.2), green},
      {p(552.8, 0, 0), p(549.6, 0, 559.2), p(556, 548.8, 559.2), p(556, 548.8, 0), red},
      // short block: top, then four sides
      {p(130, 165, 65), p(82, 165, 225), p(240, 165, 272), p(290, 165, 114), white},
      {p(290, 0, 114), p(290, 165, 114), p(240, 165, 272), p(240, 0, 272), white},
      {p(130, 0, 65), p(130, 165, 65), p(290, 165, 114), p(290, 0, 114), white},
      {p(82, 0, 225), p(82, 165, 225), p(130, 165, 65), p(130, 0, 65), white},
      {p(240, 0, 272), p(240, 165, 272), p(82, 165, 225), p(82, 0, 225), white},
      // tall block: top, then four sides
      {p(423, 330, 247), p(265, 330, 296), p(314, 330, 456), p(472, 330, 406), white},
      {p(423, 0, 247), p(423, 330, 247), p(472, 330, 406), p(472, 0, 406), white},
      {p(472, 0, 406), p(472, 330, 406), p(314, 330, 456), p(314, 0, 456), white},
      {p(314, 0, 456), p(314, 330, 456), p(265, 330, 296), p(265, 0, 296), white},
      {p(265, 0, 296), p(265, 330, 296), p(423, 330, 247), p(423, 0, 247), white},
  };
  std::vector<uint32_t> tri_material;
  for (const Quad& q : quads) {
    scene.geometry.triangles.push_back({q.a, q.b, q.c});
    scene.geometry.triangles.push_back({q.a, q.c, q.d});
    tri_material.insert(tri_material.end(), 2, q.material);
  }
  // Ceiling light: 130 x 105; edge_u x edge_v points down, into the box.
  add_area_light(scene, tri_material, Vec3(343.0f, 548.7f, 227.0f), Vec3(0.0f, 0.0f, 105.0f),
                 Vec3(-130.0f, 0.0f, 0.0f), Vec3(17.0f, 12.0f, 4.0f), "light");
  set_prim_material(scene, tri_material, {}, {});

  // The original camera: 35 mm focal length, 25 mm film -> fov 2 atan(12.5 / 35) = 39.31 degrees.
  scene.camera.position = Vec3(278.0f, 273.0f, -800.0f);
  scene.camera.look_at = Vec3(278.0f, 273.0f, 0.0f);
  scene.camera.fov_y_deg = 39.3076f;
  scene.camera.width = 512;
  scene.camera.height = 512;
  scene.has_camera = true;
  return scene;
}

// icosphere: a closed, watertight subdivided icosahedron, camera outside on +z, a point light above it.
Scene make_icosphere_scene(int subdiv, float radius, Vec3 offset) {
  Scene scene;
  add_material(scene, diffuse_material("default", Vec3(0.8f)));
  append_triangles(make_icosphere(subdiv, radius, offset), scene.geometry.triangles);
  scene.prim_material.assign(scene.geometry.triangles.size(), 0);
  scene.camera.position = offset + radius * Vec3(0.0f, 0.0f, 4.0f);
  scene.camera.look_at = offset;
  scene.has_camera = true;
  scene.lights.push_back(point_light(offset + radius * Vec3(2.0f, 3.0f, 4.0f), Vec3(30.0f * radius * radius)));
  return scene;
}

struct BuiltinInfo {
  const char* name;
  const char* description;
  bool takes_params;  // the icosphere or hair parameters
};

constexpr BuiltinInfo kBuiltins[] = {
    {"seed",
     "mirror sphere, glass sphere (ior 1.5) and a diffuse torus (3072 triangles) on a ground plane, "
     "one point light, 640x480",
     false},
    {"cornell", "the Cornell box (measured data, mm): 30 wall and block triangles, 2 ceiling area-light triangles",
     false},
    {"icosphere",
     "closed watertight icosphere, 5120 triangles; ?subdiv=N (0..8, default 4)&radius=R "
     "(default 1)&offset=X,Y,Z (default 0,0,0)",
     true},
    {"icosphere_far", "icosphere with offset=148376,1234,-223423 (far from the origin); same parameters", true},
    // The benchmark suite's procedural scenes (suite_scenes.h, scenes/suite.json).
    {"hairball", "hard: thin overlapping tubes; 512 curved tubes in a unit ball, 196,608 triangles", false},
    {"hair",
     "hard: hair; a head with 24,000 strands of 8 linear swept spheres (192,000 curve segments), half curly; "
     "?as=curves|ribbons|dots (the same strands as camera-facing ribbons or two orthogonal strips of "
     "triangles)&strands=N (1..400000)",
     true},
    {"atrium",
     "hard: occlusion; a two-storey hall of columns and arches round an open court, lit inside, 19,422 triangles",
     false},
    {"city",
     "hard: instancing; 4 building prototypes placed 256 times on a ground: 257 instances, 161,216 triangles "
     "flattened from 2,308",
     false},
    {"forest",
     "hard: alpha-tested foliage; 64 trees of 72 leaf cards (texture, alpha_mode mask) on trunks and a ground, "
     "13,324 triangles",
     false},
};

std::string valid_names() {
  std::string s;
  for (const BuiltinInfo& b : kBuiltins) s += (s.empty() ? "" : ", ") + std::string(b.name);
  return s;
}

[[noreturn]] void fail_param(const std::string& spec, const std::string& key, const std::string& value,
                             const char* expected) {
  throw Error("builtin:" + spec + ": invalid value '" + value + "' for '" + key + "' (expected " + expected + ")");
}

bool parse_float(const std::string& text, float& out) {
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(text.data(), end, out);
  return ec == std::errc() && ptr == end && std::isfinite(out);
}

Params parse_params(const std::string& spec, const std::string& query) {
  Params params;
  size_t start = 0;
  while (start <= query.size()) {
    size_t end = query.find('&', start);
    if (end == std::string::npos) end = query.size();
    const std::string item = query.substr(start, end - start);
    const size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw Error("builtin:" + spec + ": malformed parameter '" + item + "' (expected key=value)");
    }
    if (!params.emplace(item.substr(0, eq), item.substr(eq + 1)).second) {
      throw Error("builtin:" + spec + ": parameter '" + item.substr(0, eq) + "' given twice");
    }
    start = end + 1;
  }
  return params;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> builtin_scene_names() {
  std::vector<std::pair<std::string, std::string>> names;
  for (const BuiltinInfo& b : kBuiltins) names.emplace_back(b.name, b.description);
  return names;
}

Scene load_builtin_scene(const std::string& spec) {
  const size_t q = spec.find('?');
  const std::string name = spec.substr(0, q);
  const BuiltinInfo* info = nullptr;
  for (const BuiltinInfo& b : kBuiltins) {
    if (name == b.name) info = &b;
  }
  if (!info)
    throw Error("builtin:" + spec + ": unknown built-in scene '" + name + "' (valid: " + valid_names() + ")");
  const Params params = q == std::string::npos ? Params{} : parse_params(spec, spec.substr(q + 1));
  if (!info->takes_params && !params.empty())
    throw Error("builtin:" + spec + ": '" + name + "' takes no parameters");

  Scene scene;
  if (name == "seed") {
    scene = make_seed();
  } else if (name == "cornell") {
    scene = make_cornell();
  } else if (name == "hairball") {
    scene = make_hairball_scene();
  } else if (name == "hair") {
    HairForm form = HairForm::kCurves;
    int strands = kHairStrands;
    for (const auto& [key, value] : params) {
      if (key == "as") {
        if (value == "curves")
          form = HairForm::kCurves;
        else if (value == "ribbons")
          form = HairForm::kRibbons;
        else if (value == "dots")
          form = HairForm::kDots;
        else
          fail_param(spec, key, value, "curves, ribbons or dots");
      } else if (key == "strands") {
        const char* end = value.data() + value.size();
        auto [ptr, ec] = std::from_chars(value.data(), end, strands);
        if (ec != std::errc() || ptr != end || strands < 1 || strands > kMaxHairStrands)
          fail_param(spec, key, value, "an integer 1..400000");
      } else {
        throw Error("builtin:" + spec + ": unknown parameter '" + key + "' for 'hair' (valid: as, strands)");
      }
    }
    scene = make_hair_scene(form, strands);
  } else if (name == "atrium") {
    scene = make_atrium_scene();
  } else if (name == "city") {
    scene = make_city_scene();
  } else if (name == "forest") {
    scene = make_forest_scene();
  } else {
    int subdiv = 4;
    float radius = 1.0f;
    Vec3 offset = name == "icosphere_far" ? kFarOffset : Vec3(0.0f);
    for (const auto& [key, value] : params) {
      if (key == "subdiv") {
        const char* end = value.data() + value.size();
        auto [ptr, ec] = std::from_chars(value.data(), end, subdiv);
        if (ec != std::errc() || ptr != end || subdiv < 0 || subdiv > kMaxIcosphereSubdiv) {
          fail_param(spec, key, value, "an integer 0..8");
        }
      } else if (key == "radius") {
        if (!parse_float(value, radius) || !(radius > 0.0f)) fail_param(spec, key, value, "a number > 0");
      } else if (key == "offset") {
        const size_t c1 = value.find(','), c2 = c1 == std::string::npos ? c1 : value.find(',', c1 + 1);
        if (c2 == std::string::npos || value.find(',', c2 + 1) != std::string::npos ||
            !parse_float(value.substr(0, c1), offset.x) ||
            !parse_float(value.substr(c1 + 1, c2 - c1 - 1), offset.y) ||
            !parse_float(value.substr(c2 + 1), offset.z)) {
          fail_param(spec, key, value, "three finite numbers X,Y,Z");
        }
      } else {
        throw Error("builtin:" + spec + ": unknown parameter '" + key + "' for '" + name +
                    "' (valid: subdiv, radius, offset)");
      }
    }
    scene = make_icosphere_scene(subdiv, radius, offset);
  }
  scene.name = "builtin:" + spec;
  return scene;
}

}  // namespace rtu::host
