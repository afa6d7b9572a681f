// Curve segments (linear swept spheres) through the whole house: scene files, the image check, the devices.
// - A torus of strands (rings round the tube, overlapping): rays aimed through its shell at the core circle, at
//   ring joints and between rings, from near and far, leak through on no device (0 leaks, in every format).
// - The timed device's hits are the fixed device's, bit for bit, with and without curve units; curve tests are
//   counted, and a curve unit changes cycles, never a hit.
// - The fixed device agrees with the float reference on builtin:hair (every hit/miss; t within grid steps).
// - Scene files: the curves entry and its errors, named; hybrid renders of curve scenes are refused.
// - The image check refuses a curve record out of the grid, a curve in an image without curve_bits, unknown
//   round-primitive bits, and formats too wide for the curve test (curve_limits).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

#include "host/devices/direct_device.h"
#include "host/io/error.h"
#include "host/io/json_io.h"
#include "host/jobs/render.h"
#include "host/scene/curves.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/timing/timing_config.h"

using namespace rtu;

namespace {

constexpr double kPi = std::numbers::pi;

// A torus (core radius R, tube radius a, round the y axis) covered by `rings` closed strands round the tube, each
// of `sides` segments of radius rho. Neighbouring rings overlap where they are closest (the inner equator):
// 2 pi (R - a) / rings < 2 rho.
hw::Geometry strand_torus(double R, double a, int rings, int sides, double rho) {
  hw::Geometry g;
  for (int i = 0; i < rings; ++i) {
    const double phi = 2 * kPi * i / rings;
    std::vector<hw::Vec3> p;
    for (int j = 0; j <= sides; ++j) {
      const double th = 2 * kPi * (j % sides) / sides;
      const double r = R + a * std::cos(th);
      p.push_back(hw::Vec3(float(r * std::cos(phi)), float(a * std::sin(th)), float(r * std::sin(phi))));
    }
    host::add_strand(g, p, std::vector<float>(p.size(), float(rho)), "ring");
  }
  return g;
}

std::vector<hw::Hit> curve_trace(const hw::Geometry& g, const host::DeviceOptions& o,
                                 const std::vector<hw::Ray>& rays, bool any = false,
                                 hw::TimingStats* ts = nullptr) {
  std::vector<hw::Hit> hits(rays.size());
  hw::TraversalStats s;
  const auto dev = host::make_device(g, o);
  dev->trace_batch(rays.data(), hits.data(), rays.size(), any, 2, s);
  if (ts) *ts = dev->timed()->timing();
  return hits;
}

}  // namespace

TEST_CASE("a torus of strands leaks no ray, on every device and format", "[curve][fixed][float][scale]") {
  constexpr double R = 1.0, a = 0.3, rho = 0.02;
  constexpr int kRings = 300, kSides = 24;
  // Rings are furthest apart on the outer equator: there they still overlap by a quarter of their width. A ring's
  // chords sag a (1 - cos(pi / sides)) = 0.0026 inside it, well within rho.
  static_assert(2 * kPi * (R + a) / kRings < 1.5 * rho);
  const hw::Geometry g = strand_torus(R, a, kRings, kSides, rho);
  // Rays from outside the torus (distance 3 or 30 from the origin: inside every format's guard range) aimed at its
  // core circle: at ring joints, at the middle of a segment, between two rings and anywhere; every one crosses the
  // shell of strands.
  hw::Pcg32 rng(77);
  std::vector<hw::Ray> rays;
  for (int k = 0; k < 60000; ++k) {
    const int kind = k % 4;
    double phi = 2 * kPi * rng.next_float();
    if (kind == 0) phi = 2 * kPi * double(rng.next_u32() % kRings) / kRings;  // a ring's plane (its joints)
    if (kind == 1) phi = 2 * kPi * (double(rng.next_u32() % kRings) + 0.5) / kRings;  // between two rings
    const hw::Vec3 target(float(R * std::cos(phi)), 0.0f, float(R * std::sin(phi)));
    hw::Vec3 from;
    do {
      from = hw::Vec3(2 * rng.next_float() - 1, 2 * rng.next_float() - 1, 2 * rng.next_float() - 1);
    } while (glm::length(from) < 0.2f);
    from = glm::normalize(from) * (k % 8 == 7 ? 30.0f : 3.0f);
    // Not through the hole from its axis' side: the ray must meet the shell before the core (the origin is
    // outside the torus, so it does).
    rays.push_back(hw::Ray{from, 0.0f, target - from, 1.0f});
  }
  for (const hw::DeviceKind kind : {hw::DeviceKind::kFloat, hw::DeviceKind::kFixed, hw::DeviceKind::kTimed}) {
    for (const char* fmt : {"default", "compact", "precise", "rdna4"}) {
      if (kind == hw::DeviceKind::kFloat && std::string(fmt) != "default") continue;
      CAPTURE(hw::device_kind_name(kind), fmt);
      host::DeviceOptions o;
      o.kind = kind;
      o.format = hw::format_preset(fmt);
      o.timing = hw::timing_preset("rdna2");
      const std::vector<hw::Hit> hits = curve_trace(g, o, rays);
      uint64_t leaks = 0;
      for (const hw::Hit& h : hits) leaks += !h.hit();
      CHECK(leaks == 0);
      const std::vector<hw::Hit> shadow = curve_trace(g, o, rays, true);
      uint64_t shadow_leaks = 0;
      for (const hw::Hit& h : shadow) shadow_leaks += !h.hit();
      CHECK(shadow_leaks == 0);
    }
  }
}

TEST_CASE("curves: timed hits are the fixed device's, curve units change cycles only", "[curve][timing]") {
  const host::Scene scene = host::load_scene("builtin:hair?strands=3000");
  std::vector<hw::Ray> rays = host::primary_rays(scene.camera, 6000);
  const std::vector<hw::Ray> inc = host::incoherent_rays(scene.geometry.bounds(), 6000, 5);
  rays.insert(rays.end(), inc.begin(), inc.end());
  host::DeviceOptions o;
  o.kind = hw::DeviceKind::kFixed;
  o.format = hw::format_preset("default");
  const std::vector<hw::Hit> fixed = curve_trace(scene.geometry, o, rays);
  o.kind = hw::DeviceKind::kTimed;
  hw::TimingStats ts[2];
  for (int units = 0; units < 2; ++units) {
    o.timing = hw::timing_preset("rdna2");
    o.timing.curve_units = units;
    const std::vector<hw::Hit> timed = curve_trace(scene.geometry, o, rays, false, &ts[units]);
    CHECK(std::memcmp(timed.data(), fixed.data(), rays.size() * sizeof(hw::Hit)) == 0);
  }
  CHECK(ts[0].curve_tests > rays.size());
  CHECK(ts[1].curve_tests == ts[0].curve_tests);
  // Without a curve unit each curve test holds a triangle slot for curve_issue clocks.
  CHECK(ts[0].tri_issue_cycles == ts[0].tri_tests + ts[0].sphere_tests + ts[0].plane_tests +
                                      ts[0].curve_tests * uint64_t(hw::timing_preset("rdna2").curve_issue));
  CHECK(ts[1].tri_issue_cycles == ts[1].tri_tests + ts[1].sphere_tests + ts[1].plane_tests);
  CHECK(ts[1].cycles != ts[0].cycles);
}

TEST_CASE("curves: the fixed device agrees with the float reference on builtin:hair", "[curve][fixed]") {
  const host::Scene scene = host::load_scene("builtin:hair?strands=6000");
  std::vector<hw::Ray> rays = host::primary_rays(scene.camera, 20000);
  const std::vector<hw::Ray> inc = host::incoherent_rays(scene.geometry.bounds(), 20000, 9);
  rays.insert(rays.end(), inc.begin(), inc.end());
  host::DeviceOptions o;
  const std::vector<hw::Hit> ref = curve_trace(scene.geometry, o, rays);
  o.kind = hw::DeviceKind::kFixed;
  o.format = hw::format_preset("default");
  const std::vector<hw::Hit> fx = curve_trace(scene.geometry, o, rays);
  // The fixed shape is the float one's with end points rounded to the grid (half a step) and radii rounded up
  // (2^-F steps), moved by at most eps of the test (tests/hwmodel/test_fixed_curve.cpp): a few grid steps. A ray
  // may disagree only where it passes within that of a silhouette, which random rays seldom do.
  uint64_t hit_miss = 0, curve_hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    hit_miss += ref[i].hit() != fx[i].hit();
    curve_hits += fx[i].hit() && scene.geometry.kind(fx[i].prim) == hw::PrimKind::kCurve;
  }
  CHECK(curve_hits > rays.size() / 10);
  CHECK(double(hit_miss) <= 1e-4 * double(rays.size()));
}

TEST_CASE("curves: scene files, and what is refused", "[curve][scene]") {
  const std::string ok = R"({"curves": [{"points": [[0,0,0],[1,0,0],[2,1,0]], "radii": [0.1, 0.2, 0.05]},
                                       {"points": [[0,2,0],[0,3,0]], "radius": 0.3, "segments": [0]}]})";
  const host::Scene s = host::load_scene_json(host::parse_json_limited(ok, "x.json"), "x.json", ".");
  REQUIRE(s.geometry.curves.size() == 3);
  CHECK(s.geometry.curves[0].flags == hw::kCurveCapStart);
  CHECK(s.geometry.curves[1].flags == 0);  // continues segment 0
  CHECK(s.geometry.curves[1].r1 == 0.05f);
  CHECK(s.geometry.kind(2) == hw::PrimKind::kCurve);
  auto bad = [](const std::string& json) {
    return host::load_scene_json(host::parse_json_limited(json, "x.json"), "x.json", ".");
  };
  CHECK_THROWS_WITH(bad(R"({"curves": [{"points": [[0,0,0]], "radius": 1}]})"),
                    Catch::Contains("curves[0].points") && Catch::Contains("at least 2 points"));
  CHECK_THROWS_WITH(bad(R"({"curves": [{"points": [[0,0,0],[1,0,0]]}]})"),
                    Catch::Contains("give either 'radius' or 'radii'"));
  CHECK_THROWS_WITH(bad(R"({"curves": [{"points": [[0,0,0],[1,0,0]], "radii": [1]}]})"),
                    Catch::Contains("one radius per point"));
  CHECK_THROWS_WITH(bad(R"({"curves": [{"points": [[0,0,0],[1,0,0]], "radii": [1, -1]}]})"),
                    Catch::Contains("curves[0].radii[1]") && Catch::Contains(">= 0"));
  CHECK_THROWS_WITH(bad(R"({"curves": [{"points": [[0,0,0],[1,0,0]], "radius": 1, "segments": [1]}]})"),
                    Catch::Contains("curves[0].segments[0]"));
  CHECK_THROWS_WITH(bad(R"({"curves": [{"points": [[0,0,0],[1,0,0]], "radius": 1, "width": 2}]})"),
                    Catch::Contains("unknown key"));
}

TEST_CASE("curves: the image check refuses malformed curve records", "[curve][image]") {
  const hw::Geometry g = strand_torus(1.0, 0.3, 8, 6, 0.05);
  const hw::FixedFormat f = hw::format_preset("default");
  const hw::DeviceImage img = hw::encode_scene(g, f, nullptr);
  std::vector<uint8_t> b(img.data(), img.data() + img.size());
  REQUIRE_NOTHROW(hw::DeviceImage::from_bytes(b.data(), b.size()));
  REQUIRE(hw::is_curve_record(img.record(0)));
  CHECK(img.format().curve_bits == f.curve_bits);
  const size_t at = img.header().record_offset;
  auto refused = [&](std::vector<uint8_t> bad, const std::string& why) {
    CHECK_THROWS_WITH(hw::DeviceImage::from_bytes(bad.data(), bad.size()), Catch::Contains(why));
  };
  std::vector<uint8_t> bad = b;
  const int32_t outside = -1;
  std::memcpy(bad.data() + at, &outside, 4);
  refused(bad, "record 0: curve end point outside the grid");
  bad = b;
  bad[at + 33] = 0x80;  // a round-primitive bit beyond kRoundCapStart
  refused(bad, "record 0: unknown round-primitive bits");
  bad = b;
  uint32_t flags;
  std::memcpy(&flags, bad.data() + offsetof(hw::ImageHeader, flags), 4);
  flags &= ~hw::kImageCurveBitsMask;
  std::memcpy(bad.data() + offsetof(hw::ImageHeader, flags), &flags, 4);
  refused(bad, "a curve segment in an image without curve_bits");
  // A format whose curve test would overflow: refused at encode with the rule, triangles still fine.
  const hw::FixedFormat wide = hw::format_from_spec("default:curve_bits=31");
  CHECK_FALSE(wide.curve_limits().empty());
  CHECK_THROWS_WITH(hw::encode_scene(g, wide, nullptr), Catch::Contains("cannot hold curve segments"));
}

TEST_CASE("curves: a mesh file's lines become strands", "[curve][scene][mesh]") {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "rtu_test_curves_lines";
  std::filesystem::create_directories(dir);
  const std::string obj = (dir / "strands.obj").string();
  {
    std::ofstream f(obj);
    f << "v 0 0 0\nv 0 1 0\nv 0.2 2 0\nv 0.5 2.5 0.3\nv 1 0 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 -1 1\n"
         "l 1 2 3 4\nl 5 6\nf 7 8 9\n";
  }
  // A bare mesh file: a polyline of 3 segments (one strand: only its first holds its start sphere) and a line.
  const host::Scene bare = host::load_scene(obj);
  REQUIRE(bare.geometry.curves.size() == 4);
  REQUIRE(bare.geometry.triangles.size() == 1);
  const std::vector<uint32_t> flags = {bare.geometry.curves[0].flags, bare.geometry.curves[1].flags,
                                       bare.geometry.curves[2].flags, bare.geometry.curves[3].flags};
  CHECK(flags == std::vector<uint32_t>{hw::kCurveCapStart, 0, 0, hw::kCurveCapStart});
  CHECK(bare.geometry.curves[1].p0 == hw::Vec3(0, 1, 0));
  // A thousandth of the diagonal of the file's triangle and lines.
  CHECK(bare.geometry.curves[0].r0 ==
        host::default_line_radius(hw::Aabb{hw::Vec3(0, -1, 0), hw::Vec3(1, 2.5f, 1)}));
  CHECK(bare.prim_material.size() == bare.geometry.num_prims());
  // In a scene file: the entry's radius and transform.
  const std::string json = R"({"meshes": [{"file": ")" + obj + R"(", "curve_radius": 0.05,
                              "transform": {"translate": [10, 0, 0]}}]})";
  const host::Scene s = host::load_scene_json(host::parse_json_limited(json, "x.json"), "x.json", ".");
  REQUIRE(s.geometry.curves.size() == 4);
  CHECK(s.geometry.curves[0].r0 == 0.05f);
  CHECK(s.geometry.curves[0].p0 == hw::Vec3(10, 0, 0));
  CHECK(s.geometry.kind(1) == hw::PrimKind::kCurve);  // after the file's one triangle
  const std::string tri = (dir / "tri.obj").string();
  {
    std::ofstream f(tri);
    f << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  }
  const std::string no_lines = R"({"meshes": [{"file": ")" + tri + R"(", "curve_radius": 0.05}]})";
  CHECK_THROWS_WITH(host::load_scene_json(host::parse_json_limited(no_lines, "x.json"), "x.json", "."),
                    Catch::Contains("curve_radius") && Catch::Contains("has no lines"));
  std::filesystem::remove_all(dir);
}
