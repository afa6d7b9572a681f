// The float reference datapath: ray-box, ray-triangle, ray-sphere and ray-plane tests in IEEE single precision.
// Pure functions: inputs -> outputs; statistics and traversal live around them.
//
// - Box: slab test with the conservative margin of Ize, "Robust BVH Ray Traversal" (JCGT 2013), as in pbrt-v4:
//   t_far is scaled by 1 + 2 gamma(3) so rounding never culls a box the exact test accepts. Zero direction
//   components give +-inf reciprocals; a 0 * inf NaN (origin exactly on a slab plane) counts as inside the slab.
// - Triangle: the watertight test of Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection" (JCGT 2013):
//   vertices are translated to the ray origin and sheared so the ray is +z, then three edge functions decide.
//   Evaluated in double (see below). A ray through a shared edge or vertex of a closed mesh hits at least one
//   of its triangles.
// - Sphere: the quadratic with the discriminant in the form of Haines et al., "Precision Improvements for
//   Ray/Sphere Intersection" (Ray Tracing Gems, 2019), and roots by the stable q-form (no cancellation).
// - Plane: t = (c - p.n) / (d.n); a ray parallel to the plane (d.n == 0) misses.
// - Linear swept sphere: the cone tangent to two end spheres and the sphere at its end, in double (below).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>

#include "hwmodel/interface/ray.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

inline constexpr float kFloatEps = 0x1p-24f;  // unit roundoff of float (half an ulp of 1)
constexpr float gamma_n(int n) {
  return (n * kFloatEps) / (1.0f - n * kFloatEps);
}
inline constexpr float kIzeScale = 1.0f + 2.0f * gamma_n(3);  // scales t_far of the slab test

// Per-ray values shared by every box and triangle test of one traversal.
struct RayPrecomp {
  Vec3 origin;
  Vec3 dir;
  Vec3 inv_dir;    // 1/d per axis (+-inf for +-0)
  int near_lo[3];  // 1 when the near slab plane on that axis is the low plane (inv_dir >= 0, including +inf)
  int kx, ky, kz;  // Woop: kz = axis of largest |d|, kx, ky the others (swapped to keep winding)
  float sx, sy, sz;

  explicit RayPrecomp(const Ray& r) : origin(r.origin), dir(r.dir) {
    for (int a = 0; a < 3; ++a) {
      inv_dir[a] = 1.0f / r.dir[a];
      near_lo[a] = std::signbit(inv_dir[a]) ? 0 : 1;
    }
    Vec3 ad = glm::abs(r.dir);
    kz = ad.x >= ad.y && ad.x >= ad.z ? 0 : (ad.y >= ad.z ? 1 : 2);
    kx = kz == 2 ? 0 : kz + 1;
    ky = kx == 2 ? 0 : kx + 1;
    if (r.dir[kz] < 0.0f) {
      int t = kx;
      kx = ky;
      ky = t;
    }
    sx = r.dir[kx] / r.dir[kz];
    sy = r.dir[ky] / r.dir[kz];
    sz = 1.0f / r.dir[kz];
  }
};

// Slab test of one box given as lo/hi per axis. On overlap of [tmin, tmax] returns true and the entry distance.
inline bool intersect_box(const float lo[3], const float hi[3], const RayPrecomp& r, float tmin, float tmax,
                          float& t_enter) {
  float t0 = tmin, t1 = tmax;
  for (int a = 0; a < 3; ++a) {
    float tn = ((r.near_lo[a] ? lo[a] : hi[a]) - r.origin[a]) * r.inv_dir[a];
    float tf = ((r.near_lo[a] ? hi[a] : lo[a]) - r.origin[a]) * r.inv_dir[a];
    tf *= kIzeScale;
    // Written so that a NaN (0 * inf) leaves the interval unchanged.
    t0 = tn > t0 ? tn : t0;
    t1 = tf < t1 ? tf : t1;
  }
  t_enter = t0;
  return t0 <= t1;
}

inline bool intersect_box(const Aabb& b, const RayPrecomp& r, float tmin, float tmax, float& t_enter) {
  const float lo[3] = {b.lo.x, b.lo.y, b.lo.z};
  const float hi[3] = {b.hi.x, b.hi.y, b.hi.z};
  return intersect_box(lo, hi, r, tmin, tmax, t_enter);
}

// The children of a float wide node the ray enters within [tmin, tmax]: their refs and entry distances in child
// order, their count returned; `tested` counts the non-empty children. The expand step of the float tracers.
template <int N>
inline int expand_wide_node(const WideNode<N>& n, const RayPrecomp& rp, float tmin, float tmax, uint32_t refs[N],
                            float dists[N], int& tested) {
  int k = 0;
  for (int i = 0; i < N; ++i) {
    if (n.child[i] == kEmptyChild) continue;
    ++tested;
    const float lo[3] = {n.bounds[0][i], n.bounds[2][i], n.bounds[4][i]};
    const float hi[3] = {n.bounds[1][i], n.bounds[3][i], n.bounds[5][i]};
    float t;
    if (intersect_box(lo, hi, rp, tmin, tmax, t)) {
      refs[k] = n.child[i];
      dists[k] = t;
      ++k;
    }
  }
  return k;
}

struct PrimHit {
  float t;
  float u, v;
};

// Watertight triangle test. Returns true for a hit with tmin <= t <= tmax (either facing).
// The translated and sheared vertices, the edge functions, det and the scaled t are computed in double: the
// translation of float vertices is exact there, so an edge function depends only on its two vertices and the
// ray and is the exact negation of its neighbour's (watertight), and t keeps float accuracy on long thin
// triangles, where float edge functions lose ~10 bits (seen on CAD meshes). Results are rounded to float once.
inline bool intersect_triangle(const Vec3& v0, const Vec3& v1, const Vec3& v2, const RayPrecomp& r, float tmin,
                               float tmax, PrimHit& out) {
  const double ox = r.origin[r.kx], oy = r.origin[r.ky], oz = r.origin[r.kz];
  const double sx = r.sx, sy = r.sy, sz = r.sz;
  const double az = double(v0[r.kz]) - oz, bz = double(v1[r.kz]) - oz, cz = double(v2[r.kz]) - oz;
  const double ax = (double(v0[r.kx]) - ox) - sx * az, ay = (double(v0[r.ky]) - oy) - sy * az;
  const double bx = (double(v1[r.kx]) - ox) - sx * bz, by = (double(v1[r.ky]) - oy) - sy * bz;
  const double cx = (double(v2[r.kx]) - ox) - sx * cz, cy = (double(v2[r.ky]) - oy) - sy * cz;
  const double u = cx * by - cy * bx;
  const double v = ax * cy - ay * cx;
  const double w = bx * ay - by * ax;
  if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) return false;
  const double det = u + v + w;
  if (det == 0.0) return false;
  const double t = (u * az + v * bz + w * cz) * sz / det;
  if (!(t >= double(tmin) && t <= double(tmax))) return false;
  out.t = float(t);
  if (out.t < tmin || out.t > tmax) return false;  // rounding to float may cross an end of the interval
  out.u = float(v / det);
  out.v = float(w / det);
  return true;
}

inline bool intersect_triangle(const Triangle& tri, const RayPrecomp& r, float tmin, float tmax, PrimHit& out) {
  return intersect_triangle(tri.v0, tri.v1, tri.v2, r, tmin, tmax, out);
}

// Sphere: the nearest root in [tmin, tmax] (the far root when the near one is before tmin).
inline bool intersect_sphere(const Vec3& center, float radius, const RayPrecomp& r, float tmin, float tmax,
                             PrimHit& out) {
  const Vec3 f = r.origin - center;
  const float a = glm::dot(r.dir, r.dir);
  const float b = -glm::dot(f, r.dir);  // -b/2 of the textbook quadratic
  const float c = glm::dot(f, f) - radius * radius;
  // (b^2 - a c) / a = r^2 - |f + (b/a) d|^2: the squared distance from the center to the line, without the
  // cancellation of b^2 - a c.
  const Vec3 l = f + (b / a) * r.dir;
  const float disc = a * (radius * radius - glm::dot(l, l));
  if (!(disc >= 0.0f)) return false;
  const float q = b + std::copysign(std::sqrt(disc), b);
  float t0, t1;
  if (q == 0.0f) {
    t0 = t1 = 0.0f;  // b == 0 and disc == 0: the origin touches the sphere tangentially
  } else {
    t0 = c / q;
    t1 = q / a;
  }
  if (t0 > t1) std::swap(t0, t1);
  float t = t0;
  if (t < tmin) t = t1;
  if (t < tmin || t > tmax) return false;
  out.t = t;
  out.u = out.v = 0.0f;  // filled for the final hit only (sphere_uv)
  return true;
}

// Linear swept sphere (a round linear curve segment, the hair primitive of NVIDIA's Blackwell RT core and Embree's
// RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE): the spheres centered on p0 + s (p1 - p0) of radius r0 + s (r1 - r0),
// s in [0, 1]. As Embree builds a segment (kernels/geometry/roundline_intersector.h): the cone tangent to the end
// spheres between its two circles of tangency, plus the sphere at p1; the sphere at p0 only with `start_cap` (a
// strand's first segment; the others get it from the segment before). The nearest crossing of these surfaces in
// [tmin, tmax]: from outside, where the ray enters the exact union of the spheres (tests/oracle/
// test_swept_sphere.cpp: within a float ulp of it; Embree's start cap differs). u = s of the hit (0 or 1 on the
// end spheres), v = 0.
//
// In double, relative to p0 (thin, long segments far from the origin keep their digits). The cone is the
// envelope of the spheres: a point q = x - p0 lies on sphere s's circle of tangency when (q - s ba) . ba =
// -r(s) dr, so s = (q . ba + r0 dr) / (|ba|^2 - dr^2), linear along the ray, and |q - s ba|^2 = r(s)^2 is a
// quadratic in t; its roots count where 0 <= s <= 1. When one end sphere holds the other (|ba| <= |dr|) there is
// no cone and the segment is its larger sphere.
inline bool intersect_swept_sphere(const Vec3& p0, float r0, const Vec3& p1, float r1, bool start_cap,
                                   const RayPrecomp& r, float tmin, float tmax, PrimHit& out) {
  if (!(r0 > 0.0f) && !(r1 > 0.0f)) return false;  // a line: no surface (as the fixed test)
  using D3 = glm::dvec3;
  const D3 o = D3(r.origin) - D3(p0), d = D3(r.dir), ba = D3(p1) - D3(p0);
  const double R0 = r0, R1 = r1, dr = R1 - R0, L2 = glm::dot(ba, ba), a = glm::dot(d, d);
  double best = std::numeric_limits<double>::infinity(), best_s = 0.0;
  const auto consider = [&](double t, double s) {
    if (t >= double(tmin) && t <= double(tmax) && t < best) {
      best = t;
      best_s = s;
    }
  };
  // A sphere's roots, as intersect_sphere forms them (Haines et al.), in double.
  const auto sphere = [&](const D3& c, double R, double s) {
    if (!(R > 0.0)) return;  // a point: no surface
    const D3 f = o - c;
    const double b = -glm::dot(f, d);
    const D3 l = f + (b / a) * d;
    const double disc = a * (R * R - glm::dot(l, l));
    if (!(disc >= 0.0)) return;
    const double q = b + std::copysign(std::sqrt(disc), b);
    if (q == 0.0) return consider(0.0, s);
    consider((glm::dot(f, f) - R * R) / q, s);
    consider(q / a, s);
  };
  sphere(ba, R1, 1.0);
  if (start_cap || L2 <= dr * dr) sphere(D3(0.0), R0, 0.0);
  const double K = L2 - dr * dr;
  if (K > 0.0) {
    // s(t) = alpha + beta t; q(t) - s(t) ba = u + t w; r(s(t)) = rho + t sigma.
    const double alpha = (glm::dot(o, ba) + R0 * dr) / K, beta = glm::dot(d, ba) / K;
    const D3 u = o - alpha * ba, w = d - beta * ba;
    const double rho = R0 + alpha * dr, sigma = beta * dr;
    const double A = glm::dot(w, w) - sigma * sigma, B = glm::dot(u, w) - rho * sigma,
                 C = glm::dot(u, u) - rho * rho;
    const auto lateral = [&](double t) {
      const double s = alpha + beta * t;
      if (s >= 0.0 && s <= 1.0) consider(t, s);
    };
    if (A != 0.0) {
      const double disc = B * B - A * C;
      if (disc >= 0.0) {
        const double q = -(B + std::copysign(std::sqrt(disc), B));
        if (q != 0.0) lateral(C / q);
        lateral(q / A);
      }
    } else if (B != 0.0) {
      lateral(-C / (2.0 * B));  // the ray parallel to a generator of the cone
    }
  }
  if (best == std::numeric_limits<double>::infinity()) return false;  // no crossing in [tmin, tmax]
  out.t = float(best);
  if (out.t < tmin || out.t > tmax) return false;  // rounding to float may cross an end of the interval
  out.u = float(best_s);
  out.v = 0.0f;
  return true;
}

// Longitude/(2 pi) and colatitude/pi of a point on a sphere, the u, v of sphere hits.
inline void sphere_uv(const Vec3& center, const Vec3& p, float& u, float& v) {
  const Vec3 n = p - center;
  const float len = glm::length(n);
  if (!(len > 0.0f)) {
    u = v = 0.0f;
    return;
  }
  float phi = std::atan2(n.z, n.x);
  if (phi < 0.0f) phi += 2.0f * 3.14159265358979f;
  u = std::min(phi / (2.0f * 3.14159265358979f), std::nextafter(1.0f, 0.0f));
  v = std::acos(std::clamp(n.y / len, -1.0f, 1.0f)) / 3.14159265358979f;
}

inline bool intersect_plane(const Plane& p, const RayPrecomp& r, float tmin, float tmax, PrimHit& out) {
  const float dn = glm::dot(r.dir, p.normal);
  if (dn == 0.0f) return false;
  const float t = (p.offset - glm::dot(r.origin, p.normal)) / dn;
  if (!(t >= tmin && t <= tmax)) return false;
  out.t = t;
  out.u = out.v = 0.0f;
  return true;
}

}  // namespace rtu::hw
