// Lockstep comparison of two devices' hits on identical rays: the per-ray metrics of `rtusim compare` and of the
// demo's report.
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/interface/ray.h"

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
  double t_rel_sd = 0.0;  // sample standard deviation of the relative error over the t_compared rays
  uint64_t t_rel_max_ray = 0;
  // The same hits' error as a distance along the ray, |t_dev - t_ref| |d|, in grid steps of the device's
  // quantization frame (0 when no grid step was given). A ray starting on a surface has a tiny t_ref: its relative
  // error can be large while its distance error is a fraction of a step.
  double t_abs_steps_max = 0.0, t_abs_steps_mean = 0.0;
  uint64_t t_abs_steps_max_ray = 0;
  std::vector<RayDisagreement> disagreements;  // every disagreeing ray, in ray order

  double hit_agreement() const { return compared ? double(hit_agree) / double(compared) : 1.0; }
  double prim_agreement() const { return compared ? double(prim_agree) / double(compared) : 1.0; }
};

// valid[i]: ray i was valid on both devices (invalid rays are not compared). For any-hit queries only hit/miss
// is compared. t relative error = |t_dev - t_ref| / |t_ref|; with `rays` and a grid step (world units) the
// distance error in steps too.
HitComparison compare_hits(const std::vector<hw::Hit>& ref, const std::vector<hw::Hit>& dev,
                           const std::vector<bool>& valid, bool any_hit,
                           const std::vector<hw::Ray>* rays = nullptr, double grid_step = 0.0);

}  // namespace rtu::host
