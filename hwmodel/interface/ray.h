// Ray and hit records: the layout of the user-facing ray and hit files (docs/file-formats.md) and of
// the ray/hit buffers the unit reads and writes. Little-endian, no padding.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "hwmodel/interface/vec.h"

namespace rtu::hw {

// A ray x = origin + t * dir, for t in [tmin, tmax].
struct Ray {
  Vec3 origin;  // ox oy oz: world-space origin
  float tmin;   // start of the t interval (usually 0 or a small offset)
  Vec3 dir;     // dx dy dz: direction, need not be normalized; t is in units of |dir|
  float tmax;   // end of the t interval; +inf for an unbounded ray
};
static_assert(sizeof(Ray) == 32);
static_assert(offsetof(Ray, origin) == 0 && offsetof(Ray, tmin) == 12);
static_assert(offsetof(Ray, dir) == 16 && offsetof(Ray, tmax) == 28);

inline constexpr uint32_t kMissPrim = 0xFFFFFFFFu;
inline constexpr uint32_t kNoPrim = kMissPrim;

// Result of one ray. On a miss: t = +inf, prim = kMissPrim, u = v = 0.
// u, v: triangle barycentrics with hit point (1-u-v) v0 + u v1 + v v2 (Embree's convention); for a sphere the
// hit normal's longitude/(2 pi) in [0,1) and colatitude/pi in [0,1]; for a plane 0, 0.
struct Hit {
  float t = std::numeric_limits<float>::infinity();  // ray parameter of the hit
  uint32_t prim = kMissPrim;                         // scene primitive index: triangles, then spheres, then planes
  float u = 0.0f;                                    // see above
  float v = 0.0f;                                    // see above
  bool hit() const { return prim != kMissPrim; }
};
static_assert(sizeof(Hit) == 16);
static_assert(offsetof(Hit, t) == 0 && offsetof(Hit, prim) == 4 && offsetof(Hit, u) == 8 &&
              offsetof(Hit, v) == 12);

// Why a ray was rejected at ray setup. The value is the reason code reported in stats and errors.
enum class RayStatus : uint8_t {
  kOk = 0,
  kNanOrigin = 1,      // an origin component is NaN
  kInfOrigin = 2,      // an origin component is +-inf
  kNanDirection = 3,   // a direction component is NaN
  kInfDirection = 4,   // a direction component is +-inf
  kZeroDirection = 5,  // all direction components are +-0
  kNanInterval = 6,    // tmin or tmax is NaN, or tmin is +-inf
  kOutOfFrame = 7,     // (fixed-point devices) not representable in the scene's quantization frame
};

const char* ray_status_name(RayStatus s);

// Validity of a ray for every device. An empty interval (tmin > tmax) is valid and simply misses.
inline RayStatus validate_ray(const Ray& r) {
  for (int a = 0; a < 3; ++a) {
    if (std::isnan(r.origin[a])) return RayStatus::kNanOrigin;
    if (std::isinf(r.origin[a])) return RayStatus::kInfOrigin;
  }
  for (int a = 0; a < 3; ++a) {
    if (std::isnan(r.dir[a])) return RayStatus::kNanDirection;
    if (std::isinf(r.dir[a])) return RayStatus::kInfDirection;
  }
  if (r.dir.x == 0.0f && r.dir.y == 0.0f && r.dir.z == 0.0f) return RayStatus::kZeroDirection;
  if (std::isnan(r.tmin) || std::isnan(r.tmax) || std::isinf(r.tmin)) return RayStatus::kNanInterval;
  return RayStatus::kOk;
}

}  // namespace rtu::hw
