// Motion blur on the unit (hwmodel/datapath/motion_tracer.h): the fixed datapath's interpolated boxes contain
// what its triangle unit tests at every time they stand for, traversal loses no hit the triangle unit finds,
// moving watertight balls do not leak, a scene that does not move traces as the static tracer does; the timed
// units (hwmodel/timing/motion_timing.h) and rtusim motion.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "host/io/image.h"
#include "host/io/ray_io.h"
#include "host/scene/motion_scene.h"
#include "host/scene/ray_gen.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/motion_tracer.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/timing/motion_timing.h"
#include "tests/host/cli_checks.h"

using namespace rtu;
using hw::MotionFormat;

namespace {

// Random rays through the scene's bounds at random shutter times (PCG32 from seed).
host::MotionRays random_motion_rays(const hw::MotionGeometry& g, size_t n, uint64_t seed) {
  const hw::MotionBvh b = hw::MotionBvh::build(g);
  hw::Aabb all = b.key_bounds[0];
  all.extend(b.key_bounds[1]);
  host::MotionRays out;
  out.rays = host::incoherent_rays(all, n, seed);
  hw::Pcg32 rng(seed + 1);
  for (size_t i = 0; i < n; ++i) out.times.push_back(i % 97 == 0 ? float(i % 2) : rng.next_float());
  return out;
}

}  // namespace

TEST_CASE("motion: a box at the box unit's time holds the triangle unit's vertices at every time it stands for",
          "[motion]") {
  // Random grid boxes of random triangles at both key frames, every time register value of small formats.
  hw::Pcg32 rng(5);
  for (int trial = 0; trial < 200; ++trial) {
    int32_t key[18];
    for (int32_t& k : key) k = int32_t(rng.next_u32() % 4096);
    int32_t box[12];
    for (int k = 0; k < 2; ++k)
      for (int a = 0; a < 3; ++a) {
        box[6 * k + a] = std::min({key[9 * k + a], key[9 * k + 3 + a], key[9 * k + 6 + a]});
        box[6 * k + 3 + a] = std::max({key[9 * k + a], key[9 * k + 3 + a], key[9 * k + 6 + a]});
      }
    for (const MotionFormat m : {MotionFormat{8, 0}, MotionFormat{8, 3}, MotionFormat{8, 8}, MotionFormat{5, 2}}) {
      for (uint32_t tq = 0; tq <= (1u << m.time_bits); ++tq) {
        const hw::BoxTime bt = hw::box_time(tq, m);
        // The interval holds tq: s0 <= tq / 2^time_bits <= s1 in units of 2^-box_time_bits.
        REQUIRE(bt.s0 << (m.time_bits - m.box_time_bits) <= int64_t(tq));
        REQUIRE(int64_t(tq) <= bt.s1 << (m.time_bits - m.box_time_bits));
        int64_t lo[3], hi[3];
        hw::motion_box(box, bt, lo, hi);
        int32_t v[3][3];
        hw::motion_vertices(key, tq, m.time_bits, v);
        for (int i = 0; i < 3; ++i)
          for (int a = 0; a < 3; ++a) {
            INFO("trial " << trial << " tq " << tq << " " << m.describe());
            REQUIRE(lo[a] <= v[i][a]);
            REQUIRE(v[i][a] <= hi[a]);
          }
      }
    }
  }
  // Without box time bits the box is the whole shutter's: the key frames' union.
  const int32_t key[12] = {0, 10, 20, 5, 15, 25, 4, 2, 30, 9, 12, 40};
  int64_t lo[3], hi[3];
  hw::motion_box(key, hw::box_time(77, MotionFormat{8, 0}), lo, hi);
  CHECK((lo[0] == 0 && lo[1] == 2 && lo[2] == 20 && hi[0] == 9 && hi[1] == 15 && hi[2] == 40));
  // With all of them, at time 1 exactly the key frame 1 box.
  hw::motion_box(key, hw::box_time(256, MotionFormat{8, 8}), lo, hi);
  CHECK((lo[0] == 4 && lo[1] == 2 && lo[2] == 30 && hi[0] == 9 && hi[1] == 12 && hi[2] == 40));
}

TEST_CASE("motion: the fixed unit's traversal loses no hit its triangle unit finds, at any box time bits",
          "[motion][fixed]") {
  const host::MotionScene scene = host::builtin_motion_scene(2);
  const hw::MotionBvh bvh = hw::MotionBvh::build(scene.geometry);
  const host::MotionRays rays = random_motion_rays(scene.geometry, 3000, 17);
  for (const MotionFormat m :
       {MotionFormat{16, 0}, MotionFormat{16, 3}, MotionFormat{16, 6}, MotionFormat{16, 16}, MotionFormat{4, 2}}) {
    const hw::MotionImage img = hw::MotionImage::encode(scene.geometry, bvh, hw::format_preset("default"), m);
    const hw::MotionFixedTracer tracer(img, true);
    std::vector<hw::Hit> hits;
    hw::TraversalStats s;
    tracer.trace_batch(rays.rays, rays.times, hits, false, 1, s);
    size_t hit = 0;
    for (size_t i = 0; i < rays.rays.size(); ++i) {
      const hw::Hit want = tracer.trace_all(rays.rays[i], rays.times[i]);
      INFO(m.describe() << " ray " << i << " time " << rays.times[i]);
      REQUIRE(hits[i].hit() == want.hit());
      if (want.hit()) REQUIRE(hits[i].t == want.t);  // a tie may report another triangle at the same t
      hit += want.hit();
    }
    CHECK(hit > rays.rays.size() / 4);
    CHECK(s.box_checks == s.box_tests);
    CHECK(s.box_false_negatives == 0);
    // Any hit finds a hit exactly when closest hit does.
    std::vector<hw::Hit> any;
    hw::TraversalStats sa;
    tracer.trace_batch(rays.rays, rays.times, any, true, 1, sa);
    for (size_t i = 0; i < hits.size(); ++i) REQUIRE(any[i].hit() == hits[i].hit());
  }
}

TEST_CASE("motion: finer box time bits test fewer boxes, and the same hits on 1 and 3 threads", "[motion]") {
  const host::MotionScene scene = host::builtin_motion_scene(3);
  const hw::MotionBvh bvh = hw::MotionBvh::build(scene.geometry);
  const host::MotionRays rays = host::motion_frame_rays(scene.camera, 64, 48, 2, 3);
  uint64_t previous = UINT64_MAX;
  std::vector<hw::Hit> first;
  for (int bits : {0, 2, 4, 8}) {
    const hw::MotionImage img =
        hw::MotionImage::encode(scene.geometry, bvh, hw::format_preset("default"), MotionFormat{16, bits});
    const hw::MotionFixedTracer tracer(img);
    std::vector<hw::Hit> h1, h3;
    hw::TraversalStats s1, s3;
    tracer.trace_batch(rays.rays, rays.times, h1, false, 1, s1);
    tracer.trace_batch(rays.rays, rays.times, h3, false, 3, s3);
    for (size_t i = 0; i < h1.size(); ++i) {
      REQUIRE(h1[i].t == h3[i].t);
      REQUIRE(h1[i].prim == h3[i].prim);
    }
    CHECK(s1.box_tests == s3.box_tests);
    // The boxes only shrink with more bits (each interval inside the coarser one). The work need not fall at
    // every step (a tighter box may enter later and change the order of the closest-hit search), but the whole
    // shutter's boxes (0 bits) must cost clearly more than 8 bits' on a scene where a third of the balls move
    // fast.
    INFO("box_time_bits " << bits << ": " << s1.nodes_visited << " nodes, " << s1.prim_tests << " triangles");
    if (bits == 0) previous = s1.nodes_visited + s1.prim_tests;
    if (bits == 8) CHECK(double(s1.nodes_visited + s1.prim_tests) < 0.95 * double(previous));
    if (first.empty()) first = h1;
    for (size_t i = 0; i < h1.size(); ++i) REQUIRE(h1[i].t == first[i].t);  // the hits never depend on them
  }
}

TEST_CASE("motion: rays from inside a moving closed ball never leak, fixed and float, at any time",
          "[motion][watertight]") {
  const host::MotionScene scene = host::builtin_motion_scene(3);
  const hw::MotionBvh bvh = hw::MotionBvh::build(scene.geometry);
  const hw::MotionImage img = hw::MotionImage::encode(scene.geometry, bvh, hw::format_preset("default"), {});
  const hw::MotionFixedTracer fixed(img);
  const hw::MotionFloatTracer flt(scene.geometry, bvh);
  hw::Pcg32 rng(9);
  uint64_t leaks_fixed = 0, leaks_float = 0, rays = 0;
  for (const host::MotionScene::Ball& b : scene.balls) {
    for (int i = 0; i < 20000; ++i) {
      const float time = i % 50 == 0 ? float(i % 100 == 0) : rng.next_float();
      // The ball's center at that time; directions uniform on the sphere, some along axes and diagonals (rays
      // through vertices and edges of the octahedron's subdivision).
      const hw::Vec3 c = hw::lerp_point(b.center[0], b.center[1], time);
      hw::Vec3 d;
      if (i % 8 == 0) {
        d = hw::Vec3(float(int(rng.next_u32() % 3) - 1), float(int(rng.next_u32() % 3) - 1), 1.0f);
      } else {
        const float z = 2.0f * rng.next_float() - 1.0f, phi = 6.2831853f * rng.next_float();
        const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
        d = hw::Vec3(r * std::cos(phi), r * std::sin(phi), z);
      }
      const hw::Ray ray{c, 0.0f, d, INFINITY};
      hw::TraversalStats s;
      const hw::Hit hx = fixed.trace(ray, time, false, s), hf = flt.trace(ray, time, false, s);
      ++rays;
      const auto inside = [&](const hw::Hit& h) {
        return h.hit() && h.prim >= b.first && h.prim < b.first + b.count;
      };
      leaks_fixed += !inside(hx);
      leaks_float += !inside(hf);
    }
  }
  INFO(rays << " rays");
  CHECK(leaks_fixed == 0);
  CHECK(leaks_float == 0);
}

TEST_CASE("motion: a scene that does not move traces as the static float tracer does", "[motion]") {
  host::MotionScene scene = host::builtin_motion_scene(2);
  for (hw::MotionTriangle& t : scene.geometry.triangles) t.key[1] = t.key[0];
  const hw::MotionBvh bvh = hw::MotionBvh::build(scene.geometry);
  const hw::MotionFloatTracer moving(scene.geometry, bvh);
  const hw::Geometry still = scene.geometry.at(0.0f);
  hw::TracerOptions opt;
  opt.accel = hw::AccelMode::kBvh;
  const hw::FloatTracer ref(still, opt);
  const host::MotionRays rays = random_motion_rays(scene.geometry, 4000, 23);
  std::vector<hw::Hit> got, want(rays.rays.size());
  hw::TraversalStats s1, s2;
  moving.trace_batch(rays.rays, rays.times, got, false, 1, s1);
  ref.trace_batch(rays.rays.data(), want.data(), want.size(), false, 1, s2);
  size_t hits = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    INFO("ray " << i);
    REQUIRE(got[i].hit() == want[i].hit());
    REQUIRE(got[i].t == want[i].t);  // the same float test on the same vertices; ties may name another triangle
    hits += got[i].hit();
  }
  CHECK(hits > got.size() / 4);
}

TEST_CASE("motion: shutter times outside [0, 1] are refused, and NaN rays and times are counted misses",
          "[motion][errors]") {
  const host::MotionScene scene = host::builtin_motion_scene(1);
  const hw::MotionBvh bvh = hw::MotionBvh::build(scene.geometry);
  const hw::MotionFloatTracer flt(scene.geometry, bvh);
  const hw::MotionImage img = hw::MotionImage::encode(scene.geometry, bvh, hw::format_preset("default"), {});
  const hw::MotionFixedTracer fixed(img);
  const std::vector<hw::Ray> rays(3, hw::Ray{{0, 1, 10}, 0.0f, {0, 0, -1}, INFINITY});
  std::vector<hw::Hit> hits;
  hw::TraversalStats s;
  for (const std::vector<float>& bad : {std::vector<float>{0.0f, 1.5f, 0.0f}, std::vector<float>{0.0f, NAN, 0.0f},
                                        std::vector<float>{-0.0001f, 0.0f, 0.0f}, std::vector<float>{0.5f}}) {
    CHECK_THROWS_WITH(flt.trace_batch(rays, bad, hits, false, 1, s),
                      Catch::Contains(bad.size() == 1 ? "1 shutter times for 3 rays" : "is not in [0, 1]"));
    CHECK_THROWS_AS(fixed.trace_batch(rays, bad, hits, false, 1, s), std::invalid_argument);
  }
  hw::TraversalStats c;
  CHECK(!fixed.trace(rays[0], NAN, false, c).hit());
  CHECK(!flt.trace(hw::Ray{{NAN, 0, 0}, 0.0f, {0, 0, 1}, 1.0f}, 0.5f, false, c).hit());
  CHECK(c.invalid_rays == 2);
  CHECK(fixed.trace(rays[0], 0.5f, false, c).hit());
  CHECK_THROWS_WITH(
      hw::MotionImage::encode(scene.geometry, bvh, hw::format_preset("default"), MotionFormat{16, 17}),
      Catch::Contains("box_time_bits"));
  CHECK_THROWS_WITH(
      hw::MotionImage::encode(scene.geometry, bvh, hw::format_preset("default"), MotionFormat{25, 1}),
      Catch::Contains("time_bits"));
  CHECK_THROWS_WITH(hw::MotionImage::encode(scene.geometry, bvh, hw::format_from_spec("default:width=8"), {}),
                    Catch::Contains("4 wide, the format 8"));
  hw::MotionGeometry nan_scene = scene.geometry;
  nan_scene.triangles[3].key[1].v2.y = NAN;
  CHECK_THROWS_WITH(hw::MotionBvh::build(nan_scene), Catch::Contains("moving triangle 3"));
  CHECK_THROWS_WITH(hw::MotionBvh::build(hw::MotionGeometry{}), Catch::Contains("at least one primitive"));
}

TEST_CASE("motion: timing never changes a hit, and each unit is priced as it is built", "[motion][timing]") {
  const host::MotionScene scene = host::builtin_motion_scene(2);
  const hw::MotionBvh bvh = hw::MotionBvh::build(scene.geometry);
  const host::MotionRays rays = host::motion_frame_rays(scene.camera, 48, 36, 2, 5);
  const hw::FixedFormat f = hw::format_preset("default");
  const hw::MotionImage aware = hw::MotionImage::encode(scene.geometry, bvh, f, MotionFormat{16, 6});
  const hw::MotionImage whole = hw::MotionImage::encode(scene.geometry, bvh, f, MotionFormat{16, 0});
  const hw::TimingConfig c = hw::timing_preset("rdna2");
  std::vector<hw::Hit> want;
  hw::TraversalStats s;
  hw::MotionFixedTracer(aware).trace_batch(rays.rays, rays.times, want, false, 1, s);
  const hw::MotionTiming a = hw::time_motion_rays(aware, hw::MotionUnit::kTimeAware, c, rays.rays, rays.times);
  const hw::MotionTiming a2 = hw::time_motion_rays(aware, hw::MotionUnit::kTimeAware, c, rays.rays, rays.times);
  const hw::MotionTiming o = hw::time_motion_rays(whole, hw::MotionUnit::kTimeOblivious, c, rays.rays, rays.times);
  for (size_t i = 0; i < want.size(); ++i) {
    REQUIRE(a.hits[i].t == want[i].t);
    REQUIRE(o.hits[i].t == want[i].t);
  }
  CHECK(a.cycles == a2.cycles);
  CHECK(a.traversal.prim_tests == s.prim_tests);
  // The time-oblivious unit calls the shader once per moving triangle it tests, never for the floor; the
  // time-aware unit never does.
  CHECK(a.timing.any_hit_requests == 0);
  CHECK(o.timing.any_hit_requests > 0);
  CHECK(o.timing.any_hit_requests < o.traversal.prim_tests);
  // Bytes: the second key frame's child boxes (6 planes of 4 children at 1 byte) and a moving record's 9 grid
  // coordinates.
  CHECK(hw::motion_node_bytes(f, hw::MotionUnit::kStatic) == 56);
  CHECK(hw::motion_node_bytes(f, hw::MotionUnit::kTimeAware) == 80);
  const hw::TimingModel::Layout la = hw::motion_layout(aware, hw::MotionUnit::kTimeAware);
  for (size_t i = 0; i < aware.prim_ids.size(); ++i)
    REQUIRE(la.record_spans[i].bytes == (aware.moving[aware.prim_ids[i]] ? 76u : 40u));
  const hw::TimingConfig ta = hw::motion_timing_config(c, hw::MotionUnit::kTimeAware);
  CHECK(ta.box_latency == c.box_latency + 1);
  CHECK((ta.tri_latency == c.tri_latency + 2 && ta.sphere_latency == c.sphere_latency + 2 &&
         ta.curve_latency == c.curve_latency + 2));
  CHECK(hw::motion_timing_config(c, hw::MotionUnit::kTimeOblivious).curve_latency == c.curve_latency);
  // Each unit needs its image.
  CHECK_THROWS_WITH(hw::time_motion_rays(aware, hw::MotionUnit::kTimeOblivious, c, rays.rays, rays.times),
                    Catch::Contains("box_time_bits 0"));
  CHECK_THROWS_WITH(hw::time_motion_rays(aware, hw::MotionUnit::kStatic, c, rays.rays, rays.times),
                    Catch::Contains("must not move"));
}

TEST_CASE("rtusim motion: images, figures and refusals", "[motion][cli]") {
  const test::TempDir d("motion");
  const std::string prefix = (d.path / "mb").string(), json = (d.path / "mb.json").string();
  const test::Run r = test::run_rtusim("motion --width 40 --height 30 --samples 2 --level 2 --image " + prefix +
                                       " --json " + json);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(test::contains(r.output, "time-oblivious"));
  const host::Image fl = host::read_png(prefix + "_float.png"), fx = host::read_png(prefix + "_fixed.png");
  CHECK((fl.width == 40 && fl.height == 30 && fx.width == 40));
  const nlohmann::json j = test::read_json(json);
  REQUIRE(j["designs"].size() == 3);
  CHECK(j["rays"] == 2400);
  CHECK(j["designs"][0]["ratio_to_static"] == 1.0);
  CHECK(j["designs"][2]["shader_calls"].get<uint64_t>() > 0);
  test::check_refused({{"motion --samples 0", "samples"},
                       {"motion --box-time-bits 20 --time-bits 16", "box_time_bits"},
                       {"motion --motion-scale 2", "motion-scale"},
                       {"motion --set nosuchkey=1", "nosuchkey"},
                       {"motion --config rdna2-chip", "timed on one unit; the configuration has 80 units"},
                       {"motion --move 1 0 0", "--scene only"},
                       {"motion --scene builtin:cornell --move 1 0 0 --motion-scale 0.5", "built-in scene only"},
                       {"motion --scene builtin:seed --move 1 0 0",
                        "triangles, spheres and curve segments only (this one has 1 planes)"},
                       {"motion --scene builtin:cornell --move 1e38 0 0", "not finite or beyond 2^62"}});
  // A loaded scene set in motion: its triangles, all moving; a move of 0 costs the time-aware unit only its larger
  // nodes and latency, and the time-oblivious unit a shader call per triangle it tests.
  const std::string j2 = (d.path / "cornell.json").string();
  REQUIRE(test::run_rtusim("motion --scene builtin:cornell --move 0.2 0 0 --width 32 --height 24 --json " + j2)
              .status == 0);
  const nlohmann::json c = test::read_json(j2);
  CHECK(c["triangles"] == c["moving_primitives"]);
  CHECK(c["designs"][2]["shader_calls"] == c["designs"][2]["triangle_tests"]);
  // Strands set in motion: every segment moves, the time-aware unit interpolates them.
  const std::string j3 = (d.path / "hair.json").string();
  REQUIRE(test::run_rtusim(
              "motion --scene builtin:hair?strands=100 --move 0.05 0 0 --width 32 --height 24 --json " + j3)
              .status == 0);
  const nlohmann::json h = test::read_json(j3);
  CHECK(h["curve_segments"].get<uint64_t>() > 0);
  CHECK(h["moving_primitives"] == h["triangles"].get<uint64_t>() + h["curve_segments"].get<uint64_t>());
}

namespace {

// 400 spheres of radii 0.05-0.5 in a 20-unit cube, a third still, the rest moving up to 3 units and some changing
// radius; a floor of two triangles below them (no sphere reaches it).
hw::MotionGeometry sphere_scene(uint64_t seed) {
  hw::Pcg32 rng(seed);
  hw::MotionGeometry g;
  const auto v3 = [&](float s) { return hw::Vec3(rng.next_float(), rng.next_float(), rng.next_float()) * s; };
  for (int i = 0; i < 400; ++i) {
    hw::MotionSphere s;
    s.center[0] = v3(20.0f) - hw::Vec3(10.0f);
    s.center[1] = i % 3 == 0 ? s.center[0] : s.center[0] + v3(6.0f) - hw::Vec3(3.0f);
    s.radius[0] = 0.05f + 0.45f * rng.next_float();
    s.radius[1] = i % 4 == 0 ? 0.05f + 0.45f * rng.next_float() : s.radius[0];
    g.spheres.push_back(s);
  }
  const hw::Vec3 f[4] = {{-15, -14, -15}, {15, -14, -15}, {15, -14, 15}, {-15, -14, 15}};
  for (const hw::Triangle& t : {hw::Triangle{f[0], f[1], f[2]}, hw::Triangle{f[0], f[2], f[3]}})
    g.triangles.push_back(hw::MotionTriangle{{t, t}});
  return g;
}

}  // namespace

TEST_CASE("motion: moving spheres lose no hit and do not leak, at any box time bits", "[motion][fixed]") {
  const hw::MotionGeometry g = sphere_scene(4);
  const hw::MotionBvh bvh = hw::MotionBvh::build(g);
  const host::MotionRays rays = random_motion_rays(g, 4000, 19);
  for (const MotionFormat m :
       {MotionFormat{16, 0}, MotionFormat{16, 4}, MotionFormat{16, 16}, MotionFormat{3, 1}}) {
    for (const char* spec : {"default", "compact"}) {
      const hw::MotionImage img = hw::MotionImage::encode(g, bvh, hw::format_from_spec(spec), m);
      const hw::MotionFixedTracer tracer(img, true);
      std::vector<hw::Hit> hits;
      hw::TraversalStats s;
      tracer.trace_batch(rays.rays, rays.times, hits, false, 1, s);
      size_t sphere_hits = 0;
      for (size_t i = 0; i < hits.size(); ++i) {
        const hw::Hit want = tracer.trace_all(rays.rays[i], rays.times[i]);
        INFO(spec << " " << m.describe() << " ray " << i);
        REQUIRE(hits[i].hit() == want.hit());
        if (want.hit()) REQUIRE(hits[i].t == want.t);
        sphere_hits += want.hit() && want.prim >= 2;
      }
      CHECK(sphere_hits > 200);
      CHECK(s.box_false_negatives == 0);
    }
  }
  // From the center of each sphere at a random time, every ray leaves through that sphere: fixed and float.
  const hw::MotionImage img = hw::MotionImage::encode(g, bvh, hw::format_preset("default"), {});
  const hw::MotionFixedTracer fixed(img);
  const hw::MotionFloatTracer flt(g, bvh);
  hw::Pcg32 rng(8);
  uint64_t leaks = 0, inside_other = 0;
  for (uint32_t k = 0; k < g.spheres.size(); ++k)
    for (int i = 0; i < 50; ++i) {
      const float time = i == 0 ? 0.0f : i == 1 ? 1.0f : rng.next_float();
      const hw::Sphere s = g.spheres[k].at(time);
      const hw::Vec3 d(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f);
      const hw::Ray ray{s.center, 0.0f, d, INFINITY};
      hw::TraversalStats st;
      for (const hw::Hit& h : {fixed.trace(ray, time, false, st), flt.trace(ray, time, false, st)}) {
        if (!h.hit() || h.prim < 2) {  // a miss, or the floor: out of the sphere
          ++leaks;
        } else if (h.prim != 2 + k) {
          // Another sphere met first: only if it overlaps this one at that time (the spheres may intersect).
          const hw::Sphere o = g.spheres[h.prim - 2].at(time);
          inside_other += glm::length(o.center - s.center) < o.radius + s.radius + 1e-3f;
          leaks += !(glm::length(o.center - s.center) < o.radius + s.radius + 1e-3f);
        }
      }
    }
  INFO(inside_other << " rays met an overlapping sphere first");
  CHECK(leaks == 0);
}

namespace {

// 300 moving curve segments (strands of 3 segments: the first with its start cap), some still, some with growing
// radii, over a floor.
hw::MotionGeometry curve_scene(uint64_t seed) {
  hw::Pcg32 rng(seed);
  hw::MotionGeometry g;
  const auto v3 = [&](float s) { return hw::Vec3(rng.next_float(), rng.next_float(), rng.next_float()) * s; };
  for (int i = 0; i < 100; ++i) {
    hw::Vec3 p = v3(20.0f) - hw::Vec3(10.0f);
    const hw::Vec3 move = i % 3 == 0 ? hw::Vec3(0.0f) : v3(6.0f) - hw::Vec3(3.0f);
    float r = 0.05f + 0.3f * rng.next_float();
    for (int k = 0; k < 3; ++k) {
      const hw::Vec3 q = p + v3(4.0f) - hw::Vec3(2.0f);
      const float rq = 0.02f + 0.3f * rng.next_float();
      hw::MotionCurve c;
      c.key[0] = hw::CurveSegment{p, r, q, rq, k == 0 ? hw::kCurveCapStart : 0u};
      c.key[1] = hw::CurveSegment{p + move, i % 4 == 0 ? 1.5f * r : r, q + move, rq, c.key[0].flags};
      g.curves.push_back(c);
      p = q;
      r = rq;
    }
  }
  const hw::Vec3 f[4] = {{-15, -14, -15}, {15, -14, -15}, {15, -14, 15}, {-15, -14, 15}};
  for (const hw::Triangle& t : {hw::Triangle{f[0], f[1], f[2]}, hw::Triangle{f[0], f[2], f[3]}})
    g.triangles.push_back(hw::MotionTriangle{{t, t}});
  return g;
}

}  // namespace

TEST_CASE("motion: moving curve segments lose no hit, at any box time bits", "[motion][fixed][curve]") {
  const hw::MotionGeometry g = curve_scene(6);
  const hw::MotionBvh bvh = hw::MotionBvh::build(g);
  const host::MotionRays rays = random_motion_rays(g, 4000, 23);
  for (const MotionFormat m :
       {MotionFormat{16, 0}, MotionFormat{16, 4}, MotionFormat{16, 16}, MotionFormat{3, 1}}) {
    const hw::MotionImage img = hw::MotionImage::encode(g, bvh, hw::format_preset("default"), m);
    const hw::MotionFixedTracer tracer(img, true);
    std::vector<hw::Hit> hits;
    hw::TraversalStats s;
    tracer.trace_batch(rays.rays, rays.times, hits, false, 1, s);
    size_t curve_hits = 0;
    for (size_t i = 0; i < hits.size(); ++i) {
      const hw::Hit want = tracer.trace_all(rays.rays[i], rays.times[i]);
      INFO(m.describe() << " ray " << i);
      REQUIRE(hits[i].hit() == want.hit());
      if (want.hit()) REQUIRE(hits[i].t == want.t);
      curve_hits += want.hit() && want.prim >= 2;
    }
    CHECK(curve_hits > 300);  // the test needs rays that hit the strands
    CHECK(s.box_false_negatives == 0);
  }
  // A still scene's curves trace as the static float tracer's (the same float test at the same segment).
  hw::MotionGeometry still = g;
  for (hw::MotionCurve& c : still.curves) c.key[1] = c.key[0];
  const hw::MotionBvh sb = hw::MotionBvh::build(still);
  const hw::Geometry frozen = still.at(0.5f);
  const hw::FloatTracer ref(frozen);
  const hw::MotionFloatTracer flt(still, sb);
  uint64_t differ = 0;
  for (size_t i = 0; i < rays.rays.size(); ++i) {
    hw::TraversalStats st;
    const hw::Hit a = flt.trace(rays.rays[i], rays.times[i], false, st), b = ref.trace(rays.rays[i], false, st);
    differ += a.hit() != b.hit() || (a.hit() && (a.prim != b.prim || a.t != b.t));
  }
  CHECK(differ == 0);
  // Key frames of different flags are refused by name.
  hw::MotionGeometry bad = g;
  bad.curves[1].key[1].flags = hw::kCurveCapStart;
  CHECK_THROWS_WITH(hw::MotionBvh::build(bad), Catch::Contains("moving curve segment 1"));
}

TEST_CASE("rtusim motion --rays: the user's rays at their shutter times, the fixed unit's hits", "[motion][cli]") {
  const test::TempDir d("motion_rays");
  const host::Scene cornell = host::load_scene("builtin:cornell");
  const std::vector<hw::Ray> rays = host::incoherent_rays(cornell.geometry.bounds(), 3000, 4);
  const std::string rays_path = (d.path / "r.rays").string(), bin = (d.path / "t.f32").string();
  const std::string csv = (d.path / "t.csv").string(), hits = (d.path / "h.hits").string();
  host::write_rays(rays_path, rays);
  hw::Pcg32 rng(9);
  std::vector<float> times;
  for (size_t i = 0; i < rays.size(); ++i) times.push_back(i % 50 == 0 ? float(i % 2) : rng.next_float());
  {
    std::ofstream b(bin, std::ios::binary);
    b.write(reinterpret_cast<const char*>(times.data()), std::streamsize(times.size() * 4));
    std::ofstream c(csv);
    c << "time\n";
    char buf[32];
    for (const float t : times) {
      std::snprintf(buf, sizeof buf, "%.9g", double(t));  // 9 digits: a float's exact round trip
      c << buf << '\n';
    }
  }
  // The moving scene and its fixed unit, traced here: what the command must write.
  const host::MotionScene ms = host::moving_scene(cornell, hw::Vec3(0.2f, 0.0f, 0.1f));
  hw::BvhBuildParams bp;
  bp.width = hw::format_preset("default").width;
  const hw::MotionBvh bvh = hw::MotionBvh::build(ms.geometry, bp);
  const hw::MotionImage img = hw::MotionImage::encode(ms.geometry, bvh, hw::format_preset("default"), {});
  std::vector<hw::Hit> want;
  hw::TraversalStats s;
  hw::MotionFixedTracer(img).trace_batch(rays, times, want, false, 1, s);
  for (const std::string& t : {bin, csv}) {
    const test::Run r = test::run_rtusim("motion --scene builtin:cornell --move 0.2 0 0.1 --rays " + rays_path +
                                         " --times " + t + " --out " + hits);
    INFO(r.output);
    REQUIRE(r.status == 0);
    const std::vector<hw::Hit> got = host::read_hits(hits);
    REQUIRE(got.size() == want.size());
    CHECK(std::memcmp(got.data(), want.data(), got.size() * sizeof(hw::Hit)) == 0);
  }
  // One time for every ray: as the file of that time.
  REQUIRE(test::run_rtusim("motion --scene builtin:cornell --move 0.2 0 0.1 --rays " + rays_path +
                           " --times 0.25 --out " + hits)
              .status == 0);
  std::vector<hw::Hit> quarter;
  hw::MotionFixedTracer(img).trace_batch(rays, std::vector<float>(rays.size(), 0.25f), quarter, false, 1, s);
  CHECK(std::memcmp(host::read_hits(hits).data(), quarter.data(), quarter.size() * sizeof(hw::Hit)) == 0);
  {
    std::ofstream c(csv);
    c << "time\n0.5\n1.5\n";
  }
  test::check_refused({{"motion --rays " + rays_path, "--rays and --times go together"},
                       {"motion --out " + hits, "--out needs --rays"},
                       {"motion --rays " + rays_path + " --times " + csv, "2 shutter times for 3000 rays"},
                       {"motion --rays " + rays_path + " --times 2", "not in [0, 1]"},
                       {"motion --rays " + rays_path + " --times uniform --image x", "no frame"}});
}
