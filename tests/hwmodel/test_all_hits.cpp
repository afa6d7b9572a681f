// All-hit traversal (FloatTracer::trace_all, FixedTracer::trace_all): the BVH finds exactly the hits of testing
// every primitive (the interval is never narrowed, so no subtree is skipped), the nearest of them is trace()'s
// hit, the output bound keeps the first hits and counts the rest, and fixed and float find the same primitives but
// near silhouettes.
#include <catch2/catch.hpp>

#include <algorithm>
#include <utility>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/rng.h"
#include "tests/hwmodel/fixed_checks.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

namespace {

// Rays through the soup: origins outside it, aimed across it, long intervals (many hits each).
std::vector<Ray> crossing_rays(uint64_t seed, int n) {
  Pcg32 g(seed);
  std::vector<Ray> rays;
  for (int i = 0; i < n; ++i) {
    const Vec3 o(rand_float(g, -14, 14), rand_float(g, -14, 14), -15.0f);
    const Vec3 to(rand_float(g, -10, 10), rand_float(g, -10, 10), rand_float(g, -10, 10));
    rays.push_back(Ray{o, i % 5 == 0 ? 3.0f : 0.0f, to - o, i % 7 == 0 ? 1.0f : 40.0f});
  }
  return rays;
}

// (prim, t) of a list's kept hits, sorted.
std::vector<std::pair<uint32_t, float>> hit_set(const std::vector<Hit>& buf, const HitList& l) {
  std::vector<std::pair<uint32_t, float>> v;
  for (uint32_t i = 0; i < l.kept(); ++i) v.emplace_back(buf[i].prim, buf[i].t);
  std::sort(v.begin(), v.end());
  return v;
}

}  // namespace

TEST_CASE("all-hit traversal: the BVH finds every hit testing each primitive finds, on float and fixed",
          "[tracer][allhits]") {
  const Geometry g = random_scene(31, 8000, 40);
  const std::vector<Ray> rays = crossing_rays(32, 2000);
  TracerOptions bvh_opt, brute_opt;
  bvh_opt.accel = AccelMode::kBvh;
  brute_opt.accel = AccelMode::kBrute;
  const FloatTracer fb(g, bvh_opt), fa(g, brute_opt);
  const FixedFormat f = format_preset("default");
  REQUIRE(fb.bvh()->width() == f.width);
  const DeviceImage with_bvh = encode_scene(g, f, fb.bvh()), brute = encode_scene(g, f, nullptr);
  const FixedTracer xb(with_bvh), xa(brute);
  uint64_t total = 0, differ_float_fixed = 0, many = 0;
  std::vector<Hit> b1(4096), b2(4096), b3(4096), b4(4096);
  for (size_t i = 0; i < rays.size(); ++i) {
    TraversalStats s;
    HitList l1{b1.data(), 4096}, l2{b2.data(), 4096}, l3{b3.data(), 4096}, l4{b4.data(), 4096};
    fb.trace_all(rays[i], l1, s);
    fa.trace_all(rays[i], l2, s);
    xb.trace_all(rays[i], l3, s);
    xa.trace_all(rays[i], l4, s);
    INFO("ray " << i);
    REQUIRE(hit_set(b1, l1) == hit_set(b2, l2));
    REQUIRE(hit_set(b3, l3) == hit_set(b4, l4));
    // The nearest hit is trace()'s (t; a tie may name another primitive).
    TraversalStats s2;
    const Hit nearest_float = fb.trace(rays[i], false, s2), nearest_fixed = xb.trace(rays[i], false, s2);
    REQUIRE((l1.count > 0) == nearest_float.hit());
    REQUIRE((l3.count > 0) == nearest_fixed.hit());
    if (l1.count > 0) {
      float t = INFINITY;
      for (uint32_t k = 0; k < l1.kept(); ++k) t = std::min(t, b1[k].t);
      REQUIRE(t == nearest_float.t);
    }
    if (l3.count > 0) {
      float t = INFINITY;
      for (uint32_t k = 0; k < l3.kept(); ++k) t = std::min(t, b3[k].t);
      REQUIRE(t == nearest_fixed.t);
    }
    // Float and fixed hit the same primitives, but for a ray near a silhouette.
    std::vector<uint32_t> pf, px;
    for (uint32_t k = 0; k < l1.kept(); ++k) pf.push_back(b1[k].prim);
    for (uint32_t k = 0; k < l3.kept(); ++k) px.push_back(b3[k].prim);
    std::sort(pf.begin(), pf.end());
    std::sort(px.begin(), px.end());
    differ_float_fixed += pf != px;
    total += l1.count;
    many += l1.count >= 3;
  }
  INFO(total << " hits, " << many << " rays with 3 or more, " << differ_float_fixed << " rays differ");
  CHECK(many > rays.size() / 4);  // the rays cross the soup: most hit several primitives
  // As for closest hits (test_fixed_tracer.cpp): a ray changes only within ~1e-6 of a silhouette, here of any of
  // the primitives it passes (several each): 0.5% leaves a wide margin.
  CHECK(double(differ_float_fixed) <= 0.005 * double(rays.size()));
}

TEST_CASE("all-hit traversal: the bound keeps the first hits and counts them all, counts alone, bad rays",
          "[tracer][allhits]") {
  const Geometry g = random_scene(33, 8000, 0);
  const std::vector<Ray> rays = crossing_rays(34, 500);
  TracerOptions opt;
  opt.accel = AccelMode::kBvh;
  const FloatTracer ft(g, opt);
  const DeviceImage img = encode_scene(g, format_preset("default"), ft.bvh());
  const FixedTracer xt(img);
  uint64_t overflowed = 0;
  std::vector<Hit> all(4096), few(3);
  for (const Ray& r : rays) {
    TraversalStats s;
    HitList big{all.data(), 4096}, small{few.data(), 3}, count{nullptr, 0};
    xt.trace_all(r, big, s);
    xt.trace_all(r, small, s);
    xt.trace_all(r, count, s);
    REQUIRE(small.count == big.count);
    REQUIRE(count.count == big.count);
    REQUIRE(small.overflow() == (big.count > 3));
    REQUIRE(count.overflow() == (big.count > 0));
    for (uint32_t k = 0; k < small.kept(); ++k) {  // the first three, in the traversal's order
      REQUIRE(few[k].prim == all[k].prim);
      REQUIRE(few[k].t == all[k].t);
    }
    overflowed += small.overflow();
  }
  CHECK(overflowed > 20);
  // Rejected rays count as invalid and find nothing.
  TraversalStats s;
  HitList l{all.data(), 4096};
  CHECK(xt.trace_all(Ray{{NAN, 0, 0}, 0.0f, {0, 0, 1}, 1.0f}, l, s) == 0);
  CHECK(ft.trace_all(Ray{{0, 0, 0}, 0.0f, {0, 0, 0}, 1.0f}, l, s) == 0);
  CHECK(s.invalid_rays == 2);
}
