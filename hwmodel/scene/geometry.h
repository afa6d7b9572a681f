// Scene geometry as the unit sees it: world-space triangles, spheres and planes, indexed in one space.
// Primitive index p counts triangles first (in import order), then spheres, then planes.
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

// The unbounded plane {x : dot(x, normal) = offset}. Kept out of the BVH.
struct Plane {
  Vec3 normal;   // need not be unit length
  float offset;  // c in dot(x, n) = c
};

enum class PrimKind : uint8_t { kTriangle, kSphere, kPlane };

struct Geometry {
  struct Counts {
    uint32_t triangles = 0, spheres = 0, planes = 0;
  };

  std::vector<Triangle> triangles;
  std::vector<Sphere> spheres;
  std::vector<Plane> planes;
  // Per triangle, 1 where the triangle is not opaque (alpha-tested: its candidate hits go to the any-hit stage,
  // any_hit.h); empty when every triangle is opaque.
  std::vector<uint8_t> non_opaque;

  Counts counts() const { return {uint32_t(triangles.size()), uint32_t(spheres.size()), uint32_t(planes.size())}; }
  uint32_t num_prims() const { return uint32_t(triangles.size() + spheres.size() + planes.size()); }
  // Primitives that go into a BVH (triangles and spheres): indices [0, num_bounded()).
  uint32_t num_bounded() const { return uint32_t(triangles.size() + spheres.size()); }
  PrimKind kind(uint32_t prim) const {
    if (prim < triangles.size()) return PrimKind::kTriangle;
    return prim < num_bounded() ? PrimKind::kSphere : PrimKind::kPlane;
  }
  bool opaque(uint32_t prim) const { return prim >= non_opaque.size() || !non_opaque[prim]; }
  uint32_t sphere_prim(uint32_t i) const { return uint32_t(triangles.size()) + i; }
  uint32_t plane_prim(uint32_t i) const { return num_bounded() + i; }
  Aabb prim_bounds(uint32_t prim) const {
    return prim < triangles.size() ? triangles[prim].bounds() : spheres[prim - triangles.size()].bounds();
  }
  // Bounds of the bounded primitives (planes excluded).
  Aabb bounds() const {
    Aabb b;
    for (const Triangle& t : triangles) b.extend(t.bounds());
    for (const Sphere& s : spheres) b.extend(s.bounds());
    return b;
  }
};

}  // namespace rtu::hw
