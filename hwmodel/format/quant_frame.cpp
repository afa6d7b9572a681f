#include "hwmodel/format/quant_frame.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rtu::hw {

double QuantFrame::step() const {
  return pow2(step_exp);
}

double QuantFrame::to_world(int64_t g, int axis) const {
  return std::ldexp(double(origin[axis] + g), step_exp);
}

int64_t QuantFrame::to_grid(float x, int axis, Round r, int frac_bits) const {
  if (std::isnan(x)) {
    ++saturation_counter();
    return 0;
  }
  if (std::isinf(x)) {
    ++saturation_counter();
    return x > 0 ? kGridLimit : -kGridLimit;
  }
  int64_t g64;
  if (to_grid_64(x, axis, r, frac_bits, g64)) return g64;
  int64_t m;
  int k;
  split_float(x, m, k);
  const int sh = k - step_exp + frac_bits;
  const Wide o = Wide(origin[axis]) << frac_bits;  // |origin| < 2^52, frac_bits <= 24: below 2^76
  Wide g;
  const Wide beyond = Wide(kGridLimit) + 1;  // any value past the limit; saturates below
  if (sh >= 0) {
    g = sh > 64 ? (m > 0 ? beyond : -beyond) : (Wide(m) << sh) - o;
  } else if (-sh <= 40) {
    g = round_shift(Wide(m) - (o << -sh), -sh, r);  // below 2^117
  } else {
    // |m * 2^sh| < 2^-16: the result is -origin, or one step off it by the sign of m and the rounding.
    g = -o;
    if (m > 0 && r == Round::kUp) g += 1;
    if (m < 0 && r == Round::kDown) g -= 1;
  }
  if (g > kGridLimit || g < -kGridLimit) {
    ++saturation_counter();
    return g > 0 ? kGridLimit : -kGridLimit;
  }
  return int64_t(g);
}

QuantFrame QuantFrame::fit(const Aabb& b, int bits) {
  if (bits < kMinBits || bits > kMaxBits) throw std::invalid_argument("coordinate bits must be in [2, 40]");
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(b.lo[a]) || !std::isfinite(b.hi[a]) || b.lo[a] > b.hi[a])
      throw std::invalid_argument("quantization frame: empty or non-finite bounds");
  }
  const double extent = std::max({double(b.hi.x) - b.lo.x, double(b.hi.y) - b.lo.y, double(b.hi.z) - b.lo.z});
  const double mag = std::max({std::abs(double(b.lo.x)), std::abs(double(b.lo.y)), std::abs(double(b.lo.z)),
                               std::abs(double(b.hi.x)), std::abs(double(b.hi.y)), std::abs(double(b.hi.z))});
  // Start below the ideal step and grow until the bounds fit; a zero extent starts from the magnitude.
  int e = (extent > 0.0 ? std::ilogb(extent) : (mag > 0.0 ? std::ilogb(mag) - 24 : -149)) - bits - 1;
  for (;; ++e) {
    QuantFrame f;
    f.bits = bits;
    f.step_exp = e;
    bool ok = true;
    for (int a = 0; a < 3 && ok; ++a) {
      f.origin[a] = 0;
      const int64_t lo = f.to_grid(b.lo[a], a, Round::kDown);  // relative to world 0
      f.origin[a] = lo;
      ok = f.to_grid(b.hi[a], a, Round::kUp) <= f.grid_max() && std::abs(lo) < (int64_t(1) << 52);
    }
    if (ok) return f;
  }
}

}  // namespace rtu::hw
