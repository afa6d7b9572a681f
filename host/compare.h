// Lockstep comparison of two devices' hits on identical rays: the per-ray metrics of `rtusim compare` and of the
// demo's report.
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/ray.h"

namespace rtu::host {

enum class Disagreement : uint8_t { kFalseMiss, kFalseHit, kOtherPrimitive };
const char* disagreement_name(Disagreement d);

struct RayDisagreement {
  uint64_t ray;  // index into the ray set
  Disagreement kind;
};

struct HitComparison {
  uint64_t rays = 0;      // all rays
  uint64_t compared = 0;  // rays valid on both devices
  uint64_t hit_agree = 0, prim_agree = 0;
  uint64_t false_misses = 0;  // reference hit, device miss
  uint64_t false_hits = 0;    // reference miss, device hit
  uint64_t other_prim = 0;    // both hit, different primitives (closest hit only)
  uint64_t t_compared = 0;    // both hit the same primitive
  double t_rel_max = 0.0, t_rel_mean = 0.0;
  uint64_t t_rel_max_ray = 0;
  std::vector<RayDisagreement> disagreements;  // every disagreeing ray, in ray order

  double hit_agreement() const { return compared ? double(hit_agree) / double(compared) : 1.0; }
  double prim_agreement() const { return compared ? double(prim_agree) / double(compared) : 1.0; }
};

// valid[i]: ray i was valid on both devices (invalid rays are not compared). For any-hit queries only hit/miss
// is compared. t relative error = |t_dev - t_ref| / |t_ref|.
HitComparison compare_hits(const std::vector<hw::Hit>& ref, const std::vector<hw::Hit>& dev,
                           const std::vector<bool>& valid, bool any_hit);

}  // namespace rtu::host
