// Fixed-point numbers of the unit's datapath.
//
// Two layers:
// - integer helpers with runtime widths (round_shift, saturate, div_round, isqrt_round): the datapath calls
//   these on raw two's-complement values, so every width can be a run-time parameter for sweeps;
// - Fixed<I, F>, a compile-time format (I integer bits, F fraction bits, plus a sign bit) usable as a GLM
//   scalar, with the operations the datapath needs and a shim for GLM's float-only functions (below).
//
// Rounding is always explicit in the helpers: toward -inf (kDown), toward +inf (kUp), to nearest with ties to
// even (kNearestEven). Fixed's operators use kNearestEven; mul/div/sqrt take the mode. Results that do not fit
// the format saturate to its largest or smallest value, and each saturation is counted (saturation_count()).
// Values are exact two's complement: no undefined behaviour on overflow (intermediates are 128-bit).
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <type_traits>

#include <glm/glm.hpp>

namespace rtu::hw {

enum class Round : uint8_t {
  kDown = 0,         // toward -inf (floor)
  kUp = 1,           // toward +inf (ceil)
  kNearestEven = 2,  // to nearest, ties to even
};

using Wide = __int128;

// Saturations since the thread started (or since reset). Counted by every saturating operation below.
uint64_t& saturation_counter();
inline uint64_t saturation_count() {
  return saturation_counter();
}
inline void reset_saturation_count() {
  saturation_counter() = 0;
}

// Largest and smallest raw value of a signed format `bits` wide (sign included), 2 <= bits <= 64.
constexpr int64_t raw_max(int bits) {
  return int64_t((uint64_t(1) << (bits - 1)) - 1);
}
constexpr int64_t raw_min(int bits) {
  return -raw_max(bits) - 1;
}

// Clamps x to a signed `bits`-wide value; counts a saturation when it had to.
inline int64_t saturate(Wide x, int bits) {
  const int64_t hi = raw_max(bits), lo = raw_min(bits);
  if (x > hi) {
    ++saturation_counter();
    return hi;
  }
  if (x < lo) {
    ++saturation_counter();
    return lo;
  }
  return int64_t(x);
}

// x / 2^s rounded by r, exactly (no intermediate rounding), in the integer type of x: for 0 <= s <= 120 on Wide,
// 0 <= s <= 62 on int64_t (the 64-bit fast paths of ray setup; the same function where x fits 64 bits).
template <class Int>
constexpr Int round_shift_in(Int x, int s, Round r) {
  if (s <= 0) return x;
  const Int floor_q = x >> s;          // arithmetic shift: floor
  const Int rem = x - (floor_q << s);  // in [0, 2^s)
  if (rem == 0) return floor_q;
  switch (r) {
    case Round::kDown:
      return floor_q;
    case Round::kUp:
      return floor_q + 1;
    case Round::kNearestEven: {
      const Int half = Int(1) << (s - 1);
      if (rem > half) return floor_q + 1;
      if (rem < half) return floor_q;
      return (floor_q & 1) ? floor_q + 1 : floor_q;
    }
  }
  return floor_q;
}
constexpr Wide round_shift(Wide x, int s, Round r) {
  return round_shift_in<Wide>(x, s, r);
}
constexpr int64_t round_shift64(int64_t x, int s, Round r) {
  return round_shift_in<int64_t>(x, s, r);
}

// n / d rounded by r (d != 0). Exact.
constexpr Wide div_round(Wide n, Wide d, Round r) {
  if (d < 0) {
    n = -n;
    d = -d;
  }
  Wide q = n / d, rem = n % d;  // truncation toward zero; rem has the sign of n
  if (rem < 0) {
    q -= 1;
    rem += d;  // now q = floor(n / d), 0 <= rem < d
  }
  if (rem == 0) return q;
  switch (r) {
    case Round::kDown:
      return q;
    case Round::kUp:
      return q + 1;
    case Round::kNearestEven: {
      const Wide twice = 2 * rem;
      if (twice > d) return q + 1;
      if (twice < d) return q;
      return (q & 1) ? q + 1 : q;
    }
  }
  return q;
}

// sqrt(x) for x >= 0, rounded by r (kNearestEven: to nearest; a tie is impossible for integer x). Exact.
constexpr Wide isqrt_round(Wide x, Round r) {
  if (x <= 0) return 0;
  // Bitwise integer square root: the largest s with s^2 <= x.
  Wide s = 0;
  Wide bit = Wide(1) << 124;
  while (bit > x) bit >>= 2;
  Wide rest = x;
  while (bit != 0) {
    if (rest >= s + bit) {
      rest -= s + bit;
      s = (s >> 1) + bit;
    } else {
      s >>= 1;
    }
    bit >>= 2;
  }
  // s = floor(sqrt(x)), rest = x - s^2.
  if (rest == 0 || r == Round::kDown) return s;
  if (r == Round::kUp) return s + 1;
  // Nearest: round up when x > (s + 1/2)^2 = s^2 + s + 1/4, i.e. rest > s (rest and s are integers).
  return rest > s ? s + 1 : s;
}

// x = m * 2^e exactly for finite x, with |m| < 2^24 (read off the bits; no libm).
inline void split_float(float x, int64_t& m, int& e) {
  const uint32_t b = std::bit_cast<uint32_t>(x);
  const int biased = int((b >> 23) & 0xFFu);
  const int64_t mant = int64_t(b & 0x7FFFFFu);
  m = biased == 0 ? mant : (mant | 0x800000);  // subnormals have no hidden bit
  e = (biased == 0 ? 1 : biased) - 150;
  if (b >> 31) m = -m;
}

// 2^e as a double, exact; e in [-1022, 1023] is built from its bits.
inline double pow2(int e) {
  if (e < -1022 || e > 1023) return std::ldexp(1.0, e);
  return std::bit_cast<double>(uint64_t(e + 1023) << 52);
}

template <int I, int F>
struct Fixed {
  static_assert(I >= 0 && F >= 0 && 1 + I + F <= 62, "Fixed<I, F>: 1 + I + F must be at most 62 bits");
  static constexpr int kIntBits = I;
  static constexpr int kFracBits = F;
  static constexpr int kWidth = 1 + I + F;  // including the sign bit
  static constexpr int64_t kMaxRaw = raw_max(kWidth);
  static constexpr int64_t kMinRaw = raw_min(kWidth);

  int64_t raw;  // value = raw * 2^-F; no initializer, so Fixed stays trivial (GLM's vec needs it)

  static Fixed from_raw(Wide r) { return Fixed{saturate(r, kWidth)}; }
  // Nearest representable to x by r; NaN is counted as a saturation and gives 0.
  static Fixed from_double(double x, Round r = Round::kNearestEven);
  static Fixed from_int(int64_t v) { return from_raw(Wide(v) << F); }
  static constexpr Fixed max() { return Fixed{kMaxRaw}; }
  static constexpr Fixed min() { return Fixed{kMinRaw}; }
  static constexpr Fixed epsilon() { return Fixed{1}; }

  double to_double() const { return double(raw) / double(Wide(1) << F); }
  explicit operator double() const { return to_double(); }

  friend Fixed operator+(Fixed a, Fixed b) { return from_raw(Wide(a.raw) + b.raw); }
  friend Fixed operator-(Fixed a, Fixed b) { return from_raw(Wide(a.raw) - b.raw); }
  friend Fixed operator-(Fixed a) { return from_raw(-Wide(a.raw)); }
  friend Fixed operator*(Fixed a, Fixed b) { return mul(a, b, Round::kNearestEven); }
  friend Fixed operator/(Fixed a, Fixed b) { return div(a, b, Round::kNearestEven); }
  Fixed& operator+=(Fixed b) { return *this = *this + b; }
  Fixed& operator-=(Fixed b) { return *this = *this - b; }
  Fixed& operator*=(Fixed b) { return *this = *this * b; }
  Fixed& operator/=(Fixed b) { return *this = *this / b; }
  friend constexpr bool operator==(Fixed a, Fixed b) { return a.raw == b.raw; }
  friend constexpr auto operator<=>(Fixed a, Fixed b) { return a.raw <=> b.raw; }

  static Fixed mul(Fixed a, Fixed b, Round r) { return from_raw(round_shift(Wide(a.raw) * b.raw, F, r)); }
  // Division by zero saturates toward the sign of the numerator (0 / 0 gives 0) and is counted.
  static Fixed div(Fixed a, Fixed b, Round r) {
    if (b.raw == 0) {
      ++saturation_counter();
      return a.raw > 0 ? max() : (a.raw < 0 ? min() : Fixed{0});
    }
    return from_raw(div_round(Wide(a.raw) << F, b.raw, r));
  }
  // sqrt of a negative value is counted as a saturation and gives 0.
  static Fixed sqrt(Fixed a, Round r) {
    if (a.raw < 0) {
      ++saturation_counter();
      return Fixed{0};
    }
    return from_raw(isqrt_round(Wide(a.raw) << F, r));
  }
};

template <int I, int F>
Fixed<I, F> Fixed<I, F>::from_double(double x, Round r) {
  if (x != x) {
    ++saturation_counter();
    return Fixed{0};
  }
  const double scaled = x * double(Wide(1) << F);  // exact: a power of two
  if (scaled >= 0x1p62) return from_raw(Wide(kMaxRaw) + 1);
  if (scaled <= -0x1p62) return from_raw(Wide(kMinRaw) - 1);
  // Split into an integer part and the rest; both exact in double for |scaled| < 2^62.
  double ip = double(int64_t(scaled));  // truncation toward zero
  if (ip > scaled) ip -= 1.0;           // floor
  Wide q = Wide(int64_t(ip));
  const double frac = scaled - ip;  // exact, in [0, 1)
  if (frac != 0.0) {
    if (r == Round::kUp || (r == Round::kNearestEven && (frac > 0.5 || (frac == 0.5 && (q & 1))))) q += 1;
  }
  return from_raw(q);
}

template <class T>
struct IsFixed : std::false_type {};
template <int I, int F>
struct IsFixed<Fixed<I, F>> : std::true_type {};

}  // namespace rtu::hw

template <int I, int F>
struct std::numeric_limits<rtu::hw::Fixed<I, F>> {
  using T = rtu::hw::Fixed<I, F>;
  static constexpr bool is_specialized = true;
  static constexpr bool is_signed = true;
  static constexpr bool is_integer = false;
  static constexpr bool is_exact = true;
  static constexpr bool is_iec559 = false;
  static constexpr int digits = I + F;
  static constexpr int radix = 2;
  static constexpr T min() { return T::epsilon(); }
  static constexpr T lowest() { return T::min(); }
  static constexpr T max() { return T::max(); }
  static constexpr T epsilon() { return T::epsilon(); }
};

// GLM shim: GLM's dot/cross/length/normalize/min/max/abs/sqrt static_assert on IEEE floats. These overloads are
// more specialized than GLM's templates, so they win for Fixed. Products round to nearest even (as operator*);
// a datapath that needs directed rounding uses the integer helpers instead.
namespace glm {

template <int I, int F>
rtu::hw::Fixed<I, F> abs(rtu::hw::Fixed<I, F> a) {
  return a.raw < 0 ? -a : a;
}
template <int I, int F>
rtu::hw::Fixed<I, F> min(rtu::hw::Fixed<I, F> a, rtu::hw::Fixed<I, F> b) {
  return b < a ? b : a;
}
template <int I, int F>
rtu::hw::Fixed<I, F> max(rtu::hw::Fixed<I, F> a, rtu::hw::Fixed<I, F> b) {
  return a < b ? b : a;
}
template <int I, int F>
rtu::hw::Fixed<I, F> sqrt(rtu::hw::Fixed<I, F> a) {
  return rtu::hw::Fixed<I, F>::sqrt(a, rtu::hw::Round::kNearestEven);
}
namespace detail_fixed {
template <length_t L, int I, int F, qualifier Q, class Op>
vec<L, rtu::hw::Fixed<I, F>, Q> componentwise(const vec<L, rtu::hw::Fixed<I, F>, Q>& a,
                                              const vec<L, rtu::hw::Fixed<I, F>, Q>& b, Op op) {
  vec<L, rtu::hw::Fixed<I, F>, Q> out;
  for (length_t i = 0; i < L; ++i) out[i] = op(a[i], b[i]);
  return out;
}
}  // namespace detail_fixed
template <length_t L, int I, int F, qualifier Q>
vec<L, rtu::hw::Fixed<I, F>, Q> abs(const vec<L, rtu::hw::Fixed<I, F>, Q>& v) {
  return detail_fixed::componentwise(v, v, [](auto x, auto) { return glm::abs(x); });
}
template <length_t L, int I, int F, qualifier Q>
vec<L, rtu::hw::Fixed<I, F>, Q> min(const vec<L, rtu::hw::Fixed<I, F>, Q>& a,
                                    const vec<L, rtu::hw::Fixed<I, F>, Q>& b) {
  return detail_fixed::componentwise(a, b, [](auto x, auto y) { return glm::min(x, y); });
}
template <length_t L, int I, int F, qualifier Q>
vec<L, rtu::hw::Fixed<I, F>, Q> max(const vec<L, rtu::hw::Fixed<I, F>, Q>& a,
                                    const vec<L, rtu::hw::Fixed<I, F>, Q>& b) {
  return detail_fixed::componentwise(a, b, [](auto x, auto y) { return glm::max(x, y); });
}
// Dot product with one rounding at the end (products summed exactly in 128 bits), as a hardware dot unit does.
template <length_t L, int I, int F, qualifier Q>
rtu::hw::Fixed<I, F> dot(const vec<L, rtu::hw::Fixed<I, F>, Q>& a, const vec<L, rtu::hw::Fixed<I, F>, Q>& b) {
  rtu::hw::Wide sum = 0;
  for (length_t i = 0; i < L; ++i) sum += rtu::hw::Wide(a[i].raw) * b[i].raw;
  return rtu::hw::Fixed<I, F>::from_raw(rtu::hw::round_shift(sum, F, rtu::hw::Round::kNearestEven));
}
// Cross product, each component a*b - c*d formed exactly and rounded once.
template <int I, int F, qualifier Q>
vec<3, rtu::hw::Fixed<I, F>, Q> cross(const vec<3, rtu::hw::Fixed<I, F>, Q>& a,
                                      const vec<3, rtu::hw::Fixed<I, F>, Q>& b) {
  using rtu::hw::Wide;
  using T = rtu::hw::Fixed<I, F>;
  auto term = [](Wide p, Wide q) {
    return T::from_raw(rtu::hw::round_shift(p - q, F, rtu::hw::Round::kNearestEven));
  };
  return vec<3, T, Q>(term(Wide(a.y.raw) * b.z.raw, Wide(a.z.raw) * b.y.raw),
                      term(Wide(a.z.raw) * b.x.raw, Wide(a.x.raw) * b.z.raw),
                      term(Wide(a.x.raw) * b.y.raw, Wide(a.y.raw) * b.x.raw));
}
// Length from the exactly summed squares, one rounding in the square root.
template <length_t L, int I, int F, qualifier Q>
rtu::hw::Fixed<I, F> length(const vec<L, rtu::hw::Fixed<I, F>, Q>& v) {
  rtu::hw::Wide sum = 0;
  for (length_t i = 0; i < L; ++i) sum += rtu::hw::Wide(v[i].raw) * v[i].raw;  // scale 2^-2F
  return rtu::hw::Fixed<I, F>::from_raw(rtu::hw::isqrt_round(sum, rtu::hw::Round::kNearestEven));
}
template <length_t L, int I, int F, qualifier Q>
vec<L, rtu::hw::Fixed<I, F>, Q> normalize(const vec<L, rtu::hw::Fixed<I, F>, Q>& v) {
  const rtu::hw::Fixed<I, F> len = glm::length(v);
  vec<L, rtu::hw::Fixed<I, F>, Q> out;
  for (length_t i = 0; i < L; ++i) out[i] = v[i] / len;
  return out;
}

}  // namespace glm
