// The quantization frame: bounds fit the grid with the smallest step, and float -> grid conversion rounds
// exactly as asked. The checks compare grid values back in world space, where the comparisons are exact
// (grid points are dyadic doubles), so they do not repeat the conversion's algorithm.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "hwmodel/quant_frame.h"

using namespace rtu::hw;

namespace {

void check_rounding(const QuantFrame& f, float x, int a) {
  const int64_t dn = f.to_grid(x, a, Round::kDown), up = f.to_grid(x, a, Round::kUp);
  const int64_t ne = f.to_grid(x, a, Round::kNearestEven);
  const double xd = x;
  INFO("x " << x << " axis " << a << " down " << dn << " up " << up << " nearest " << ne);
  REQUIRE(f.to_world(dn, a) <= xd);
  REQUIRE(f.to_world(dn + 1, a) > xd);
  REQUIRE(f.to_world(up, a) >= xd);
  REQUIRE(f.to_world(up - 1, a) < xd);
  REQUIRE((up == dn || up == dn + 1));
  if (up == dn) {
    REQUIRE(ne == dn);
  } else {
    const double mid = std::ldexp(2.0 * double(f.origin[a] + dn) + 1.0, f.step_exp - 1);  // exact
    if (xd < mid) REQUIRE(ne == dn);
    if (xd > mid) REQUIRE(ne == up);
    if (xd == mid) REQUIRE(ne == (dn % 2 == 0 ? dn : up));
  }
}

}  // namespace

TEST_CASE("quantization frame: bounds fit with the smallest power-of-two step", "[fixed][frame]") {
  const Aabb boxes[] = {
      {Vec3(-1.0f), Vec3(1.0f)},
      {Vec3(148375.0f, 1233.0f, -223424.0f), Vec3(148377.0f, 1235.0f, -223422.0f)},  // far from the origin
      {Vec3(1e-8f, 2e-8f, -3e-8f), Vec3(5e-8f, 2e-8f, 1e-8f)},                       // tiny, one flat axis
      {Vec3(-1e8f, -3.0f, 0.0f), Vec3(1e8f, 7.0f, 0.0f)},                            // huge
      {Vec3(3.0f), Vec3(3.0f)},                                                      // a single point
  };
  for (const Aabb& b : boxes) {
    for (int bits : {2, 8, 12, 16, 24, 32, 40}) {
      const QuantFrame f = QuantFrame::fit(b, bits);
      INFO("bits " << bits << " step 2^" << f.step_exp);
      for (int a = 0; a < 3; ++a) {
        CHECK(f.to_grid(b.lo[a], a, Round::kDown) >= 0);
        CHECK(f.to_grid(b.hi[a], a, Round::kUp) <= f.grid_max());
        check_rounding(f, b.lo[a], a);
        check_rounding(f, b.hi[a], a);
      }
      // Minimal: with half the step some axis no longer fits (or its origin leaves the 2^52 range in which
      // grid -> world is exact). A single point fits any step, so it has no smallest one.
      if (b.extent() == Vec3(0.0f)) continue;
      QuantFrame half = f;
      half.step_exp -= 1;
      bool fits = true;
      for (int a = 0; a < 3; ++a) {
        half.origin[a] = 0;
        half.origin[a] = half.to_grid(b.lo[a], a, Round::kDown);
        fits = fits && half.to_grid(b.hi[a], a, Round::kUp) <= half.grid_max() &&
               std::abs(half.origin[a]) < (int64_t(1) << 52);
      }
      CHECK_FALSE(fits);
    }
  }
  CHECK_THROWS(QuantFrame::fit(Aabb{}, 16));
  CHECK_THROWS(QuantFrame::fit(boxes[0], 1));
  CHECK_THROWS(QuantFrame::fit(boxes[0], 41));
}

TEST_CASE("quantization frame: float -> grid rounds exactly, every mode", "[fixed][frame]") {
  const uint32_t seed = 99;
  INFO("seed " << seed);
  std::mt19937 rng(seed);
  const QuantFrame frames[] = {QuantFrame::fit(Aabb{Vec3(-10.0f), Vec3(30.0f)}, 16),
                               QuantFrame::fit(Aabb{Vec3(148375.0f), Vec3(148377.0f)}, 24),
                               QuantFrame::fit(Aabb{Vec3(-1e-6f), Vec3(1e-6f)}, 12)};
  for (const QuantFrame& f : frames) {
    const float lo = float(f.to_world(0, 0)), hi = float(f.to_world(f.grid_max(), 0));
    std::uniform_real_distribution<float> in(lo, hi);
    for (int i = 0; i < 100000; ++i) check_rounding(f, in(rng), i % 3);
    // Grid points and midpoints exactly (ties), tiny values of both signs, zero.
    for (int64_t g = 0; g < 50; ++g) {
      check_rounding(f, float(f.to_world(g, 1)), 1);
      const float mid = float(std::ldexp(2.0 * double(f.origin[1] + g) + 1.0, f.step_exp - 1));
      check_rounding(f, mid, 1);
    }
    for (float x : {0.0f, -0.0f, 1e-38f, -1e-38f, 1e-45f, -1e-45f}) check_rounding(f, x, 2);
  }
  reset_saturation_count();
  const QuantFrame& f = frames[0];
  CHECK(f.to_grid(3e38f, 0, Round::kDown) == QuantFrame::kGridLimit);
  CHECK(f.to_grid(-INFINITY, 0, Round::kUp) == -QuantFrame::kGridLimit);
  CHECK(f.to_grid(NAN, 0, Round::kUp) == 0);
  CHECK(saturation_count() == 3);
}
