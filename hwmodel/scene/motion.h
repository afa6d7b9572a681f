// Moving geometry for motion blur: triangles given at two key frames, shutter time 0 and 1, that move linearly
// between them (DXR's and Vulkan's motion triangles, Embree 3's two time steps), and the BVH over them. Each
// child slot of a node holds its box at both key frames; the box at a time in between is their linear
// interpolation, which contains every primitive below it at that time (docs/numerics.md, "Motion blur").
#pragma once

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

// A moving scene: its triangles are primitives 0 .. n-1. A static triangle has key[0] == key[1].
struct MotionGeometry {
  std::vector<MotionTriangle> triangles;
  // The scene at one shutter time, as static geometry (for a static frame beside the moving one).
  Geometry at(float time) const;
  // Throws std::invalid_argument naming the first triangle with a coordinate that is not finite or beyond
  // kMaxCoordinate.
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

  // Throws std::invalid_argument for an empty scene or bad parameters.
  static MotionBvh build(const MotionGeometry& g, const BvhBuildParams& params = {});
};

}  // namespace rtu::hw
