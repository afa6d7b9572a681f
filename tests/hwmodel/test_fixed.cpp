// Fixed-point arithmetic against exact results. Small formats exhaustively (every pair of values, every rounding
// mode), wide formats with seeded random operands. The references never use the implementation's algorithms:
// they search for the integer result and check it by multiplication, which is exact in 128 bits.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <type_traits>

#include "hwmodel/numeric/fixed.h"

using namespace rtu::hw;

namespace {

constexpr Round kRoundModes[] = {Round::kDown, Round::kUp, Round::kNearestEven};

// The integer q that rounds n / d (d > 0) by r: start from the truncated quotient, move to the floor, which is
// checked exactly as the q with q d <= n < (q + 1) d, then round from the remainder.
Wide ref_div(Wide n, Wide d, Round r) {
  Wide q = n / d;
  while (!((q + 1) * d > n)) ++q;
  while (q * d > n) --q;
  const Wide rem = n - q * d;  // 0 <= rem < d
  if (rem == 0) return q;
  if (r == Round::kDown) return q;
  if (r == Round::kUp) return q + 1;
  if (2 * rem != d) return 2 * rem < d ? q : q + 1;
  return q % 2 == 0 ? q : q + 1;
}

// floor(sqrt(x)) by search and check, then rounded by r.
Wide ref_sqrt(Wide x, Round r) {
  Wide s = Wide(std::sqrt(double(x)));  // within a few units of the root: x < 2^124, the root < 2^62
  while (s * s > x) --s;
  while ((s + 1) * (s + 1) <= x) ++s;
  if (s * s == x || r == Round::kDown) return s;
  if (r == Round::kUp) return s + 1;
  // nearest: compare x with (s + 1/2)^2, i.e. 4x with (2s + 1)^2
  return 4 * x > (2 * s + 1) * (2 * s + 1) ? s + 1 : s;
}

template <class T>
Wide clamp_expect(Wide q, uint64_t& expected_saturations) {
  if (q > T::kMaxRaw) {
    ++expected_saturations;
    return T::kMaxRaw;
  }
  if (q < T::kMinRaw) {
    ++expected_saturations;
    return T::kMinRaw;
  }
  return q;
}

template <class T>
void exhaustive() {
  constexpr int F = T::kFracBits;
  reset_saturation_count();
  uint64_t expected = 0;
  for (int64_t a = T::kMinRaw; a <= T::kMaxRaw; ++a) {
    const T x{a};
    for (int64_t b = T::kMinRaw; b <= T::kMaxRaw; ++b) {
      const T y{b};
      INFO("a " << a << " b " << b);
      REQUIRE((x + y).raw == clamp_expect<T>(Wide(a) + b, expected));
      REQUIRE((x - y).raw == clamp_expect<T>(Wide(a) - b, expected));
      for (Round r : kRoundModes) {
        INFO("round " << int(r));
        REQUIRE(T::mul(x, y, r).raw == clamp_expect<T>(ref_div(Wide(a) * b, Wide(1) << F, r), expected));
        if (b != 0) {
          const Wide n = Wide(a) << F;
          const Wide q = b > 0 ? ref_div(n, b, r) : ref_div(-n, -Wide(b), r);
          REQUIRE(T::div(x, y, r).raw == clamp_expect<T>(q, expected));
        }
      }
      REQUIRE(saturation_count() == expected);
    }
    REQUIRE((-x).raw == clamp_expect<T>(-Wide(a), expected));
    if (a >= 0) {
      for (Round r : kRoundModes)
        REQUIRE(T::sqrt(x, r).raw == clamp_expect<T>(ref_sqrt(Wide(a) << F, r), expected));
    }
    REQUIRE(saturation_count() == expected);
  }
  // from_double on a grid finer than the format, beyond its range on both sides, and tiny values near 0.
  const double step = std::ldexp(1.0, -F - 3);
  for (double v = std::ldexp(double(T::kMinRaw) - 5, -F); v <= std::ldexp(double(T::kMaxRaw) + 5, -F); v += step) {
    for (Round r : kRoundModes) {
      const Wide n = Wide(std::llround(v / step));  // v = n * 2^(-F-3) exactly
      INFO("v " << v << " round " << int(r));
      REQUIRE(T::from_double(v, r).raw == clamp_expect<T>(ref_div(n, 8, r), expected));
    }
  }
  for (Round r : kRoundModes) {
    CHECK(T::from_double(-1e-300, r).raw == (r == Round::kDown ? -1 : 0));
    CHECK(T::from_double(1e-300, r).raw == (r == Round::kUp ? 1 : 0));
  }
  REQUIRE(saturation_count() == expected);
}

template <class T>
void randomized(uint32_t seed, int count) {
  constexpr int F = T::kFracBits;
  INFO("seed " << seed);
  std::mt19937_64 rng(seed);
  auto operand = [&]() -> int64_t {
    // Mix full-range values with small ones, so both saturating and exact results occur.
    const uint64_t u = rng();
    const int shift = int(rng() % uint64_t(T::kWidth));
    return int64_t(u) >> (64 - T::kWidth + shift);
  };
  reset_saturation_count();
  uint64_t expected = 0;
  for (int i = 0; i < count; ++i) {
    const int64_t a = operand(), b = operand();
    const T x{a}, y{b};
    INFO("a " << a << " b " << b);
    for (Round r : kRoundModes) {
      REQUIRE(T::mul(x, y, r).raw == clamp_expect<T>(ref_div(Wide(a) * b, Wide(1) << F, r), expected));
      if (b != 0) {
        const Wide n = Wide(a) << F;
        const Wide q = b > 0 ? ref_div(n, b, r) : ref_div(-n, -Wide(b), r);
        REQUIRE(T::div(x, y, r).raw == clamp_expect<T>(q, expected));
      }
      if (a >= 0) REQUIRE(T::sqrt(x, r).raw == clamp_expect<T>(ref_sqrt(Wide(a) << F, r), expected));
    }
    REQUIRE((x + y).raw == clamp_expect<T>(Wide(a) + b, expected));
  }
  REQUIRE(saturation_count() == expected);
  CHECK(expected > 0);  // the operands reach the format's limits
}

}  // namespace

static_assert(std::is_trivially_default_constructible_v<Fixed<15, 16>>);
static_assert(std::is_trivially_copyable_v<Fixed<15, 16>>);
static_assert(sizeof(Fixed<15, 16>) == 8);

TEST_CASE("Fixed: exhaustive small formats against exact results", "[fixed]") {
  exhaustive<Fixed<2, 3>>();  // 6 bits: a fraction and an integer part
  exhaustive<Fixed<0, 6>>();  // pure fraction
  exhaustive<Fixed<6, 0>>();  // pure integer
  exhaustive<Fixed<3, 4>>();  // 8 bits
}

TEST_CASE("Fixed: randomized wide formats against exact results", "[fixed]") {
  randomized<Fixed<20, 40>>(12345, 200000);  // 61 bits: 122-bit products
  randomized<Fixed<31, 16>>(777, 200000);
  randomized<Fixed<8, 23>>(4242, 200000);
}

TEST_CASE("Fixed: NaN, infinities and division by zero saturate and are counted", "[fixed]") {
  using T = Fixed<7, 8>;
  reset_saturation_count();
  CHECK(T::from_double(std::nan("")).raw == 0);
  CHECK(T::from_double(1e300).raw == T::kMaxRaw);
  CHECK(T::from_double(-INFINITY).raw == T::kMinRaw);
  CHECK(T::div(T::from_int(3), T{0}, Round::kDown).raw == T::kMaxRaw);
  CHECK(T::div(T::from_int(-3), T{0}, Round::kUp).raw == T::kMinRaw);
  CHECK(T::div(T{0}, T{0}, Round::kUp).raw == 0);
  CHECK(T::sqrt(T::from_int(-1), Round::kUp).raw == 0);
  CHECK(saturation_count() == 7);
  CHECK((-T::min()).raw == T::kMaxRaw);  // the one value whose negation does not fit
  CHECK(saturation_count() == 8);
}

TEST_CASE("Fixed as a GLM scalar: vec3 arithmetic, dot, cross, length, normalize, min, max, abs", "[fixed]") {
  using T = Fixed<12, 20>;
  using V = glm::vec<3, T>;
  auto f = [](double x) { return T::from_double(x); };
  const V a(f(1.5), f(-2.25), f(3.0)), b(f(0.5), f(4.0), f(-1.0));
  const V sum = a + b;
  CHECK(sum.x.to_double() == 2.0);
  CHECK((a * f(2.0)).y.to_double() == -4.5);
  CHECK(glm::dot(a, b).to_double() == 1.5 * 0.5 - 2.25 * 4.0 - 3.0);
  const V c = glm::cross(a, b);
  CHECK(c.x.to_double() == -2.25 * -1.0 - 3.0 * 4.0);
  CHECK(c.y.to_double() == 3.0 * 0.5 - 1.5 * -1.0);
  CHECK(c.z.to_double() == 1.5 * 4.0 - -2.25 * 0.5);
  CHECK(glm::dot(c, a).raw == 0);  // exact: every product and sum is representable
  const V e(f(3.0), f(4.0), f(12.0));
  CHECK(glm::length(e).to_double() == 13.0);
  const V n = glm::normalize(e);
  CHECK(std::abs(n.x.to_double() - 3.0 / 13.0) <= std::ldexp(1.0, -21));  // half an ulp of 2^-20
  CHECK(glm::min(a, b).y.to_double() == -2.25);
  CHECK(glm::max(a, b).z.to_double() == 3.0);
  CHECK(glm::abs(a).y.to_double() == 2.25);
  CHECK(glm::sqrt(f(2.0)).to_double() == std::ldexp(std::round(std::sqrt(2.0) * 1048576.0), -20));
}
