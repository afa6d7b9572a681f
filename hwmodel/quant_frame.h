// The quantization frame: world space -> an integer grid. One power-of-two step for all three axes (so spheres
// stay spheres and the ray parameter t is the same in world and grid space), and a grid origin that is a
// multiple of the step, so that converting a float coordinate to the grid is exact before the one rounding.
//
// fit(bounds, B) chooses the smallest step 2^e with which the bounds cover grid coordinates [0, 2^B - 1]:
// lo rounds down to >= 0, hi rounds up to <= 2^B - 1. B is a run-time parameter (2..40).
#pragma once

#include <cstdint>

#include "hwmodel/aabb.h"
#include "hwmodel/fixed.h"

namespace rtu::hw {

struct QuantFrame {
  int bits = 0;            // B: scene coordinates are grid integers in [0, 2^B - 1]
  int step_exp = 0;        // grid step = 2^step_exp world units
  int64_t origin[3] = {};  // world position of grid 0 on each axis = origin[a] * 2^step_exp

  static constexpr int kMinBits = 2;
  static constexpr int kMaxBits = 40;
  static constexpr int64_t kGridLimit = int64_t(1) << 61;  // to_grid saturates at +-2^61

  // Throws std::invalid_argument for bits outside [kMinBits, kMaxBits] or empty/non-finite bounds.
  static QuantFrame fit(const Aabb& bounds, int bits);

  int64_t grid_max() const { return (int64_t(1) << bits) - 1; }
  double step() const;
  // (x - origin) / step * 2^frac_bits rounded by r, exactly (no rounding before the final one): the grid
  // coordinate with frac_bits fraction bits (0..24). Saturates (and counts) at +-kGridLimit; NaN saturates to 0
  // and is counted. Infinite x saturates.
  int64_t to_grid(float x, int axis, Round r, int frac_bits = 0) const;
  // World coordinate of grid value g (exact when |origin + g| < 2^53).
  double to_world(int64_t g, int axis) const;
};

}  // namespace rtu::hw
