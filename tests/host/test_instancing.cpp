// Instancing: scene files with prototypes and instances, the two-level float reference against the flattened
// scene, watertightness through instances of a closed mesh, and the bad inputs instancing adds.
#include <catch2/catch.hpp>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "host/devices/device_settings.h"
#include "host/devices/direct_device.h"
#include "host/io/error.h"
#include "host/io/json_io.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/instancing.h"
#include "hwmodel/numeric/rng.h"
#include "tests/common/test_util.h"
#include "tests/host/error_checks.h"

using namespace rtu;

namespace {

const std::string kInstances = RTU_SOURCE_DIR "/scenes/instances.json";

std::string write_scene(const std::string& name, const std::string& text) {
  const std::filesystem::path dir = rtu::test::temp_dir("instancing");
  const std::string path = (dir / (name + ".json")).string();
  std::ofstream(path) << text;
  return path;
}

std::string load_error(const std::string& text) {
  return error_of([&] { host::load_scene(write_scene("bad", text)); }, "(loaded)");
}

std::vector<hw::Hit> instanced_trace(const hw::InstancedFloatTracer& t, const std::vector<hw::Ray>& rays,
                                     bool any_hit) {
  std::vector<hw::Hit> hits(rays.size());
  hw::TraversalStats s;
  t.trace_batch(rays.data(), hits.data(), rays.size(), any_hit, 0, s);
  return hits;
}

}  // namespace

TEST_CASE("scene files place instances of prototypes, nested, in the documented primitive order",
          "[scene][instancing]") {
  const host::Scene s = host::load_scene(kInstances);
  REQUIRE(s.instanced());
  const hw::InstanceSet& set = s.instances;
  // Instance 0 is the loose geometry (the ground quad, the sphere); 4 blocks of 9 towers; 3 balls.
  CHECK(set.instances.size() == 1 + 4 * 9 + 3);
  CHECK(set.meshes.size() == 3);  // loose, tower, ball ("block" has only instances)
  const size_t tower = 12 + 20 * 16, ball = 20 * 64;
  CHECK(s.geometry.triangles.size() == 2 + 36 * tower + 3 * ball);
  CHECK(s.geometry.spheres.size() == 1);
  CHECK(s.geometry.planes.size() == 1);
  CHECK(set.instances[0].to_world.is_identity());
  CHECK(set.instances[1].tri_base == 2);
  CHECK(set.instances[2].tri_base == 2 + tower);
  CHECK(set.instances[0].sphere_base == s.geometry.triangles.size());  // the loose sphere, after every triangle
  CHECK(set.instances[1].sphere_base == s.geometry.triangles.size() + 1);
  // The flattened triangles are the instances' in world space, and the materials follow the prototype's entries.
  const hw::Instance& first = set.instances[1];  // block 0, tower 0: translate (-8,0,-8) + (-3,0,-3)
  const hw::Triangle& t0 = set.meshes[first.mesh].triangles[0];
  CHECK(s.geometry.triangles[2].v0 == first.to_world.point(t0.v0));
  CHECK(first.to_world.m[0][3] == -11.0f);
  auto material = [&](uint32_t prim) { return s.materials[s.prim_material[prim]].name; };
  CHECK(material(0) == "ground");
  CHECK(material(2) == "wall");
  CHECK(material(2 + 12) == "roof");
  CHECK(material(2 + 36 * uint32_t(tower)) == "ball");
  CHECK(material(uint32_t(s.geometry.triangles.size())) == "chrome");
}

TEST_CASE("the two-level float reference finds the flattened scene's hits", "[float][instancing]") {
  const host::Scene s = host::load_scene(kInstances);
  const hw::InstancedFloatTracer two(s.instances, s.geometry);
  const hw::FloatTracer flat(s.geometry);
  for (const char* kind : {"primary", "incoherent"}) {
    const std::vector<hw::Ray> rays = std::string(kind) == "primary"
                                          ? host::primary_rays(s.camera, 40000)
                                          : host::incoherent_rays(s.geometry.bounds(), 40000, 5);
    for (bool any_hit : {false, true}) {
      const std::vector<hw::Hit> a = instanced_trace(two, rays, any_hit);
      std::vector<hw::Hit> b(rays.size());
      hw::TraversalStats st;
      flat.trace_batch(rays.data(), b.data(), rays.size(), any_hit, 0, st);
      uint64_t hits = 0, hit_miss = 0, prim_diff = 0;
      for (size_t i = 0; i < rays.size(); ++i) {
        hits += b[i].hit();
        if (a[i].hit() != b[i].hit()) {
          ++hit_miss;
        } else if (!any_hit && a[i].hit() && a[i].prim != b[i].prim) {
          ++prim_diff;
        }
      }
      // The two differ only in where they round: the flattened vertices once each, the two-level ray once per
      // coordinate in object space. A ray decides differently only within a few ulps of an edge or a silhouette
      // (and of equal t at shared edges): measured 0-3 rays in 40,000; we allow 1e-4 of the rays.
      INFO(kind << (any_hit ? " any-hit" : " closest") << ": " << hits << " hits, " << hit_miss
                << " hit/miss disagreements, " << prim_diff << " other primitives");
      CHECK(hits > rays.size() / 4);
      CHECK(double(hit_miss) <= 1e-4 * double(rays.size()));
      CHECK(double(prim_diff) <= 1e-4 * double(rays.size()));
    }
  }
}

TEST_CASE("statistics of a two-level trace count rays once and the work of both levels", "[float][instancing]") {
  const host::Scene s = host::load_scene(kInstances);
  const hw::InstancedFloatTracer two(s.instances, s.geometry);
  const std::vector<hw::Ray> rays = host::primary_rays(s.camera, 5000);
  std::vector<hw::Hit> hits(rays.size());
  hw::TraversalStats st;
  two.trace_batch(rays.data(), hits.data(), rays.size(), false, 1, st);
  uint64_t n_hit = 0;
  for (const hw::Hit& h : hits) n_hit += h.hit();
  CHECK(st.rays == rays.size());
  CHECK(st.hits == n_hit);
  CHECK(st.nodes_visited > st.rays);  // top and bottom levels
  // Threads do not change hits or counts.
  std::vector<hw::Hit> again(rays.size());
  hw::TraversalStats st2;
  two.trace_batch(rays.data(), again.data(), rays.size(), false, 0, st2);
  CHECK(std::memcmp(hits.data(), again.data(), hits.size() * sizeof(hw::Hit)) == 0);
  CHECK(st2.box_tests == st.box_tests);
}

TEST_CASE("no ray leaks through instances of the closed icosphere at offsets, rotations and scales",
          "[float][fixed][watertight][instancing]") {
  // Eight instances of one icosphere (5120 triangles): rotations about skew axes, uniform and non-uniform
  // scales, a mirror, and offsets up to 2.7e5 from the origin.
  const std::string scene = write_scene("ico8", R"({
    "prototypes": {"ico": {"meshes": [{"generate": "icosphere", "subdiv": 4, "radius": 1}]}},
    "instances": [
      {"prototype": "ico"},
      {"prototype": "ico", "transform": {"rotate": [1, 2, 3, 37], "translate": [5, 0, 0]}},
      {"prototype": "ico", "transform": {"scale": [2, 0.5, 1], "rotate": [0, 1, 1, 71], "translate": [0, 6, 0]}},
      {"prototype": "ico", "transform": {"scale": [-1, 1, 1], "translate": [0, 0, 7]}},
      {"prototype": "ico", "transform": {"scale": 1000, "rotate": [3, -1, 2, 123], "translate": [148376, 1234, -223423]}},
      {"prototype": "ico", "transform": {"scale": 0.001, "translate": [-3, -3, -3]}},
      {"prototype": "ico", "transform": {"matrix": [[0, 1, 0, 10], [0, 0, 1, 10], [1, 0, 0, 10]]}},
      {"prototype": "ico", "transform": {"rotate": [1, 1, 1, 200], "scale": 3, "translate": [-20, 4, 9]}}
    ]})");
  const host::Scene s = host::load_scene(scene);
  REQUIRE(s.instances.instances.size() == 9);  // instance 0: the (empty) loose geometry
  const hw::InstancedFloatTracer two(s.instances, s.geometry);
  host::DeviceOptions fo;
  fo.kind = hw::DeviceKind::kFixed;
  const auto fixed = host::make_device(s.geometry, fo);
  fo.instances = &s.instances;
  const auto fixed_two = host::make_device(s.geometry, fo);
  REQUIRE(fixed_two->instanced());
  hw::Pcg32 rng(11);
  uint64_t rays_total = 0, leaks_two = 0, leaks_fixed = 0, leaks_fixed_two = 0;
  for (uint32_t i = 1; i < s.instances.instances.size(); ++i) {
    // Rays from near the instance's center, aimed exactly at its flattened vertices and edge points.
    const hw::Instance& in = s.instances.instances[i];
    const hw::Vec3 center = in.to_world.point(hw::Vec3(0.0f));
    const float reach = 0.3f * std::min({glm::length(in.to_world.vector(hw::Vec3(1, 0, 0))),
                                         glm::length(in.to_world.vector(hw::Vec3(0, 1, 0))),
                                         glm::length(in.to_world.vector(hw::Vec3(0, 0, 1)))});
    std::vector<hw::Ray> rays;
    for (int k = 0; k < 4000; ++k) {
      const hw::Triangle& t = s.geometry.triangles[in.tri_base + rng.next_u32() % 5120];
      const float w = (rng.next_u32() & 1) ? 0.0f : rng.next_float();
      const hw::Vec3 target = t.v0 + w * (t.v1 - t.v0);
      hw::Vec3 o;
      for (int a = 0; a < 3; ++a) o[a] = center[a] + (rng.next_float() - 0.5f) * reach;
      rays.push_back(hw::Ray{o, 0.0f, target - o, std::numeric_limits<float>::infinity()});
    }
    const std::vector<hw::Hit> a = instanced_trace(two, rays, false);
    std::vector<hw::Hit> b(rays.size());
    hw::TraversalStats st;
    fixed->trace_batch(rays.data(), b.data(), rays.size(), false, 0, st);
    std::vector<hw::Hit> c(rays.size());
    fixed_two->trace_batch(rays.data(), c.data(), rays.size(), false, 0, st);
    // The flattened fixed scene has one quantization frame, whose grid step (2^-5 here, for 3.7e5 units in 24
    // bits) is larger than the instance scaled by 0.001: its vertices collapse to a few grid points, and an
    // origin near its center can be outside what is left, so its flattened rays are not counted. The two-level
    // fixed device quantizes each mesh in its own frame: every instance counts.
    const bool fixed_resolves = reach >= 0.01f;
    for (size_t k = 0; k < rays.size(); ++k) {
      leaks_two += !a[k].hit();
      leaks_fixed += fixed_resolves && !b[k].hit();
      leaks_fixed_two += !c[k].hit();
    }
    rays_total += rays.size();
    INFO("instance " << i << ": " << leaks_two << " two-level leaks, " << leaks_fixed << " flattened fixed leaks, "
                     << leaks_fixed_two << " two-level fixed leaks so far");
    CHECK(leaks_two == 0);
    CHECK(leaks_fixed == 0);
    CHECK(leaks_fixed_two == 0);
  }
  CHECK(rays_total == 32000);
}

TEST_CASE("instancing refuses bad scene files with a clear message", "[scene][instancing][limits]") {
  const std::string proto = R"("prototypes": {"p": {"meshes": [{"generate": "box"}]}})";
  CHECK_THAT(load_error("{" + proto + R"(, "instances": [{"prototype": "q"}]})"),
             Catch::Matchers::Contains("unknown prototype 'q' (known: p)"));
  // A shear flat to 13 digits: |det| below 2^-40 of the product of its rows' lengths (scales alone never are:
  // a uniform scale of 1e-30 is a valid instance).
  CHECK_THAT(
      load_error("{" + proto +
                 R"(, "instances": [{"prototype": "p", "transform": {"matrix": [[1, 0, 0, 0], [1, 1e-13, 0, 0],
                        [0, 0, 1, 0]]}}]})"),
      Catch::Matchers::Contains("instances[0]: the composed transform is not finite or is singular"));
  CHECK_THAT(load_error("{" + proto + R"(, "instances": [{"prototype": "p", "transform": {"scale": 1e39}}]})"),
             Catch::Matchers::Contains("instances[0].transform.scale: out of float range"));
  // Each scale is a float; their composition is not.
  CHECK_THAT(load_error(R"({"prototypes": {"p": {"meshes": [{"generate": "box"}]},
                                           "q": {"instances": [{"prototype": "p", "transform": {"scale": 1e30}}]}},
                            "instances": [{"prototype": "q", "transform": {"scale": 1e30}}]})"),
             Catch::Matchers::Contains("prototypes.q.instances[0]: the composed transform is not finite"));
  CHECK_THAT(load_error("{" + proto + R"(, "instances": [{"prototype": "p", "transform": {"scale": 1e30}}]})"),
             Catch::Matchers::Contains("instance 1: world bounds beyond 2^62"));
  CHECK_THAT(load_error("{" + proto +
                        R"(, "instances": [{"prototype": "p", "transform": {"matrix": [[1, 2, 3, 0], [2, 4, 6, 0],
                        [0, 0, 1, 0]]}}]})"),
             Catch::Matchers::Contains("instances[0].transform.matrix: singular"));
  CHECK_THAT(
      load_error("{" + proto +
                 R"(, "instances": [{"prototype": "p", "transform": {"matrix": [[1, 0, 0, 1e999], [0, 1, 0, 0],
                        [0, 0, 1, 0]]}}]})"),
      Catch::Matchers::Contains("not a finite number"));
  CHECK_THAT(load_error("{" + proto +
                        R"(, "instances": [{"prototype": "p", "transform": {"matrix": [[1, 0, 0, 0], [0, 1, 0, 0],
                        [0, 0, 1, 0]], "scale": 2}}]})"),
             Catch::Matchers::Contains("'matrix' excludes"));
  CHECK_THAT(load_error(R"({"prototypes": {"a": {"instances": [{"prototype": "b"}]},
                                           "b": {"meshes": [{"generate": "box"}], "instances": [{"prototype": "a"}]}},
                            "instances": [{"prototype": "a"}]})"),
             Catch::Matchers::Contains("instance loop: 'a' contains itself"));
  CHECK_THAT(load_error(R"({"prototypes": {"a": {"instances": []}}, "instances": [{"prototype": "a"}]})"),
             Catch::Matchers::Contains("no instance has triangles"));
  CHECK_THAT(load_error("{" + proto + R"(, "instances": [{"prototype": "p", "material": "x"}]})"),
             Catch::Matchers::Contains("unknown key 'instances[0].material'"));
  // A chain deeper than the nesting limit.
  std::string chain = R"({"prototypes": {"p0": {"meshes": [{"generate": "box"}]})";
  for (int i = 1; i <= hw::kMaxInstanceNesting + 1; ++i)
    chain +=
        ", \"p" + std::to_string(i) + "\": {\"instances\": [{\"prototype\": \"p" + std::to_string(i - 1) + "\"}]}";
  chain += "}, \"instances\": [{\"prototype\": \"p" + std::to_string(hw::kMaxInstanceNesting + 1) + "\"}]}";
  CHECK_THAT(load_error(chain), Catch::Matchers::Contains("nested deeper than 32 levels"));
  // Exponential expansion: 2^21 boxes from 21 levels of two is refused at the instance limit, quickly.
  std::string fan = R"({"prototypes": {"q0": {"meshes": [{"generate": "quad"}]})";
  for (int i = 1; i <= 21; ++i)
    fan += ", \"q" + std::to_string(i) + "\": {\"instances\": [{\"prototype\": \"q" + std::to_string(i - 1) +
           "\"}, {\"prototype\": \"q" + std::to_string(i - 1) + "\", \"transform\": {\"translate\": [1, 0, 0]}}]}";
  fan += "}, \"instances\": [{\"prototype\": \"q21\"}]}";
  CHECK_THAT(load_error(fan), Catch::Matchers::Contains("more than 1048576 instances"));
  // The same fan over prototypes without meshes adds no instance at all: 2^32 entries would be walked (a hang),
  // but a prototype that placed nothing is walked once.
  std::string empty = R"({"meshes": [{"generate": "quad"}], "prototypes": {"e0": {"instances": []})";
  for (int i = 1; i <= 32; ++i)
    empty += ", \"e" + std::to_string(i) + "\": {\"instances\": [{\"prototype\": \"e" + std::to_string(i - 1) +
             "\"}, {\"prototype\": \"e" + std::to_string(i - 1) + "\"}]}";
  empty += "}, \"instances\": [{\"prototype\": \"e31\"}]}";
  CHECK_THAT(load_error(empty), Catch::Matchers::Contains("no instance has triangles"));
}

TEST_CASE("the hwmodel refuses instance sets it cannot trace", "[instancing][limits]") {
  hw::InstanceSet set;
  set.meshes.resize(1);
  set.meshes[0].triangles.push_back({hw::Vec3(0), hw::Vec3(1, 0, 0), hw::Vec3(0, 1, 0)});
  hw::Instance in;
  in.mesh = 1;
  set.instances.push_back(in);
  set.finish();
  CHECK_THROWS_WITH(set.validate(), Catch::Matchers::Contains("mesh 1 out of range"));
  set.instances[0].mesh = 0;
  set.instances[0].to_world.m[1][1] = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_WITH(set.validate(), Catch::Matchers::Contains("not finite or is singular"));
  set.instances[0].to_world.m[1][1] = 0.0f;
  CHECK_THROWS_WITH(set.validate(), Catch::Matchers::Contains("not finite or is singular"));
  set.instances[0].to_world.m[1][1] = 1.0f;
  set.meshes[0].spheres.push_back({hw::Vec3(0), 1.0f});
  set.instances[0].to_world.m[0][3] = 2.0f;  // a translation keeps the sphere round
  set.finish();
  CHECK_NOTHROW(set.validate());
  set.instances[0].to_world.m[0][0] = 3.0f;  // a scale along x alone would make it an ellipsoid
  CHECK_THROWS_WITH(set.validate(),
                    Catch::Matchers::Contains("may only be instanced with a similarity transform"));
  set.instances[0].to_world.m[0][0] = 1.0f;
  set.instances[0].to_world.m[0][3] = 0.0f;
  set.meshes[0].planes.push_back({hw::Vec3(0, 1, 0), 0.0f});
  CHECK_THROWS_WITH(set.validate(), Catch::Matchers::Contains("has planes"));
  set.meshes[0].planes.clear();
  CHECK_NOTHROW(set.validate());
  // NaN rays are refused by the two-level tracer as by every device: a miss, counted invalid.
  const hw::Geometry flat = set.flatten({});
  const hw::InstancedFloatTracer t(set, flat);
  hw::TraversalStats st;
  const hw::Ray bad{hw::Vec3(std::numeric_limits<float>::quiet_NaN()), 0.0f, hw::Vec3(0, 0, 1), 1.0f};
  CHECK(!t.trace(bad, false, st).hit());
  CHECK(st.invalid_rays == 1);
  CHECK(st.rays == 0);
}

namespace {

// A glTF file whose node tree places one mesh (a unit quad in the z = 0 plane, x, y in [-1, 1]) several times,
// one placement nested under a parent that moves it; `parent_scale` scales that parent (0: singular).
std::string write_placed_gltf(const std::string& name, double parent_scale) {
  const std::filesystem::path dir = rtu::test::temp_dir("instancing") / name;
  std::filesystem::create_directories(dir);
  const float pos[12] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
  const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  std::ofstream bin(dir / "quad.bin", std::ios::binary);
  bin.write(reinterpret_cast<const char*>(pos), sizeof pos);
  bin.write(reinterpret_cast<const char*>(idx), sizeof idx);
  bin.close();
  std::ofstream(dir / "placed.gltf") << R"({
    "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1, 2]}],
    "nodes": [
      {"mesh": 0},
      {"mesh": 0, "translation": [4, 0, 0], "rotation": [0, 0, 0.38268343, 0.92387953]},
      {"translation": [0, 5, 0], "scale": [)"
                                     << parent_scale << ", " << parent_scale << ", " << parent_scale << R"(],
       "children": [3]},
      {"mesh": 0, "translation": [2, 0, 0]}
    ],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
    "buffers": [{"uri": "quad.bin", "byteLength": 60}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}
    ]
  })";
  return (dir / "placed.gltf").string();
}

}  // namespace

TEST_CASE("a mesh file's node tree that places a mesh more than once becomes instances", "[scene][instancing]") {
  const host::Scene s = host::load_scene(write_placed_gltf("placed", 2.0));
  REQUIRE(s.instanced());
  CHECK(s.instances.meshes.size() == 1);
  REQUIRE(s.instances.instances.size() == 3);
  REQUIRE(s.geometry.triangles.size() == 6);  // flattened: placement by placement, in node order
  // The nested placement: the parent's scale 2 and move (0, 5, 0) after the child's move (2, 0, 0).
  const hw::Instance& nested = s.instances.instances[2];
  const hw::Vec3 corner = nested.to_world.point(hw::Vec3(1, 1, 0));
  CHECK(corner.x == 6.0f);
  CHECK(corner.y == 7.0f);
  CHECK(s.geometry.triangles[4].v2 == corner);  // the flattened triangle is the placed one
  // The rotated placement (45 degrees about z): its corner (1, 1) lands on the y axis, sqrt(2) up.
  const hw::Vec3 r = s.instances.instances[1].to_world.point(hw::Vec3(1, 1, 0));
  CHECK(r.x == Approx(4.0f).margin(1e-6));
  CHECK(r.y == Approx(std::sqrt(2.0f)).margin(1e-6));
  // Two levels and flattened agree: rays at each placement's quad, off its diagonal and edges.
  std::vector<hw::Ray> rays;
  for (const hw::Instance& in : s.instances.instances)
    for (const float u : {-0.5f, 0.3f})
      for (const float v : {-0.4f, 0.6f}) {
        const hw::Vec3 target = in.to_world.point(hw::Vec3(u, v, 0.0f));
        rays.push_back(hw::Ray{target + hw::Vec3(0.1f, -0.05f, 3.0f), 0.0f, hw::Vec3(-0.1f, 0.05f, -3.0f),
                               std::numeric_limits<float>::infinity()});
      }
  const hw::InstancedFloatTracer two(s.instances, s.geometry);
  const std::vector<hw::Hit> a = instanced_trace(two, rays, false);
  host::DeviceOptions fo;
  fo.kind = hw::DeviceKind::kFixed;
  const auto fixed = host::make_device(s.geometry, fo);
  std::vector<hw::Hit> b(rays.size());
  hw::TraversalStats st;
  fixed->trace_batch(rays.data(), b.data(), rays.size(), false, 1, st);
  for (size_t i = 0; i < rays.size(); ++i) {
    INFO("ray " << i);
    REQUIRE(a[i].hit());
    CHECK(a[i].prim / 2 == i / 4);  // the placement aimed at
    CHECK(b[i].prim == a[i].prim);
  }
}

TEST_CASE("a node tree with a singular transform is flattened, as before", "[scene][instancing]") {
  // The parent scaled to zero: its placement cannot be inverted, so the file is not made two-level; the
  // placement's triangles collapse to a point (degenerate, never hit) and the others are traced as usual.
  const host::Scene s = host::load_scene(write_placed_gltf("singular", 0.0));
  CHECK(!s.instanced());
  CHECK(s.geometry.triangles.size() == 6);
}

TEST_CASE("a scene file's mesh entry keeps the file's placements as instances, under the entry's transform",
          "[scene][instancing]") {
  const std::string gltf = write_placed_gltf("placed_in_scene", 2.0);
  const host::Scene bare = host::load_scene(gltf);
  const host::Scene s = host::load_scene(write_scene("file_instances", R"({
    "materials": {"floor": {"color": [0.5, 0.5, 0.5]}},
    "meshes": [{"generate": "quad", "size": [40, 40], "material": "floor"},
               {"file": ")" + gltf + R"(", "transform": {"translate": [10, 0, 0]}}]})"));
  REQUIRE(s.instanced());
  CHECK(s.instances.meshes.size() == 2);       // the loose quad, the file's mesh
  REQUIRE(s.instances.instances.size() == 4);  // the loose geometry and the file's three placements
  REQUIRE(s.geometry.triangles.size() == 2 + bare.geometry.triangles.size());
  for (size_t k = 0; k < bare.geometry.triangles.size(); ++k) {
    const hw::Triangle& a = bare.geometry.triangles[k];
    const hw::Triangle& b = s.geometry.triangles[2 + k];
    // The composed transform is rounded to float once, the bare file's node transform once: within an ulp of 10.
    CHECK(b.v0.x == Approx(a.v0.x + 10.0f).margin(2e-6));
    CHECK(b.v2.y == Approx(a.v2.y).margin(2e-6));
  }
  CHECK(s.materials[s.prim_material[0]].name == "floor");
  // Two levels and flattened find the same triangles.
  std::vector<hw::Ray> rays;
  for (uint32_t i = 1; i < s.instances.instances.size(); ++i) {
    const hw::Vec3 target = s.instances.instances[i].to_world.point(hw::Vec3(0.3f, -0.4f, 0.0f));
    rays.push_back(hw::Ray{target + hw::Vec3(0.0f, 0.0f, 3.0f), 0.0f, hw::Vec3(0.0f, 0.0f, -1.0f),
                           std::numeric_limits<float>::infinity()});
  }
  const hw::InstancedFloatTracer two(s.instances, s.geometry);
  const hw::FloatTracer flat(s.geometry);
  const std::vector<hw::Hit> a = instanced_trace(two, rays, false);
  for (size_t i = 0; i < rays.size(); ++i) {
    hw::TraversalStats st;
    const hw::Hit b = flat.trace(rays[i], false, st);
    REQUIRE(a[i].hit());
    CHECK(a[i].prim == b.prim);
    CHECK(a[i].prim >= 2);
  }
}

TEST_CASE("lines of a mesh file whose node tree places meshes more than once: loose strands beside the instances",
          "[scene][instancing][curve]") {
  // A quad placed twice and a polyline of two segments placed twice (glTF LINES).
  const std::filesystem::path dir = rtu::test::temp_dir("instancing") / "lines";
  std::filesystem::create_directories(dir);
  const float quad[12] = {-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0};
  const uint16_t qidx[6] = {0, 1, 2, 0, 2, 3};
  const float line[9] = {0, 0, 0, 0, 1, 0, 0.5f, 2, 0};
  const uint16_t lidx[4] = {0, 1, 1, 2};
  std::ofstream bin(dir / "m.bin", std::ios::binary);
  bin.write(reinterpret_cast<const char*>(quad), sizeof quad);
  bin.write(reinterpret_cast<const char*>(qidx), sizeof qidx);
  bin.write(reinterpret_cast<const char*>(line), sizeof line);
  bin.write(reinterpret_cast<const char*>(lidx), sizeof lidx);
  bin.close();
  std::ofstream(dir / "m.gltf") << R"({
    "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1, 2, 3]}],
    "nodes": [{"mesh": 0}, {"mesh": 0, "translation": [4, 0, 0]},
              {"mesh": 1, "translation": [0, 0, 1]}, {"mesh": 1, "translation": [3, 0, 1]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]},
               {"primitives": [{"attributes": {"POSITION": 2}, "indices": 3, "mode": 1}]}],
    "buffers": [{"uri": "m.bin", "byteLength": 104}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48}, {"buffer": 0, "byteOffset": 48, "byteLength": 12},
                    {"buffer": 0, "byteOffset": 60, "byteLength": 36}, {"buffer": 0, "byteOffset": 96, "byteLength": 8}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
      {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [0.5, 2, 0]},
      {"bufferView": 3, "componentType": 5123, "count": 4, "type": "SCALAR"}
    ]
  })";
  const host::Scene s = host::load_scene((dir / "m.gltf").string());
  REQUIRE(s.instanced());
  REQUIRE(s.geometry.curves.size() == 4);  // two segments, placed twice, in world space
  CHECK(s.geometry.curves[2].p0 == hw::Vec3(3, 0, 1));
  // The two levels hold them as one more mesh under the identity, numbered after the triangles.
  const hw::Instance& loose = s.instances.instances.back();
  CHECK(s.instances.meshes[loose.mesh].curves.size() == 4);
  CHECK(loose.curve_base == s.geometry.triangles.size());
  // Rays at each segment's middle hit it, on both levels and every device.
  std::vector<hw::Ray> rays;
  for (const hw::CurveSegment& c : s.geometry.curves)
    rays.push_back(hw::Ray{0.5f * (c.p0 + c.p1) + hw::Vec3(0, 0, 5), 0.0f, hw::Vec3(0, 0, -1),
                           std::numeric_limits<float>::infinity()});
  const hw::InstancedFloatTracer two(s.instances, s.geometry);
  const std::vector<hw::Hit> a = instanced_trace(two, rays, false);
  for (size_t i = 0; i < rays.size(); ++i) CHECK(a[i].prim == s.geometry.curve_prim(uint32_t(i)));
  const hw::InstancedFixedTracer fixed(s.instances, s.geometry, hw::format_preset("default"), hw::TracerOptions{});
  for (size_t i = 0; i < rays.size(); ++i) {
    hw::TraversalStats st;
    CHECK(fixed.trace(rays[i], false, st).prim == s.geometry.curve_prim(uint32_t(i)));
  }
}

TEST_CASE("a prototype's mesh file with lines: each instance places its strands", "[scene][instancing][curve]") {
  const std::filesystem::path dir = rtu::test::temp_dir("instancing") / "proto_lines";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "strands.obj")
      << "v 0 0 0\nv 0 1 0\nv 0.2 2 0\nv 1 0 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 -1 1\n"
         "l 1 2 3\nl 4 5\nf 6 7 8\n";
  const std::string json = R"({"prototypes": {"p": {"meshes": [{"file": "strands.obj", "curve_radius": 0.05}]}},
    "instances": [{"prototype": "p", "transform": {"translate": [10, 0, 0]}},
                  {"prototype": "p", "transform": {"rotate": [0, 1, 0, 90], "scale": 2, "translate": [-10, 0, 0]}}]})";
  const host::Scene s = host::load_scene_json(host::parse_json_limited(json, "p.json"), "p.json", dir.string());
  REQUIRE(s.instanced());
  REQUIRE(s.geometry.curves.size() == 6);  // 3 segments a placement
  CHECK(s.geometry.curves[0].p0 == hw::Vec3(10, 0, 0));
  CHECK(s.geometry.curves[3].r0 == 0.1f);  // the scaled placement's radius
  CHECK(s.prim_material.size() == s.geometry.num_prims());
}

TEST_CASE("a prototype's own spheres and curves: each instance places them, radii scaled",
          "[scene][instancing][curve]") {
  const std::string json = R"({
    "materials": {"red": {"color": [1, 0, 0]}, "blue": {"color": [0, 0, 1]}},
    "spheres": [{"center": [0, -5, 0], "radius": 1}],
    "prototypes": {"tuft": {"spheres": [{"center": [0, 1, 0], "radius": 0.5, "material": "red"}],
                            "curves": [{"points": [[0, 0, 0], [0, 1, 0], [0.5, 2, 0]], "radius": 0.1,
                                        "material": "blue"}]}},
    "instances": [{"prototype": "tuft", "transform": {"translate": [10, 0, 0]}},
                  {"prototype": "tuft", "transform": {"rotate": [0, 0, 1, 90], "scale": 2, "translate": [-10, 0, 0]}}]})";
  const host::Scene s = host::load_scene_json(host::parse_json_limited(json, "t.json"), "t.json", ".");
  REQUIRE(s.instanced());
  const hw::Geometry& g = s.geometry;
  REQUIRE(g.spheres.size() == 3);  // the loose one, then one a placement
  REQUIRE(g.curves.size() == 4);   // two segments a placement
  CHECK(g.spheres[0].center == hw::Vec3(0, -5, 0));
  CHECK(g.spheres[1].center == hw::Vec3(10, 1, 0));
  CHECK(g.spheres[2].radius == 1.0f);                           // 0.5 scaled by 2
  CHECK(g.spheres[2].center.x == Approx(-12.0f).margin(1e-5));  // (0, 1) turned to (-1, 0), doubled, moved
  CHECK(g.curves[2].r0 == Approx(0.2f));
  // Materials follow the flattened order: the loose sphere's default, then red, red; blue for every segment.
  const uint32_t red = s.prim_material[g.sphere_prim(1)], blue = s.prim_material[g.curve_prim(3)];
  CHECK(s.materials[red].name == "red");
  CHECK(s.materials[blue].name == "blue");
  CHECK(s.prim_material[g.sphere_prim(2)] == red);
  // Two levels and flattened: rays at each placed sphere's and segment's middle hit it.
  const hw::InstancedFloatTracer two(s.instances, g);
  std::vector<hw::Ray> rays;
  std::vector<uint32_t> want;
  for (uint32_t i = 0; i < g.spheres.size(); ++i) {
    rays.push_back(hw::Ray{g.spheres[i].center + hw::Vec3(0, 0, 20), 0.0f, hw::Vec3(0, 0, -1), INFINITY});
    want.push_back(g.sphere_prim(i));
  }
  for (uint32_t i = 0; i < g.curves.size(); ++i) {
    rays.push_back(hw::Ray{0.5f * (g.curves[i].p0 + g.curves[i].p1) + hw::Vec3(0, 0, 20), 0.0f, hw::Vec3(0, 0, -1),
                           INFINITY});
    want.push_back(g.curve_prim(i));
  }
  const std::vector<hw::Hit> hits = instanced_trace(two, rays, false);
  for (size_t i = 0; i < rays.size(); ++i) CHECK(hits[i].prim == want[i]);
  // A prototype with round primitives under a scale that is not uniform is refused, naming the rule.
  std::string bad = json;
  bad.replace(bad.find("\"scale\": 2"), 10, "\"scale\": [2, 1, 1]");
  CHECK_THROWS_WITH(
      host::validate_scene(host::load_scene_json(host::parse_json_limited(bad, "t.json"), "t.json", ".")),
      Catch::Contains("similarity"));
}
