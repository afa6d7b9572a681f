// The quantization frame: world space -> an integer grid. One power-of-two step for all three axes (so spheres
// stay spheres and the ray parameter t is the same in world and grid space), and a grid origin that is a
// multiple of the step, so that converting a float coordinate to the grid is exact before the one rounding.
//
// fit(bounds, B) chooses the smallest step 2^e with which the bounds cover grid coordinates [0, 2^B - 1]:
// lo rounds down to >= 0, hi rounds up to <= 2^B - 1. B is a run-time parameter (2..40).
#pragma once

#include <cstdint>

#include "hwmodel/numeric/fixed.h"
#include "hwmodel/scene/aabb.h"

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
  // The same for a finite x where every intermediate stays below 2^62 in 64 bits (frames near the world origin,
  // coordinates within a few powers of two of the frame: the common case); false where it does not (then
  // to_grid). Never saturates: its results are below 2^61 in magnitude. Inline, for ray setup.
  bool to_grid_64(float x, int axis, Round r, int frac_bits, int64_t& g) const {
    // x = m * 2^k exactly, with m a 24-bit integer; (x - origin * 2^e) / 2^e * 2^f = m * 2^(k - e + f) - origin *
    // 2^f.
    int64_t m;
    int k;
    split_float(x, m, k);
    const int sh = k - step_exp + frac_bits;
    const int64_t og = origin[axis];
    if (og <= -(int64_t(1) << 36) || og >= (int64_t(1) << 36)) return false;
    const int64_t o64 = og << frac_bits;  // |o64| < 2^60
    if (m == 0) {  // +-0: exactly the frame origin's negative (its exponent would send it down the slow path)
      g = -o64;
      return true;
    }
    if (sh >= 0) {
      if (sh > 36) return false;
      g = (m << sh) - o64;  // |m << sh| < 2^60: |g| < 2^61
      return true;
    }
    const int ns = -sh;
    const int64_t oa = o64 < 0 ? -o64 : o64;
    if (ns > 36 || oa >= (int64_t(1) << (60 - ns))) return false;  // |o64 << ns| < 2^60
    g = round_shift64(m - o64 * (int64_t(1) << ns), ns, r);        // below 2^61 before the shift
    return true;
  }
  // World coordinate of grid value g (exact when |origin + g| < 2^53).
  double to_world(int64_t g, int axis) const;
};

}  // namespace rtu::hw
