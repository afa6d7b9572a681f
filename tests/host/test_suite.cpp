// The benchmark suite: its built-in scenes (hairball, atrium, city, forest) and the manifest (host/jobs/suite.h,
// scenes/suite.json), with rtusim's --suite options.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "host/io/error.h"
#include "host/jobs/suite.h"
#include "host/scene/scene.h"
#include "host/scene/shading.h"
#include "host/scene/suite_scenes.h"
#include "hwmodel/datapath/float_tracer.h"
#include "tests/common/test_util.h"
#include "tests/host/run_process.h"

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using namespace rtu::host;
using namespace rtu::test;

namespace {

const std::string kScenes = std::string(RTU_SOURCE_DIR) + "/scenes";

// Same length and same bytes; memcmp is never handed the null data() of an empty vector.
template <typename T>
bool same_bytes(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// Bit-identical geometry, materials, texture coordinates and instances.
bool same_scene(const Scene& a, const Scene& b) {
  return same_bytes(a.geometry.triangles, b.geometry.triangles) && a.prim_material == b.prim_material &&
         same_bytes(a.triangle_uv, b.triangle_uv) && same_bytes(a.instances.instances, b.instances.instances);
}

size_t material_count(const Scene& s, const std::string& name) {
  size_t n = 0;
  for (uint32_t m : s.prim_material) n += s.materials[m].name == name;
  return n;
}

// The error message of load_suite(path); fails the test when it does not throw.
std::string suite_error(const std::string& path) {
  try {
    rtu::host::load_suite(path);
  } catch (const Error& e) {
    return e.what();
  }
  FAIL("load_suite(" << path << ") did not throw");
  return {};
}

}  // namespace

// ---- The built-in scenes

TEST_CASE("suite built-ins validate, have their stated sizes and load identically twice", "[scene][suite]") {
  struct Case {
    const char* name;
    size_t min_tris, max_tris;  // the ranges suite_scenes.h and scenes/README.md state
  };
  for (const Case& c : {Case{"hairball", 100000, 300000}, Case{"atrium", 10000, 40000},
                        Case{"city", 100000, 300000}, Case{"forest", 10000, 40000}}) {
    INFO(c.name);
    const Scene a = rtu::host::load_scene(std::string("builtin:") + c.name);  // load_scene validates
    CHECK_NOTHROW(rtu::host::validate_scene(a));
    CHECK(a.geometry.triangles.size() >= c.min_tris);
    CHECK(a.geometry.triangles.size() <= c.max_tris);
    CHECK(a.has_camera);
    CHECK(!a.lights.empty());
    const Scene b = rtu::host::load_scene(std::string("builtin:") + c.name);
    CHECK(same_scene(a, b));
  }
  // The exact counts the descriptions give (builtin_scene_names, scenes/README.md).
  CHECK(rtu::host::load_scene("builtin:hairball").geometry.triangles.size() == 512 * 32 * 6 * 2);
  CHECK(rtu::host::load_scene("builtin:atrium").geometry.triangles.size() == 19422);
  CHECK(rtu::host::load_scene("builtin:forest").geometry.triangles.size() == 13324);
}

TEST_CASE("builtin:atrium: an interior lit from inside", "[scene][suite]") {
  const Scene s = rtu::host::load_scene("builtin:atrium");
  // The area light is under the court's open roof, below the walls' tops (y 11), above the aisles' roof (9.9).
  REQUIRE(s.lights[0].type == rtu::host::LightType::kArea);
  CHECK(s.lights[0].position.y > 9.9f);
  CHECK(s.lights[0].position.y < 11.0f);
  CHECK(material_count(s, "column") == 28 * 24 * 8 * 2);  // 2 storeys x 2 sides x 7 columns, 24 sides, 8 rings
  const rtu::hw::Aabb b = s.geometry.bounds();
  for (const rtu::host::Light& l : s.lights) {  // every light inside the hall's walls
    CHECK(l.position.x > b.lo.x);
    CHECK(l.position.x < b.hi.x);
    CHECK(l.position.z > b.lo.z);
    CHECK(l.position.z < b.hi.z);
  }
}

TEST_CASE("builtin:city: prototypes placed as instances", "[scene][suite]") {
  const Scene s = rtu::host::load_scene("builtin:city");
  REQUIRE(s.instanced());
  const rtu::hw::InstanceSet& set = s.instances;
  CHECK(set.meshes.size() == 5);  // the ground and four prototypes
  CHECK(set.instances.size() == 257);
  CHECK(set.instances[0].mesh == 0);
  CHECK(set.instances[0].to_world.is_identity());
  std::set<uint32_t> used;
  uint64_t mesh_tris = 0;
  for (size_t i = 1; i < set.instances.size(); ++i) used.insert(set.instances[i].mesh);
  for (const rtu::hw::Geometry& m : set.meshes) mesh_tris += m.triangles.size();
  CHECK(used == std::set<uint32_t>{1, 2, 3, 4});  // every prototype placed
  CHECK(mesh_tris == 2308);
  // The flattened scene numbers every instance's triangles: many times the prototypes'.
  CHECK(s.geometry.triangles.size() == set.num_triangles());
  CHECK(s.geometry.triangles.size() == 161216);
}

TEST_CASE("builtin:forest: alpha-tested leaf cards", "[scene][suite]") {
  const Scene s = rtu::host::load_scene("builtin:forest");
  const size_t leaves = material_count(s, "leaves");
  CHECK(leaves == 64 * 72 * 2);  // 64 trees of 72 cards
  // Exactly the leaf triangles are non-opaque (mark_non_opaque ran in load_scene).
  REQUIRE(s.geometry.non_opaque.size() == s.geometry.triangles.size());
  size_t non_opaque = 0;
  for (size_t i = 0; i < s.geometry.triangles.size(); ++i) {
    non_opaque += s.geometry.non_opaque[i];
    CHECK(bool(s.geometry.non_opaque[i]) == (s.materials[s.prim_material[i]].name == "leaves"));
  }
  CHECK(non_opaque == leaves);
  REQUIRE(s.triangle_uv.size() == s.geometry.triangles.size());

  // The texture: alpha only 0 or 255; 2,521 of its 4,096 texels (61.5%) masked, as scenes/README.md states.
  REQUIRE(s.textures.size() == 1);
  const rtu::host::Texture& tex = s.textures[0];
  REQUIRE(tex.width == rtu::host::kForestLeafSide);
  size_t masked = 0;
  for (size_t i = 3; i < tex.rgba.size(); i += 4) {
    CHECK((tex.rgba[i] == 0 || tex.rgba[i] == 255));
    masked += tex.rgba[i] == 0;
  }
  CHECK(masked == 2521);

  // A ray through a card at a masked texel passes it; at an opaque texel it hits. The first card triangle has
  // texture coordinates v0 (0, 0), v1 (1, 0), v2 (1, 1): (s, t) = (u + v, v).
  size_t card = 0;
  while (s.materials[s.prim_material[card]].name != "leaves") ++card;
  const rtu::host::TriangleUv& uv = s.triangle_uv[card];
  REQUIRE((uv.s[0] == 0.0f && uv.t[0] == 0.0f && uv.s[1] == 1.0f && uv.t[1] == 0.0f && uv.s[2] == 1.0f &&
           uv.t[2] == 1.0f));
  const rtu::hw::Triangle& tri = s.geometry.triangles[card];
  const rtu::hw::Vec3 normal = glm::normalize(glm::cross(tri.v1 - tri.v0, tri.v2 - tri.v0));
  const rtu::host::SceneAnyHit alpha(s);
  REQUIRE(alpha.stage() != nullptr);
  rtu::hw::FloatTracer tracer(s.geometry);
  tracer.set_any_hit(alpha.stage());
  // Rays along the normal, from 1 mm in front to 1 mm behind the card: nothing else is that close to the points
  // (the texels' bilinear footprints, +-1.5 texels, lie inside the masked corner and the opaque centre disc).
  auto ray_at = [&](float s_coord, float t_coord) {
    const float v = t_coord, u = s_coord - t_coord;
    const rtu::hw::Vec3 p = (1.0f - u - v) * tri.v0 + u * tri.v1 + v * tri.v2;
    return rtu::hw::Ray{p + 1e-3f * normal, 0.0f, -normal, 2e-3f};
  };
  rtu::hw::TraversalStats stats;
  const rtu::hw::Hit opaque = tracer.trace(ray_at(0.51f, 0.5f), false, stats);  // the twig at the centre
  CHECK(opaque.prim == card);
  const rtu::hw::Ray corner = ray_at(0.92f, 0.08f);  // 0.59 from the centre: beyond every leaf (0.46)
  CHECK(!tracer.trace(corner, false, stats).hit());
  CHECK(!tracer.trace(corner, true, stats).hit());  // shadow rays too
  // Without the stage the card is opaque there: the mask is what let the ray through.
  CHECK(tracer.trace(corner, false, stats, nullptr).prim == card);
}

// ---- The manifest

TEST_CASE("scenes/suite.json names every suite built-in, the benchmarks' meshes and CGAL's", "[suite]") {
  const rtu::host::Suite suite = rtu::host::load_suite(kScenes + "/suite.json");
  std::set<std::string> names, scenes;
  for (const rtu::host::SuiteEntry& e : suite.entries) {
    names.insert(e.name);
    scenes.insert(e.scene);
    CHECK(!e.hard_because.empty());
  }
  for (const char* b : {"builtin:hairball", "builtin:hair", "builtin:atrium", "builtin:city", "builtin:forest"})
    CHECK(scenes.count(b));
  CHECK(scenes.count("/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc"));
  CHECK(names.count("bunny"));
  CHECK(names.count("armadillo"));
  CHECK(names.count("elephant"));
  // Relative paths are resolved against the manifest's folder.
  for (const rtu::host::SuiteEntry& e : suite.entries)
    if (e.name == "bunny")
      CHECK(e.scene == fs::path(kScenes + "/../build/meshes/cgal/bunny00.off").lexically_normal());
}

TEST_CASE("a suite manifest with a mistake is refused with a message naming it", "[suite]") {
  TempDir d("suite");
  const std::string ok = R"({"name": "a", "scene": "builtin:seed", "hard_because": "x"})";
  struct Case {
    std::string text;
    std::vector<std::string> expect;
  };
  const Case cases[] = {
      {"[1, 2]", {"expected a JSON object"}},
      {"{\"scenes\": [" + ok + "], \"extra\": 1}", {"unknown key 'extra'", "description, scenes"}},
      {"{\"description\": \"no scenes\"}", {"missing key 'scenes'"}},
      {"{\"scenes\": {}}", {"scenes", "expected an array"}},
      {"{\"scenes\": []}", {"names no scene"}},
      {"{\"scenes\": [7]}", {"scenes[0]", "expected an object"}},
      {R"({"scenes": [{"scene": "builtin:seed", "hard_because": "x"}]})", {"scenes[0]", "missing key 'name'"}},
      {R"({"scenes": [{"name": "a", "hard_because": "x"}]})", {"missing key 'scene'"}},
      {R"({"scenes": [{"name": "a", "scene": "builtin:seed"}]})", {"missing key 'hard_because'"}},
      {R"({"scenes": [{"name": "a", "scene": "builtin:seed", "hard_because": ""}]})",
       {"scenes[0].hard_because", "must not be empty"}},
      {R"({"scenes": [{"name": "a", "scene": 3, "hard_because": "x"}]})",
       {"scenes[0].scene", "expected a string"}},
      {R"({"scenes": [{"name": "a b", "scene": "builtin:seed", "hard_because": "x"}]})", {"'a b'", "letters"}},
      {"{\"scenes\": [" + ok + ", " + ok + "]}", {"scenes[1].name", "duplicate name 'a'"}},
      {R"({"scenes": [{"name": "a", "scene": "builtin:nope", "hard_because": "x"}]})",
       {"unknown built-in scene 'nope'", "hairball"}},
      {R"({"scenes": [{"name": "a", "scene": "builtin:seed", "hard_because": "x", "why": 1}]})",
       {"unknown key 'why'"}},
      {"{\"scenes\": [" + ok + "]", {"parse error"}},
  };
  int i = 0;
  for (const Case& c : cases) {
    INFO(c.text);
    const std::string path = d.write("bad" + std::to_string(i++) + ".json", c.text);
    const std::string message = suite_error(path);
    CHECK_THAT(message, Contains(path));
    for (const std::string& e : c.expect) CHECK_THAT(message, Contains(e));
  }
  CHECK_THAT(suite_error(d.file("absent.json")), Contains("absent.json"));
}

TEST_CASE("a suite scene whose file is missing is skipped with the reason", "[suite]") {
  TempDir d("suite");
  fs::create_directories(d.file("sub"));
  const std::string manifest = d.write("suite.json", R"({"scenes": [
    {"name": "seed", "scene": "builtin:seed", "hard_because": "x"},
    {"name": "ghost", "scene": "meshes/ghost.off", "hard_because": "x", "source": "Debian libghost"},
    {"name": "folder", "scene": "sub", "hard_because": "x"},
    {"name": "cornell", "scene": "builtin:cornell", "hard_because": "x"}]})");
  const rtu::host::SuiteCheck check = rtu::host::check_suite(rtu::host::load_suite(manifest));
  REQUIRE(check.available.size() == 2);
  CHECK(check.available[0].name == "seed");
  CHECK(check.available[1].name == "cornell");
  REQUIRE(check.skipped.size() == 2);
  CHECK(check.skipped[0].entry.name == "ghost");
  CHECK_THAT(check.skipped[0].reason, Contains("missing file " + d.file("meshes/ghost.off")));
  CHECK_THAT(check.skipped[0].reason, Contains("Debian libghost"));
  CHECK_THAT(check.skipped[1].reason, Contains("not a regular file"));
  std::vector<std::string> warnings;
  const std::vector<std::string> specs =
      rtu::host::suite_scenes(manifest, [&](const std::string& w) { warnings.push_back(w); });
  CHECK(specs == std::vector<std::string>{"builtin:seed", "builtin:cornell"});
  REQUIRE(warnings.size() == 2);
  CHECK_THAT(warnings[0], Contains("skipping 'ghost'"));
}

TEST_CASE("rtusim sweep, report and info take --suite", "[suite][cli]") {
  TempDir d("suite");
  const std::string manifest = d.write("suite.json", R"({"scenes": [
    {"name": "cornell", "scene": "builtin:cornell", "hard_because": "x"},
    {"name": "ghost", "scene": "ghost.off", "hard_because": "x"}]})");
  const std::string csv = d.file("s.csv");
  const rtu::test::Run r = run_rtusim("sweep --suite " + manifest +
                                      " --formats default --bvh-width 4 --config rdna2 --rays 200 --image-width 0 "
                                      "--threads 1 --out " +
                                      csv);
  CHECK(r.status == 0);
  CHECK_THAT(r.output, Contains("skipping 'ghost': missing file"));
  std::ifstream in(csv);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  CHECK_THAT(text, Contains("builtin:cornell"));
  CHECK(text.find("ghost") == std::string::npos);

  const rtu::test::Run info = run_rtusim("info --suite " + manifest);
  CHECK(info.status == 0);
  CHECK_THAT(info.output, Contains("1 available, 1 skipped"));

  // A suite with nothing available, and a malformed one: exit 2 with the message, no crash.
  const std::string none =
      d.write("none.json", R"({"scenes": [{"name": "g", "scene": "g.off", "hard_because": "x"}]})");
  const rtu::test::Run empty = run_rtusim("sweep --suite " + none + " --out " + d.file("n.csv"));
  CHECK(empty.status == 2);
  CHECK_THAT(empty.output, Contains("no scene of the suite is available"));
  const rtu::test::Run report = run_rtusim("report --quick --suite " + none + " --out " + d.file("rep"));
  CHECK(report.status == 2);
  CHECK_THAT(report.output, Contains("no scene of the suite is available"));
  const std::string bad = d.write("bad.json", R"({"scenes": 1})");
  const rtu::test::Run malformed = run_rtusim("sweep --suite " + bad + " --out " + d.file("b.csv"));
  CHECK(malformed.status == 2);
  CHECK_THAT(malformed.output, Contains("expected an array"));
}
