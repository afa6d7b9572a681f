// The quantization frame: bounds fit the grid with the smallest step, and float -> grid conversion rounds
// exactly as asked, with and without fraction bits (fraction bits equal a finer frame). The checks compare grid
// values back in world space, where the comparisons are exact (grid points are dyadic doubles), so they do not
// repeat the conversion's algorithm.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

#include "fixed_checks.h"
#include "hwmodel/format/quant_frame.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

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

TEST_CASE("quantization frame: fraction bits equal a finer frame, rounding checked in world space",
          "[fixed][frame]") {
  const uint64_t seed = 4711;
  INFO("seed " << seed);
  Pcg32 rng(seed);
  const int bit_choices[] = {8, 12, 16, 20, 24, 28, 32};
  uint64_t samples = 0, world_checked = 0, ties = 0;
  for (int fi = 0; fi < 70; ++fi) {
    const QuantFrame frame = random_frame(rng, bit_choices[fi % 7]);
    for (int fb : {1, 3, 8, 13, 24}) {
      INFO("frame bits " << frame.bits << " step 2^" << frame.step_exp << " origin " << frame.origin[0] << " "
                         << frame.origin[1] << " " << frame.origin[2] << " frac_bits " << fb);
      // The finer frame: step 2^(e - f), origin * 2^f (when that fits in int64).
      QuantFrame fine = frame;
      fine.step_exp -= fb;
      bool fine_ok = true;
      for (int a = 0; a < 3; ++a) {
        if (std::abs(frame.origin[a]) >= (int64_t(1) << (61 - fb))) fine_ok = false;
        fine.origin[a] = fine_ok ? frame.origin[a] * (int64_t(1) << fb) : 0;
      }
      for (int i = 0; i < 120; ++i) {
        const int a = i % 3;
        const Wide of = Wide(frame.origin[a]) << fb;  // the fine grid's origin
        // World value of fine grid value g: exact in double when |of + g| < 2^53.
        auto exact_world = [&](Wide g) { return std::abs(double(of + g)) < 0x1p53; };
        auto world = [&](Wide g) { return std::ldexp(double(of + g), frame.step_exp - fb); };
        float x;
        const int kind = int(rng.next_u32() % 6);
        const Wide span = Wide(1) << (frame.bits + fb);
        if (kind == 0) {  // inside the frame, any float
          x = float(frame.to_world(0, a) + frame.step() * rand_double(rng, 0.0, double(frame.grid_max())));
        } else if (kind == 1 || kind == 2) {  // a fine grid point or a fine midpoint (a tie), when a float
          const Wide g = Wide(rand_int(rng, 0, int64_t(span - 1)));
          const double w = kind == 1 ? world(g) : std::ldexp(2.0 * double(of + g) + 1.0, frame.step_exp - fb - 1);
          x = float(w);
          if (double(x) != w) x = float(frame.to_world(0, a));
        } else if (kind == 3) {  // outside the frame, up to 4 extents away
          x = float(frame.to_world(0, a) + frame.step() * rand_double(rng, -4.0, 5.0) * double(frame.grid_max()));
        } else if (kind == 4) {  // tiny values, zeros
          const float tiny[] = {0.0f, -0.0f, 1e-38f, -1e-38f, 1e-45f, -1e-45f, 3e-20f};
          x = tiny[rng.next_u32() % 7];
        } else {  // any finite float (saturates far out)
          uint32_t bits = rng.next_u32();
          std::memcpy(&x, &bits, sizeof x);
          if (!std::isfinite(x)) x = 1.0f;
        }
        ++samples;
        int64_t got[3];
        for (int m = 0; m < 3; ++m) {
          got[m] = frame.to_grid(x, a, kModes[m], fb);
          if (fine_ok) REQUIRE(got[m] == fine.to_grid(x, a, kModes[m]));
        }
        const int64_t dn = got[0], up = got[1], ne = got[2];
        if (std::abs(dn) >= QuantFrame::kGridLimit || std::abs(up) >= QuantFrame::kGridLimit) continue;
        if (!exact_world(Wide(dn) - 2) || !exact_world(Wide(up) + 2)) continue;
        ++world_checked;
        const double xd = x;
        INFO("x " << x << " axis " << a << " down " << dn << " up " << up << " nearest " << ne);
        REQUIRE(world(dn) <= xd);
        REQUIRE(world(Wide(dn) + 1) > xd);
        REQUIRE(world(up) >= xd);
        REQUIRE(world(Wide(up) - 1) < xd);
        REQUIRE((up == dn || up == dn + 1));
        if (up == dn) {
          REQUIRE(ne == dn);
        } else {
          const double mid = std::ldexp(2.0 * double(of + dn) + 1.0, frame.step_exp - fb - 1);  // exact
          if (xd < mid) REQUIRE(ne == dn);
          if (xd > mid) REQUIRE(ne == up);
          if (xd == mid) {
            ++ties;
            REQUIRE(ne == (dn % 2 == 0 ? dn : up));
          }
        }
      }
    }
  }
  // Coverage, not a tolerance: most samples are checked in world space, and ties occur.
  CHECK(world_checked * 2 > samples);
  CHECK(ties > 100);
}
