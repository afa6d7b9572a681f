// Axis-aligned bounding box in float world space.
#pragma once

#include <algorithm>
#include <limits>

#include "hwmodel/interface/vec.h"

namespace rtu::hw {

struct Aabb {
  Vec3 lo{std::numeric_limits<float>::infinity()};   // minimum corner; +inf when empty
  Vec3 hi{-std::numeric_limits<float>::infinity()};  // maximum corner; -inf when empty

  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void extend(const Vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void extend(const Aabb& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  Vec3 extent() const { return hi - lo; }
  Vec3 center() const { return 0.5f * (lo + hi); }
  // Half the surface area (the SAH only uses ratios); 0 for an empty box.
  float half_area() const {
    if (empty()) return 0.0f;
    Vec3 e = extent();
    return e.x * e.y + e.y * e.z + e.z * e.x;
  }
  int largest_axis() const {
    Vec3 e = extent();
    return e.x >= e.y && e.x >= e.z ? 0 : (e.y >= e.z ? 1 : 2);
  }
  bool contains(const Aabb& b) const {
    return lo.x <= b.lo.x && lo.y <= b.lo.y && lo.z <= b.lo.z && hi.x >= b.hi.x && hi.y >= b.hi.y &&
           hi.z >= b.hi.z;
  }
};

}  // namespace rtu::hw
