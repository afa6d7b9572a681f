// The fixed device over two levels (hwmodel/datapath/instanced_fixed.h): agreement with the two-level float
// reference, statistics, bytes, the transform's widths, origins moved to a far mesh's bounds, and the images it
// refuses.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/devices/direct_device.h"
#include "host/io/json_io.h"
#include "host/jobs/render.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "host/scene/shading.h"
#include "hwmodel/datapath/instanced_fixed.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/timing/timing_config.h"
#include "tests/common/round_prototypes.h"
#include "tests/common/test_util.h"
#include "tests/host/run_process.h"

using namespace rtu;

namespace {

struct Traced {
  std::vector<hw::Hit> hits;
  hw::TraversalStats stats;
};

Traced run(const host::DirectDevice& d, const std::vector<hw::Ray>& rays, bool any_hit, int threads = 0) {
  Traced t;
  t.hits.resize(rays.size());
  d.trace_batch(rays.data(), t.hits.data(), rays.size(), any_hit, threads, t.stats);
  return t;
}

std::unique_ptr<host::DirectDevice> device(const host::Scene& s, hw::DeviceKind kind, const hw::AnyHitStage* stage,
                                           int xform_bits = 24) {
  host::DeviceOptions o;
  o.kind = kind;
  o.instances = &s.instances;
  o.any_hit = stage;
  o.format.xform_bits = xform_bits;
  return host::make_device(s.geometry, o);
}

// Hit/miss and primitive disagreements between a and b, and the mean relative t error on common primitives.
struct Agreement {
  uint64_t hit_miss = 0, other_prim = 0, same = 0;
  double t_rel_sum = 0.0;
  double mean_t_rel() const { return same ? t_rel_sum / double(same) : 0.0; }
};

Agreement agree(const std::vector<hw::Hit>& a, const std::vector<hw::Hit>& b) {
  Agreement g;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].hit() != b[i].hit()) {
      ++g.hit_miss;
    } else if (a[i].hit() && a[i].prim != b[i].prim) {
      ++g.other_prim;
    } else if (a[i].hit() && a[i].t > 0.0f) {
      ++g.same;
      g.t_rel_sum += std::abs(double(a[i].t) - double(b[i].t)) / double(a[i].t);
    }
  }
  return g;
}

}  // namespace

TEST_CASE("round_significant keeps the stated bits, nearest with ties to even", "[fixed][instancing]") {
  CHECK(hw::round_significant(1.0 + std::ldexp(1.0, -8), 8) == 1.0f);           // a tie: to the even 1.0
  CHECK(hw::round_significant(1.0 + 3 * std::ldexp(1.0, -8), 8) == 1.015625f);  // a tie: to the even 1 + 2^-6
  CHECK(hw::round_significant(1.0 + std::ldexp(1.0, -7), 8) == 1.0f + std::ldexp(1.0f, -7));  // representable
  CHECK(hw::round_significant(-0.1, 24) == -0.1f);  // float's own rounding
  CHECK(hw::round_significant(0.0, 12) == 0.0f);
  CHECK(hw::round_significant(255.5, 8) == 256.0f);  // 255.5 needs 9 bits; the tie goes to even 256
  CHECK_THROWS_AS(hw::round_significant(1.0, 7), std::invalid_argument);
  // Every stored entry has at most `bits` significant bits.
  hw::Pcg32 rng(3);
  for (int bits : {8, 13, 24}) {
    for (int k = 0; k < 1000; ++k) {
      const double x = (rng.next_float() - 0.5) * std::ldexp(1.0, int(rng.next_u32() % 40) - 20);
      const float r = hw::round_significant(x, bits);
      int e;
      const double m = std::frexp(double(r), &e);
      CHECK(std::ldexp(m, bits) == std::nearbyint(std::ldexp(m, bits)));
      CHECK(std::abs(double(r) - x) <= std::ldexp(std::abs(x), -bits));  // half a unit of the last kept bit
    }
  }
  CHECK(hw::StoredXform::bytes(24) == 48);  // 12 float32 entries
  CHECK(hw::StoredXform::bytes(8) == 24);   // 12 x (1 + 8 + 7) bits
}

TEST_CASE("the two-level fixed device finds the two-level float reference's hits", "[fixed][instancing]") {
  for (const char* spec : {RTU_SOURCE_DIR "/scenes/instances.json", "builtin:city"}) {
    const host::Scene s = host::load_scene(spec);
    REQUIRE(s.instanced());
    const auto ref = device(s, hw::DeviceKind::kFloat, nullptr);
    const auto two = device(s, hw::DeviceKind::kFixed, nullptr);
    REQUIRE(two->instanced());
    for (const bool primary : {true, false}) {
      const std::vector<hw::Ray> rays =
          primary ? host::primary_rays(s.camera, 40000) : host::incoherent_rays(s.geometry.bounds(), 40000, 9);
      for (const bool any_hit : {false, true}) {
        const Traced a = run(*ref, rays, any_hit), b = run(*two, rays, any_hit);
        const Agreement g = agree(a.hits, b.hits);
        // The fixed datapath rounds each mesh's vertices to its grid (2^-24 of the mesh's extent) and each ray
        // component once in the transform: only a ray within a few grid steps of a silhouette or of a shared
        // edge can decide differently. Measured on 307,200 rays of each scene: 0 hit/miss disagreements and at
        // most 0.66% other primitives on incoherent rays (coplanar faces of touching boxes); allowed 1e-4 and 1%.
        INFO(spec << (primary ? " primary" : " incoherent") << (any_hit ? " any-hit" : " closest") << ": "
                  << g.hit_miss << " hit/miss, " << g.other_prim << " other primitives");
        CHECK(double(g.hit_miss) <= 1e-4 * double(rays.size()));
        if (!any_hit) CHECK(double(g.other_prim) <= 1e-2 * double(rays.size()));
        CHECK(a.stats.hits > rays.size() / 8);
        // Rays counted once; the work of both levels.
        CHECK(b.stats.rays == rays.size());
        uint64_t hits = 0;
        for (const hw::Hit& h : b.hits) hits += h.hit();
        CHECK(b.stats.hits == hits);
        CHECK(b.stats.box_false_negatives == 0);
      }
    }
  }
}

TEST_CASE("two-level fixed traces are the same on any number of threads and cost less memory",
          "[fixed][instancing]") {
  const host::Scene s = host::load_scene("builtin:city");
  const auto two = device(s, hw::DeviceKind::kFixed, nullptr);
  const std::vector<hw::Ray> rays = host::incoherent_rays(s.geometry.bounds(), 20000, 4);
  const Traced one = run(*two, rays, false, 1), many = run(*two, rays, false, 2);
  CHECK(std::memcmp(one.hits.data(), many.hits.data(), rays.size() * sizeof(hw::Hit)) == 0);
  CHECK(one.stats.box_tests == many.stats.box_tests);
  CHECK(one.stats.prim_tests == many.stats.prim_tests);
  CHECK(one.stats.nodes_visited == many.stats.nodes_visited);
  // Bytes: the top image, 5 bottom images and 257 stored transforms (48 bytes) with their addresses (8) against
  // the flattened image of 161,216 triangles.
  const hw::InstancedFixedTracer& t = *two->instanced();
  CHECK(t.transform_bytes() == 257 * (48 + 8));
  uint64_t bottoms = 0;
  for (uint32_t m = 0; m < s.instances.meshes.size(); ++m) bottoms += t.bottom(m).size();
  CHECK(t.bytes() == t.top().size() + bottoms + t.transform_bytes());
  host::DeviceOptions flat;
  flat.kind = hw::DeviceKind::kFixed;
  const auto flat_device = host::make_device(s.geometry, flat);
  INFO("two-level " << t.bytes() << " bytes, flattened " << flat_device->image()->size());
  CHECK(t.bytes() * 20 < flat_device->image()->size());
}

TEST_CASE("fewer transform bits give a larger t error, and 24 bits gives float rounding", "[fixed][instancing]") {
  const host::Scene s = host::load_scene("builtin:city");
  const auto ref = device(s, hw::DeviceKind::kFloat, nullptr);
  const std::vector<hw::Ray> rays = host::primary_rays(s.camera, 20000);
  const Traced a = run(*ref, rays, false);
  double last = 0.0;
  for (const int bits : {24, 16, 12, 8}) {
    const Traced b = run(*device(s, hw::DeviceKind::kFixed, nullptr, bits), rays, false);
    const Agreement g = agree(a.hits, b.hits);
    INFO(bits << " bits: mean relative t error " << g.mean_t_rel() << ", " << g.hit_miss << " hit/miss");
    // An entry rounded to X bits moves an object-space point by up to 2^-X of its distance from the instance's
    // origin; the camera is 20-40 units from buildings of 1-12 units, so below 16 bits the transform's error
    // outgrows the grid's (2^-24 of a mesh) and the mean error must grow with every bit taken away.
    if (bits < 24) CHECK(g.mean_t_rel() > last);
    if (bits == 24) CHECK(g.mean_t_rel() < 1e-6);
    last = g.mean_t_rel();
  }
  CHECK(last > 1e-4);  // 8 bits: an error of 2^-9 per entry
}

TEST_CASE("an origin far outside a small mesh's frame starts at the mesh's bounds, without leaks",
          "[fixed][instancing][watertight]") {
  // An icosphere of radius 0.001 (its frame spans 0.002 units; guard bits 6 allow origins within 64 times that)
  // seen from 100 units away.
  const std::filesystem::path path = rtu::test::temp_dir("instanced_fixed") / "far_instance.json";
  std::ofstream(path) << R"({
    "prototypes": {"ico": {"meshes": [{"generate": "icosphere", "subdiv": 3, "radius": 1}]}},
    "instances": [
      {"prototype": "ico", "transform": {"scale": 0.001, "translate": [1, 2, 3]}},
      {"prototype": "ico", "transform": {"scale": 1, "translate": [-50, 0, 0]}}
    ]})";
  const host::Scene s = host::load_scene(path.string());
  const auto ref = device(s, hw::DeviceKind::kFloat, nullptr);
  const auto two = device(s, hw::DeviceKind::kFixed, nullptr);
  const hw::Instance& small = s.instances.instances[1];  // instance 0 is the empty loose geometry
  REQUIRE(s.instances.meshes[small.mesh].triangles.size() == 1280);
  hw::Pcg32 rng(5);
  std::vector<hw::Ray> rays;
  const hw::Vec3 eye(101.0f, 2.0f, 3.0f);
  for (int k = 0; k < 4000; ++k) {
    // Aimed at a point inside the sphere (a vertex or edge point pulled halfway to the center): the ray crosses
    // the surface wherever the silhouette is.
    const hw::Triangle& t = s.geometry.triangles[small.tri_base + rng.next_u32() % 1280];
    const float w = (rng.next_u32() & 1) ? 0.0f : rng.next_float();
    const hw::Vec3 target = 0.5f * (t.v0 + w * (t.v1 - t.v0)) + 0.5f * hw::Vec3(1.0f, 2.0f, 3.0f);
    rays.push_back(hw::Ray{eye, 0.0f, target - eye, std::numeric_limits<float>::infinity()});
  }
  const Traced a = run(*ref, rays, false), b = run(*two, rays, false);
  uint64_t leaks = 0, small_hits = 0;
  for (size_t k = 0; k < rays.size(); ++k) {
    leaks += !b.hits[k].hit();
    small_hits += b.hits[k].hit() && b.hits[k].prim >= small.tri_base && b.hits[k].prim < small.tri_base + 1280;
  }
  CHECK(two->instanced()->rebased() > 0);
  CHECK(leaks == 0);
  CHECK(small_hits == rays.size());
  // t agrees up to the rounding of the moved origin and of t0 (an ulp of 100 is 2^-17 of t).
  const Agreement g = agree(a.hits, b.hits);
  CHECK(g.hit_miss == 0);
  CHECK(g.mean_t_rel() < 1e-5);
}

TEST_CASE("alpha-tested instances: the two-level fixed device asks the any-hit stage as the reference does",
          "[fixed][instancing][alpha]") {
  // Leaf cards with a 4 x 4 checker mask, placed 25 times, over a floor.
  std::string cards;
  for (int i = 0; i < 25; ++i)
    cards += std::string(i ? ", " : "") + R"({"prototype": "card", "transform": {"rotate": [0, 1, 0, )" +
             std::to_string(i * 17) + R"(], "translate": [)" + std::to_string(i % 5 - 2) + ", 0.7, " +
             std::to_string(i / 5 - 2) + "]}}";
  const std::filesystem::path path = rtu::test::temp_dir("instanced_fixed") / "alpha_instances.json";
  std::ofstream(path) << R"({
    "camera": {"position": [0, 4, 8], "look_at": [0, 0.5, 0], "fov_y": 45, "width": 320, "height": 200},
    "textures": {"checker": {"width": 4, "height": 4, "texels": [
      [60, 160, 50, 255], [60, 160, 50, 0], [60, 160, 50, 255], [60, 160, 50, 0],
      [60, 160, 50, 0], [60, 160, 50, 255], [60, 160, 50, 0], [60, 160, 50, 255],
      [60, 160, 50, 255], [60, 160, 50, 0], [60, 160, 50, 255], [60, 160, 50, 0],
      [60, 160, 50, 0], [60, 160, 50, 255], [60, 160, 50, 0], [60, 160, 50, 255]]}},
    "materials": {"leaf": {"texture": "checker", "alpha_mode": "mask"}, "floor": {"color": [0.7, 0.7, 0.7]}},
    "prototypes": {"card": {"meshes": [{"generate": "quad", "size": [1.2, 1.2], "material": "leaf",
                                        "transform": {"rotate": [1, 0, 0, 70]}}]}},
    "meshes": [{"generate": "quad", "size": [12, 12], "material": "floor"}],
    "instances": [)" + cards +
                             "]}";
  const host::Scene s = host::load_scene(path.string());
  REQUIRE(s.instanced());
  const host::SceneAnyHit alpha(s);
  REQUIRE(alpha.stage());
  const auto ref = device(s, hw::DeviceKind::kFloat, alpha.stage());
  const auto two = device(s, hw::DeviceKind::kFixed, alpha.stage());
  const std::vector<hw::Ray> rays = host::primary_rays(s.camera, 20000);
  const Traced a = run(*ref, rays, false), b = run(*two, rays, false);
  const Agreement g = agree(a.hits, b.hits);
  CHECK(b.stats.any_hit_calls > rays.size() / 10);  // the cards cover about a quarter of the image
  // The same candidates up to rays within grid steps of a card's edge (argued as above): within 1%.
  CHECK(std::abs(double(b.stats.any_hit_calls) - double(a.stats.any_hit_calls)) <=
        0.01 * double(a.stats.any_hit_calls));
  CHECK(double(g.hit_miss) <= 1e-3 * double(rays.size()));
}

TEST_CASE("top-level images: refused where their bottom levels are missing, and checked at bind",
          "[fixed][instancing][errors]") {
  const host::Scene s = host::load_scene("builtin:city");
  const auto two = device(s, hw::DeviceKind::kFixed, nullptr);
  const hw::DeviceImage& top = two->instanced()->top();
  CHECK((top.header().flags & hw::kImageTopLevel) != 0);
  CHECK(top.header().num_triangles == s.geometry.triangles.size());
  // A top level passes the image checks, but an engine that would bind it has no bottom levels.
  CHECK_NOTHROW(hw::DeviceImage::from_bytes(top.data(), top.size()));
  for (const hw::DeviceKind kind : {hw::DeviceKind::kFixed, hw::DeviceKind::kTimed}) {
    const auto engine = hw::make_engine(kind, hw::EngineOptions{}, hw::TimingConfig{});
    CHECK_THROWS_WITH(engine->bind(top.data(), top.size()), Catch::Contains("a top level"));
  }
  // The flag cleared: instance records in a bottom level. The flag set on a mesh's image: primitives in a top
  // level.
  std::vector<uint8_t> bytes(top.data(), top.data() + top.size());
  hw::ImageHeader h;
  std::memcpy(&h, bytes.data(), sizeof h);
  h.flags &= ~hw::kImageTopLevel;
  std::memcpy(bytes.data(), &h, sizeof h);
  CHECK_THROWS_AS(hw::DeviceImage::from_bytes(bytes.data(), bytes.size()), std::invalid_argument);
  const hw::DeviceImage& mesh = two->instanced()->bottom(0);
  bytes.assign(mesh.data(), mesh.data() + mesh.size());
  std::memcpy(&h, bytes.data(), sizeof h);
  h.flags |= hw::kImageTopLevel;
  std::memcpy(bytes.data(), &h, sizeof h);
  CHECK_THROWS_WITH(hw::DeviceImage::from_bytes(bytes.data(), bytes.size()),
                    Catch::Contains("a primitive in a top level"));
}

namespace {

struct Timed {
  std::vector<hw::Hit> hits;
  hw::TimingStats timing;
};

Timed run_timed(const host::Scene& s, const hw::TimingConfig& c, const std::vector<hw::Ray>& rays, bool flatten,
                int threads = 0) {
  host::DeviceOptions o;
  o.kind = hw::DeviceKind::kTimed;
  o.timing = c;
  o.format = hw::format_preset(c.format);
  o.tracer.bvh.width = o.format.width;
  o.instances = &s.instances;
  o.flatten = flatten;
  const auto d = host::make_device(s.geometry, o);
  REQUIRE((d->instanced() != nullptr) == !flatten);
  Timed t;
  t.hits.resize(rays.size());
  hw::TraversalStats st;
  d->trace_batch(rays.data(), t.hits.data(), rays.size(), false, threads, st);
  t.timing = d->timed()->timing();
  return t;
}

}  // namespace

TEST_CASE("the timed device over two levels: the fixed device's hits, a transform per instance visit",
          "[timed][instancing]") {
  const host::Scene s = host::load_scene(RTU_SOURCE_DIR "/scenes/instances.json");
  const std::vector<hw::Ray> rays = host::primary_rays(s.camera, 3000);
  hw::TimingConfig a = hw::timing_preset("rdna2");
  const Timed full = run_timed(s, a, rays, false, 2);
  // The hits are the two-level fixed device's, bit for bit; the cycles do not depend on the host's threads.
  const Traced fixed = run(*device(s, hw::DeviceKind::kFixed, nullptr), rays, false);
  CHECK(std::memcmp(full.hits.data(), fixed.hits.data(), rays.size() * sizeof(hw::Hit)) == 0);
  CHECK(run_timed(s, a, rays, false, 1).timing.cycles == full.timing.cycles);
  CHECK(full.timing.instance_transforms >= rays.size() / 2);
  // One ray slot: nothing overlaps a transform, so each adds the latency difference exactly.
  a.ray_slots = 1;
  a.xform_latency = 10;
  hw::TimingConfig b = a;
  b.xform_latency = 1010;
  const Timed ta = run_timed(s, a, rays, false), tb = run_timed(s, b, rays, false);
  REQUIRE(ta.timing.instance_transforms == tb.timing.instance_transforms);
  CHECK(tb.timing.cycles - ta.timing.cycles == ta.timing.instance_transforms * 1000);
  // Flattened, no transforms.
  CHECK(run_timed(s, a, rays, true).timing.instance_transforms == 0);
}

TEST_CASE("a city of instances fits the node cache where its flattened image does not", "[timed][instancing]") {
  // builtin:city: 257 instances of 5 buildings, 166 kB in two levels against 8.5 MB flattened, in front of
  // rdna2's 64 KiB cache: incoherent rays reuse the buildings' few nodes, so the two-level trace reads less DRAM
  // per ray and takes fewer cycles, though it visits the top level's nodes too.
  const host::Scene s = host::load_scene("builtin:city");
  const std::vector<hw::Ray> rays = host::incoherent_rays(s.geometry.bounds(), 20000, 3);
  const hw::TimingConfig c = hw::timing_preset("rdna2");
  const Timed two = run_timed(s, c, rays, false), flat = run_timed(s, c, rays, true);
  INFO("two-level " << two.timing.cycles << " cycles, " << two.timing.dram_bytes << " DRAM bytes; flattened "
                    << flat.timing.cycles << ", " << flat.timing.dram_bytes);
  CHECK(two.timing.dram_bytes * 2 < flat.timing.dram_bytes);
  CHECK(two.timing.cycles < flat.timing.cycles);
}

TEST_CASE("instance_bytes: what an instance visit fetches, hits unchanged", "[timed][instancing]") {
  // The IFC house: 294 instances of 200 meshes. Its instance records and stored transforms (96 bytes each at 24
  // transform bits, 28 KB) do not fit rdna2-mem's 16 KiB cache beside the nodes, and each ray visits about 1.7
  // instances: a one-line (64-byte) instance leaf reads fewer lines and less DRAM, and 0 is the 96-byte default.
  const host::Scene s = host::load_scene("/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc");
  REQUIRE(s.instanced());
  const std::vector<hw::Ray> rays = host::incoherent_rays(s.geometry.bounds(), 8000, 5);
  hw::TimingConfig c = hw::timing_preset("rdna2-mem");
  c.format = "packed";
  const Timed def = run_timed(s, c, rays, false);
  c.instance_bytes = 96;  // the default's size, now as a key: the same layout, the same cycles
  const Timed same = run_timed(s, c, rays, false);
  c.instance_bytes = 64;
  const Timed leaf = run_timed(s, c, rays, false);
  CHECK(same.timing.cycles == def.timing.cycles);
  CHECK(same.timing.dram_bytes == def.timing.dram_bytes);
  CHECK(std::memcmp(leaf.hits.data(), def.hits.data(), rays.size() * sizeof(hw::Hit)) == 0);
  CHECK(leaf.timing.instance_transforms == def.timing.instance_transforms);
  CHECK(leaf.timing.cache_hits + leaf.timing.cache_misses < def.timing.cache_hits + def.timing.cache_misses);
  CHECK(leaf.timing.dram_bytes < def.timing.dram_bytes);
}

TEST_CASE("rtusim: two levels by default on instanced scenes, --flatten for one", "[cli][instancing]") {
  const std::filesystem::path dir = rtu::test::temp_dir("instanced_fixed") / "two_level_cli";
  std::filesystem::create_directories(dir);
  const std::string two = (dir / "two.json").string(), one = (dir / "one.json").string();
  REQUIRE(rtu::test::run_rtusim("compare --scene builtin:city --rays primary:2000 --json " + two).status == 0);
  REQUIRE(
      rtu::test::run_rtusim("compare --scene builtin:city --rays primary:2000 --flatten --json " + one).status ==
      0);
  const auto a = host::read_json_file(two), b = host::read_json_file(one);
  CHECK(a["bvh"]["image"]["two_level"]["total_bytes"].get<uint64_t>() * 20 <
        b["bvh"]["image"]["total_bytes"].get<uint64_t>());
  CHECK_FALSE(b["bvh"]["image"].contains("two_level"));
  CHECK(a["hit_agreement"].get<double>() == 1.0);
  CHECK(b["hit_agreement"].get<double>() == 1.0);
  // The timed device counts a transform per instance visit, and none flattened.
  const std::string rays = (dir / "p.rays").string();
  REQUIRE(rtu::test::run_rtusim("rays --scene builtin:city --count 500 --out " + rays).status == 0);
  for (const bool flatten : {false, true}) {
    const std::string stats = (dir / "s.json").string();
    REQUIRE(rtu::test::run_rtusim("trace --scene builtin:city --device timed --rays " + rays + " --out " +
                                  (dir / "h.bin").string() + " --stats " + stats + (flatten ? " --flatten" : ""))
                .status == 0);
    const uint64_t transforms = host::read_json_file(stats)["timing"]["instance_transforms"].get<uint64_t>();
    CHECK((transforms == 0) == flatten);
  }
  // Treelet layouts are one level's: refused over two, the refusal naming --flatten, which then runs.
  const std::string treelets = "trace --scene builtin:city --device timed --set treelet_bytes=512 --rays " + rays;
  const rtu::test::Run refused = rtu::test::run_rtusim(treelets);
  INFO(refused.output);
  CHECK(refused.status == 2);
  CHECK(refused.output.find("instanced") != std::string::npos);
  CHECK(refused.output.find("--flatten") != std::string::npos);
  CHECK(rtu::test::run_rtusim(treelets + " --flatten").status == 0);
  const rtu::test::Run info = rtu::test::run_rtusim("info --scene builtin:city");
  REQUIRE(info.status == 0);
  CHECK(info.output.find("two levels   fixed: top ") != std::string::npos);
}

TEST_CASE("two levels as one block of device memory: encoded, bound by the engines, checked at bind",
          "[fixed][timed][instancing][errors]") {
  const host::Scene s = host::load_scene("builtin:city");
  hw::TracerOptions topt;
  const hw::InstancedFixedTracer two(s.instances, s.geometry, hw::FixedFormat{}, topt);
  const std::vector<uint64_t> words = two.encode();
  const auto* data = reinterpret_cast<const uint8_t*>(words.data());
  const size_t bytes = words.size() * 8;
  REQUIRE(hw::is_two_level(data, bytes));
  const std::vector<hw::Ray> rays = host::incoherent_rays(s.geometry.bounds(), 5000, 8);
  std::vector<hw::Hit> want(rays.size()), got(rays.size()), timed(rays.size());
  hw::TraversalStats sw, sg, st;
  two.trace_batch(rays.data(), want.data(), rays.size(), false, 1, sw);
  // Decoded: the same hits and work; bound by the fixed and timed engines: the same hits.
  const auto back = hw::InstancedFixedTracer::from_bytes(data, bytes);
  back->trace_batch(rays.data(), got.data(), rays.size(), false, 1, sg);
  CHECK(std::memcmp(want.data(), got.data(), rays.size() * sizeof(hw::Hit)) == 0);
  CHECK(sg.box_tests == sw.box_tests);
  CHECK(back->encode() == words);
  const auto fixed = hw::make_engine(hw::DeviceKind::kFixed, hw::EngineOptions{}, hw::TimingConfig{});
  fixed->bind(data, bytes);
  fixed->trace(rays.data(), got.data(), rays.size(), false, sg);
  CHECK(std::memcmp(want.data(), got.data(), rays.size() * sizeof(hw::Hit)) == 0);
  CHECK(fixed->counts().triangles == s.geometry.triangles.size());
  hw::TimedEngine te(hw::EngineOptions{}, hw::timing_preset("rdna2"));
  te.bind(data, bytes);
  te.trace_cycles(rays.data(), timed.data(), rays.size(), false, st, 0, 0);
  CHECK(std::memcmp(want.data(), timed.data(), rays.size() * sizeof(hw::Hit)) == 0);
  CHECK(te.timing().instance_transforms > 0);

  // Corruptions, each refused with its reason.
  auto refused = [&](const std::function<void(std::vector<uint64_t>&)>& edit, const std::string& why) {
    std::vector<uint64_t> w = words;
    edit(w);
    INFO(why);
    CHECK_THROWS_WITH(
        hw::InstancedFixedTracer::from_bytes(reinterpret_cast<const uint8_t*>(w.data()), w.size() * 8),
        Catch::Contains(why));
  };
  hw::TwoLevelHeader h;
  std::memcpy(&h, data, sizeof h);
  auto header = [&](std::vector<uint64_t>& w) { return reinterpret_cast<hw::TwoLevelHeader*>(w.data()); };
  auto entry = [&](std::vector<uint64_t>& w, uint32_t i) {
    return reinterpret_cast<hw::InstanceEntry*>(reinterpret_cast<uint8_t*>(w.data()) + h.instance_offset) + i;
  };
  refused([&](auto& w) { header(w)->version = 7; }, "unsupported version");
  refused([&](auto& w) { header(w)->total_bytes += 8; }, "total_bytes");
  refused([&](auto& w) { header(w)->xform_bits = 30; }, "xform_bits");
  refused([&](auto& w) { header(w)->top_offset = bytes; }, "top image outside");
  refused([&](auto& w) { header(w)->num_triangles -= 1; }, "primitive counts");
  refused([&](auto& w) { entry(w, 3)->mesh = 99; }, "instance 3: mesh out of range");
  refused([&](auto& w) { entry(w, 5)->tri_base = h.num_triangles; }, "instance 5: its primitives fall outside");
  refused([&](auto& w) { entry(w, 2)->m[0][0] = std::numeric_limits<float>::quiet_NaN(); }, "not finite");
  refused([&](auto& w) { header(w)->xform_bits = 8; }, "wider than xform_bits");
  refused([&](auto& w) { header(w)->instance_count = 100; }, "names no instance");
  refused(
      [&](auto& w) {
        hw::MeshEntry m;
        std::memcpy(&m, reinterpret_cast<uint8_t*>(w.data()) + h.mesh_offset, sizeof m);
        m.offset = h.top_offset;  // the top level where a mesh should be
        m.bytes = h.top_bytes;
        std::memcpy(reinterpret_cast<uint8_t*>(w.data()) + h.mesh_offset, &m, sizeof m);
      },
      "mesh 0: a top level");
  // The engines refuse a corrupted block before anything changes.
  std::vector<uint64_t> w = words;
  header(w)->version = 7;
  CHECK_THROWS_AS(fixed->bind(reinterpret_cast<const uint8_t*>(w.data()), w.size() * 8), std::invalid_argument);
}

TEST_CASE("renders of an instanced scene bind its two levels on the fixed and timed devices",
          "[render][instancing]") {
  const host::Scene s = host::load_scene("builtin:city");
  auto render = [&](hw::DeviceKind kind, bool flatten) {
    host::RenderOptions ro;
    ro.device.kind = kind;
    ro.device.flatten = flatten;
    ro.device.format = hw::format_preset(kind == hw::DeviceKind::kTimed ? ro.device.timing.format : "default");
    ro.width = 96;
    ro.height = 64;
    ro.max_depth = 2;
    return host::render(s, ro);
  };
  const host::RenderResult fixed = render(hw::DeviceKind::kFixed, false);
  const host::RenderResult timed = render(hw::DeviceKind::kTimed, false);
  const host::RenderResult flat = render(hw::DeviceKind::kTimed, true);
  // The timed device's image is the fixed device's; its memory holds the two levels, far smaller than flattened.
  CHECK(fixed.rgb == timed.rgb);
  CHECK(timed.scene_image_bytes * 20 < flat.scene_image_bytes);
  CHECK(timed.timing.instance_transforms > 0);
  CHECK(flat.timing.instance_transforms == 0);
}

TEST_CASE("curves beside instances: the loose geometry's strands in two levels, as the flattened scene",
          "[fixed][instancing][curve]") {
  nlohmann::ordered_json j = host::read_json_file(RTU_SOURCE_DIR "/scenes/instances.json");
  // Strands through the towers and the balls, loose (not in a prototype): instance 0's, under the identity.
  nlohmann::ordered_json strands = nlohmann::ordered_json::array();
  for (int s = 0; s < 16; ++s) {
    nlohmann::ordered_json pts = nlohmann::ordered_json::array();
    for (int k = 0; k < 8; ++k)
      pts.push_back({-12.0 + 2.0 * s + 0.3 * k, 0.2 + 0.9 * k, -8.0 + 2.2 * k + 0.1 * s});
    strands.push_back({{"points", pts}, {"radius", 0.15 + 0.01 * s}});
  }
  j["curves"] = strands;
  const host::Scene s = host::load_scene_json(j, "instances+curves", RTU_SOURCE_DIR "/scenes");
  REQUIRE(s.instanced());
  const hw::Geometry& g = s.geometry;
  REQUIRE(g.curves.size() == 16 * 7);
  CHECK(s.instances.meshes[0].curves.size() == g.curves.size());
  // Every device traces the two levels; hits name the flattened scene's curves (after its spheres).
  const std::vector<hw::Ray> rays = host::incoherent_rays(g.bounds(), 40000, 21);
  host::DeviceOptions flat_opt;
  flat_opt.kind = hw::DeviceKind::kFloat;
  const Traced one_level = run(*host::make_device(g, flat_opt), rays, false);
  uint64_t curve_hits = 0;
  for (const hw::Hit& h : one_level.hits) curve_hits += h.hit() && g.kind(h.prim) == hw::PrimKind::kCurve;
  INFO(curve_hits << " rays hit a curve");
  CHECK(curve_hits > 400);  // the test needs rays that hit the strands
  for (const hw::DeviceKind kind : {hw::DeviceKind::kFloat, hw::DeviceKind::kFixed, hw::DeviceKind::kTimed}) {
    CAPTURE(hw::device_kind_name(kind));
    const auto two = device(s, kind, nullptr);
    REQUIRE(two->kind() == kind);
    if (kind != hw::DeviceKind::kFloat) REQUIRE(two->instanced());
    const Agreement a = agree(one_level.hits, run(*two, rays, false).hits);
    // As for triangles (the first test case): the two-level devices round each mesh to its own grid and the ray
    // once in the transform, so only rays within a few grid steps of a silhouette may decide otherwise: 1e-4
    // hit/miss and 1% other primitives allowed (measured on the 40,000 rays: 0 hit/miss, 8-9 other primitives).
    INFO(a.hit_miss << " hit/miss, " << a.other_prim << " other primitives");
    CHECK(double(a.hit_miss) <= 1e-4 * double(rays.size()));
    CHECK(double(a.other_prim) <= 1e-2 * double(rays.size()));
  }
  // Curves under a transform that is not a similarity are refused by name (they would not stay round).
  hw::InstanceSet bad = s.instances;
  bad.meshes[0].spheres.clear();
  bad.instances[1].mesh = 0;
  bad.instances[1].to_world.m[0][0] *= 2.0f;
  bad.finish();
  CHECK_THROWS_WITH(bad.validate(), Catch::Contains("may only be instanced with a similarity transform"));
}

TEST_CASE(
    "round primitives in prototypes: spheres and strands under similarity transforms, as the flattened scene",
    "[fixed][instancing][curve][sphere]") {
  // Every prototype mesh gets two strands and two spheres in object space, beside its triangles; the instances
  // place them rotated (about several axes) and uniformly scaled, each placement its own round primitives.
  const host::Scene s = test::round_prototypes_scene();
  const hw::InstanceSet& set = s.instances;
  const hw::Geometry& g = s.geometry;
  REQUIRE(g.spheres.size() > 8);
  REQUIRE(g.curves.size() > 16);
  // The numbering: instance i's round primitives at its sphere_base and curve_base of the flattened scene.
  for (uint32_t i = 0; i < set.instances.size(); ++i) {
    const hw::Geometry& m = set.meshes[set.instances[i].mesh];
    const uint32_t nt = uint32_t(m.triangles.size()), ns = uint32_t(m.spheres.size());
    for (uint32_t c = 0; c < m.curves.size(); ++c)
      REQUIRE(set.global_prim(i, nt + ns + c) == set.instances[i].curve_base + c);
    if (!m.curves.empty()) CHECK(g.kind(set.instances[i].curve_base) == hw::PrimKind::kCurve);
    if (!m.spheres.empty()) CHECK(g.kind(set.instances[i].sphere_base) == hw::PrimKind::kSphere);
  }
  const std::vector<hw::Ray> rays = host::incoherent_rays(g.bounds(), 40000, 23);
  host::DeviceOptions flat_opt;
  flat_opt.kind = hw::DeviceKind::kFloat;
  const Traced one_level = run(*host::make_device(g, flat_opt), rays, false);
  uint64_t round_hits = 0;
  for (const hw::Hit& h : one_level.hits) round_hits += h.hit() && h.prim >= g.triangles.size();
  INFO(round_hits << " rays hit a sphere or a strand");
  CHECK(round_hits > 400);
  for (const hw::DeviceKind kind : {hw::DeviceKind::kFloat, hw::DeviceKind::kFixed, hw::DeviceKind::kTimed}) {
    CAPTURE(hw::device_kind_name(kind));
    const auto two = device(s, kind, nullptr);
    if (kind != hw::DeviceKind::kFloat) REQUIRE(two->instanced());
    const Agreement a = agree(one_level.hits, run(*two, rays, false).hits);
    // As for the loose strands above: the flattened scene rounds each placed center, end point and scaled radius
    // to float once, the two levels the ray once (and the fixed devices each mesh to its own grid): only rays
    // grazing a silhouette may differ. 1e-4 hit/miss, 1% other primitives.
    INFO(a.hit_miss << " hit/miss, " << a.other_prim << " other primitives");
    CHECK(double(a.hit_miss) <= 1e-4 * double(rays.size()));
    CHECK(double(a.other_prim) <= 1e-2 * double(rays.size()));
  }
  // The device memory's block carries the curve bases: read back, it traces as the tracer that wrote it.
  const hw::InstancedFixedTracer t(set, g, hw::format_preset("default"), hw::TracerOptions{});
  const std::vector<uint64_t> block = t.encode();
  const auto back =
      hw::InstancedFixedTracer::from_bytes(reinterpret_cast<const uint8_t*>(block.data()), 8 * block.size());
  for (size_t i = 0; i < 5000; ++i) {
    hw::TraversalStats st;
    const hw::Hit x = t.trace(rays[i], false, st), y = back->trace(rays[i], false, st);
    REQUIRE(x.prim == y.prim);
    REQUIRE(x.t == y.t);
  }
}
