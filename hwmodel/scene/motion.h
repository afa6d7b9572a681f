// Moving geometry for motion blur: triangles given at two key frames, shutter time 0 and 1, that move linearly
// between them (DXR's and Vulkan's motion triangles, Embree 3's two time steps), and the BVH over them. Each
// child slot of a node holds its box at both key frames; the box at a time in between is their linear
// interpolation, which contains every primitive below it at that time (docs/numerics.md, "Motion blur").
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "hwmodel/scene/aabb.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

// A ray's shutter time is valid in [0, 1] (false for NaN).
inline bool valid_shutter_time(float time) {
  return time >= 0.0f && time <= 1.0f;
}

// (1 - time) a + time b per component, in double, rounded to float once. Two triangles sharing a key-frame
// vertex share it at every time, so a watertight mesh stays watertight while it moves.
inline Vec3 lerp_point(const Vec3& a, const Vec3& b, float time) {
  const double s = time, r = 1.0 - s;
  return Vec3(float(r * a.x + s * b.x), float(r * a.y + s * b.y), float(r * a.z + s * b.z));
}

struct MotionTriangle {
  Triangle key[2];  // the triangle at shutter time 0 and at time 1

  Triangle at(float time) const {
    return Triangle{lerp_point(key[0].v0, key[1].v0, time), lerp_point(key[0].v1, key[1].v1, time),
                    lerp_point(key[0].v2, key[1].v2, time)};
  }
  // The box over the whole shutter: both key frames (linear motion stays inside their hull).
  Aabb swept_bounds() const {
    Aabb b = key[0].bounds();
    b.extend(key[1].bounds());
    return b;
  }
};

// A sphere whose center and radius move linearly between the key frames (Embree's moving sphere points).
struct MotionSphere {
  Vec3 center[2];
  float radius[2];  // > 0 at both key frames

  Sphere at(float time) const {
    return Sphere{lerp_point(center[0], center[1], time),
                  float((1.0 - double(time)) * double(radius[0]) + double(time) * double(radius[1]))};
  }
  // center -+ radius in double, rounded outward to floats (a float sum rounded to nearest could cut into the
  // sphere by half an ulp, and a ray leaving the sphere there would miss its box).
  Aabb key_bounds(int k) const {
    Aabb b;
    for (int a = 0; a < 3; ++a) {
      const double lo = double(center[k][a]) - double(radius[k]), hi = double(center[k][a]) + double(radius[k]);
      b.lo[a] = float(lo);
      if (double(b.lo[a]) > lo) b.lo[a] = std::nextafter(b.lo[a], -INFINITY);
      b.hi[a] = float(hi);
      if (double(b.hi[a]) < hi) b.hi[a] = std::nextafter(b.hi[a], INFINITY);
    }
    return b;
  }
  Aabb swept_bounds() const {
    Aabb b = key_bounds(0);
    b.extend(key_bounds(1));
    return b;
  }
};

// A segment of a round linear curve whose end points and radii move linearly between the key frames (Embree's
// round linear curves with two time steps). Its cap flag is the first key frame's (both must agree).
struct MotionCurve {
  CurveSegment key[2];

  CurveSegment at(float time) const {
    const double s = time, r = 1.0 - s;
    return CurveSegment{lerp_point(key[0].p0, key[1].p0, time), float(r * key[0].r0 + s * key[1].r0),
                        lerp_point(key[0].p1, key[1].p1, time), float(r * key[0].r1 + s * key[1].r1),
                        key[0].flags};
  }
  // Both end spheres' boxes, rounded outward as MotionSphere's.
  Aabb key_bounds(int k) const {
    Aabb b = MotionSphere{{key[k].p0, key[k].p0}, {key[k].r0, key[k].r0}}.key_bounds(0);
    b.extend(MotionSphere{{key[k].p1, key[k].p1}, {key[k].r1, key[k].r1}}.key_bounds(0));
    return b;
  }
  Aabb swept_bounds() const {
    Aabb b = key_bounds(0);
    b.extend(key_bounds(1));
    return b;
  }
};

// A moving scene: triangles are primitives 0 .. n-1, spheres n .. n+m-1, curve segments after them. A static
// primitive has equal key frames.
struct MotionGeometry {
  std::vector<MotionTriangle> triangles;
  std::vector<MotionSphere> spheres;
  std::vector<MotionCurve> curves;
  uint32_t num_prims() const { return uint32_t(triangles.size() + spheres.size() + curves.size()); }
  // Primitive p's box at key frame k, and over the whole shutter.
  Aabb key_bounds(uint32_t p, int k) const {
    if (p < triangles.size()) return triangles[p].key[k].bounds();
    if (p < triangles.size() + spheres.size()) return spheres[p - triangles.size()].key_bounds(k);
    return curves[p - triangles.size() - spheres.size()].key_bounds(k);
  }
  // The scene at one shutter time, as static geometry (for a static frame beside the moving one).
  Geometry at(float time) const;
  // Throws std::invalid_argument naming the first triangle or sphere with a coordinate that is not finite or
  // beyond kMaxCoordinate, a sphere whose radius is not positive, or a curve segment invalid at a key frame
  // (check_curve_segment) or with key frames of different flags.
  void validate() const;
};

// The BVH of a moving scene. Its topology is the binned-SAH tree over the swept boxes (Bvh::build over boxes);
// each child slot holds the box of the primitives below it at key frame 0 and at key frame 1.
struct MotionBvh {
  int width = 4;
  uint32_t root_ref = kEmptyChild;
  std::vector<uint32_t> child;     // node * width + slot: a child reference (bvh.h) or kEmptyChild
  std::vector<Aabb> key_box[2];    // node * width + slot: the child's box at key frame 0 and 1
  std::vector<uint32_t> prim_ids;  // leaf order -> triangle index
  Aabb key_bounds[2];              // the whole scene at each key frame
  uint64_t nodes() const { return child.size() / uint64_t(width); }
  // Child slot `slot`'s box at shutter time `time`: its key boxes interpolated in double, rounded outward to
  // float.
  void box_at(size_t slot, float time, float lo[3], float hi[3]) const;

  // Throws std::invalid_argument for an empty scene, an invalid one (validate) or bad parameters.
  static MotionBvh build(const MotionGeometry& g, const BvhBuildParams& params = {});
  // The same over items given by their boxes at both key frames (instances with two transforms,
  // motion_instances.h): the topology over each item's union of both. Throws std::invalid_argument for no items,
  // sizes that differ, an empty or non-finite box, or bad parameters.
  static MotionBvh build(const std::vector<Aabb>& key0, const std::vector<Aabb>& key1,
                         const BvhBuildParams& params = {});
};

}  // namespace rtu::hw
