// Hybrid rendering: the firmware rasterizer's primary visibility against the unit's ray-traced primary hits on
// the built-in scenes and a real mesh (same primitive on >= 99.9% of the samples, every disagreement on an
// edge), the images of the two modes within a PSNR bound, the rays hybrid mode saves, and the rasterizer's cost
// model (exact cycles from the configuration on a tiny case).
#include <algorithm>
#include <bit>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "host/io/image.h"
#include "host/jobs/image_diff.h"
#include "host/jobs/render.h"
#include "host/scene/scene.h"
#include "hwmodel/timing/raster_timing.h"

using namespace rtu::host;
using rtu::hw::Vec3;
using rtu::hw::cmd::RayType;

namespace {

struct Visibility {
  uint64_t samples = 0, agree = 0, disagree = 0, off_edge = 0;
  uint64_t hits = 0;  // samples the ray tracer hits
};

// Compares the primary hits of a raytrace and a hybrid render (1 spp: one sample per pixel). A disagreement is
// on an edge when some 8-neighbour's primitive differs from the pixel's in either buffer: a primitive boundary
// (or a silhouette) passes through the pixel's neighbourhood.
Visibility compare_visibility(const RenderResult& rt, const RenderResult& hy) {
  Visibility v;
  const int w = rt.width, h = rt.height;
  REQUIRE(rt.primary.size() == size_t(w) * h);
  REQUIRE(hy.primary.size() == rt.primary.size());
  auto id = [&](const RenderResult& r, int x, int y) { return r.primary[size_t(y) * w + x].prim; };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      ++v.samples;
      const uint32_t a = id(rt, x, y), b = id(hy, x, y);
      v.hits += a != rtu::hw::kMissPrim;
      if (a == b) {
        ++v.agree;
        continue;
      }
      ++v.disagree;
      bool edge = false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int nx = x + dx, ny = y + dy;
          if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
          edge = edge || id(rt, nx, ny) != a || id(hy, nx, ny) != b;
        }
      if (!edge) {
        ++v.off_edge;
        UNSCOPED_INFO("disagreement off an edge at pixel (" << x << ", " << y << "): traced " << a
                                                            << ", rasterized " << b);
      }
    }
  }
  return v;
}

RenderOptions options(const std::string& device, bool hybrid, int w, int h) {
  RenderOptions o;
  o.device.kind = rtu::hw::parse_device_kind(device);
  o.hybrid = hybrid;
  o.width = w;
  o.height = h;
  o.threads = 2;
  o.keep_primary = true;
  return o;
}

// A ray-traced and a hybrid render of `scene` at depth 0 without indirect light (only the primary hits matter).
std::pair<RenderResult, RenderResult> both_modes(const Scene& scene, const std::string& device, int w, int h) {
  RenderOptions o = options(device, false, w, h);
  o.max_depth = 0;
  o.indirect = false;
  RenderResult rt = rtu::host::render(scene, o);
  o.hybrid = true;
  return {std::move(rt), rtu::host::render(scene, o)};
}

}  // namespace

TEST_CASE("hybrid: rasterized primary visibility agrees with ray-traced primary hits", "[hybrid][scale]") {
  // The scenes' own cameras (the mesh is framed automatically) at their own resolution or a 320x240 one: seed
  // has spheres, a plane and a 3072-triangle torus; cornell large triangles sharing edges; icosphere a closed
  // 5120-triangle mesh; Wuson a real 7k-triangle mesh. Depth 0 without indirect light: only the primary hits
  // matter here.
  struct Case {
    std::string scene;
    int w, h;
  };
  const Case cases[] = {{"builtin:seed", 640, 480},
                        {"builtin:cornell", 256, 256},
                        {"builtin:icosphere", 320, 240},
                        {"builtin:icosphere_far", 320, 240},
                        {"/usr/share/assimp/models/BLEND/SuzanneSubdiv_252.blend", 320, 240},
                        {"/usr/share/assimp/models/OBJ/WusonOBJ.obj", 320, 240}};
  for (const Case& c : cases) {
    const Scene scene = rtu::host::load_scene(c.scene);
    for (const char* dev : {"float", "fixed"}) {
      CAPTURE(c.scene, dev);
      const auto [rt, hy] = both_modes(scene, dev, c.w, c.h);
      const Visibility v = compare_visibility(rt, hy);
      std::printf(
          "hybrid visibility %s on %s: %llu samples (%llu hit), %llu disagree (%.4f%%), %llu off an edge\n",
          c.scene.c_str(), dev, (unsigned long long)v.samples, (unsigned long long)v.hits,
          (unsigned long long)v.disagree, 100.0 * double(v.disagree) / double(v.samples),
          (unsigned long long)v.off_edge);
      // The scene is in view (a test of nothing otherwise), the primitives agree on >= 99.9% of the samples,
      // and every disagreement is on an edge.
      CHECK(v.hits > v.samples / 20);
      CHECK(double(v.agree) >= 0.999 * double(v.samples));
      CHECK(v.off_edge == 0);
      // Hybrid traced no primary ray and says so; the raytrace render traced one per sample.
      CHECK(hy.fw.rays[int(RayType::kPrimary)] == 0);
      CHECK(hy.fw.primary_rasterized == v.samples);
      CHECK(rt.fw.rays[int(RayType::kPrimary)] == v.samples);
      CHECK(rt.fw.primary_rasterized == 0);
      // The rasterizer's depth is the ray's t: both devices' t and the rasterizer's come from the same ray and
      // surface. Float: two float computations of one distance (the watertight test's t against the plane
      // met along the ray), each a few ulps (6e-8) times 1/cos of the incidence, which grazing hits of the
      // curved meshes raise to ~100 (1.5e-6 measured): 1e-5. Fixed: the unit's vertices are rounded to the
      // grid (up to sqrt(3)/2 steps, 2^-22 of the scene's size), a relative 1e-7 of t, also times 1/cos (3e-5
      // measured on seed): 1e-3.
      double worst = 0.0;
      for (size_t i = 0; i < rt.primary.size(); ++i)
        if (rt.primary[i].prim == hy.primary[i].prim && rt.primary[i].prim != rtu::hw::kMissPrim)
          worst = std::max(worst,
                           std::abs(double(rt.primary[i].t) - double(hy.primary[i].t)) / double(rt.primary[i].t));
      std::printf("  largest relative t difference on agreeing hits: %.3g\n", worst);
      CHECK(worst < (std::string(dev) == "float" ? 1e-5 : 1e-3));
    }
  }
}

namespace {

// A scene built so that its raster work can be counted by hand: a 16x16 image, 90-degree field of view, camera
// at the origin looking down +z; a square of two triangles at depth 2 whose corners sit on the pixel centers
// (2.5, 2.5) and (6.5, 6.5), and a plane z = 5 behind it filling the image.
Scene counted_scene() {
  Scene s;
  s.name = "counted";
  s.materials.push_back(rtu::host::Material{});
  s.camera.position = Vec3(0.0f);
  s.camera.look_at = Vec3(0.0f, 0.0f, 1.0f);
  s.camera.up = Vec3(0.0f, 1.0f, 0.0f);
  s.camera.fov_y_deg = 90.0f;
  s.camera.width = s.camera.height = 16;
  s.has_camera = true;
  // right = forward x up = -x here: pixel position (px, py) at depth z is (-(2 px / 16 - 1) z, (1 - 2 py / 16) z).
  auto at = [](double px, double py, double z) {
    return Vec3(float(-(px / 8.0 - 1.0) * z), float((1.0 - py / 8.0) * z), float(z));
  };
  s.geometry.triangles.push_back({at(2.5, 2.5, 2.0), at(6.5, 2.5, 2.0), at(6.5, 6.5, 2.0)});
  s.geometry.triangles.push_back({at(2.5, 2.5, 2.0), at(6.5, 6.5, 2.0), at(2.5, 6.5, 2.0)});
  s.geometry.planes.push_back({Vec3(0.0f, 0.0f, 1.0f), 5.0f});
  s.prim_material.assign(3, 0);
  return s;
}

}  // namespace

TEST_CASE("hybrid refuses images wider than the rasterizer's range", "[hybrid]") {
  // Edge functions fit 64 bits up to kMaxRasterSide pixels a side (firmware/raster.h): one more is refused.
  const Scene s = rtu::host::load_scene("builtin:cornell");
  RenderOptions o = options("float", true, int(rtu::fw::kMaxRasterSide) + 1, 1);
  o.max_depth = 0;
  CHECK_THROWS_WITH(rtu::host::render(s, o), Catch::Contains("at most 16384 pixels a side"));
  o.hybrid = false;
  CHECK_NOTHROW(rtu::host::render(s, o));
}

TEST_CASE("hybrid on the timed device: exact raster cycles from the configuration", "[hybrid][timing]") {
  // By hand: one pass; 3 primitives read and set up; the square covers columns and rows 2..5 (16 samples; its
  // right and bottom sides, on the centers of column and row 6, belong to no one by the top-left rule), each
  // triangle scans its bounding box of pixel centers 2..6 x 2..6 (25 samples), the plane all 256; fragments:
  // 16 of the square + 256 of the plane; depth writes: 16 (square, first in primitive order) + 240 (the plane
  // where the square is not); 256 texels cleared.
  const Scene s = counted_scene();
  const uint64_t prims = 3, setups = 3, samples = 2 * 25 + 256, fragments = 16 + 256, writes = 16 + 240,
                 clears = 256;
  struct Case {
    const char* set;  // one override, making one stage the slowest
    const char* limit;
  };
  for (const Case& k : {Case{"", "fragments"}, Case{"raster_setup_cycles=100", "setup"},
                        Case{"raster_samples_per_clock=0.5", "scan"}, Case{"dram_bytes_per_cycle=2", "dram"}}) {
    CAPTURE(k.set);
    RenderOptions o = options("timed", true, 0, 0);
    o.device.timing = rtu::hw::timing_preset("rdna2");
    const std::string set = k.set;
    if (!set.empty())
      rtu::hw::set_timing_key(o.device.timing, set.substr(0, set.find('=')), set.substr(set.find('=') + 1));
    o.device.format = rtu::hw::format_preset(o.device.timing.format);
    o.device.tracer.bvh.width = o.device.format.width = o.device.timing.bvh_width;
    o.max_depth = 1;
    const RenderResult r = rtu::host::render(s, o);
    const rtu::fw::RasterStats& st = r.fw.raster;
    CHECK(st.passes == 1);
    CHECK(st.prims_read == prims);
    CHECK(st.setups == setups);
    CHECK(st.samples_tested == samples);
    CHECK(st.fragments == fragments);
    CHECK(st.depth_writes == writes);
    CHECK(st.clears == clears);
    const rtu::hw::TimingConfig& c = o.device.timing;
    const uint64_t bytes = prims * uint64_t(c.raster_prim_bytes) +
                           (clears + fragments) * uint64_t(c.raster_depth_bytes) +
                           writes * uint64_t(c.raster_depth_bytes + c.raster_gbuffer_bytes);
    const double stage =
        std::max({double(setups) * c.raster_setup_cycles, double(samples) / c.raster_samples_per_clock,
                  double(fragments) / c.raster_fragments_per_clock, double(bytes) / c.dram_bytes_per_cycle});
    CHECK(r.raster_cycles.dram_bytes == bytes);
    CHECK(r.raster_cycles.cycles == uint64_t(c.raster_latency) + uint64_t(std::ceil(stage)));
    CHECK(std::string(r.raster_cycles.limit) == k.limit);
    // The frame: raster, then the unit's packets (secondary rays only).
    CHECK(r.frame_cycles == r.raster_cycles.cycles + r.device_clock);
    CHECK(r.fw.primary_rasterized == 256);
    CHECK(r.fw.rays[int(RayType::kPrimary)] == 0);
    // rdna2 written out: setup 3 x 20 = 60, scan 306 / 6.4 = 47.8, fragments 272 / 1.6 = 170, DRAM
    // (108 + 528 x 4 + 256 x 16) / 64 = 98.7 bytes: 100 cycles of latency + 170.
    if (set.empty()) CHECK(r.raster_cycles.cycles == 270);
  }
}

TEST_CASE("hybrid renders repeat bit for bit, cycles included, whatever the thread count", "[hybrid][timing]") {
  const Scene s = rtu::host::load_scene("builtin:seed");
  RenderOptions o = options("timed", true, 80, 60);
  o.spp = 2;
  o.max_depth = 2;
  const RenderResult a = rtu::host::render(s, o);
  o.threads = 1;
  const RenderResult b = rtu::host::render(s, o);
  CHECK(a.rgb == b.rgb);
  CHECK(a.frame_cycles == b.frame_cycles);
  CHECK(a.raster_cycles.cycles == b.raster_cycles.cycles);
  CHECK(a.raster_cycles.cycles > 0);
}

TEST_CASE("hybrid cost model: each stage limits in turn, latency per pass", "[hybrid][timing]") {
  rtu::hw::TimingConfig c = rtu::hw::timing_preset("rdna2");
  c.raster_setup_cycles = 2.0;
  c.raster_samples_per_clock = 8.0;
  c.raster_fragments_per_clock = 2.0;
  c.raster_latency = 30;
  c.raster_prim_bytes = 32;
  c.raster_depth_bytes = 4;
  c.raster_gbuffer_bytes = 12;
  c.dram_bytes_per_cycle = 16.0;
  rtu::hw::RasterWork w;
  w.passes = 2;
  w.prims_read = 10;
  w.setups = 100;          // 200 cycles
  w.samples_tested = 800;  // 100
  w.fragments = 300;       // 150
  w.depth_writes = 100;    // bytes: 320 + (50 + 300) * 4 + 100 * 16 = 3320 -> 207.5 cycles
  w.clears = 50;
  rtu::hw::RasterCycles r = rtu::hw::raster_cycles(w, c);
  CHECK(r.dram_bytes == 3320);
  CHECK(r.cycles == 60 + 208);
  CHECK(std::string(r.limit) == "dram");
  c.dram_bytes_per_cycle = 3320.0 / 200.0;  // exactly the setup's 200: the first stage named wins the tie
  r = rtu::hw::raster_cycles(w, c);
  CHECK(r.cycles == 60 + 200);
  CHECK(std::string(r.limit) == "setup");
  c.raster_samples_per_clock = 3.0;  // 266.67 -> 267
  r = rtu::hw::raster_cycles(w, c);
  CHECK(r.cycles == 60 + 267);
  CHECK(std::string(r.limit) == "scan");
  c.raster_fragments_per_clock = 1.0;  // 300
  r = rtu::hw::raster_cycles(w, c);
  CHECK(r.cycles == 60 + 300);
  CHECK(std::string(r.limit) == "fragments");
  CHECK(rtu::hw::raster_cycles(rtu::hw::RasterWork{}, c).cycles == 0);
}

TEST_CASE("hybrid images agree with ray-traced images within a PSNR bound", "[hybrid][scale]") {
  // Where the primary hits agree, the shading is the same computation on the same random numbers: the hit
  // points differ by float rounding (t within 1e-5 relative, above), which moves secondary rays by about as
  // much and can flip a discrete choice (a Fresnel draw, a shadow ray grazing an edge) only with a probability of
  // that order. So the images differ essentially on the <= 0.1% of pixels whose primary hit differs (and where
  // the secondary rays of edge pixels see other things): even at full-scale error on each of them, MSE <=
  // 0.001 * 255^2, PSNR >= 10 log10(1 / 0.001) = 30 dB. Measured: identical images here; 47 dB and more at full
  // size on the timed presets (bench/results/hybrid.md).
  // At 2 spp the jittered samples agree as well: the rasterizer places them where the camera rays go.
  struct Case {
    const char* scene;
    int w, h, spp, depth;
  };
  for (const Case& c : {Case{"builtin:seed", 320, 240, 1, 4}, Case{"builtin:cornell", 128, 128, 2, 3},
                        Case{"/usr/share/assimp/models/OBJ/WusonOBJ.obj", 160, 120, 1, 3}}) {
    const Scene scene = rtu::host::load_scene(c.scene);
    for (const char* dev : {"float", "fixed"}) {
      CAPTURE(c.scene, dev);
      RenderOptions o = options(dev, false, c.w, c.h);
      o.spp = c.spp;
      o.max_depth = c.depth;
      const RenderResult rt = rtu::host::render(scene, o);
      o.hybrid = true;
      const RenderResult hy = rtu::host::render(scene, o);
      uint64_t agree = 0;
      for (size_t i = 0; i < rt.primary.size(); ++i) agree += rt.primary[i].prim == hy.primary[i].prim;
      CHECK(double(agree) >= 0.999 * double(rt.primary.size()));
      const rtu::host::ImageDiff d = rtu::host::diff_images(rtu::host::to_image(rt), rtu::host::to_image(hy));
      std::printf("hybrid image %s on %s (%dx%d, %d spp, depth %d): PSNR %.2f dB, %llu pixels differ\n", c.scene,
                  dev, c.w, c.h, c.spp, c.depth, d.identical() ? 999.0 : d.psnr_db,
                  (unsigned long long)d.pixels_differing);
      CHECK((d.identical() || d.psnr_db >= 30.0));
      // Hybrid traced every secondary ray type the raytrace render traced, and no primary ray.
      CHECK(hy.fw.rays[int(RayType::kPrimary)] == 0);
      CHECK(hy.fw.rays[int(RayType::kShadow)] > 0);
      CHECK(hy.fw.primary_rasterized == rt.fw.rays[int(RayType::kPrimary)]);
    }
  }
}

TEST_CASE("hybrid: curve segments rasterized as the float reference's swept spheres", "[hybrid][curve]") {
  // builtin:hair with 1500 strands (12,000 segments, half of them curly, a strand's first segment capped) at
  // 200x150, float device, depth 0. The rasterizer tests each sample's camera ray against a segment with the
  // float reference's own arithmetic (intersect_swept_sphere), so where both name the same segment their t are
  // the same computation on the same ray: equal. Triangle hits (the head) agree as in the test above.
  const Scene scene = rtu::host::load_scene("builtin:hair?strands=1500");
  REQUIRE(!scene.geometry.curves.empty());
  const auto [rt, hy] = both_modes(scene, "float", 200, 150);
  const Visibility v = compare_visibility(rt, hy);
  uint64_t curve_hits = 0, worst_ulps = 0;
  for (size_t i = 0; i < rt.primary.size(); ++i) {
    const rtu::hw::Hit &a = rt.primary[i], &b = hy.primary[i];
    if (a.prim != b.prim || a.prim == rtu::hw::kMissPrim) continue;
    if (scene.geometry.kind(a.prim) != rtu::hw::PrimKind::kCurve) continue;
    ++curve_hits;
    CHECK(a.u == b.u);  // the position along the segment
    worst_ulps = std::max<uint64_t>(worst_ulps, uint64_t(std::abs(int64_t(std::bit_cast<int32_t>(a.t)) -
                                                                  int64_t(std::bit_cast<int32_t>(b.t)))));
  }
  std::printf("hybrid hair: %llu samples, %llu curve hits agreeing, %llu disagree, %llu off an edge\n",
              (unsigned long long)v.samples, (unsigned long long)curve_hits, (unsigned long long)v.disagree,
              (unsigned long long)v.off_edge);
  CHECK(curve_hits > v.samples / 20);
  CHECK(double(v.agree) >= 0.999 * double(v.samples));
  CHECK(v.off_edge == 0);
  CHECK(worst_ulps == 0);
  CHECK(hy.fw.rays[int(RayType::kPrimary)] == 0);
  CHECK(hy.fw.primary_rasterized == v.samples);
}
