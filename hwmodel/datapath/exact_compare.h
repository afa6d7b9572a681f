// Exact comparisons of distances between float points: no rounding decides an answer. Each coordinate difference
// of two floats is held exactly as a double-double (TwoSum, Knuth), each product of two doubles exactly as a
// double-double (TwoProduct by fma), and the sum of all the terms exactly as a nonoverlapping expansion (Shewchuk,
// "Adaptive Precision Floating-Point Arithmetic and Fast Robust Geometric Predicates", 1997: Grow-Expansion),
// whose sign is the sign of its largest component. Inputs are floats, so no term overflows or underflows in
// double: |x| < 2^128 gives squares below 2^258, and the smallest nonzero float's square (2^-298) is a normal
// double, as is any nonzero error term of a product of such values (>= 2^-298-106 > 2^-1022).
#pragma once

#include <cmath>

#include "hwmodel/interface/vec.h"

namespace rtu::hw {

namespace exact_detail {

// a + b = s + e exactly (Knuth's TwoSum).
inline void two_sum(double a, double b, double& s, double& e) {
  s = a + b;
  const double bv = s - a, av = s - bv;
  e = (a - av) + (b - bv);
}

// a * b = p + e exactly (fma).
inline void two_product(double a, double b, double& p, double& e) {
  p = a * b;
  e = std::fma(a, b, -p);
}

// An expansion: a sum of nonoverlapping doubles in increasing magnitude (Shewchuk), at most N of them.
template <int N>
struct Expansion {
  double c[N];
  int n = 0;
  // Adds b exactly (Grow-Expansion), dropping zero components.
  void add(double b) {
    int m = 0;
    for (int i = 0; i < n; ++i) {
      double s, e;
      two_sum(b, c[i], s, e);
      b = s;
      if (e != 0.0) c[m++] = e;
    }
    if (b != 0.0) c[m++] = b;
    n = m;
  }
  // The sign of the exact sum: that of its largest component.
  int sign() const { return n == 0 ? 0 : (c[n - 1] > 0.0 ? 1 : -1); }
};

// Adds s * (x - y)^2 exactly to e, x and y floats (s = +1 or -1).
template <int N>
inline void add_square_difference(Expansion<N>& e, float x, float y, double s) {
  double h, l;
  two_sum(double(x), -double(y), h, l);  // x - y = h + l exactly (floats are exact in double)
  double p, q;
  two_product(h, h, p, q);
  e.add(s * p);
  e.add(s * q);
  two_product(2.0 * h, l, p, q);
  e.add(s * p);
  e.add(s * q);
  two_product(l, l, p, q);
  e.add(s * p);
  e.add(s * q);
}

}  // namespace exact_detail

// The sign of |p - q|^2 - r^2, exactly (r a float, r^2 exact as a double-double).
inline int exact_distance_sign(const Vec3& p, const Vec3& q, float r) {
  exact_detail::Expansion<24> e;
  for (int a = 0; a < 3; ++a) exact_detail::add_square_difference(e, p[a], q[a], 1.0);
  double s, t;
  exact_detail::two_product(double(r), double(r), s, t);
  e.add(-s);
  e.add(-t);
  return e.sign();
}

// |p - q| <= r, exactly.
inline bool exact_within(const Vec3& p, const Vec3& q, float r) {
  return exact_distance_sign(p, q, r) <= 0;
}

// The sign of |q - a|^2 - |q - b|^2, exactly: which of a and b is nearer to q (0: as near).
inline int exact_compare_distance(const Vec3& q, const Vec3& a, const Vec3& b) {
  exact_detail::Expansion<40> e;
  for (int i = 0; i < 3; ++i) {
    exact_detail::add_square_difference(e, q[i], a[i], 1.0);
    exact_detail::add_square_difference(e, q[i], b[i], -1.0);
  }
  return e.sign();
}

}  // namespace rtu::hw
