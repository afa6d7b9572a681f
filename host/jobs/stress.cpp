#include "host/jobs/stress.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>

#include "host/io/error.h"
#include "host/scene/generators.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/rng.h"

namespace rtu::host {

namespace {

using hw::Ray;
using hw::Vec3;
using Json = nlohmann::ordered_json;
constexpr float kInf = std::numeric_limits<float>::infinity();

// Both devices on one scene and one ray set; the fixed device checks every box test exactly.
struct Run {
  std::vector<hw::Hit> fl, fx;
  hw::TraversalStats sfl, sfx;
};

Run run_both(const hw::Geometry& g, const StressOptions& o, const std::vector<Ray>& rays, bool any_hit = false) {
  hw::TracerOptions topt;
  topt.accel = g.num_bounded() > 1 ? hw::AccelMode::kBvh : hw::AccelMode::kAuto;
  topt.bvh.width = o.format.width;
  const hw::FloatTracer fl(g, topt);
  const hw::DeviceImage img = hw::encode_scene(g, o.format, fl.bvh());
  const hw::FixedTracer fx(img, hw::FixedTraceOptions{true});
  Run r;
  r.fl.resize(rays.size());
  r.fx.resize(rays.size());
  fl.trace_batch(rays.data(), r.fl.data(), rays.size(), any_hit, o.threads, r.sfl);
  fx.trace_batch(rays.data(), r.fx.data(), rays.size(), any_hit, o.threads, r.sfx);
  return r;
}

uint64_t misses(const std::vector<hw::Hit>& h) {
  return uint64_t(std::count_if(h.begin(), h.end(), [](const hw::Hit& x) { return !x.hit(); }));
}
uint64_t hits(const std::vector<hw::Hit>& h) {
  return h.size() - misses(h);
}

Json device_json(const std::vector<hw::Hit>& h, const hw::TraversalStats& s) {
  Json j;
  j["hits"] = hits(h);
  j["misses"] = misses(h);
  j["invalid_rays"] = s.invalid_rays;
  if (s.box_checks) {
    j["box_checks"] = s.box_checks;
    j["box_false_negatives"] = s.box_false_negatives;
  }
  j["saturations"] = s.saturations;
  return j;
}

hw::Geometry geometry_of(const IndexedMesh& m) {
  hw::Geometry g;
  append_triangles(m, g.triangles);
  return g;
}

IndexedMesh translated(IndexedMesh m, Vec3 offset) {
  for (Vec3& v : m.vertices) v += offset;
  return m;
}

Vec3 random_in(hw::Pcg32& rng, Vec3 center, float half) {
  return center + half * Vec3(2.0f * rng.next_float() - 1.0f, 2.0f * rng.next_float() - 1.0f,
                              2.0f * rng.next_float() - 1.0f);
}

// Rays from points around `inside` (within `spread`) at vertices or edge points of random faces.
std::vector<Ray> rays_at_mesh_edges(const IndexedMesh& m, Vec3 inside, float spread, uint64_t n, hw::Pcg32& rng) {
  std::vector<Ray> rays(n);
  for (Ray& r : rays) {
    const auto& f = m.faces[rng.next_u32() % m.faces.size()];
    const int k = int(rng.next_u32() % 3);
    const Vec3& a = m.vertices[f[size_t(k)]];
    const Vec3& c = m.vertices[f[size_t((k + 1) % 3)]];
    const float s = (rng.next_u32() & 1) ? 0.0f : rng.next_float();
    const Vec3 target = a + s * (c - a);
    const Vec3 o = random_in(rng, inside, spread);
    r = Ray{o, 0.0f, target - o, kInf};
  }
  return rays;
}

// Leaks on both devices count as failures; box false negatives too.
void tally_closed(StressResult& res, const Run& r, const char* variant) {
  const uint64_t lf = misses(r.fl), lx = misses(r.fx);
  res.cases += r.fl.size();
  res.failures += lf + lx + r.sfx.box_false_negatives + r.sfl.invalid_rays + r.sfx.invalid_rays;
  res.figures[variant] = {{"rays", r.fl.size()},
                          {"float", device_json(r.fl, r.sfl)},
                          {"fixed", device_json(r.fx, r.sfx)},
                          {"leaks_float", lf},
                          {"leaks_fixed", lx}};
}

// ---- Categories

void nan_inf(const StressOptions& o, StressResult& res) {
  res.checks = "rays with NaN/Inf origins, directions and intervals, zero directions, far origins";
  res.failure_rule =
      "a bad ray not rejected with its reason (validate_ray; origins out of the frame for fixed), or a hit "
      "reported for it";
  const hw::Geometry g = geometry_of(make_box(Vec3(2.0f)));
  hw::Pcg32 rng(o.seed);
  const float specials[] = {std::numeric_limits<float>::quiet_NaN(), kInf, -kInf, 0.0f, -0.0f, 1e38f, -1e-38f};
  std::vector<Ray> rays(o.count);
  for (Ray& r : rays) {
    r = Ray{random_in(rng, Vec3(0.0f), 3.0f), 0.0f, random_in(rng, Vec3(0.0f), 1.0f), kInf};
    // Poison one to three of the eight fields.
    const int n = 1 + int(rng.next_u32() % 3);
    float fields[8];
    static_assert(sizeof fields == sizeof(Ray));
    std::memcpy(fields, &r, sizeof r);
    for (int i = 0; i < n; ++i) fields[rng.next_u32() % 8] = specials[rng.next_u32() % 7];
    std::memcpy(&r, fields, sizeof r);
    if (rng.next_u32() % 8 == 0) r.dir = Vec3(0.0f, -0.0f, 0.0f);
  }
  const Run run = run_both(g, o, rays);
  // Expected reasons: validate_ray for both devices; the fixed device also rejects valid rays whose origin lies
  // 2^(B+G) grid steps or more from the frame origin (checked here in double, away from the boundary).
  const hw::QuantFrame frame = hw::QuantFrame::fit(g.bounds(), o.format.coord_bits);
  const double reach = std::ldexp(frame.step(), o.format.coord_bits + o.format.guard_bits);
  std::array<uint64_t, 8> want_fl{}, want_fx{};
  uint64_t bad = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    const hw::RayStatus st = hw::validate_ray(rays[i]);
    hw::RayStatus st_fx = st;
    if (st == hw::RayStatus::kOk) {
      for (int a = 0; a < 3; ++a)
        if (std::abs(double(rays[i].origin[a]) - frame.to_world(0, a)) >= reach)
          st_fx = hw::RayStatus::kOutOfFrame;
    }
    ++want_fl[size_t(st)];
    ++want_fx[size_t(st_fx)];
    if ((st != hw::RayStatus::kOk && run.fl[i].hit()) || (st_fx != hw::RayStatus::kOk && run.fx[i].hit())) ++bad;
  }
  const uint64_t expected_float = rays.size() - want_fl[0], expected_fixed = rays.size() - want_fx[0];
  for (size_t k = 1; k < 8; ++k) {
    bad += run.sfl.invalid_by_reason[k] != want_fl[k];
    bad += run.sfx.invalid_by_reason[k] != want_fx[k];
  }
  res.cases = rays.size();
  res.failures = bad;
  res.figures["invalid_expected"] = {{"float", expected_float}, {"fixed", expected_fixed}};
  res.figures["float"] = device_json(run.fl, run.sfl);
  res.figures["fixed"] = device_json(run.fx, run.sfx);
}

void axis_parallel(const StressOptions& o, StressResult& res) {
  res.checks = "axis-parallel rays with +0/-0 components, from inside a closed box and from outside at its faces";
  res.failure_rule = "a miss (the box is closed, or the ray aims at a face interior), or a box false negative";
  const Vec3 c(0.5f, 0.25f, -0.75f);
  const hw::Geometry g = geometry_of(translated(make_box(Vec3(2.0f)), c));
  hw::Pcg32 rng(o.seed + 1);
  std::vector<Ray> rays(o.count);
  for (size_t i = 0; i < rays.size(); ++i) {
    const int axis = int(rng.next_u32() % 3);
    const float sign = (rng.next_u32() & 1) ? 1.0f : -1.0f;
    Vec3 dir((rng.next_u32() & 1) ? 0.0f : -0.0f, (rng.next_u32() & 1) ? 0.0f : -0.0f,
             (rng.next_u32() & 1) ? 0.0f : -0.0f);
    dir[axis] = sign * (0.5f + rng.next_float());
    Vec3 origin = random_in(rng, c, 0.999f);
    if (i % 2 == 1) origin[axis] = c[axis] - sign * (2.0f + 10.0f * rng.next_float());  // outside, facing in
    rays[i] = Ray{origin, 0.0f, dir, kInf};
  }
  tally_closed(res, run_both(g, o, rays), "box");
}

void box_faces_edges(const StressOptions& o, StressResult& res) {
  res.checks =
      "rays from inside closed boxes aimed exactly at their edges and corners, in a grid of boxes whose faces "
      "touch (BVH boxes share planes)";
  res.failure_rule = "a miss, or a box the fixed test rejects that exact arithmetic accepts";
  IndexedMesh cells;
  // 4 x 4 x 4 unit cubes, edge 1, touching: faces at integer coordinates (exact in float and on the grid).
  for (int x = 0; x < 4; ++x)
    for (int y = 0; y < 4; ++y)
      for (int z = 0; z < 4; ++z) {
        const IndexedMesh b = translated(make_box(Vec3(1.0f)), Vec3(x + 0.5f, y + 0.5f, z + 0.5f));
        const uint32_t base = uint32_t(cells.vertices.size());
        cells.vertices.insert(cells.vertices.end(), b.vertices.begin(), b.vertices.end());
        for (auto f : b.faces) cells.faces.push_back({f[0] + base, f[1] + base, f[2] + base});
      }
  const hw::Geometry g = geometry_of(cells);
  hw::Pcg32 rng(o.seed + 2);
  std::vector<Ray> rays(o.count);
  for (Ray& r : rays) {
    const Vec3 cell(float(rng.next_u32() % 4), float(rng.next_u32() % 4), float(rng.next_u32() % 4));
    Vec3 target = cell + Vec3(float(rng.next_u32() & 1), float(rng.next_u32() & 1), float(rng.next_u32() & 1));
    if (rng.next_u32() & 1) {  // a point on an edge instead of a corner
      const int ax = int(rng.next_u32() % 3);
      target[ax] = cell[ax] + rng.next_float();
    }
    const Vec3 o2 = cell + Vec3(0.5f) +
                    0.45f * Vec3(2.0f * rng.next_float() - 1.0f, 2.0f * rng.next_float() - 1.0f,
                                 2.0f * rng.next_float() - 1.0f);
    r = Ray{o2, 0.0f, target - o2, kInf};
  }
  tally_closed(res, run_both(g, o, rays), "cells");
}

void closed_mesh_edges(const StressOptions& o, StressResult& res) {
  res.checks =
      "rays from inside a closed icosphere at its shared vertices and edges, centered and far from the origin";
  res.failure_rule = "a ray that escapes (a miss), on either device; a box false negative";
  hw::Pcg32 rng(o.seed + 3);
  for (const auto& [name, offset] :
       {std::pair{"centered", Vec3(0.0f)}, std::pair{"far", Vec3(148376.0f, 1234.0f, -223423.0f)}}) {
    const IndexedMesh m = make_icosphere(4, 1.0f, offset);
    const std::vector<Ray> rays = rays_at_mesh_edges(m, offset, 0.5f, o.count, rng);
    tally_closed(res, run_both(geometry_of(m), o, rays), name);
  }
}

void fans_needles(const StressOptions& o, StressResult& res) {
  res.checks =
      "a closed cone of 1024 needle triangles (apex fan) and its base fan, rays at the shared vertices and edges";
  res.failure_rule = "a ray from inside that escapes; a box false negative";
  IndexedMesh cone;
  const int n = 1024;
  cone.vertices.push_back(Vec3(0.0f, 4.0f, 0.0f));  // apex
  cone.vertices.push_back(Vec3(0.0f, 0.0f, 0.0f));  // base center
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * 3.141592653589793 * i / n;
    cone.vertices.push_back(Vec3(float(0.5 * std::cos(a)), 0.0f, float(0.5 * std::sin(a))));
  }
  for (int i = 0; i < n; ++i) {
    const uint32_t a = 2 + uint32_t(i), b = 2 + uint32_t((i + 1) % n);
    cone.faces.push_back({0, b, a});
    cone.faces.push_back({1, a, b});
  }
  hw::Pcg32 rng(o.seed + 4);
  std::vector<Ray> rays = rays_at_mesh_edges(cone, Vec3(0.0f, 1.0f, 0.0f), 0.15f, o.count, rng);
  tally_closed(res, run_both(geometry_of(cone), o, rays), "cone");
}

void self_intersection(const StressOptions& o, StressResult& res) {
  res.checks =
      "rays spawned outward from hit points on a convex closed mesh (icosphere), with origin offsets of 0 and of "
      "the recommended spawn offset";
  res.failure_rule =
      "any hit from an offset origin (a convex surface cannot be hit again going outward); hits from the raw hit "
      "point are self-intersections, reported but not failures";
  const Vec3 offset(3.0f, -2.0f, 7.0f);
  const IndexedMesh m = make_icosphere(4, 2.0f, offset);
  const hw::Geometry g = geometry_of(m);
  const hw::QuantFrame frame = hw::QuantFrame::fit(g.bounds(), o.format.coord_bits);
  hw::Pcg32 rng(o.seed + 5);
  // Primary rays from inside hit the surface; then spawn outward from the float hit point.
  std::vector<Ray> first(o.count);
  for (Ray& r : first) r = Ray{random_in(rng, offset, 0.5f), 0.0f, random_in(rng, Vec3(0.0f), 1.0f), kInf};
  const Run hit = run_both(g, o, first);
  // Recommended offsets along the normal: float, 2^-18 relative to the coordinate magnitude (64 float ulps);
  // fixed, 4 grid steps (the quantized surface is within half a step of the float one, the origin within
  // 2^-F-1 steps; the rest covers the direction rounding), and at least 8 float ulps so the float origin is
  // not rounded back onto the surface.
  const float mag = std::max({std::abs(offset.x), std::abs(offset.y), std::abs(offset.z)}) + 2.0f;
  const double eps[2] = {std::ldexp(double(mag), -18), std::max(4.0 * frame.step(), std::ldexp(double(mag), -21))};
  uint64_t fails = 0;
  for (int dev = 0; dev < 2; ++dev) {
    const std::vector<hw::Hit>& h = dev == 0 ? hit.fl : hit.fx;
    std::vector<Ray> raw, shifted;
    for (size_t i = 0; i < h.size(); ++i) {
      if (!h[i].hit()) continue;
      const hw::Triangle& t = g.triangles[h[i].prim];
      const Vec3 nrm = glm::normalize(glm::cross(t.v1 - t.v0, t.v2 - t.v0));  // outward (CCW from outside)
      const Vec3 p = first[i].origin + h[i].t * first[i].dir;
      Vec3 d = random_in(rng, Vec3(0.0f), 1.0f);
      if (glm::dot(d, nrm) < 0.0f) d = -d;
      d += 0.05f * nrm;  // strictly outward
      raw.push_back(Ray{p, 0.0f, d, kInf});
      shifted.push_back(Ray{p + float(eps[dev]) * nrm, 0.0f, d, kInf});
    }
    const Run a = run_both(g, o, raw), b = run_both(g, o, shifted);
    const uint64_t self_raw = hits(dev == 0 ? a.fl : a.fx), self_off = hits(dev == 0 ? b.fl : b.fx);
    res.cases += shifted.size();
    fails += self_off + b.sfx.box_false_negatives + a.sfx.box_false_negatives;
    res.figures[dev == 0 ? "float" : "fixed"] = {{"spawned_rays", shifted.size()},
                                                 {"self_hits_at_zero_offset", self_raw},
                                                 {"offset", eps[dev]},
                                                 {"hits_with_offset", self_off}};
  }
  res.failures = fails;
}

void grazing_spheres(const StressOptions& o, StressResult& res) {
  res.checks =
      "rays passing a sphere at distances r (1 +- 10^-k), k = 1..6, from origins 2 to 50 radii away, and far "
      "from the world origin";
  res.failure_rule =
      "a wrong hit/miss outside the band the format implies (float: 2^-20 r; fixed: 4 grid steps plus the "
      "direction rounding 2^-D times the distance); cases inside the band are counted as ambiguous";
  hw::Pcg32 rng(o.seed + 6);
  for (const auto& [name, center] :
       {std::pair{"centered", Vec3(0.0f)}, std::pair{"far", Vec3(-52000.0f, 91000.0f, 12000.0f)}}) {
    hw::Geometry g;
    const float radius = 1.0f;
    g.spheres.push_back(hw::Sphere{center, radius});
    const hw::QuantFrame frame = hw::QuantFrame::fit(g.bounds(), o.format.coord_bits);
    std::vector<Ray> rays(o.count);
    std::vector<double> dist(o.count), band_fx(o.count), far_ulps(o.count);
    for (size_t i = 0; i < rays.size(); ++i) {
      const hw::DVec3 u = glm::normalize(hw::DVec3(random_in(rng, Vec3(0.0f), 1.0f)) + hw::DVec3(1e-3));
      hw::DVec3 w = glm::normalize(glm::cross(u, hw::DVec3(0.3, 0.5, 0.8)));
      const int k = 1 + int(rng.next_u32() % 6);
      const double b = radius * (1.0 + ((rng.next_u32() & 1) ? 1.0 : -1.0) * std::pow(10.0, -k));
      const double far = 2.0 + 48.0 * rng.next_float();
      const hw::DVec3 cd(center);
      const Vec3 orig(cd - far * u + b * w);  // origin rounded to float
      const Vec3 target(cd + b * w);
      rays[i] = Ray{orig, 0.0f, target - orig, kInf};
      // Exact distance from the center to the float ray's line (double is plenty here).
      const hw::DVec3 od(rays[i].origin), dd(rays[i].dir);
      const hw::DVec3 f = od - cd;
      const hw::DVec3 l = f - glm::dot(f, dd) / glm::dot(dd, dd) * dd;
      dist[i] = glm::length(l);
      band_fx[i] = 4.0 * frame.step() + std::ldexp(glm::length(f), -o.format.dir_bits) * 2.0;
      far_ulps[i] = std::ldexp(glm::length(f) + glm::length(cd), -21);
    }
    const Run r = run_both(g, o, rays);
    uint64_t wrong_fl = 0, wrong_fx = 0, amb_fl = 0, amb_fx = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      const double gap = dist[i] - radius;
      const bool should_hit = gap < 0;
      // Float: the sphere test's rounding of f = o - c and of the direction, a few ulps of |f|, plus 2^-20 r.
      const double band_fl = std::ldexp(double(radius), -20) + far_ulps[i];
      if (std::abs(gap) <= band_fl)
        ++amb_fl;
      else
        wrong_fl += r.fl[i].hit() != should_hit;
      if (std::abs(gap) <= band_fx[i])
        ++amb_fx;
      else
        wrong_fx += r.fx[i].hit() != should_hit;
    }
    res.cases += rays.size();
    res.failures += wrong_fl + wrong_fx + r.sfx.box_false_negatives;
    res.figures[name] = {{"rays", rays.size()},
                         {"float", {{"wrong", wrong_fl}, {"ambiguous", amb_fl}}},
                         {"fixed", {{"wrong", wrong_fx}, {"ambiguous", amb_fx}}}};
  }
}

// Distance from the line through o along d (double) to the segment [a, b]: the closest points of the two lines,
// the segment's parameter clamped to [0, 1] and the line's re-projected (convex: exact in exact arithmetic).
double line_segment_distance(const hw::DVec3& o, const hw::DVec3& d, const hw::DVec3& a, const hw::DVec3& b) {
  const hw::DVec3 e = b - a, w = o - a;
  const double dd = glm::dot(d, d), de = glm::dot(d, e), ee = glm::dot(e, e), dw = glm::dot(d, w),
               ew = glm::dot(e, w), den = dd * ee - de * de;
  double s = den > 1e-300 * dd * ee ? (dd * ew - de * dw) / den : 0.0;
  s = ee > 0.0 ? std::clamp(s, 0.0, 1.0) : 0.0;
  const hw::DVec3 c = a + s * e;
  const hw::DVec3 f = o - c;
  const hw::DVec3 l = f - glm::dot(f, d) / dd * d;
  double best = glm::length(l);
  // The clamp can leave the segment's end closer than the re-projection found: check both ends too.
  for (const hw::DVec3& p : {a, b}) {
    const hw::DVec3 g = o - p;
    best = std::min(best, glm::length(g - glm::dot(g, d) / dd * d));
  }
  return best;
}

void curves(const StressOptions& o, StressResult& res) {
  res.checks =
      "curve segments of constant radius r (capsules): rays passing the axis at r (1 +- 10^-k), k = 1..6, from 2 "
      "to 50 radii away, across and nearly along the axis (end caps), centered and far from the world origin; "
      "zero-length segments (a sphere) and zero-radius segments (no surface)";
  res.failure_rule =
      "a wrong hit/miss outside the band the format implies (float: 2^-20 r plus 2^-21 of the distances; fixed: "
      "8 grid steps plus the direction rounding 2^-D times the distance); any hit on a zero-radius segment";
  hw::Pcg32 rng(o.seed + 12);
  struct Variant {
    const char* name;
    Vec3 center;
    float length;  // 0: a zero-length segment
    bool along;    // rays nearly along the axis, at the end caps
  };
  const Variant variants[] = {{"across", Vec3(0.0f), 6.0f, false},
                              {"along_axis", Vec3(0.0f), 6.0f, true},
                              {"zero_length", Vec3(0.0f), 0.0f, false},
                              {"far", Vec3(-52000.0f, 91000.0f, 12000.0f), 6.0f, false}};
  for (const Variant& v : variants) {
    const float radius = 1.0f;
    const hw::DVec3 axis = glm::normalize(hw::DVec3(0.37, 0.81, -0.45));
    const hw::DVec3 cd(v.center), a = cd - 0.5 * double(v.length) * axis, b = cd + 0.5 * double(v.length) * axis;
    hw::Geometry g;
    const Vec3 fa(a), fb(b);
    g.curves.push_back(hw::CurveSegment{fa, radius, fb, radius, hw::kCurveCapStart});
    const hw::QuantFrame frame = hw::QuantFrame::fit(g.bounds(), o.format.coord_bits);
    std::vector<Ray> rays(o.count);
    std::vector<double> gap(o.count), band_fx(o.count), band_fl(o.count);
    for (size_t i = 0; i < rays.size(); ++i) {
      const int k = 1 + int(rng.next_u32() % 6);
      const double off = radius * (1.0 + ((rng.next_u32() & 1) ? 1.0 : -1.0) * std::pow(10.0, -k));
      const double far = 2.0 + 48.0 * rng.next_float();
      hw::DVec3 u, w;  // u: the ray's direction; w: the offset's, perpendicular to u
      hw::DVec3 target;
      if (v.along) {
        // Toward the segment's p0 from beyond p1, nearly along the axis: the end cap at p1 decides.
        u = glm::normalize(-axis + 1e-3 * hw::DVec3(random_in(rng, Vec3(0.0f), 1.0f)));
        w = glm::normalize(glm::cross(u, hw::DVec3(0.3, 0.5, 0.8)));
        target = b + off * w;
      } else {
        const hw::DVec3 r = glm::normalize(hw::DVec3(random_in(rng, Vec3(0.0f), 1.0f)) + hw::DVec3(1e-3));
        u = glm::normalize(r - glm::dot(r, axis) * axis + 1e-9 * axis);
        w = glm::normalize(glm::cross(u, axis));
        target = a + (0.2 + 0.6 * rng.next_float()) * (b - a) + off * w;
      }
      const Vec3 orig(target - far * u);
      rays[i] = Ray{orig, 0.0f, Vec3(target) - orig, kInf};
      const hw::DVec3 od(rays[i].origin), dd(rays[i].dir);
      gap[i] = line_segment_distance(od, dd, hw::DVec3(fa), hw::DVec3(fb)) - radius;
      const double dist = glm::length(od - cd);
      band_fx[i] = 8.0 * frame.step() + std::ldexp(dist, -o.format.dir_bits) * 2.0;
      band_fl[i] = std::ldexp(double(radius), -20) + std::ldexp(dist + glm::length(cd), -21);
    }
    const Run r = run_both(g, o, rays);
    uint64_t wrong_fl = 0, wrong_fx = 0, amb_fl = 0, amb_fx = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      const bool should_hit = gap[i] < 0;
      if (std::abs(gap[i]) <= band_fl[i])
        ++amb_fl;
      else
        wrong_fl += r.fl[i].hit() != should_hit;
      if (std::abs(gap[i]) <= band_fx[i])
        ++amb_fx;
      else
        wrong_fx += r.fx[i].hit() != should_hit;
    }
    res.cases += rays.size();
    res.failures += wrong_fl + wrong_fx + r.sfx.box_false_negatives;
    res.figures[v.name] = {{"rays", rays.size()},
                           {"float", {{"wrong", wrong_fl}, {"ambiguous", amb_fl}}},
                           {"fixed", {{"wrong", wrong_fx}, {"ambiguous", amb_fx}}}};
  }
  // Zero-radius segments: a line has no surface, so no ray of these hits it, on either device (rays through its
  // points included).
  hw::Geometry g;
  g.curves.push_back(hw::CurveSegment{Vec3(-1.0f, 0.0f, 0.0f), 0.0f, Vec3(1.0f, 0.5f, 0.25f), 0.0f, 0});
  g.curves.push_back(hw::CurveSegment{Vec3(0.0f, 1.0f, 0.0f), 0.0f, Vec3(0.0f, 1.0f, 0.0f), 0.0f, 0});
  g.curves.push_back(hw::CurveSegment{Vec3(0.0f, -1.0f, 0.0f), 1.0f, Vec3(0.0f, -1.0f, 0.0f), 0.0f, 0});
  std::vector<Ray> rays(o.count);
  for (size_t i = 0; i < rays.size(); ++i) {
    const float s = rng.next_float();
    const Vec3 on = i % 2 ? Vec3(-1.0f, 0.0f, 0.0f) + s * Vec3(2.0f, 0.5f, 0.25f) : Vec3(0.0f, 1.0f, 0.0f);
    const Vec3 from = on + 5.0f * glm::normalize(random_in(rng, Vec3(0.0f), 1.0f) + Vec3(1e-3f));
    rays[i] = Ray{from, 0.0f, on - from, 2.0f};
  }
  const Run r = run_both(g, o, rays);
  uint64_t line_fl = 0, line_fx = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    // The third segment (a zero-length one whose end sphere has radius 0 and start sphere radius 1) is a sphere of
    // radius 1 at (0, -1, 0): rays toward y >= 0 from above it may meet it only if they pass within 1 of it.
    line_fl += r.fl[i].hit() && r.fl[i].prim != 2;
    line_fx += r.fx[i].hit() && r.fx[i].prim != 2;
  }
  res.cases += rays.size();
  res.failures += line_fl + line_fx;
  res.figures["zero_radius"] = {{"rays", rays.size()}, {"float_hits", line_fl}, {"fixed_hits", line_fx}};
}

void coordinate_range(const StressOptions& o, StressResult& res) {
  res.checks = "a closed icosphere of radius 1e-8 .. 1e8, centered and offset by 1e3 radii, rays at its edges";
  res.failure_rule = "a leak or an invalid ray on either device; a box false negative";
  hw::Pcg32 rng(o.seed + 7);
  for (float radius : {1e-8f, 1e-4f, 1.0f, 1e4f, 1e8f}) {
    for (float off : {0.0f, 1e3f}) {
      const Vec3 offset = Vec3(off, -0.5f * off, 0.25f * off) * radius;
      const IndexedMesh m = make_icosphere(3, radius, offset);
      const std::vector<Ray> rays = rays_at_mesh_edges(m, offset, 0.5f * radius, o.count / 10 + 1, rng);
      char name[64];
      std::snprintf(name, sizeof name, "r%g_offset%g", double(radius), double(off));
      tally_closed(res, run_both(geometry_of(m), o, rays), name);
    }
  }
}

void degenerate_triangles(const StressOptions& o, StressResult& res) {
  res.checks = "zero-area triangles (a repeated vertex, axis-collinear vertices, one point) among a closed box";
  res.failure_rule = "a hit on a degenerate triangle, or a non-finite t";
  hw::Geometry g = geometry_of(make_box(Vec3(4.0f)));
  const uint32_t first_degenerate = uint32_t(g.triangles.size());
  hw::Pcg32 rng(o.seed + 8);
  for (int i = 0; i < 3000; ++i) {
    const Vec3 a = random_in(rng, Vec3(0.0f), 1.9f), b = random_in(rng, Vec3(0.0f), 1.9f);
    switch (i % 3) {
      case 0:
        g.triangles.push_back(hw::Triangle{a, a, b});
        break;
      case 1: {  // collinear along x: y and z shared, so they stay collinear on the grid
        const Vec3 c(b.x, a.y, a.z), d(0.5f * (a.x + b.x), a.y, a.z);
        g.triangles.push_back(hw::Triangle{a, c, d});
        break;
      }
      default:
        g.triangles.push_back(hw::Triangle{a, a, a});
    }
  }
  std::vector<Ray> rays(o.count);
  for (Ray& r : rays) r = Ray{random_in(rng, Vec3(0.0f), 1.9f), 0.0f, random_in(rng, Vec3(0.0f), 1.0f), kInf};
  const Run r = run_both(g, o, rays);
  uint64_t bad_fl = 0, bad_fx = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    bad_fl += r.fl[i].hit() && (r.fl[i].prim >= first_degenerate || !std::isfinite(r.fl[i].t));
    bad_fx += r.fx[i].hit() && (r.fx[i].prim >= first_degenerate || !std::isfinite(r.fx[i].t));
  }
  res.cases = rays.size();
  res.failures = bad_fl + bad_fx + misses(r.fl) + misses(r.fx) + r.sfx.box_false_negatives;
  res.figures["float"] = device_json(r.fl, r.sfl);
  res.figures["fixed"] = device_json(r.fx, r.sfx);
  res.figures["degenerate_hits"] = {{"float", bad_fl}, {"fixed", bad_fx}};
}

void subgrid_triangles(const StressOptions& o, StressResult& res) {
  res.checks = "triangles smaller than one quantization step (1e-6 in a frame 2000 wide), rays at their centroids";
  res.failure_rule =
      "a box false negative or a non-finite t; triangles that collapse on the grid are lost by design (reported)";
  hw::Geometry g = geometry_of(translated(make_box(Vec3(2000.0f)), Vec3(0.0f)));
  const uint32_t first_tiny = uint32_t(g.triangles.size());
  hw::Pcg32 rng(o.seed + 9);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 p = random_in(rng, Vec3(0.0f), 900.0f);
    g.triangles.push_back(hw::Triangle{p, p + Vec3(1e-6f, 0.0f, 0.0f), p + Vec3(0.0f, 1e-6f, 0.0f)});
  }
  std::vector<Ray> rays(o.count);
  for (Ray& r : rays) {
    const hw::Triangle& t = g.triangles[first_tiny + rng.next_u32() % 2000];
    const Vec3 c = (t.v0 + t.v1 + t.v2) / 3.0f;
    const Vec3 orig = c + Vec3(0.0f, 0.0f, 1.0f);
    r = Ray{orig, 0.0f, c - orig, kInf};
  }
  const Run r = run_both(g, o, rays);
  uint64_t tiny_fl = 0, tiny_fx = 0, bad = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    tiny_fl += r.fl[i].hit() && r.fl[i].prim >= first_tiny;
    tiny_fx += r.fx[i].hit() && r.fx[i].prim >= first_tiny;
    bad += (r.fl[i].hit() && !std::isfinite(r.fl[i].t)) + (r.fx[i].hit() && !std::isfinite(r.fx[i].t));
  }
  res.cases = rays.size();
  res.failures = bad + r.sfx.box_false_negatives;
  res.figures["tiny_triangle_hits"] = {{"float", tiny_fl}, {"fixed", tiny_fx}};
  res.figures["grid_step"] = hw::QuantFrame::fit(g.bounds(), o.format.coord_bits).step();
}

void determinism(const StressOptions& o, StressResult& res) {
  res.checks = "the same incoherent rays on 1 and 2 threads, twice, on both devices";
  res.failure_rule = "any difference in hit bits or statistics";
  const IndexedMesh m = make_torus(1.0f, 0.3f, 64, 32);
  const hw::Geometry g = geometry_of(m);
  hw::Pcg32 rng(o.seed + 10);
  std::vector<Ray> rays(o.count);
  for (Ray& r : rays) r = Ray{random_in(rng, Vec3(0.0f), 1.5f), 0.0f, random_in(rng, Vec3(0.0f), 1.0f), kInf};
  StressOptions one = o, two = o;
  one.threads = 1;
  two.threads = 2;
  const Run a = run_both(g, one, rays), b = run_both(g, two, rays);
  auto same = [](const std::vector<hw::Hit>& x, const std::vector<hw::Hit>& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(hw::Hit)) == 0;
  };
  auto same_stats = [](const hw::TraversalStats& x, const hw::TraversalStats& y) {
    return x.nodes_visited == y.nodes_visited && x.prim_tests == y.prim_tests && x.box_tests == y.box_tests &&
           x.hits == y.hits && x.saturations == y.saturations;
  };
  res.cases = 2 * rays.size();
  res.failures = uint64_t(!same(a.fl, b.fl)) + uint64_t(!same(a.fx, b.fx)) + uint64_t(!same_stats(a.sfl, b.sfl)) +
                 uint64_t(!same_stats(a.sfx, b.sfx)) + a.sfx.box_false_negatives;
  res.figures["float"] = device_json(a.fl, a.sfl);
  res.figures["fixed"] = device_json(a.fx, a.sfx);
}

struct Category {
  const char* name;
  void (*run)(const StressOptions&, StressResult&);
};

const Category kCategories[] = {
    {"nan_inf", nan_inf},
    {"axis_parallel", axis_parallel},
    {"box_faces_edges", box_faces_edges},
    {"closed_mesh_edges", closed_mesh_edges},
    {"fans_needles", fans_needles},
    {"self_intersection", self_intersection},
    {"grazing_spheres", grazing_spheres},
    {"curves", curves},
    {"coordinate_range", coordinate_range},
    {"degenerate_triangles", degenerate_triangles},
    {"subgrid_triangles", subgrid_triangles},
    {"determinism", determinism},
};

}  // namespace

const std::vector<std::string>& stress_categories() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const Category& c : kCategories) v.push_back(c.name);
    return v;
  }();
  return names;
}

std::vector<StressResult> run_stress(const StressOptions& o, const std::vector<std::string>& only) {
  o.format.validate();
  for (const std::string& n : only) {
    if (std::find(stress_categories().begin(), stress_categories().end(), n) == stress_categories().end())
      throw Error("stress: unknown category '" + n + "'");
  }
  std::vector<StressResult> out;
  for (const Category& c : kCategories) {
    if (!only.empty() && std::find(only.begin(), only.end(), c.name) == only.end()) continue;
    StressResult r;
    r.name = c.name;
    const auto start = std::chrono::steady_clock::now();
    c.run(o, r);
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace rtu::host
