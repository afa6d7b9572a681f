// Instances with two transforms (hwmodel/datapath/motion_instances.h): the fixed unit's top level loses no
// instance hit at any box time bits and transform width, moving instanced balls do not leak, the float reference
// traces as the flattened moving scene does, still instances as the static two-level tracer, and bad sets are
// refused.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>

#include "host/jobs/motion.h"
#include "host/scene/motion_scene.h"
#include "host/scene/ray_gen.h"
#include "hwmodel/datapath/motion_instances.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/timing/motion_timing.h"
#include "tests/host/cli_checks.h"

using namespace rtu;
using hw::MotionFormat;

namespace {

// Random rays through the set's bounds at random shutter times (some exactly 0 and 1).
host::MotionRays random_instance_rays(const hw::MotionInstanceSet& s, size_t n, uint64_t seed) {
  hw::Aabb all;
  for (uint32_t i = 0; i < s.set.instances.size(); ++i)
    for (int k = 0; k < 2; ++k) all.extend(s.key_bounds(i, k));
  host::MotionRays out;
  out.rays = host::incoherent_rays(all, n, seed);
  hw::Pcg32 rng(seed + 1);
  for (size_t i = 0; i < n; ++i) out.times.push_back(i % 97 == 0 ? float(i % 2) : rng.next_float());
  return out;
}

hw::TracerOptions bvh_options(int width) {
  hw::TracerOptions opt;
  opt.bvh.width = width;
  return opt;
}

}  // namespace

TEST_CASE("motion instances: the top level loses no instance hit, at any box time bits and transform width",
          "[motion][instancing][fixed]") {
  const host::MotionInstanceScene scene = host::builtin_motion_instances(2);
  const host::MotionRays rays = random_instance_rays(scene.set, 3000, 31);
  for (const int xform_bits : {24, 12}) {
    hw::FixedFormat f = hw::format_preset("default");
    f.xform_bits = xform_bits;
    for (const MotionFormat m :
         {MotionFormat{16, 0}, MotionFormat{16, 6}, MotionFormat{16, 16}, MotionFormat{4, 2}}) {
      const hw::MotionInstancedFixedTracer tracer(scene.set, f, m, bvh_options(f.width), true);
      std::vector<hw::Hit> hits;
      hw::TraversalStats s;
      tracer.trace_batch(rays.rays, rays.times, hits, false, 1, s);
      size_t hit = 0;
      for (size_t i = 0; i < rays.rays.size(); ++i) {
        const hw::Hit want = tracer.trace_all(rays.rays[i], rays.times[i]);
        INFO("xform_bits " << xform_bits << " " << m.describe() << " ray " << i << " time " << rays.times[i]);
        REQUIRE(hits[i].hit() == want.hit());
        if (want.hit()) REQUIRE(hits[i].t == want.t);
        hit += want.hit();
      }
      CHECK(hit > rays.rays.size() / 4);
      CHECK(s.box_checks == s.box_tests);
      CHECK(s.box_false_negatives == 0);
      std::vector<hw::Hit> any;
      hw::TraversalStats sa;
      tracer.trace_batch(rays.rays, rays.times, any, true, 1, sa);
      for (size_t i = 0; i < hits.size(); ++i) REQUIRE(any[i].hit() == hits[i].hit());
    }
  }
}

TEST_CASE("motion instances: rays from inside a moving instanced ball never leak, fixed and float, at any time",
          "[motion][instancing][watertight]") {
  const host::MotionInstanceScene scene = host::builtin_motion_instances(3);
  const hw::FixedFormat f = hw::format_preset("default");
  const hw::MotionInstancedFixedTracer fixed(scene.set, f, {}, bvh_options(f.width));
  const hw::MotionInstancedFloatTracer flt(scene.set);
  hw::Pcg32 rng(19);
  uint64_t leaks_fixed = 0, leaks_float = 0, rays = 0;
  for (const host::MotionScene::Ball& b : scene.balls) {
    for (int i = 0; i < 5000; ++i) {
      const float time = i % 50 == 0 ? float(i % 100 == 0) : rng.next_float();
      // The mesh's origin at that time is the interpolated transform's translation: the ball's center.
      const hw::Vec3 c = hw::lerp_point(b.center[0], b.center[1], time);
      const float z = 2.0f * rng.next_float() - 1.0f, phi = 6.2831853f * rng.next_float();
      const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
      const hw::Ray ray{c, 0.0f, hw::Vec3(r * std::cos(phi), r * std::sin(phi), z), INFINITY};
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

TEST_CASE("motion instances: the float reference traces as the flattened moving scene, fixed as float",
          "[motion][instancing]") {
  const host::MotionInstanceScene scene = host::builtin_motion_instances(3);
  const hw::MotionGeometry flat = scene.set.flatten();
  REQUIRE(flat.triangles.size() == scene.set.set.num_triangles());
  const hw::MotionBvh bvh = hw::MotionBvh::build(flat);
  const hw::MotionFloatTracer ref(flat, bvh);
  const hw::MotionInstancedFloatTracer two(scene.set);
  const hw::FixedFormat f = hw::format_preset("default");
  const hw::MotionInstancedFixedTracer fixed(scene.set, f, {}, bvh_options(f.width));
  host::MotionRays rays = host::motion_frame_rays(scene.camera, 96, 72, 2, 5);
  const host::MotionRays inc = random_instance_rays(scene.set, 20000, 41);
  rays.rays.insert(rays.rays.end(), inc.rays.begin(), inc.rays.end());
  rays.times.insert(rays.times.end(), inc.times.begin(), inc.times.end());
  std::vector<hw::Hit> want, got, fx;
  hw::TraversalStats s;
  ref.trace_batch(rays.rays, rays.times, want, false, 0, s);
  two.trace_batch(rays.rays, rays.times, got, false, 0, s);
  fixed.trace_batch(rays.rays, rays.times, fx, false, 0, s);
  // The flattened scene holds each vertex placed by each key transform and rounded to float, then interpolated;
  // the two levels interpolate the transform and carry the ray into object space: the same surface up to a few
  // ulps, so rays grazing an edge (or the silhouette) may differ. Allowed: 1 in 2,000 on hit/miss or triangle.
  size_t differ = 0, hits = 0, fixed_differ = 0;
  for (size_t i = 0; i < want.size(); ++i) {
    hits += want[i].hit();
    differ += want[i].hit() != got[i].hit() || (want[i].hit() && want[i].prim != got[i].prim);
    if (want[i].hit() && got[i].hit() && want[i].prim == got[i].prim)
      REQUIRE(std::abs(got[i].t - want[i].t) <= 1e-4f * std::max(1.0f, want[i].t));  // 2^-13: a few float ulps of
                                                                                     // the scene's 16 units
    fixed_differ += got[i].hit() != fx[i].hit();
  }
  INFO(want.size() << " rays, " << hits << " hits, " << differ << " differ, " << fixed_differ << " fixed differ");
  CHECK(hits > want.size() / 3);
  CHECK(differ * 2000 <= want.size());
  // The fixed unit against the float reference: its grid (2^-17 of the scene at the default format) and its
  // transform's and time's roundings move a hit by far less than a ball's triangle, so only rays within that of
  // a silhouette may disagree: 1 in 500.
  CHECK(fixed_differ * 500 <= want.size());
}

TEST_CASE("motion instances: still instances trace as the static two-level tracer", "[motion][instancing]") {
  host::MotionInstanceScene scene = host::builtin_motion_instances(2);
  for (size_t i = 0; i < scene.set.end.size(); ++i) scene.set.end[i] = scene.set.set.instances[i].to_world;
  const hw::Geometry flat = scene.set.set.flatten({});
  const hw::InstancedFloatTracer still(scene.set.set, flat);
  const hw::MotionInstancedFloatTracer moving(scene.set);
  const host::MotionRays rays = random_instance_rays(scene.set, 5000, 43);
  for (size_t i = 0; i < rays.rays.size(); ++i) {
    hw::TraversalStats s;
    const hw::Hit a = still.trace(rays.rays[i], false, s), b = moving.trace(rays.rays[i], rays.times[i], false, s);
    INFO("ray " << i);
    REQUIRE(a.hit() == b.hit());
    if (a.hit()) REQUIRE(a.t == b.t);
  }
}

TEST_CASE("motion instances: bad sets are refused with the instance named", "[motion][instancing][errors]") {
  host::MotionInstanceScene scene = host::builtin_motion_instances(1);
  auto refused = [&](hw::MotionInstanceSet s, const char* what) {
    INFO(what);
    CHECK_THROWS_WITH(s.validate(), Catch::Contains(what));
  };
  hw::MotionInstanceSet s = scene.set;
  s.end.pop_back();
  refused(s, "end transforms for");
  s = scene.set;
  s.end[2].m[0][3] = NAN;
  refused(s, "instance 2: its transform at time 1");
  // A turn by 180 degrees through the interpolation: the transform passes through a singular one mid-shutter.
  s = scene.set;
  s.end[3].m[0][0] = -s.set.instances[3].to_world.m[0][0];
  s.end[3].m[2][2] = -s.set.instances[3].to_world.m[2][2];
  refused(s, "instance 3: its transform is singular at some time of the shutter");
  // A sphere in a moving instance.
  s = scene.set;
  s.set.meshes[0].spheres.push_back(hw::Sphere{hw::Vec3(0.0f), 0.5f});
  s.set.finish();
  CHECK_THROWS(s.validate());
  // The refusal reaches the tracers' constructors.
  s = scene.set;
  s.end[0].m[1][1] = INFINITY;
  CHECK_THROWS_AS(hw::MotionInstancedFloatTracer(s), std::invalid_argument);
  // An instance that shrinks to a tiny scale (its inverse beyond the float range at the end of the shutter) is
  // traced without an error: near time 1 the transform unit's output is refused, a miss.
  s = scene.set;
  for (int a = 0; a < 3; ++a) s.end[0].m[a][a] = 1e-39f;
  REQUIRE_NOTHROW(s.validate());
  const hw::FixedFormat f = hw::format_preset("default");
  const hw::MotionInstancedFixedTracer tiny(s, f, {}, bvh_options(f.width));
  const host::MotionRays rays = random_instance_rays(s, 2000, 47);
  std::vector<float> late(rays.rays.size(), 1.0f);
  std::vector<hw::Hit> hits;
  hw::TraversalStats ts;
  REQUIRE_NOTHROW(tiny.trace_batch(rays.rays, late, hits, false, 2, ts));
  for (const hw::Hit& h : hits)
    CHECK_FALSE((h.hit() && s.set.global_prim(0, 0) <= h.prim && h.prim < s.set.instances[1].tri_base));
  // NaN rays and times outside [0, 1] are counted misses.
  const hw::MotionInstancedFloatTracer flt(scene.set);
  hw::TraversalStats st;
  CHECK_FALSE(flt.trace(hw::Ray{hw::Vec3(0.0f), 0.0f, hw::Vec3(NAN), INFINITY}, 0.5f, false, st).hit());
  CHECK_FALSE(
      flt.trace(hw::Ray{hw::Vec3(0.0f, 4.0f, 14.0f), 0.0f, hw::Vec3(0, -0.2f, -1), INFINITY}, 1.5f, false, st)
          .hit());
  CHECK(st.rays == 0);
}

TEST_CASE("motion instances: timing never changes a hit, and each unit is priced as it is built",
          "[motion][instancing][timing]") {
  const host::MotionInstanceScene scene = host::builtin_motion_instances(2);
  const host::MotionRays rays = host::motion_frame_rays(scene.camera, 48, 36, 2, 7);
  const hw::FixedFormat f = hw::format_preset("default");
  const hw::TracerOptions opt = bvh_options(f.width);
  const hw::MotionInstancedFixedTracer aware(scene.set, f, {}, opt), oblivious(scene.set, f, {16, 0}, opt);
  const hw::TimingConfig c = hw::timing_preset("rdna2");
  std::vector<hw::Hit> want;
  hw::TraversalStats s;
  aware.trace_batch(rays.rays, rays.times, want, false, 1, s);
  const hw::MotionTiming ta =
      hw::time_motion_instance_rays(aware, hw::MotionUnit::kTimeAware, c, rays.rays, rays.times);
  const hw::MotionTiming to =
      hw::time_motion_instance_rays(oblivious, hw::MotionUnit::kTimeOblivious, c, rays.rays, rays.times);
  for (size_t i = 0; i < want.size(); ++i) {
    REQUIRE(ta.hits[i].t == want[i].t);
    REQUIRE(to.hits[i].t == want[i].t);
  }
  // The time-aware unit transforms every instance with its interpolation's clocks and reads both key transforms;
  // the time-oblivious one sends each moving instance it reaches to the shader and back.
  CHECK(ta.timing.instance_transforms > 0);
  CHECK(ta.timing.any_hit_requests == 0);
  CHECK(to.timing.any_hit_requests > 0);
  CHECK(to.timing.any_hit_requests <= to.timing.instance_transforms);
  CHECK(hw::motion_instance_layout(aware, hw::MotionUnit::kTimeAware).instance_bytes >
        hw::motion_instance_layout(oblivious, hw::MotionUnit::kTimeOblivious).instance_bytes);
  CHECK(hw::motion_timing_config(c, hw::MotionUnit::kTimeAware).xform_latency > c.xform_latency);
  // Refusals: the time-oblivious unit's boxes span the shutter; the static unit's instances do not move.
  CHECK_THROWS_WITH(hw::time_motion_instance_rays(aware, hw::MotionUnit::kTimeOblivious, c, rays.rays, rays.times),
                    Catch::Contains("box_time_bits 0"));
  CHECK_THROWS_WITH(hw::time_motion_instance_rays(aware, hw::MotionUnit::kStatic, c, rays.rays, rays.times),
                    Catch::Contains("must not move"));
}

TEST_CASE("rtusim motion --instances and a scene of instances set in motion", "[motion][instancing][cli]") {
  const test::TempDir d("motion_instances");
  const std::string prefix = (d.path / "mi").string(), json = (d.path / "mi.json").string();
  const test::Run r = test::run_rtusim("motion --instances --width 40 --height 30 --samples 2 --level 2 --image " +
                                       prefix + " --json " + json);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(test::contains(r.output, "10, 8 of them with two transforms"));
  const nlohmann::json j = test::read_json(json);
  CHECK(j["instances"] == 10);
  CHECK(j["moving_instances"] == 8);
  CHECK(j["fixed_vs_float"]["hit_miss_agree"] == j["rays"]);
  CHECK(j["designs"][2]["shader_calls"].get<uint64_t>() > 0);
  CHECK(j["designs"][1]["ratio_to_static"].get<double>() < j["designs"][2]["ratio_to_static"].get<double>());
  CHECK(host::read_png(prefix + "_fixed.png").width == 40);
  // A mesh file whose node tree places meshes: every instance moved by --move.
  const std::string j2 = (d.path / "engine.json").string();
  REQUIRE(test::run_rtusim("motion --scene /usr/share/assimp/models"
                           "/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb --move 20 0 0 --width 32 "
                           "--height 24 --samples 1 --json " +
                           j2)
              .status == 0);
  const nlohmann::json e = test::read_json(j2);
  CHECK(e["instances"].get<uint64_t>() > 1);
  CHECK(e["moving_instances"] == e["instances"]);
  CHECK(e["moving_primitives"] == e["triangles"]);
  // Generated rays of the moving instances at uniform shutter times: the fixed unit's hits, one a ray.
  const std::string hits = (d.path / "g.hits").string(), j3 = (d.path / "g.json").string();
  REQUIRE(test::run_rtusim("motion --instances --level 2 --rays incoherent:500 --times uniform --out " + hits +
                           " --json " + j3)
              .status == 0);
  CHECK(std::filesystem::file_size(hits) == 500 * sizeof(hw::Hit));
  CHECK(test::read_json(j3)["rays"] == 500);
  test::check_refused(
      {{"motion --instances --scene builtin:cornell", "--instances chooses the built-in"},
       {"motion --rays incoherent:10 --times 2", "not in [0, 1]"},
       {"motion --rays nosuchfile.rays --times 0.5", "nosuchfile.rays"},
       {"motion --scene " RTU_SOURCE_DIR "/scenes/instances.json --move 1 0 0", "hold no planes"}});
}
