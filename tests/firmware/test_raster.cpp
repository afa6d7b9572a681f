// The firmware rasterizer (firmware/raster.h) on its own, in host memory: the top-left fill rule covers every
// sample of a tiled polygon exactly once, near-plane and guard-band clipping keep the coverage of the ray
// tracer, sphere impostors and plane passes agree with the float reference sample for sample, jittered samples
// are placed where the renderer places them, and the counts the cost model reads are right.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "firmware/raster.h"
#include "firmware/sampling.h"
#include "hwmodel/datapath/intersect_float.h"

using namespace rtu::fw;
using rtu::hw::Hit;
using rtu::hw::Vec3;

namespace {

// A camera at the origin looking down +z with a 90-degree field of view: the sample at pixel position (px, py)
// looks along (sx, sy, 1) with sx = 2 px / W - 1, sy = 1 - 2 py / H, so a point (x, y, z) projects to
// px = (x / z + 1) W / 2 (y likewise, downwards).
RenderJob camera_job(uint32_t w, uint32_t h, uint32_t spp = 1) {
  RenderJob j{};
  j.width = w;
  j.height = h;
  j.spp = spp;
  j.seed = 7;
  j.eye = {0.0f, 0.0f, 0.0f};
  j.forward = {0.0f, 0.0f, 1.0f};
  j.right = {1.0f, 0.0f, 0.0f};
  j.up = {0.0f, 1.0f, 0.0f};
  j.raster_near = 1e-4f;
  return j;
}

// The world point at depth z that projects to pixel position (px, py) of job j.
rtu::fw::F3 at_pixel(const RenderJob& j, double px, double py, double z) {
  const double sx = 2.0 * px / j.width - 1.0, sy = 1.0 - 2.0 * py / j.height;
  return {float(sx * z), float(sy * z), float(z)};
}

SurfaceRecord triangle(rtu::fw::F3 a, rtu::fw::F3 b, rtu::fw::F3 c) {
  return SurfaceRecord{uint32_t(SurfaceKind::kTriangle), 0, a, b, c};
}

std::vector<Hit> raster(const RenderJob& job, std::vector<SurfaceRecord> prims, RasterStats& st,
                        const SampleOffset* offsets = nullptr) {
  RenderJob j = job;
  j.num_prims = uint32_t(prims.size());
  const uint32_t n = j.width * j.height * (j.spp ? j.spp : 1);
  std::vector<Hit> g(n);
  st = RasterStats{};
  rtu::fw::rasterize(j, prims.data(), offsets, 0, n, g.data(), st);
  return g;
}

// The camera ray of a sample, as the renderer builds it.
rtu::hw::Ray camera_ray(const RenderJob& j, uint32_t x, uint32_t y, SampleOffset o) {
  float sx, sy;
  rtu::fw::image_plane(j, x, y, o, sx, sy);
  const Vec3 d = glm::normalize(Vec3(j.forward.x, j.forward.y, j.forward.z) +
                                sx * Vec3(j.right.x, j.right.y, j.right.z) + sy * Vec3(j.up.x, j.up.y, j.up.z));
  return rtu::hw::Ray{Vec3(j.eye.x, j.eye.y, j.eye.z), 0.0f, d, std::numeric_limits<float>::infinity()};
}

// The float reference's closest hit of a ray over the primitives (brute force).
uint32_t reference_hit(const rtu::hw::Ray& ray, const std::vector<SurfaceRecord>& prims, float& t_out) {
  const rtu::hw::RayPrecomp r(ray);
  uint32_t best = rtu::hw::kMissPrim;
  float t = ray.tmax;
  auto v = [](rtu::fw::F3 f) { return Vec3(f.x, f.y, f.z); };
  for (uint32_t p = 0; p < prims.size(); ++p) {
    rtu::hw::PrimHit h;
    bool hit = false;
    const SurfaceRecord& s = prims[p];
    if (s.kind == uint32_t(SurfaceKind::kTriangle))
      hit = rtu::hw::intersect_triangle(v(s.a), v(s.b), v(s.c), r, 0.0f, t, h);
    else if (s.kind == uint32_t(SurfaceKind::kSphere))
      hit = rtu::hw::intersect_sphere(v(s.a), s.b.x, r, 0.0f, t, h);
    else
      hit = rtu::hw::intersect_plane(rtu::hw::Plane{v(s.a), s.b.x}, r, 0.0f, t, h);
    if (hit && (h.t < t || best == rtu::hw::kMissPrim)) {
      t = h.t;
      best = p;
    }
  }
  t_out = t;
  return best;
}

uint64_t covered(const std::vector<Hit>& g) {
  uint64_t n = 0;
  for (const Hit& h : g) n += h.hit();
  return n;
}

}  // namespace

TEST_CASE("raster: a square of two triangles covers its samples exactly once (top-left rule)", "[raster]") {
  // Corners on pixel centers, so that all four sides and the diagonal pass through samples: the top-left rule
  // gives the samples on the left and top sides to the square, those on the right and bottom sides to nobody,
  // and those on the diagonal to exactly one of the two triangles.
  const RenderJob j = camera_job(16, 16);
  const auto a = at_pixel(j, 2.5, 3.5, 2.0), b = at_pixel(j, 10.5, 3.5, 2.0), c = at_pixel(j, 10.5, 11.5, 2.0),
             d = at_pixel(j, 2.5, 11.5, 2.0);
  for (bool flip : {false, true}) {  // both windings: both faces are drawn
    CAPTURE(flip);
    RasterStats st;
    const std::vector<Hit> g = raster(j, {flip ? triangle(a, c, b) : triangle(a, b, c), triangle(a, c, d)}, st);
    CHECK(covered(g) == 64);    // columns 2..9, rows 3..10
    CHECK(st.fragments == 64);  // no sample twice
    CHECK(st.depth_writes == 64);
    for (uint32_t y = 0; y < 16; ++y)
      for (uint32_t x = 0; x < 16; ++x) CHECK(g[y * 16 + x].hit() == (x >= 2 && x <= 9 && y >= 3 && y <= 10));
    // The diagonal from (2.5, 3.5) to (10.5, 11.5) goes to one side: the samples on it belong to one triangle.
    const uint32_t diag = g[3 * 16 + 2].prim;
    for (uint32_t k = 1; k < 8; ++k) CHECK(g[(3 + k) * 16 + 2 + k].prim == diag);
    CHECK(st.setups == 2);
    CHECK(st.samples_tested > 0);
  }
}

TEST_CASE("raster: a random fan tiles its polygon without holes or overlaps", "[raster]") {
  // Triangles around a shared center whose vertices lie on a fine grid (1/4 pixel: many samples exactly on
  // edges and vertices) cover the convex polygon: every sample strictly inside is covered once, none twice.
  const unsigned seed = Catch::rngSeed() ? Catch::rngSeed() : 12345u;
  std::printf("raster fan test seed %u\n", seed);
  std::mt19937 rng(seed);
  const RenderJob j = camera_job(48, 40);
  for (int trial = 0; trial < 20; ++trial) {
    const double cx = 24.0 + (int(rng() % 9) - 4) * 0.25, cy = 20.0 + (int(rng() % 9) - 4) * 0.25;
    const int n = 3 + int(rng() % 10);
    // Vertices on an ellipse at increasing angles, snapped to quarter pixels (the fan stays convex or nearly).
    std::vector<std::pair<double, double>> ring;
    for (int i = 0; i < n; ++i) {
      const double ang = 2.0 * 3.14159265358979 * (i + 0.3 * double(rng() % 100) / 100.0) / n;
      ring.push_back({std::round((cx + 18.0 * std::cos(ang)) * 4.0) / 4.0,
                      std::round((cy + 15.0 * std::sin(ang)) * 4.0) / 4.0});
    }
    std::vector<SurfaceRecord> prims;
    for (int i = 0; i < n; ++i) {
      const auto& p = ring[size_t(i)];
      const auto& q = ring[size_t((i + 1) % n)];
      prims.push_back(triangle(at_pixel(j, cx, cy, 3.0), at_pixel(j, p.first, p.second, 3.0),
                               at_pixel(j, q.first, q.second, 3.0)));
    }
    RasterStats st;
    const std::vector<Hit> g = raster(j, prims, st);
    CAPTURE(trial, n);
    CHECK(st.fragments == covered(g));  // no sample covered twice
    // Samples strictly inside a fan triangle (not on any of its edges) must be covered.
    uint64_t inside = 0, missing = 0;
    for (uint32_t y = 0; y < j.height; ++y)
      for (uint32_t x = 0; x < j.width; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        for (int i = 0; i < n; ++i) {
          const auto& p = ring[size_t(i)];
          const auto& q = ring[size_t((i + 1) % n)];
          auto e = [&](double ax, double ay, double bx, double by) {
            return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
          };
          const double e0 = e(cx, cy, p.first, p.second), e1 = e(p.first, p.second, q.first, q.second),
                       e2 = e(q.first, q.second, cx, cy);
          if ((e0 > 0 && e1 > 0 && e2 > 0) || (e0 < 0 && e1 < 0 && e2 < 0)) {
            ++inside;
            missing += !g[y * j.width + x].hit();
            break;
          }
        }
      }
    CHECK(inside > 100);
    CHECK(missing == 0);
  }
}

TEST_CASE("raster: triangles through the near plane and far past the image are clipped, not lost", "[raster]") {
  // A floor under the camera from behind the eye to far ahead, and a huge wall whose corners project thousands
  // of pixels outside the image: both are clipped (near plane, guard band) and cover what the rays hit.
  const RenderJob j = camera_job(40, 30);
  const std::vector<SurfaceRecord> prims = {
      triangle({-50.0f, -1.0f, -5.0f}, {50.0f, -1.0f, -5.0f}, {0.0f, -1.0f, 80.0f}),
      triangle({-1e5f, -1e5f, 90.0f}, {1e5f, -1e5f, 90.0f}, {0.0f, 1e5f, 90.0f}),
  };
  RasterStats st;
  const std::vector<Hit> g = raster(j, prims, st);
  CHECK(st.triangles_clipped == 2);
  uint64_t disagree = 0;
  for (uint32_t y = 0; y < j.height; ++y)
    for (uint32_t x = 0; x < j.width; ++x) {
      float t = 0.0f;
      const uint32_t ref = reference_hit(camera_ray(j, x, y, SampleOffset{0.5f, 0.5f}), prims, t);
      const Hit& h = g[y * j.width + x];
      disagree += ref != h.prim;
      if (ref == h.prim && ref != rtu::hw::kMissPrim) CHECK(std::abs(h.t - t) <= 1e-5f * t);
    }
  // The floor's far edge and the wall meet at the horizon: a few samples on that line may go either way.
  CHECK(disagree <= 2);
  CHECK(covered(g) == j.width * j.height);  // nothing behind the wall is visible: every sample hits
}

TEST_CASE("raster: a triangle entirely behind the eye or beside the view is culled", "[raster]") {
  const RenderJob j = camera_job(16, 16);
  RasterStats st;
  const std::vector<Hit> g = raster(j,
                                    {triangle({-1.0f, -1.0f, -2.0f}, {1.0f, -1.0f, -2.0f}, {0.0f, 1.0f, -2.0f}),
                                     triangle({5.0f, 0.0f, 1.0f}, {6.0f, 0.0f, 1.0f}, {5.0f, 1.0f, 1.0f})},
                                    st);
  CHECK(covered(g) == 0);
  CHECK(st.triangles_culled == 2);
  CHECK(st.setups == 0);
  CHECK(st.samples_tested == 0);
  CHECK(st.prims_read == 2);
  CHECK(st.clears == 256);
  // A small triangle between the pixel centers holds no sample in its bounding box: culled before setup. Moved
  // over a center (3.5, 3.5) it is set up and covers that one sample.
  for (double shift : {0.0, -0.25}) {
    CAPTURE(shift);
    RasterStats s2;
    const double a = 3.55 + shift;  // (3.55, 4.2): no center inside; (3.3, 3.95): (3.5, 3.5) inside
    const std::vector<Hit> g2 = raster(
        j, {triangle(at_pixel(j, a, a, 2.0), at_pixel(j, a + 0.65, a, 2.0), at_pixel(j, a, a + 0.65, 2.0))}, s2);
    CHECK(s2.setups == (shift == 0.0 ? 0u : 1u));
    CHECK(s2.triangles_culled == (shift == 0.0 ? 1u : 0u));
    CHECK(covered(g2) == (shift == 0.0 ? 0u : 1u));
  }
}

TEST_CASE("raster: sphere impostors and plane passes equal the float reference at every sample", "[raster]") {
  // Per sample the rasterizer runs the reference's own sphere and plane tests on the camera ray, so only the
  // bounding square could lose samples (it must not), and the depth test must pick the same primitive. A
  // sphere around the eye (near plane inside it: full-screen square) is drawn from inside.
  for (uint32_t spp : {1u, 3u}) {
    CAPTURE(spp);
    const RenderJob j = camera_job(64, 48, spp);
    const std::vector<SurfaceRecord> prims = {
        {uint32_t(SurfaceKind::kSphere), 0, {0.3f, 0.2f, 4.0f}, {1.1f, 0.0f, 0.0f}, {}},
        {uint32_t(SurfaceKind::kSphere), 0, {-1.5f, -0.4f, 6.0f}, {0.7f, 0.0f, 0.0f}, {}},
        {uint32_t(SurfaceKind::kPlane), 0, {0.0f, 1.0f, 0.1f}, {-1.2f, 0.0f, 0.0f}, {}},
        {uint32_t(SurfaceKind::kSphere), 0, {0.0f, 0.0f, 0.0f}, {50.0f, 0.0f, 0.0f}, {}},
    };
    std::vector<SampleOffset> offsets;
    for (uint32_t p = 0; p < j.width * j.height; ++p)
      for (uint32_t s = 0; s < spp; ++s) offsets.push_back(rtu::fw::sample_offset(j, p, s));
    RasterStats st;
    const std::vector<Hit> g = raster(j, prims, st, spp > 1 ? offsets.data() : nullptr);
    CHECK(st.setups == 4);
    uint64_t spheres = 0;
    for (uint32_t p = 0; p < j.width * j.height; ++p)
      for (uint32_t s = 0; s < spp; ++s) {
        const SampleOffset o = offsets[p * spp + s];
        float t = 0.0f;
        const uint32_t ref = reference_hit(camera_ray(j, p % j.width, p / j.width, o), prims, t);
        const Hit& h = g[p * spp + s];
        REQUIRE(h.prim == ref);
        CHECK(h.t == t);
        spheres += ref < 2;
      }
    CHECK(spheres > 200);  // the small spheres are in view
  }
}

TEST_CASE("raster: jittered samples are where the renderer puts them", "[raster]") {
  // At 4 spp a triangle's coverage at each jittered sample equals the float reference's hit of that sample's
  // camera ray, except within the 1/8192-pixel snapping of samples and vertices to the subpixel grid.
  const RenderJob j = camera_job(32, 32, 4);
  const std::vector<SurfaceRecord> prims = {
      triangle(at_pixel(j, 3.1, 2.7, 2.0), at_pixel(j, 29.3, 9.9, 2.0), at_pixel(j, 11.7, 30.2, 5.0))};
  std::vector<SampleOffset> offsets;
  for (uint32_t p = 0; p < j.width * j.height; ++p)
    for (uint32_t s = 0; s < 4; ++s) offsets.push_back(rtu::fw::sample_offset(j, p, s));
  CHECK(offsets[0].jx != 0.5f);  // jittered
  RasterStats st;
  const std::vector<Hit> g = raster(j, prims, st, offsets.data());
  uint64_t agree = 0, hits = 0;
  for (uint32_t k = 0; k < g.size(); ++k) {
    float t = 0.0f;
    const uint32_t p = k / 4;
    const uint32_t ref = reference_hit(camera_ray(j, p % j.width, p / j.width, offsets[k]), prims, t);
    agree += ref == g[k].prim;
    hits += ref != rtu::hw::kMissPrim;
  }
  CHECK(hits > 1000);
  // About 3 * 40 pixels of edge, 4 samples each, each within 1/8192 pixel of the edge with probability ~1/4096:
  // a handful at most.
  CHECK(agree >= g.size() - 8);
  CHECK(st.fragments == covered(g));
}

TEST_CASE("raster: a pass over part of the image touches only its samples", "[raster]") {
  // The renderer rasterizes each batch of paths on its own: a pass over paths [first, first + n) writes only
  // gbuf[0, n) and the union of passes equals one pass over everything.
  const RenderJob j0 = camera_job(24, 20, 2);
  RenderJob j = j0;
  const std::vector<SurfaceRecord> prims = {
      triangle(at_pixel(j, 1.0, 1.0, 2.0), at_pixel(j, 23.0, 4.0, 2.0), at_pixel(j, 6.0, 19.0, 2.0)),
      {uint32_t(SurfaceKind::kPlane), 0, {0.0f, 0.0f, -1.0f}, {-9.0f, 0.0f, 0.0f}, {}}};
  j.num_prims = 2;
  const uint32_t total = 24 * 20 * 2;
  std::vector<SampleOffset> offsets;
  for (uint32_t k = 0; k < total; ++k) offsets.push_back(rtu::fw::sample_offset(j, k / 2, k % 2));
  RasterStats whole_st;
  const std::vector<Hit> whole = raster(j, prims, whole_st, offsets.data());
  std::vector<Hit> parts(total + 1);
  parts[total].prim = 12345;  // a canary past the end
  RasterStats st;
  for (uint32_t first = 0; first < total; first += 77) {
    const uint32_t n = std::min(77u, total - first);
    rtu::fw::rasterize(j, prims.data(), offsets.data() + first, first, n, parts.data() + first, st);
  }
  CHECK(parts[total].prim == 12345);
  for (uint32_t k = 0; k < total; ++k) {
    CHECK(parts[k].prim == whole[k].prim);
    CHECK(parts[k].t == whole[k].t);
  }
  CHECK(st.passes == (total + 76) / 77);
  CHECK(st.fragments == whole_st.fragments);
  CHECK(st.clears == total);
  CHECK(st.prims_read == 2 * st.passes);
}

TEST_CASE("raster: records with NaN or infinite coordinates draw nothing and break nothing", "[raster]") {
  // The host validates scenes, so these come only from corrupted memory: they must not reach a float-to-integer
  // conversion out of range (undefined behaviour; the sanitizer build runs this) nor write outside the G-buffer.
  const RenderJob j = camera_job(16, 12);
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const std::vector<SurfaceRecord> prims = {
      triangle({nan, 0.0f, 2.0f}, {1.0f, 0.0f, 2.0f}, {0.0f, 1.0f, 2.0f}),
      triangle({-inf, -1.0f, 2.0f}, {inf, -1.0f, 2.0f}, {0.0f, 1.0f, 2.0f}),
      triangle({-1e38f, -1e38f, 1e38f}, {1e38f, -1e38f, 1e38f}, {0.0f, 1e38f, 1e38f}),  // huge but finite
      {uint32_t(SurfaceKind::kSphere), 0, {0.0f, 0.0f, 3.0f}, {nan, 0.0f, 0.0f}, {}},
      {uint32_t(SurfaceKind::kSphere), 0, {0.0f, inf, 3.0f}, {1.0f, 0.0f, 0.0f}, {}},
      {uint32_t(SurfaceKind::kPlane), 0, {nan, 1.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, {}},
  };
  RasterStats st;
  std::vector<Hit> g = raster(j, prims, st);
  CHECK(st.prims_read == prims.size());
  CHECK(st.triangles_culled >= 2);
  // Only the huge finite triangle may cover samples (it spans the view at depth 1e38).
  for (const Hit& h : g) CHECK((!h.hit() || h.prim == 2));
  // Too wide an image: nothing is drawn (the renderer refuses it before).
  RenderJob wide = camera_job(rtu::fw::kMaxRasterSide + 1, 1);
  wide.num_prims = 1;
  std::vector<Hit> one(4);
  rtu::fw::rasterize(wide, prims.data() + 2, nullptr, 0, 4, one.data(), st);
  for (const Hit& h : one) CHECK_FALSE(h.hit());
}
