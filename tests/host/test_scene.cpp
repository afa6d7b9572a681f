// Scene layer: built-in scenes, scene files, mesh import, primitive order, and the errors on bad input.
#include <unistd.h>

#include <array>
#include <bit>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

#include "host/io/error.h"
#include "host/scene/generators.h"
#include "host/scene/scene.h"
#include "tests/common/test_util.h"

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using namespace rtu::host;
using rtu::hw::Triangle;
using rtu::hw::Vec3;

using rtu::test::TempDir;

namespace {

const std::string kModels = "/usr/share/assimp/models";
const std::string kScenes = std::string(RTU_SOURCE_DIR) + "/scenes";

// The message of the Error that f throws; fails the test if it throws none.
std::string scene_error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  FAIL("no rtu::host::Error thrown");
  return {};
}

// load_scene(spec) throws an Error whose message contains every one of `words` (the file name among them).
void check_load_error(const std::string& spec, const std::vector<std::string>& words) {
  const std::string message = scene_error_of([&] { rtu::host::load_scene(spec); });
  INFO("spec: " << spec << "\nmessage: " << message);
  for (const std::string& w : words) CHECK_THAT(message, Contains(w));
}

using Bits = std::array<uint32_t, 3>;
Bits bits(const Vec3& v) {
  return {std::bit_cast<uint32_t>(v.x), std::bit_cast<uint32_t>(v.y), std::bit_cast<uint32_t>(v.z)};
}

// Number of directed edges in triangles [begin, end) that break closedness: each directed edge must occur
// exactly once and its reverse exactly once (every edge shared by exactly two triangles, consistently wound,
// with bit-identical endpoints). Degenerate edges count as broken.
size_t open_edges(const std::vector<Triangle>& tris, size_t begin, size_t end) {
  std::map<std::pair<Bits, Bits>, int> directed;
  for (size_t i = begin; i < end; ++i) {
    const Bits v[3] = {bits(tris[i].v0), bits(tris[i].v1), bits(tris[i].v2)};
    for (int k = 0; k < 3; ++k) ++directed[{v[k], v[(k + 1) % 3]}];
  }
  size_t broken = 0;
  for (const auto& [edge, count] : directed) {
    auto reverse = directed.find({edge.second, edge.first});
    if (edge.first == edge.second || count != 1 || reverse == directed.end() || reverse->second != 1) ++broken;
  }
  return broken;
}

bool same_bits(const Triangle& a, const Triangle& b) {
  return std::memcmp(&a, &b, sizeof(Triangle)) == 0;
}

bool same_triangles(const std::vector<Triangle>& a, const std::vector<Triangle>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(Triangle)) == 0);
}

// Imports `file` twice: `count` triangles (measured with Assimp 5.2.5, Debian 12), the same bits both times.
void check_import(const std::string& file, size_t count) {
  REQUIRE(fs::exists(file));  // Debian package assimp-testmodels
  const auto a = rtu::host::import_mesh(file);
  CHECK(a.size() == count);
  const auto b = rtu::host::import_mesh(file);
  REQUIRE(!a.empty());
  CHECK(same_bits(a[0], b[0]));
  CHECK(same_triangles(a, b));
}

MaterialType material_type(const Scene& s, uint32_t prim) {
  return s.materials.at(s.prim_material.at(prim)).type;
}

// Common checks of a loaded scene's bookkeeping.
void check_consistent(const Scene& s) {
  REQUIRE(s.prim_material.size() == s.geometry.num_prims());
  for (uint32_t m : s.prim_material) REQUIRE(m < s.materials.size());
}

}  // namespace

// ---- Built-in scenes

TEST_CASE("every listed built-in scene loads", "[scene]") {
  const auto names = rtu::host::builtin_scene_names();
  REQUIRE(names.size() ==
          9);  // seed, cornell, icosphere, icosphere_far, hair and the suite's four (test_suite.cpp)
  for (const auto& [name, description] : names) {
    INFO(name);
    CHECK(!description.empty());
    const Scene s = rtu::host::load_scene("builtin:" + name);
    CHECK(s.name == "builtin:" + name);
    CHECK(s.has_camera);
    CHECK(!s.lights.empty());
    check_consistent(s);
  }
}

TEST_CASE("builtin:seed", "[scene]") {
  const Scene s = rtu::host::load_scene("builtin:seed");
  const auto& g = s.geometry;
  CHECK(g.triangles.size() == 3072);  // torus, 64 x 24 x 2
  REQUIRE(g.spheres.size() == 2);
  REQUIRE(g.planes.size() == 1);
  check_consistent(s);
  CHECK(open_edges(g.triangles, 0, g.triangles.size()) == 0);
  CHECK(material_type(s, 0) == MaterialType::kDiffuse);
  CHECK(material_type(s, g.sphere_prim(0)) == MaterialType::kMirror);
  CHECK(material_type(s, g.sphere_prim(1)) == MaterialType::kGlass);
  CHECK(s.materials[s.prim_material[g.sphere_prim(1)]].ior == 1.5f);
  CHECK(material_type(s, g.plane_prim(0)) == MaterialType::kDiffuse);
  REQUIRE(s.lights.size() == 1);
  CHECK(s.lights[0].type == rtu::host::LightType::kPoint);
  CHECK(s.camera.width == 640);
  CHECK(s.camera.height == 480);
  // Everything stands on the ground plane y = 0.
  CHECK(g.bounds().lo.y >= 0.0f);
  CHECK(g.planes[0].normal == Vec3(0.0f, 1.0f, 0.0f));
}

TEST_CASE("builtin:cornell", "[scene]") {
  const Scene s = rtu::host::load_scene("builtin:cornell");
  const auto& g = s.geometry;
  CHECK(g.triangles.size() == 32);  // 5 walls + 2 blocks of 5 sides, 2 triangles each; 2 light triangles
  CHECK(g.spheres.empty());
  CHECK(g.planes.empty());
  check_consistent(s);
  REQUIRE(s.lights.size() == 1);
  const auto& light = s.lights[0];
  CHECK(light.type == rtu::host::LightType::kArea);
  CHECK(light.first_prim == 30);  // after every wall and block triangle
  CHECK(material_type(s, 30) == MaterialType::kEmissive);
  CHECK(material_type(s, 31) == MaterialType::kEmissive);
  for (uint32_t p = 0; p < 30; ++p) CHECK(material_type(s, p) == MaterialType::kDiffuse);
  CHECK(g.triangles[30].v0 == light.position);
  CHECK(g.triangles[30].v2 == light.position + light.edge_u + light.edge_v);
  // The light faces down into the box.
  CHECK(glm::cross(light.edge_u, light.edge_v).y < 0.0f);
  // Camera in front of the open side (z = 0), looking in.
  CHECK(s.camera.position.z < 0.0f);
  CHECK(s.camera.look_at.z > s.camera.position.z);
}

TEST_CASE("builtin:icosphere is closed and watertight", "[scene]") {
  const Scene s = rtu::host::load_scene("builtin:icosphere");
  const auto& tris = s.geometry.triangles;
  REQUIRE(tris.size() == 5120);
  CHECK(open_edges(tris, 0, tris.size()) == 0);
  for (const Triangle& t : tris) {
    for (const Vec3& v : {t.v0, t.v1, t.v2}) REQUIRE(std::fabs(glm::length(v) - 1.0f) < 1e-6f);
  }
  // Deterministic: a second load gives the same bits.
  CHECK(same_triangles(tris, rtu::host::load_scene("builtin:icosphere").geometry.triangles));
  // Camera outside, looking at the center.
  CHECK(glm::length(s.camera.position) > 1.5f);
  CHECK(s.camera.look_at == Vec3(0.0f));
}

TEST_CASE("builtin:icosphere_far is closed and watertight", "[scene]") {
  const Vec3 offset(148376.0f, 1234.0f, -223423.0f);
  const Scene s = rtu::host::load_scene("builtin:icosphere_far");
  const auto& tris = s.geometry.triangles;
  REQUIRE(tris.size() == 5120);
  CHECK(open_edges(tris, 0, tris.size()) == 0);
  CHECK(s.camera.look_at == offset);
  CHECK(glm::length(s.geometry.bounds().center() - offset) < 0.1f);
  // The same as the explicit offset.
  const Scene explicit_offset = rtu::host::load_scene("builtin:icosphere?offset=148376,1234,-223423");
  CHECK(same_triangles(tris, explicit_offset.geometry.triangles));
}

TEST_CASE("builtin:icosphere parameters", "[scene]") {
  const Scene s = rtu::host::load_scene("builtin:icosphere?subdiv=5&radius=2&offset=10,-20,30.5");
  const auto& tris = s.geometry.triangles;
  REQUIRE(tris.size() == 20480);
  CHECK(open_edges(tris, 0, tris.size()) == 0);
  CHECK(glm::length(tris[0].v0 - Vec3(10.0f, -20.0f, 30.5f)) == Approx(2.0f).epsilon(1e-5));
  CHECK(rtu::host::load_scene("builtin:icosphere?subdiv=0").geometry.triangles.size() == 20);
  CHECK(rtu::host::load_scene("builtin:icosphere_far?subdiv=2").geometry.triangles.size() == 320);
}

TEST_CASE("generators build closed meshes with the documented counts", "[scene]") {
  std::vector<Triangle> tris;
  rtu::host::append_triangles(rtu::host::make_torus(1.0f, 0.25f, 48, 24), tris);
  CHECK(tris.size() == 2304);
  CHECK(open_edges(tris, 0, tris.size()) == 0);
  tris.clear();
  rtu::host::append_triangles(rtu::host::make_box(Vec3(1.0f, 2.0f, 3.0f)), tris);
  CHECK(tris.size() == 12);
  CHECK(open_edges(tris, 0, tris.size()) == 0);
  // Outward winding: the +x side's normal points along +x.
  const Triangle& t = tris[0];
  CHECK(glm::cross(t.v1 - t.v0, t.v2 - t.v0).x > 0.0f);
  // Torus wound outward: the normal points away from the tube's center line.
  tris.clear();
  rtu::host::append_triangles(rtu::host::make_torus(1.0f, 0.25f, 16, 8), tris);
  for (const Triangle& tri : tris) {
    const Vec3 c = (tri.v0 + tri.v1 + tri.v2) / 3.0f;
    const Vec3 ring = glm::normalize(Vec3(c.x, 0.0f, c.z));
    REQUIRE(glm::dot(glm::cross(tri.v1 - tri.v0, tri.v2 - tri.v0), c - ring) > 0.0f);
  }
  const auto icosphere = rtu::host::make_icosphere(3, 1.0f);
  CHECK(icosphere.faces.size() == 1280);
  CHECK(icosphere.vertices.size() == 642);  // 10 * 4^3 + 2: every vertex computed once
  for (const auto& f : icosphere.faces) {   // wound outward
    const Vec3 a = icosphere.vertices[f[0]], b = icosphere.vertices[f[1]], c = icosphere.vertices[f[2]];
    REQUIRE(glm::dot(glm::cross(b - a, c - a), a + b + c) > 0.0f);
  }
  tris.clear();
  rtu::host::append_triangles(rtu::host::make_quad(2.0f, 4.0f), tris);
  REQUIRE(tris.size() == 2);
  CHECK(glm::cross(tris[0].v1 - tris[0].v0, tris[0].v2 - tris[0].v0).y > 0.0f);
}

// ---- Scene files

TEST_CASE("scenes/generated.json loads in the documented primitive order", "[scene]") {
  const Scene s = rtu::host::load_scene(kScenes + "/generated.json");
  const auto& g = s.geometry;
  check_consistent(s);
  // quad 2, icosphere (subdiv 3) 1280, torus 32 x 16 x 2 = 1024, box 12; then 2 area-light triangles.
  REQUIRE(g.triangles.size() == 2 + 1280 + 1024 + 12 + 2);
  CHECK(g.spheres.empty());
  CHECK(g.planes.empty());
  CHECK(open_edges(g.triangles, 2, 2 + 1280) == 0);        // transformed icosphere
  CHECK(open_edges(g.triangles, 1282, 1282 + 1024) == 0);  // rotated, translated torus
  CHECK(open_edges(g.triangles, 2306, 2306 + 12) == 0);    // scaled, rotated, translated box
  REQUIRE(s.lights.size() == 2);
  CHECK(s.lights[1].type == rtu::host::LightType::kArea);
  CHECK(s.lights[1].first_prim == 2318);
  CHECK(material_type(s, 2318) == MaterialType::kEmissive);
  CHECK(material_type(s, 2319) == MaterialType::kEmissive);
  CHECK(material_type(s, 2) == MaterialType::kGlass);
  CHECK(material_type(s, 2306) == MaterialType::kMirror);
  // No camera in the file: framed automatically.
  CHECK(!s.has_camera);
  CHECK(s.camera.look_at == g.bounds().center());
  // The translated icosphere (radius 0.75) is centered at (-1.5, 0.75, 0).
  rtu::hw::Aabb ico;
  for (size_t i = 2; i < 1282; ++i) ico.extend(g.triangles[i].bounds());
  CHECK(ico.center().x == Approx(-1.5f).margin(1e-5));
  CHECK(ico.center().y == Approx(0.75f).margin(1e-5));
  CHECK(ico.extent().y == Approx(1.5f).margin(1e-5));
}

TEST_CASE("scenes/example.json loads", "[scene]") {
  const std::string spider = kModels + "/OBJ/spider.obj";
  REQUIRE(fs::exists(spider));  // Debian package assimp-testmodels
  const Scene s = rtu::host::load_scene(kScenes + "/example.json");
  const auto& g = s.geometry;
  check_consistent(s);
  REQUIRE(g.triangles.size() == 1368 + 2);  // spider.obj (measured: 1368), then the area light
  REQUIRE(g.spheres.size() == 2);
  REQUIRE(g.planes.size() == 2);
  CHECK(s.has_camera);
  CHECK(s.camera.width == 640);
  CHECK(s.camera.fov_y_deg == 45.0f);
  CHECK(material_type(s, g.sphere_prim(0)) == MaterialType::kMirror);
  CHECK(material_type(s, g.sphere_prim(1)) == MaterialType::kGlass);
  CHECK(s.materials[s.prim_material[g.plane_prim(1)]].name == "wall");
  // Plane given by a point: dot(point, n) = c.
  CHECK(g.planes[1].offset == -4.0f);
  REQUIRE(s.lights.size() == 2);
  CHECK(s.lights[1].first_prim == 1368);
  // Transform order: scale, then rotate, then translate.
  const Triangle first = rtu::host::import_mesh(spider)[0];
  const glm::dmat4 m = glm::translate(glm::dmat4(1.0), glm::dvec3(0, 0.85, 0)) *
                       glm::rotate(glm::dmat4(1.0), glm::radians(30.0), glm::dvec3(0, 1, 0)) *
                       glm::scale(glm::dmat4(1.0), glm::dvec3(0.02));
  const Vec3 expected(m * glm::dvec4(glm::dvec3(first.v0), 1.0));
  CHECK(glm::length(g.triangles[0].v0 - expected) < 1e-5f);
}

TEST_CASE("scene file: order does not depend on the order of keys in the file", "[scene]") {
  TempDir dir("scene");
  const std::string file = dir.write("order.json", R"({
    "planes": [{"normal": [0, 1, 0], "offset": -1, "material": "p"}],
    "lights": [{"type": "area", "corner": [0, 5, 0], "edge_u": [1, 0, 0], "edge_v": [0, 0, 1]}],
    "spheres": [{"center": [0, 0, 0], "radius": 1, "material": "s0"}, {"center": [3, 0, 0], "radius": 0.5}],
    "meshes": [{"generate": "box", "material": "m"}, {"generate": "quad", "size": 2}],
    "materials": {"p": {}, "s0": {"type": "mirror"}, "m": {"color": [0.1, 0.2, 0.3]}}
  })");
  const Scene s = rtu::host::load_scene(file);
  const auto& g = s.geometry;
  check_consistent(s);
  REQUIRE(g.triangles.size() == 12 + 2 + 2);
  REQUIRE(g.spheres.size() == 2);
  REQUIRE(g.planes.size() == 1);
  CHECK(s.lights[0].first_prim == 14);
  CHECK(g.triangles[14].v0 == Vec3(0.0f, 5.0f, 0.0f));
  auto material_name = [&](uint32_t prim) { return s.materials[s.prim_material[prim]].name; };
  CHECK(material_name(0) == "m");
  CHECK(material_name(12) == "default");  // implicit
  CHECK(material_type(s, 14) == MaterialType::kEmissive);
  CHECK(material_name(16) == "s0");
  CHECK(material_name(17) == "default");
  CHECK(material_name(18) == "p");
  CHECK(g.sphere_prim(1) == 17);
  CHECK(g.plane_prim(0) == 18);
  // The implicit default material comes first; the file's materials follow in file order.
  REQUIRE(s.materials.size() >= 4);
  CHECK(s.materials[0].name == "default");
  CHECK(s.materials[1].name == "p");
  CHECK(s.materials[2].name == "s0");
  CHECK(s.materials[3].name == "m");
}

TEST_CASE("scene file: mesh paths are relative to the scene file", "[scene]") {
  TempDir dir("scene");
  fs::create_directories(dir.file("sub"));
  dir.write("sub/tri.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::string file = dir.write("rel.json", R"({"meshes": [{"file": "sub/tri.obj",
      "transform": {"scale": [2, 3, 4], "translate": [1, 1, 1]}}]})");
  const Scene s = rtu::host::load_scene(file);
  REQUIRE(s.geometry.triangles.size() == 1);
  CHECK(s.geometry.triangles[0].v0 == Vec3(1.0f, 1.0f, 1.0f));
  CHECK(s.geometry.triangles[0].v1 == Vec3(3.0f, 1.0f, 1.0f));
  CHECK(s.geometry.triangles[0].v2 == Vec3(1.0f, 4.0f, 1.0f));
  // A camera given in the file is used as is.
  const std::string with_camera = dir.write("cam.json", R"({"meshes": [{"file": "sub/tri.obj"}],
      "camera": {"position": [0, 0, 3], "width": 32, "height": 16, "fov_y": 30}})");
  const Scene c = rtu::host::load_scene(with_camera);
  CHECK(c.has_camera);
  CHECK(c.camera.position == Vec3(0.0f, 0.0f, 3.0f));
  CHECK(c.camera.width == 32);
  CHECK(c.camera.height == 16);
  CHECK(c.camera.fov_y_deg == 30.0f);
  CHECK(c.camera.look_at == Vec3(0.0f));  // default
}

// ---- Mesh import

TEST_CASE("import: 2CylinderEngine.glb", "[scene]") {
  check_import(kModels + "/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb", 121496);
}

TEST_CASE("import: AC14-FZK-Haus.ifc", "[scene]") {
  check_import(kModels + "/IFC/AC14-FZK-Haus.ifc", 35906);
}

TEST_CASE("import: a bare mesh file is a scene with an automatic camera and a light", "[scene]") {
  const std::string file = kModels + "/OBJ/spider.obj";
  REQUIRE(fs::exists(file));  // Debian package assimp-testmodels
  const Scene s = rtu::host::load_scene(file);
  CHECK(s.name == file);
  CHECK(s.geometry.triangles.size() == 1368);
  check_consistent(s);
  // Its materials come from spider.mtl: the four its faces use, each with its JPEG texture (map_Kd, written
  // with Windows separators), and texture coordinates for every triangle.
  REQUIRE(s.materials.size() == 4);
  for (const rtu::host::Material& m : s.materials) {
    INFO(m.name);
    CHECK(m.texture >= 0);
    CHECK(m.alpha_mode == rtu::host::AlphaMode::kOpaque);
  }
  CHECK(s.materials[s.prim_material[0]].name == "HLeibTex");
  CHECK(s.textures.size() >= 4);
  CHECK(s.triangle_uv.size() == s.geometry.triangles.size());
  CHECK(!s.has_camera);
  CHECK(s.camera.look_at == s.geometry.bounds().center());
  REQUIRE(s.lights.size() == 1);
  CHECK(s.lights[0].position == s.camera.position);
  CHECK(s.lights[0].intensity.x > 0.0f);
}

TEST_CASE("import: OBJ polygons are triangulated, points and lines dropped", "[scene]") {
  TempDir dir("scene");
  const std::string file = dir.write("mixed.obj",
                                     "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                     "f 1 2 3 4\n"  // quad -> 2 triangles
                                     "l 1 3\n"      // line: dropped
                                     "p 2\n"        // point: dropped
                                     "f 1 2 3\n");
  const auto tris = rtu::host::import_mesh(file);
  REQUIRE(tris.size() == 3);
  for (const Triangle& t : tris) CHECK(glm::length(glm::cross(t.v1 - t.v0, t.v2 - t.v0)) > 0.0f);
}

namespace {

std::string base64(const std::vector<unsigned char>& data) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < data.size(); i += 3) {
    uint32_t n = uint32_t(data[i]) << 16;
    if (i + 1 < data.size()) n |= uint32_t(data[i + 1]) << 8;
    if (i + 2 < data.size()) n |= data[i + 2];
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < data.size() ? kAlphabet[(n >> 6) & 63] : '=';
    out += i + 2 < data.size() ? kAlphabet[n & 63] : '=';
  }
  return out;
}

}  // namespace

TEST_CASE("import: node tree depth-first with parent * child transforms", "[scene]") {
  // glTF: node 0 (translate 10, 0, 0) -> children [1, 2]; node 1 (scale 2, mesh 0) -> child 3 (translate 0, 5, 0,
  // mesh 1); node 2 (mesh 1). Both meshes: the triangle (0,0,0) (1,0,0) (0,1,0).
  std::vector<unsigned char> buffer(48, 0);
  const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const uint16_t indices[3] = {0, 1, 2};
  std::memcpy(buffer.data(), positions, sizeof(positions));
  std::memcpy(buffer.data() + 36, indices, sizeof(indices));
  const std::string gltf = R"({
    "asset": {"version": "2.0"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [
      {"translation": [10, 0, 0], "children": [1, 2]},
      {"scale": [2, 2, 2], "mesh": 0, "children": [3]},
      {"mesh": 1},
      {"translation": [0, 5, 0], "mesh": 1}
    ],
    "meshes": [
      {"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]},
      {"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}
    ],
    "buffers": [{"byteLength": 48, "uri": "data:application/octet-stream;base64,)" +
                           base64(buffer) + R"("}],
    "bufferViews": [
      {"buffer": 0, "byteOffset": 0, "byteLength": 36, "target": 34962},
      {"buffer": 0, "byteOffset": 36, "byteLength": 6, "target": 34963}
    ],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
    ]
  })";
  TempDir dir("scene");
  const auto tris = rtu::host::import_mesh(dir.write("tree.gltf", gltf));
  REQUIRE(tris.size() == 3);
  // node 1: T(10) S(2)
  CHECK(tris[0].v0 == Vec3(10, 0, 0));
  CHECK(tris[0].v1 == Vec3(12, 0, 0));
  CHECK(tris[0].v2 == Vec3(10, 2, 0));
  // node 3, child of node 1 (before node 1's sibling): T(10) S(2) T(0, 5, 0)
  CHECK(tris[1].v0 == Vec3(10, 10, 0));
  CHECK(tris[1].v1 == Vec3(12, 10, 0));
  CHECK(tris[1].v2 == Vec3(10, 12, 0));
  // node 2: T(10)
  CHECK(tris[2].v0 == Vec3(10, 0, 0));
  CHECK(tris[2].v1 == Vec3(11, 0, 0));
  CHECK(tris[2].v2 == Vec3(10, 1, 0));
}

TEST_CASE("import: glTF with an out-of-range index", "[scene]") {
  const std::string dir = kModels + "/glTF2/IndexOutOfRange";
  REQUIRE(fs::exists(dir));  // Debian package assimp-testmodels
  // Assimp itself drops the face with the bad index (11 of the box's 12 triangles remain); what is left is clean.
  const auto tris = rtu::host::import_mesh(dir + "/IndexOutOfRange.gltf");
  CHECK(tris.size() == 11);
  // All indices bad: Assimp rejects the file; the message names it.
  check_load_error(dir + "/AllIndicesOutOfRange.gltf", {"AllIndicesOutOfRange.gltf", "no faces"});
}

// ---- Bad input

TEST_CASE("error: missing file", "[scene]") {
  TempDir dir("scene");
  check_load_error(dir.file("nope.obj"), {"nope.obj", "file not found"});
  check_load_error(dir.file("nope.json"), {"nope.json", "file not found"});
  const std::string scene = dir.write("s.json", R"({"meshes": [{"file": "gone.obj"}]})");
  check_load_error(scene, {"s.json", "meshes[0].file", "gone.obj", "file not found"});
}

TEST_CASE("error: unparsable files", "[scene]") {
  TempDir dir("scene");
  check_load_error(dir.write("bad.json", R"({"meshes": [})"), {"bad.json", "parse error", "line 1"});
  check_load_error(dir.write("empty.json", ""), {"empty.json", "parse error"});
  check_load_error(dir.write("top.json", "[1, 2]"), {"top.json", "expected a JSON object"});
  check_load_error(dir.write("bad.obj", "this is not a mesh\n"), {"bad.obj"});
  check_load_error(dir.write("dup.json", R"({"spheres": [{"center": [0, 0, 0], "radius": 1, "radius": 2}]})"),
                   {"dup.json", "duplicate key 'spheres[0].radius'"});
}

TEST_CASE("error: unknown keys name their path", "[scene]") {
  TempDir dir("scene");
  check_load_error(dir.write("x.json", R"({"meshes": [{"generate": "box"}, {"generate": "quad"},
      {"generate": "box", "trnasform": {}}]})"),
                   {"x.json", "unknown key 'meshes[2].trnasform'"});
  check_load_error(dir.write("a.json", R"({"sphere": []})"), {"a.json", "unknown key 'sphere'"});
  check_load_error(
      dir.write("b.json", R"({"camera": {"fov": 40}, "spheres": [{"center": [0,0,0], "radius": 1}]})"),
      {"b.json", "unknown key 'camera.fov'"});
  check_load_error(dir.write("c.json", R"({"materials": {"red": {"colour": [1, 0, 0]}}})"),
                   {"c.json", "unknown key 'materials.red.colour'"});
  check_load_error(dir.write("d.json", R"({"meshes": [{"generate": "box", "transform": {"translate": [0,0,0],
      "rotation": [0, 1, 0, 90]}}]})"),
                   {"d.json", "unknown key 'meshes[0].transform.rotation'"});
  // Generator parameters belong to their generator.
  check_load_error(dir.write("e.json", R"({"meshes": [{"generate": "box", "radius": 2}]})"),
                   {"e.json", "unknown key 'meshes[0].radius'"});
  check_load_error(dir.write("f.json", R"({"lights": [{"type": "point", "position": [0,0,0], "emission": [1,1,1]}],
      "spheres": [{"center": [0,0,0], "radius": 1}]})"),
                   {"f.json", "unknown key 'lights[0].emission'"});
}

TEST_CASE("error: wrong types, lengths and values name the key path", "[scene]") {
  TempDir dir("scene");
  auto sphere = [&](const std::string& body) { return dir.write("s.json", R"({"spheres": [)" + body + "]}"); };
  check_load_error(sphere(R"({"center": [0, 0], "radius": 1})"), {"s.json", "spheres[0].center", "3 numbers"});
  check_load_error(sphere(R"({"center": [0, 0, "z"], "radius": 1})"),
                   {"s.json", "spheres[0].center[2]", "number"});
  check_load_error(sphere(R"({"center": [0, 0, 0], "radius": "big"})"), {"s.json", "spheres[0].radius", "number"});
  check_load_error(sphere(R"({"center": [0, 0, 0], "radius": 0})"), {"s.json", "spheres[0].radius", "> 0"});
  check_load_error(sphere(R"({"center": [0, 0, 0], "radius": -1})"), {"s.json", "spheres[0].radius", "> 0"});
  check_load_error(sphere(R"({"center": [0, 0, 0]})"), {"s.json", "spheres[0]", "missing key 'radius'"});
  check_load_error(sphere(R"({"center": [0, 0, 0], "radius": 1, "material": "gold"})"),
                   {"s.json", "spheres[0].material", "unknown material 'gold'"});
  check_load_error(dir.write("p.json", R"({"planes": [{"normal": [0, 0, 0]}]})"),
                   {"p.json", "planes[0].normal", "zero"});
  check_load_error(dir.write("p2.json", R"({"planes": [{"normal": [0, 1, 0], "offset": 1, "point": [0, 0, 0]}]})"),
                   {"p2.json", "planes[0]", "not both"});
  check_load_error(dir.write("m.json", R"({"materials": {"x": {"type": "metal"}}})"),
                   {"m.json", "materials.x.type", "unknown material type 'metal'"});
  check_load_error(dir.write("m2.json", R"({"materials": {"x": {"type": "diffuse", "ior": 1.3}}})"),
                   {"m2.json", "materials.x.ior", "glass"});
  check_load_error(dir.write("l.json", R"({"lights": [{"type": "spot"}]})"),
                   {"l.json", "lights[0].type", "unknown light type 'spot'"});
  check_load_error(dir.write("l2.json", R"({"lights": [{"type": "area", "corner": [0,0,0], "edge_u": [1,0,0],
      "edge_v": [2,0,0]}]})"),
                   {"l2.json", "lights[0]", "parallel"});
  check_load_error(dir.write("g.json", R"({"meshes": [{"generate": "cone"}]})"),
                   {"g.json", "meshes[0].generate", "unknown generator 'cone'"});
  check_load_error(dir.write("g2.json", R"({"meshes": [{"generate": "icosphere", "subdiv": 2.5}]})"),
                   {"g2.json", "meshes[0].subdiv", "integer"});
  check_load_error(dir.write("g3.json", R"({"meshes": [{"generate": "icosphere", "subdiv": 99}]})"),
                   {"g3.json", "meshes[0].subdiv", "0..8"});
  check_load_error(dir.write("g4.json", R"({"meshes": [{"generate": "box", "file": "a.obj"}]})"),
                   {"g4.json", "meshes[0]", "exactly one of 'file' and 'generate'"});
  check_load_error(dir.write("t.json", R"({"meshes": [{"generate": "box", "transform": {"scale": 0}}]})"),
                   {"t.json", "meshes[0].transform.scale", "non-zero"});
  check_load_error(
      dir.write("t2.json", R"({"meshes": [{"generate": "box", "transform": {"rotate": [0, 0, 0, 9]}}]})"),
      {"t2.json", "meshes[0].transform.rotate", "zero"});
  check_load_error(dir.write("c.json", R"({"camera": {"width": 0}, "meshes": [{"generate": "box"}]})"),
                   {"c.json", "camera.width", "integer"});
  check_load_error(dir.write("c2.json", R"({"camera": {"position": [0, 0, 0]}, "meshes": [{"generate": "box"}]})"),
                   {"c2.json", "camera", "same point"});
}

TEST_CASE("error: NaN/Inf coordinates", "[scene]") {
  TempDir dir("scene");
  check_load_error(dir.write("nan.obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"),
                   {"nan.obj", "NaN/Inf coordinate", "face 0"});
  check_load_error(dir.write("inf.obj", "v 1 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n"),
                   {"inf.obj", "NaN/Inf coordinate"});
  check_load_error(dir.write("inf.json", R"({"spheres": [{"center": [0, 1e999, 0], "radius": 1}]})"),
                   {"inf.json", "spheres[0].center[1]", "NaN/Inf"});
  check_load_error(dir.write("big.json", R"({"spheres": [{"center": [0, 0, 0], "radius": 1e39}]})"),
                   {"big.json", "spheres[0].radius", "float range"});
  // Finite input that overflows float after the transform.
  dir.write("huge.obj", "v 0 0 0\nv 3e38 0 0\nv 0 1 0\nf 1 2 3\n");
  check_load_error(dir.write("over.json", R"({"meshes": [{"file": "huge.obj", "transform": {"scale": 10}}]})"),
                   {"over.json", "NaN/Inf coordinate"});
  const std::string infinites = kModels + "/glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb";
  if (fs::exists(infinites)) check_load_error(infinites, {"BoxWithInfinites.glb", "NaN/Inf coordinate"});
}

TEST_CASE("error: index out of range", "[scene]") {
  TempDir dir("scene");
  check_load_error(dir.write("oor.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n"),
                   {"oor.obj", "index out of range"});
  const std::string scene = dir.write("oor.json", R"({"meshes": [{"file": "oor.obj"}]})");
  check_load_error(scene, {"oor.json", "meshes[0].file", "oor.obj", "index out of range"});
}

TEST_CASE("error: empty scene", "[scene]") {
  TempDir dir("scene");
  check_load_error(dir.write("empty.json", "{}"), {"empty.json", "empty scene"});
  check_load_error(dir.write("mats.json", R"({"materials": {"a": {}}, "lights": [{"type": "point",
      "position": [0, 1, 0]}], "meshes": [], "spheres": []})"),
                   {"mats.json", "empty scene"});
  const std::string verts = dir.write("verts.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  check_load_error(verts, {"verts.obj", "empty scene"});
  // Lines alone are a scene of curve segments (test_curves.cpp), one strand here.
  const Scene lines = rtu::host::load_scene(dir.write("lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n"));
  CHECK(lines.geometry.curves.size() == 2);
  CHECK(lines.geometry.triangles.empty());
  // In a scene file, a mesh file without triangles is an error of its own.
  check_load_error(dir.write("nomesh.json", R"({"meshes": [{"file": "verts.obj"}], "spheres": [
      {"center": [0, 0, 0], "radius": 1}]})"),
                   {"nomesh.json", "meshes[0].file", "verts.obj", "no triangles"});
}

TEST_CASE("error: unknown built-in scenes and parameters", "[scene]") {
  check_load_error("builtin:nope",
                   {"builtin:nope", "unknown built-in scene 'nope'", "seed", "cornell", "icosphere"});
  check_load_error("builtin:", {"builtin:", "unknown built-in scene", "seed"});
  check_load_error("builtin:icosphere?foo=1", {"builtin:icosphere?foo=1", "unknown parameter 'foo'", "subdiv"});
  check_load_error("builtin:icosphere?subdiv=99", {"builtin:icosphere?subdiv=99", "subdiv", "0..8"});
  check_load_error("builtin:icosphere?subdiv=two", {"subdiv", "'two'"});
  check_load_error("builtin:icosphere?radius=-1", {"radius", "> 0"});
  check_load_error("builtin:icosphere?radius=nan", {"radius"});
  check_load_error("builtin:icosphere?offset=1,2", {"offset", "X,Y,Z"});
  check_load_error("builtin:icosphere?subdiv", {"malformed parameter 'subdiv'"});
  check_load_error("builtin:icosphere?subdiv=1&subdiv=2", {"'subdiv' given twice"});
  check_load_error("builtin:seed?subdiv=1", {"builtin:seed?subdiv=1", "takes no parameters"});
}

// ---- Validation and the automatic camera

TEST_CASE("validate_scene names the scene and the first problem", "[scene]") {
  Scene s = rtu::host::load_scene("builtin:seed");
  s.name = "my-scene";
  REQUIRE_NOTHROW(rtu::host::validate_scene(s));

  Scene bad = s;
  bad.geometry.spheres[1].center.y = std::nanf("");
  CHECK_THAT(scene_error_of([&] { rtu::host::validate_scene(bad); }),
             Contains("my-scene") && Contains("sphere 1"));
  bad = s;
  bad.geometry.spheres[0].radius = 0.0f;
  CHECK_THAT(scene_error_of([&] { rtu::host::validate_scene(bad); }), Contains("radius"));
  bad = s;
  bad.geometry.planes[0].normal = Vec3(0.0f);
  CHECK_THAT(scene_error_of([&] { rtu::host::validate_scene(bad); }), Contains("zero normal"));
  bad = s;
  bad.geometry.triangles[7].v1.z = INFINITY;
  CHECK_THAT(scene_error_of([&] { rtu::host::validate_scene(bad); }),
             Contains("triangle 7") && Contains("NaN/Inf"));
  bad = s;
  bad.prim_material.back() = uint32_t(bad.materials.size());
  CHECK_THAT(scene_error_of([&] { rtu::host::validate_scene(bad); }), Contains("material index out of range"));
  bad = s;
  bad.prim_material.pop_back();
  CHECK_THAT(scene_error_of([&] { rtu::host::validate_scene(bad); }), Contains("prim_material"));
}

TEST_CASE("frame_camera", "[scene]") {
  const rtu::host::Camera def;
  // Empty bounds (e.g. only planes): the default camera.
  const auto empty = rtu::host::frame_camera(rtu::hw::Aabb{});
  CHECK(empty.position == def.position);
  CHECK(empty.look_at == def.look_at);

  // A box: looks at its center from the (1, 0.6, 1.4) diagonal; the bounding sphere fits the 45 degree view.
  const rtu::hw::Aabb box{Vec3(-1.0f, 0.0f, 2.0f), Vec3(3.0f, 2.0f, 4.0f)};
  const auto cam = rtu::host::frame_camera(box);
  CHECK(cam.look_at == box.center());
  CHECK(cam.fov_y_deg == 45.0f);
  const Vec3 dir = glm::normalize(cam.position - cam.look_at);
  CHECK(glm::length(dir - glm::normalize(Vec3(1.0f, 0.6f, 1.4f))) < 1e-5f);
  const float radius = 0.5f * glm::length(box.extent());
  const float distance = glm::length(cam.position - cam.look_at);
  CHECK(distance * std::sin(glm::radians(22.5f)) == Approx(radius).epsilon(1e-5));

  // Degenerate: a single point, at the origin and far away; the camera stays apart from its target.
  for (const Vec3 p : {Vec3(0.0f), Vec3(148376.0f, 1234.0f, -223423.0f)}) {
    const auto point = rtu::host::frame_camera(rtu::hw::Aabb{p, p});
    CHECK(point.look_at == p);
    CHECK(point.position != point.look_at);
    CHECK(std::isfinite(point.position.x));
  }
  // Flat bounds (a quad) are fine too.
  const auto flat = rtu::host::frame_camera(rtu::hw::Aabb{Vec3(0.0f), Vec3(1.0f, 0.0f, 1.0f)});
  CHECK(flat.position != flat.look_at);
}
