// Scene geometry as the unit sees it: world-space triangles, spheres, curve segments and planes, indexed in one
// space. Primitive index p counts triangles first (in import order), then spheres, then curve segments, then
// planes (a scene without curves numbers its planes as before curves existed).
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/interface/vec.h"
#include "hwmodel/scene/aabb.h"

namespace rtu::hw {

// Largest magnitude of a scene coordinate, sphere radius, plane offset or normal component accepted at import and
// at BIND_SCENE: the product of two stays finite in float (2^124 < FLT_MAX), so bounds, centroids and the float
// datapath's dot products never overflow to Inf or NaN.
inline constexpr float kMaxCoordinate = 0x1p62f;

struct Triangle {
  Vec3 v0, v1, v2;  // vertices; winding does not matter (no culling)
  Aabb bounds() const {
    Aabb b;
    b.extend(v0);
    b.extend(v1);
    b.extend(v2);
    return b;
  }
};

struct Sphere {
  Vec3 center;   // world-space center
  float radius;  // > 0
  Aabb bounds() const { return Aabb{center - Vec3(radius), center + Vec3(radius)}; }
};

// One segment of a round linear curve (a linear swept sphere, the hair primitive of NVIDIA's Blackwell RT core and
// Embree's RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE): the union of the spheres centered on p0 + s (p1 - p0) of radius
// r0 + s (r1 - r0), s in [0, 1]. A strand is a chain of segments that share end points. As in Embree, a segment
// holds the sphere at p1 but the one at p0 only with kCurveCapStart (a strand's first segment); a later segment's
// start sphere is its predecessor's end sphere. intersect_float.h has the test.
struct CurveSegment {
  Vec3 p0;
  float r0;  // >= 0
  Vec3 p1;
  float r1;        // >= 0; r0 + r1 > 0
  uint32_t flags;  // kCurveCapStart
  Aabb bounds() const {
    Aabb b{p0 - Vec3(r0), p0 + Vec3(r0)};
    b.extend(Aabb{p1 - Vec3(r1), p1 + Vec3(r1)});
    return b;
  }
};
inline constexpr uint32_t kCurveCapStart = 1u << 0;
static_assert(sizeof(CurveSegment) == 36);
// Empty when the segment is valid: finite end points and radii within kMaxCoordinate, radii >= 0 (0 allowed: a
// zero-radius end is a cone's tip; both zero, a segment no ray hits), no unknown flags. Else what is wrong.
inline const char* check_curve_segment(const CurveSegment& c) {
  const auto in = [](float v) { return v >= -kMaxCoordinate && v <= kMaxCoordinate; };  // false for NaN
  for (int a = 0; a < 3; ++a)
    if (!in(c.p0[a]) || !in(c.p1[a])) return "an end point is not finite or beyond 2^62";
  if (!(c.r0 >= 0.0f && c.r0 <= kMaxCoordinate && c.r1 >= 0.0f && c.r1 <= kMaxCoordinate))
    return "a radius is negative, not finite or beyond 2^62";
  if (c.flags & ~kCurveCapStart) return "unknown flags";
  return "";
}

// The unbounded plane {x : dot(x, normal) = offset}. Kept out of the BVH.
struct Plane {
  Vec3 normal;   // need not be unit length
  float offset;  // c in dot(x, n) = c
};

enum class PrimKind : uint8_t { kTriangle, kSphere, kPlane, kCurve };

struct Geometry {
  struct Counts {
    uint32_t triangles = 0, spheres = 0, planes = 0, curves = 0;
  };

  std::vector<Triangle> triangles;
  std::vector<Sphere> spheres;
  std::vector<Plane> planes;
  std::vector<CurveSegment> curves;  // segments of round linear curves
  // Per triangle, 1 where the triangle is not opaque (alpha-tested: its candidate hits go to the any-hit stage,
  // any_hit.h); empty when every triangle is opaque.
  std::vector<uint8_t> non_opaque;

  Counts counts() const {
    return {uint32_t(triangles.size()), uint32_t(spheres.size()), uint32_t(planes.size()),
            uint32_t(curves.size())};
  }
  uint32_t num_prims() const {
    return uint32_t(triangles.size() + spheres.size() + curves.size() + planes.size());
  }
  // Primitives that go into a BVH (triangles, spheres, curve segments): indices [0, num_bounded()).
  uint32_t num_bounded() const { return uint32_t(triangles.size() + spheres.size() + curves.size()); }
  // Spheres and curve segments, the round primitives: indices [triangles.size(), num_bounded()).
  uint32_t num_round() const { return uint32_t(spheres.size() + curves.size()); }
  PrimKind kind(uint32_t prim) const {
    if (prim < triangles.size()) return PrimKind::kTriangle;
    if (prim < triangles.size() + spheres.size()) return PrimKind::kSphere;
    return prim < num_bounded() ? PrimKind::kCurve : PrimKind::kPlane;
  }
  bool opaque(uint32_t prim) const { return prim >= non_opaque.size() || !non_opaque[prim]; }
  uint32_t sphere_prim(uint32_t i) const { return uint32_t(triangles.size()) + i; }
  uint32_t curve_prim(uint32_t i) const { return uint32_t(triangles.size() + spheres.size()) + i; }
  uint32_t plane_prim(uint32_t i) const { return num_bounded() + i; }
  const CurveSegment& curve(uint32_t prim) const { return curves[prim - triangles.size() - spheres.size()]; }
  Aabb prim_bounds(uint32_t prim) const {
    if (prim < triangles.size()) return triangles[prim].bounds();
    if (prim < triangles.size() + spheres.size()) return spheres[prim - triangles.size()].bounds();
    return curve(prim).bounds();
  }
  // Bounds of the bounded primitives (planes excluded).
  Aabb bounds() const {
    Aabb b;
    for (const Triangle& t : triangles) b.extend(t.bounds());
    for (const Sphere& s : spheres) b.extend(s.bounds());
    for (const CurveSegment& c : curves) b.extend(c.bounds());
    return b;
  }
};

}  // namespace rtu::hw
