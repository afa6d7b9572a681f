// Motion blur against Embree 3's (two time steps, the ray's time): the float reference agrees with Embree as on
// static scenes (tests/oracle/test_embree.cpp: hit/miss on >= 99.999% of rays, t within 32 eps S / cos), and the
// fixed unit agrees with the float reference within the bound its roundings give (below).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "host/oracle/embree_motion.h"
#include "host/oracle/embree_oracle.h"
#include "host/scene/motion_scene.h"
#include "host/scene/ray_gen.h"
#include "hwmodel/datapath/motion_tracer.h"
#include "hwmodel/numeric/rng.h"

using namespace rtu;

namespace {

constexpr double kEps = 0x1p-24;

// The rays of the test: the camera's frame at 4 samples per pixel (stratified times) and incoherent rays at
// uniform times, some exactly at 0 and 1.
host::MotionRays test_rays(const host::MotionScene& scene, const hw::MotionBvh& bvh, uint64_t incoherent) {
  host::MotionRays r = host::motion_frame_rays(scene.camera, 320, 240, 4, 11);
  hw::Aabb all = bvh.key_bounds[0];
  all.extend(bvh.key_bounds[1]);
  const std::vector<hw::Ray> inc = host::incoherent_rays(all, incoherent, 12);
  hw::Pcg32 rng(13);
  for (size_t i = 0; i < inc.size(); ++i) {
    r.rays.push_back(inc[i]);
    r.times.push_back(i % 101 == 0 ? float(i % 2) : rng.next_float());
  }
  return r;
}

// |cos| of the angle between the ray and the hit triangle's normal at the ray's time.
double cos_theta(const hw::MotionGeometry& g, const hw::Ray& r, const hw::Hit& h, float time) {
  const hw::Triangle t = g.triangles[h.prim].at(time);
  const hw::DVec3 n = glm::cross(hw::DVec3(t.v1) - hw::DVec3(t.v0), hw::DVec3(t.v2) - hw::DVec3(t.v0));
  return std::abs(glm::dot(glm::normalize(n), glm::normalize(hw::DVec3(r.dir))));
}

double scale_of(const hw::Ray& r, const hw::Hit& h) {
  const hw::Vec3 p = r.origin + h.t * r.dir;
  return std::max({std::abs(r.origin.x), std::abs(r.origin.y), std::abs(r.origin.z), std::abs(p.x), std::abs(p.y),
                   std::abs(p.z)});
}

// 200,000 incoherent rays through g's bounds at random times (some exactly 0 and 1), traced by the float
// reference and the fixed unit (default format and motion format).
struct Traced {
  std::vector<hw::Ray> rays;
  std::vector<float> times;
  std::vector<hw::Hit> fh, xh;
};
Traced trace_both(const hw::MotionGeometry& g, uint64_t seed, hw::Pcg32& rng) {
  const hw::MotionBvh bvh = hw::MotionBvh::build(g);
  hw::Aabb all = bvh.key_bounds[0];
  all.extend(bvh.key_bounds[1]);
  Traced t;
  t.rays = host::incoherent_rays(all, 200000, seed);
  t.times.resize(t.rays.size());
  for (size_t i = 0; i < t.times.size(); ++i) t.times[i] = i % 101 == 0 ? float(i % 2) : rng.next_float();
  hw::TraversalStats s;
  hw::MotionFloatTracer(g, bvh).trace_batch(t.rays, t.times, t.fh, false, 0, s);
  const hw::MotionImage img = hw::MotionImage::encode(g, bvh, hw::format_preset("default"), {});
  hw::MotionFixedTracer(img).trace_batch(t.rays, t.times, t.xh, false, 0, s);
  return t;
}

}  // namespace

TEST_CASE("motion: the float reference agrees with Embree's motion blur at every ray time", "[motion][embree]") {
  const host::MotionScene scene = host::builtin_motion_scene(4);
  const hw::MotionBvh bvh = hw::MotionBvh::build(scene.geometry);
  const hw::MotionFloatTracer ours(scene.geometry, bvh);
  const oracle::EmbreeMotionScene embree(scene.geometry);
  const host::MotionRays rays = test_rays(scene, bvh, 200000);
  std::vector<hw::Hit> hits;
  hw::TraversalStats s;
  ours.trace_batch(rays.rays, rays.times, hits, false, 0, s);
  uint64_t hit_miss = 0, t_off = 0, both = 0, occluded_diff = 0;
  double worst = 0.0;
  for (size_t i = 0; i < hits.size(); ++i) {
    const hw::Ray& r = rays.rays[i];
    const hw::Hit e = embree.intersect(r, rays.times[i]);
    occluded_diff += (i % 4 == 0) && embree.occluded(r, rays.times[i]) != e.hit();
    if (e.hit() != hits[i].hit()) {
      ++hit_miss;
      continue;
    }
    if (!e.hit()) continue;
    ++both;
    // As for static scenes: 24 eps S / cos for the two tracers' roundings, 32 used. Embree interpolates the
    // vertices in float ((1 - t) v0 + t v1, two roundings per coordinate), ours in double rounded once: a
    // perturbation of 2 eps S per coordinate more, which 32 - 24 = 8 covers.
    const double unit = kEps * scale_of(r, hits[i]) / cos_theta(scene.geometry, r, hits[i], rays.times[i]);
    const double err = std::abs(double(hits[i].t) - double(e.t)) * glm::length(hw::DVec3(r.dir));
    if (err > 32.0 * unit)
      ++t_off;
    else
      worst = std::max(worst, err / unit);
  }
  std::printf(
      "motion blur, float against Embree: %zu rays, %llu both hit, %llu hit/miss, %llu t beyond bound (worst "
      "%.2f eps S/cos)\n",
      hits.size(), (unsigned long long)both, (unsigned long long)hit_miss, (unsigned long long)t_off, worst);
  INFO(hits.size() << " rays, " << both << " both hit, " << hit_miss << " hit/miss, " << t_off << " t off");
  CHECK(double(hit_miss) <= 1e-5 * double(hits.size()));
  CHECK(double(t_off) <= 1e-5 * double(hits.size()));
  CHECK(occluded_diff == 0);
  CHECK(both > hits.size() / 4);
}

TEST_CASE("motion: the fixed unit agrees with the float reference within its roundings",
          "[motion][fixed][embree]") {
  const host::MotionScene scene = host::builtin_motion_scene(4);
  const hw::MotionBvh bvh = hw::MotionBvh::build(scene.geometry);
  const hw::MotionFloatTracer flt(scene.geometry, bvh);
  const host::MotionRays rays = test_rays(scene, bvh, 100000);
  // The largest key-frame move of any vertex coordinate (world units).
  double vmax = 0.0;
  for (const hw::MotionTriangle& t : scene.geometry.triangles)
    for (int a = 0; a < 3; ++a)
      vmax = std::max({vmax, double(std::abs(t.key[1].v0[a] - t.key[0].v0[a])),
                       double(std::abs(t.key[1].v1[a] - t.key[0].v1[a])),
                       double(std::abs(t.key[1].v2[a] - t.key[0].v2[a]))});
  std::vector<hw::Hit> want;
  hw::TraversalStats fs;
  flt.trace_batch(rays.rays, rays.times, want, false, 0, fs);
  for (const int time_bits : {8, 16}) {
    const hw::MotionFormat m{time_bits, 6};
    const hw::MotionImage img = hw::MotionImage::encode(scene.geometry, bvh, hw::format_preset("default"), m);
    const hw::MotionFixedTracer fixed(img);
    std::vector<hw::Hit> got;
    hw::TraversalStats s;
    fixed.trace_batch(rays.rays, rays.times, got, false, 0, s);
    // Each vertex coordinate of the fixed unit differs from the float reference's by at most: half a grid step
    // from rounding each key frame (their interpolation keeps that bound), half a step from rounding the
    // interpolation, and the move times the time register's error, vmax 2^-(time_bits + 1). A displacement of
    // delta per coordinate moves the surface by at most sqrt(3) delta along its normal, so the hit by
    // sqrt(3) delta / cos along the ray; twice that is used, plus the float bound of the static test.
    const double delta = img.frame.step() + vmax * std::ldexp(1.0, -(time_bits + 1));
    uint64_t agree = 0, t_off = 0, both = 0;
    for (size_t i = 0; i < got.size(); ++i) {
      agree += got[i].hit() == want[i].hit();
      if (!(got[i].hit() && want[i].hit())) continue;
      ++both;
      const hw::Ray& r = rays.rays[i];
      const double c = cos_theta(scene.geometry, r, want[i], rays.times[i]);
      const double bound = (2.0 * std::sqrt(3.0) * delta + 32.0 * kEps * scale_of(r, want[i])) / c;
      t_off += std::abs(double(got[i].t) - double(want[i].t)) * glm::length(hw::DVec3(r.dir)) > bound;
    }
    std::printf("motion blur, fixed (%s) against float: %zu rays, %llu agree on hit/miss, %llu t beyond bound\n",
                m.describe().c_str(), got.size(), (unsigned long long)agree, (unsigned long long)t_off);
    INFO(m.describe() << ": " << agree << " of " << got.size() << " agree, " << t_off << " t off of " << both);
    // As for static scenes (tests/hwmodel/test_fixed_tracer.cpp): hit/miss changes only for rays within delta of
    // a silhouette, 99.9% leaves a wide margin. A hit at a different primitive (behind a silhouette) is also
    // outside the t bound: 0.1% of the rays.
    CHECK(double(agree) >= 0.999 * double(got.size()));
    CHECK(double(t_off) <= 1e-3 * double(got.size()));
    CHECK(both > got.size() / 4);
  }
}

TEST_CASE("motion: moving spheres agree with Embree's, and the fixed unit with the float reference",
          "[motion][embree]") {
  hw::Pcg32 rng(21);
  hw::MotionGeometry g;
  for (int i = 0; i < 2000; ++i) {
    hw::MotionSphere s;
    s.center[0] = hw::Vec3(rng.next_float(), rng.next_float(), rng.next_float()) * 40.0f - hw::Vec3(20.0f);
    s.center[1] = s.center[0] + hw::Vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, 0.0f) * 4.0f;
    s.radius[0] = 0.1f + 0.4f * rng.next_float();
    s.radius[1] = i % 2 ? s.radius[0] : 0.1f + 0.4f * rng.next_float();
    g.spheres.push_back(s);
  }
  const oracle::EmbreeMotionScene embree(g);
  const Traced tr = trace_both(g, 5, rng);
  const std::vector<hw::Ray>& rays = tr.rays;
  const std::vector<float>& times = tr.times;
  const std::vector<hw::Hit>&fh = tr.fh, &xh = tr.xh;
  uint64_t hit_miss = 0, t_off = 0, both = 0, fixed_agree = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const hw::Hit e = embree.intersect(rays[i], times[i]);
    fixed_agree += xh[i].hit() == fh[i].hit();
    if (e.hit() != fh[i].hit()) {
      ++hit_miss;
      continue;
    }
    if (!e.hit()) continue;
    ++both;
    // Spheres: the float bound of tests/oracle/test_embree.cpp (32 eps S / cos), cos from the sphere's normal.
    const hw::Sphere sp = g.spheres[fh[i].prim].at(times[i]);
    const hw::Vec3 p = rays[i].origin + fh[i].t * rays[i].dir;
    const double c =
        std::abs(glm::dot(glm::normalize(hw::DVec3(p - sp.center)), glm::normalize(hw::DVec3(rays[i].dir))));
    const double unit = kEps * scale_of(rays[i], fh[i]) / std::max(c, 1e-3);
    t_off += std::abs(double(fh[i].t) - double(e.t)) * glm::length(hw::DVec3(rays[i].dir)) > 32.0 * unit;
  }
  std::printf(
      "moving spheres, float against Embree: %zu rays, %llu both hit, %llu hit/miss, %llu t beyond bound; "
      "fixed agrees with float on %llu\n",
      rays.size(), (unsigned long long)both, (unsigned long long)hit_miss, (unsigned long long)t_off,
      (unsigned long long)fixed_agree);
  CHECK(double(hit_miss) <= 1e-5 * double(rays.size()));
  CHECK(double(t_off) <= 1e-5 * double(rays.size()));
  CHECK(both > rays.size() / 20);
  // As for triangles: hit/miss changes only within the fixed unit's roundings of a silhouette.
  CHECK(double(fixed_agree) >= 0.999 * double(rays.size()));
}

TEST_CASE("motion: moving curve segments agree with Embree's, and the fixed unit with the float reference",
          "[motion][embree][curve]") {
  // Isolated segments (each with both end spheres: kCurveCapStart), as the oracle builds them.
  hw::Pcg32 rng(31);
  hw::MotionGeometry g;
  const auto v3 = [&](float s) { return hw::Vec3(rng.next_float(), rng.next_float(), rng.next_float()) * s; };
  for (int i = 0; i < 2000; ++i) {
    hw::MotionCurve c;
    const hw::Vec3 p = v3(40.0f) - hw::Vec3(20.0f), q = p + v3(3.0f) - hw::Vec3(1.5f);
    const hw::Vec3 move = i % 3 == 0 ? hw::Vec3(0.0f) : v3(4.0f) - hw::Vec3(2.0f);
    const float r0 = 0.05f + 0.3f * rng.next_float(), r1 = 0.05f + 0.3f * rng.next_float();
    c.key[0] = hw::CurveSegment{p, r0, q, r1, hw::kCurveCapStart};
    c.key[1] =
        hw::CurveSegment{p + move, i % 2 ? r0 : 0.05f + 0.3f * rng.next_float(), q + move, r1, hw::kCurveCapStart};
    g.curves.push_back(c);
  }
  const oracle::EmbreeMotionScene embree(g);
  const Traced tr = trace_both(g, 7, rng);
  const std::vector<hw::Ray>& rays = tr.rays;
  const std::vector<float>& times = tr.times;
  const std::vector<hw::Hit>&fh = tr.fh, &xh = tr.xh;
  // Embree's start cap of an isolated segment is not the sphere at p0 (tests/oracle/test_swept_sphere.cpp: it
  // reaches up to 1.5 radii beyond it), so rays where either tracer's hit is on a start cap (u = 0) are counted
  // apart, not bounded.
  uint64_t hit_miss = 0, other = 0, both = 0, at_caps = 0, starts_inside = 0, fixed_agree = 0;
  // At the shutter's ends (times exactly 0 and 1) Embree 3.13's motion-blurred round curves miss hits on a
  // segment's end sphere that its static curves of the same key frame find (28 of the 1,980 such rays here, each
  // one where ours and the static scene agree): there the key frame's static scene is the oracle.
  const oracle::EmbreeScene key0(g.at(0.0f)), key1(g.at(1.0f));
  for (size_t i = 0; i < rays.size(); ++i) {
    const hw::Hit e = times[i] == 0.0f   ? key0.intersect(rays[i])
                      : times[i] == 1.0f ? key1.intersect(rays[i])
                                         : embree.intersect(rays[i], times[i]);
    fixed_agree += xh[i].hit() == fh[i].hit();
    if ((e.hit() && e.u == 0.0f) || (fh[i].hit() && fh[i].u == 0.0f)) {
      at_caps += e.hit() != fh[i].hit() || e.prim != fh[i].prim;
      continue;
    }
    if (e.hit() != fh[i].hit()) {
      ++hit_miss;
      continue;
    }
    if (!e.hit()) continue;
    ++both;
    // Another segment named only where two surfaces meet the ray within rounding of the same t (32 eps S, the
    // triangles' allowance of tests/oracle/test_embree.cpp).
    const double dt = std::abs(double(fh[i].t) - double(e.t)) * glm::length(hw::DVec3(rays[i].dir));
    if (e.prim == fh[i].prim || dt <= 32.0 * kEps * scale_of(rays[i], fh[i])) continue;
    // A ray that starts inside a segment: ours reports the nearest crossing of its surface, Embree's curves may
    // not report one (counted apart).
    const hw::CurveSegment c = g.curves[fh[i].prim].at(times[i]);
    bool inside = false;
    for (int k = 0; k <= 1024 && !inside; ++k) {
      const float u = float(k) / 1024.0f;
      inside = glm::length(rays[i].origin - (c.p0 + u * (c.p1 - c.p0))) < c.r0 + u * (c.r1 - c.r0);
    }
    (inside ? starts_inside : other) += 1;
  }
  std::printf(
      "moving curves, float against Embree: %zu rays, %llu both hit, %llu hit/miss, %llu other segments, %llu "
      "differ at start caps, %llu start inside a segment; fixed agrees with float on %llu\n",
      rays.size(), (unsigned long long)both, (unsigned long long)hit_miss, (unsigned long long)other,
      (unsigned long long)at_caps, (unsigned long long)starts_inside, (unsigned long long)fixed_agree);
  // As for static curves (tests/oracle/test_swept_sphere.cpp): the float test is within a float ulp of the exact
  // union, Embree's within its own rounding, so away from the start caps they disagree only within rounding of a
  // silhouette: 1e-5.
  CHECK(double(hit_miss) <= 1e-5 * double(rays.size()));
  CHECK(double(other) <= 1e-5 * double(rays.size()));
  CHECK(both > rays.size() / 20);
  // As for triangles and spheres: hit/miss changes only within the fixed unit's roundings of a silhouette.
  CHECK(double(fixed_agree) >= 0.999 * double(rays.size()));
}

TEST_CASE("motion: instances with two transforms agree with Embree's, and the fixed unit with the float reference",
          "[motion][instancing][embree]") {
  const host::MotionInstanceScene scene = host::builtin_motion_instances(4);
  const hw::MotionInstancedFloatTracer ours(scene.set);
  const oracle::EmbreeMotionInstances embree(scene.set);
  const hw::MotionGeometry flat = scene.set.flatten();  // numbers the triangles for cos_theta
  host::MotionRays rays = host::motion_frame_rays(scene.camera, 320, 240, 2, 21);
  hw::Aabb all;
  for (uint32_t i = 0; i < scene.set.set.instances.size(); ++i)
    for (int k = 0; k < 2; ++k) all.extend(scene.set.key_bounds(i, k));
  const std::vector<hw::Ray> inc = host::incoherent_rays(all, 50000, 22);
  hw::Pcg32 rng(23);
  for (size_t i = 0; i < inc.size(); ++i) {
    rays.rays.push_back(inc[i]);
    rays.times.push_back(i % 101 == 0 ? float(i % 2) : rng.next_float());
  }
  std::vector<hw::Hit> hits, fixed;
  hw::TraversalStats s;
  ours.trace_batch(rays.rays, rays.times, hits, false, 0, s);
  const hw::FixedFormat f = hw::format_preset("default");
  hw::TracerOptions opt;
  opt.bvh.width = f.width;
  hw::MotionInstancedFixedTracer(scene.set, f, {}, opt).trace_batch(rays.rays, rays.times, fixed, false, 0, s);
  uint64_t hit_miss = 0, t_off = 0, both = 0, fixed_hit_miss = 0;
  double worst = 0.0;
  for (size_t i = 0; i < hits.size(); ++i) {
    const hw::Ray& r = rays.rays[i];
    const hw::Hit e = embree.intersect(r, rays.times[i]);
    fixed_hit_miss += fixed[i].hit() != hits[i].hit();
    if (e.hit() != hits[i].hit()) {
      ++hit_miss;
      continue;
    }
    if (!e.hit()) continue;
    ++both;
    // As for static instances of similarities (test_embree.cpp: 64 eps S / cos): the interpolated transforms here
    // stay similarities (a uniform scale and a turn about one axis, interpolated entrywise, are another such).
    // Embree interpolates the matrix in float, two roundings an entry (2 eps of it), and inverts it in float:
    // per tracer 3 x 2 eps S more per coordinate of the object ray, 18 eps S / cos at the hit; ours in double.
    // 64 + 18 = 82: 96 used.
    const double unit = kEps * scale_of(r, hits[i]) / cos_theta(flat, r, hits[i], rays.times[i]);
    const double err = std::abs(double(hits[i].t) - double(e.t)) * glm::length(hw::DVec3(r.dir));
    if (err > 96.0 * unit)
      ++t_off;
    else
      worst = std::max(worst, err / unit);
  }
  std::printf(
      "moving instances, float against Embree: %zu rays, %llu both hit, %llu hit/miss, %llu t beyond bound (worst "
      "%.2f eps S/cos); fixed against float: %llu hit/miss\n",
      hits.size(), (unsigned long long)both, (unsigned long long)hit_miss, (unsigned long long)t_off, worst,
      (unsigned long long)fixed_hit_miss);
  INFO(hits.size() << " rays, " << both << " both hit, " << hit_miss << " hit/miss, " << t_off << " t off");
  CHECK(double(hit_miss) <= 1e-5 * double(hits.size()));
  CHECK(double(t_off) <= 1e-5 * double(hits.size()));
  CHECK(both > hits.size() / 4);
  // The fixed unit: its grid is 2^-17 of the scene, far below a triangle of the balls; silhouette rays may differ.
  CHECK(double(fixed_hit_miss) <= 1e-3 * double(hits.size()));
}
