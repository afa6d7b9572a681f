// The fixed-point datapath: ray setup and the box, triangle, sphere and plane tests, as bit-accurate pure
// functions on integers. Formats and the bounds behind every width: fixed_format.h/.cpp. Units:
//   grid    integer coordinates of the quantization frame (quant_frame.h); values with F fraction bits are
//           "grid.F" (raw = grid * 2^F)
//   d       the direction scaled by 2^-k' so its largest component is in [1/2, 1], D fraction bits
//   t       ray units (world t * 2^k, see FixedRay::t_exp), T fraction bits, clamped to +-t_limit
// Intermediates are computed exactly in 128-bit integers (FixedFormat::validate() proves they fit); every
// rounding is one explicit call with its direction.
#pragma once

#include <cstdint>

#include "hwmodel/format/hw_format.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/numeric/fixed.h"
#include "hwmodel/numeric/fixed_format.h"

namespace rtu::hw {

// A ray after setup, with the format constants the tests need.
struct FixedRay {
  int64_t o[3];       // origin, grid.F, nearest; |o| < 2^(B+G+F) raw
  int64_t d[3];       // direction, D fraction bits, nearest; |d| <= 2^D raw, largest >= 2^(D-1)
  int64_t rcp_dn[3];  // 1/d with R fraction bits rounded down (toward -inf); 0 where d = 0
  int64_t rcp_up[3];  // 1/d with R fraction bits rounded up (toward +inf); 0 where d = 0
  // The box unit's reciprocals: rcp_dn and rcp_up rounded further to R + 1 significant bits (down and up), as
  // mantissa * 2^e; the box test computes (plane - origin) * mantissa >> (F + R - T - e) (a left shift, clamped
  // to +-2^62, when that is negative). Relative error still <= 2^-R, and 64-bit products when narrow.
  int64_t rcpm_dn[3];
  int64_t rcpm_up[3];
  int rcp_sh[3];    // F + R - T - e per axis
  bool narrow;      // a + R + 2 <= 63 and F + R - T <= 61: 64-bit products (the default format), else 128
  bool zero[3];     // d[a] == 0: the box test compares the origin with the slab instead
  int64_t tmin;     // interval start, t raw, rounded down
  int64_t tmax;     // interval end, t raw, rounded up (+inf -> t_limit)
  int t_exp;        // world t = t raw * 2^-t_exp (t_exp = T + k)
  int frac;         // F
  int dir_bits;     // D
  int box_shift;    // F + R - T: box product -> t raw
  int t_shift;      // D - F + T: (grid.F / d) quotients -> t raw
  int64_t t_limit;  // largest t raw: 2^t_bits - 1
  int curve_bits;   // FixedFormat::curve_bits (swept_sphere_test)
};

// The format constants of a FixedRay (frac, dir_bits, box_shift, t_shift, t_limit, curve_bits): the part of
// setup_ray that depends on the format only, for code that builds rays on the grid.
void set_format_fields(FixedRay& r, const FixedFormat& f);

// Ray setup: float world ray -> FixedRay. Rejects what validate_ray() rejects, and rays whose origin is out of
// the frame's guard range (RayStatus::kOutOfFrame). An empty or negative interval is valid (it misses).
RayStatus setup_ray(const Ray& r, const QuantFrame& frame, const FixedFormat& f, FixedRay& out);

// setup_ray for one frame and format, with their constants worked out once: the same FixedRay and status bit
// for bit (tests/hwmodel/test_fast_paths.cpp compares them on rays of every kind), in fewer instructions on the
// common path (finite rays, origins where to_grid_64 applies); other rays go through setup_ray. For tracers,
// which set up every ray.
class RaySetup {
 public:
  RaySetup(const QuantFrame& frame, const FixedFormat& f);
  RayStatus operator()(const Ray& r, FixedRay& out) const;

 private:
  QuantFrame m_frame;
  FixedFormat m_f;
  int64_t m_olim = 0;   // 2^(B+G+F): origins at or beyond it are out of frame
  int64_t m_one = 0;    // 2^(D+R)
  FixedRay m_fields{};  // frac, dir_bits, box_shift, t_shift, t_limit and narrow, copied into every ray
};

// Sets d, zero, rcp_dn and rcp_up from a direction already in D-fraction-bit form (|d| <= 2^D raw, largest
// component >= 2^(D-1)); the part of setup_ray after the direction is scaled. For building rays on the grid.
void set_direction(FixedRay& r, const int64_t d[3], const FixedFormat& f);

// World t of a t raw value (rounded to float, nearest).
float t_to_world(int64_t t, const FixedRay& r);

// round(num * 2^s / den) by r, exactly, with den != 0 and rem * 2^s inside 127 bits (rem < |den|;
// validate() proves it for every use). A result beyond +-limit saturates to +-limit, not counted: the callers'
// limits lie beyond every ray interval (or, for the sphere's squared half-chord, beyond every hit), so the
// clamp never changes a decision.
inline Wide div_shift_wide(Wide num, Wide den, int s, Round r, Wide limit) {
  if (den < 0) {
    num = -num;
    den = -den;
  }
  Wide q = num / den, rem = num % den;
  if (rem < 0) {
    q -= 1;
    rem += den;
  }
  const Wide qmax = (limit >> s) + 1;
  if (q >= qmax) return limit;
  if (q < -qmax) return -limit;
  const Wide v = (q << s) + div_round(rem << s, den, r);
  return v > limit ? limit : (v < -limit ? -limit : v);
}
inline int64_t div_shift(Wide num, Wide den, int s, Round r, int64_t limit) {
  return int64_t(div_shift_wide(num, den, s, r, limit));
}

// A primitive's t is a hit only strictly inside the t register: +-t_limit is where a quotient saturated, a
// distance the unit cannot represent (beyond the frame and its guard range), so it is not reported.
inline bool in_register(int64_t t, const FixedRay& r) {
  return t > -r.t_limit && t < r.t_limit;
}

inline int64_t clamp_t(Wide v, int64_t limit) {
  return int64_t(v > limit ? limit : (v < -limit ? -limit : v));
}

// Conservative slab test of the grid box [lo, hi] against [tmin, tlim]: t_near rounds down and t_far up (with
// the reciprocal rounded the matching way for each sign), so no box the exact test accepts is rejected.
// On acceptance writes the entry distance (rounded down) to t_near.
// (plane - origin) * reciprocal mantissa, shifted to t raw: floor (up = false) or ceil (up = true). Values beyond
// +-2^62 clamp there: outside every ray interval (t_bits <= 62), so the clamp never changes a decision. On the
// 64-bit path |product| < 2^62 (a + R + 2 <= 63), so a right shift cannot leave that range.
template <class Int>
inline int64_t box_product(int64_t delta, int64_t m, int sh, bool up) {
  constexpr int64_t kClamp = int64_t(1) << 62;
  const Int p = Int(delta) * m;
  if (sh >= 0) {
    const Int q = up ? (p + ((Int(1) << sh) - 1)) >> sh : p >> sh;
    if constexpr (sizeof(Int) == 8) return q;
    return int64_t(q > Int(kClamp) ? Int(kClamp) : (q < -Int(kClamp) ? -Int(kClamp) : q));
  }
  const Int lim = Int(kClamp) >> -sh;  // exact: no rounding in a left shift
  if (p >= lim) return kClamp;
  if (p <= -lim) return -kClamp;
  return int64_t(p) << -sh;
}

// Conservative slab test of a box given by its planes minus the ray origin (grid.F: dl = (lo << F) - o,
// dh = (hi << F) - o) against [tmin, tlim]: t_near rounds down and t_far up (with the reciprocal rounded the
// matching way for each sign), so no box the exact test accepts is rejected. On acceptance writes the entry
// distance (rounded down) to t_near.
template <class Int>
inline bool box_test_delta(const FixedRay& r, const int64_t dl[3], const int64_t dh[3], int64_t tmin, int64_t tlim,
                           int64_t& t_near) {
  int64_t t0 = tmin, t1 = tlim;
  for (int a = 0; a < 3; ++a) {
    if (r.zero[a]) {
      if (dl[a] > 0 || dh[a] < 0) return false;  // parallel to the slab and outside it
      continue;
    }
    const bool pos = r.d[a] > 0;                                       // the same for every child: predictable
    const int64_t dn = pos ? dl[a] : dh[a], df = pos ? dh[a] : dl[a];  // near and far plane, minus the origin
    // Lower bound of dn / d: the reciprocal rounded toward the smaller product, the product rounded down; upper
    // bound of df / d: the other reciprocal, the product rounded up.
    // The selects are masks, not branches: the signs of dn and df vary from child to child.
    const int64_t diff = r.rcpm_dn[a] ^ r.rcpm_up[a];
    const int64_t mn = r.rcpm_up[a] ^ (diff & -int64_t(dn >= 0));  // dn >= 0 ? rcpm_dn : rcpm_up
    const int64_t mf = r.rcpm_dn[a] ^ (diff & -int64_t(df >= 0));  // df >= 0 ? rcpm_up : rcpm_dn
    const int64_t tn = box_product<Int>(dn, mn, r.rcp_sh[a], false);
    const int64_t tf = box_product<Int>(df, mf, r.rcp_sh[a], true);
    t0 = tn > t0 ? tn : t0;
    t1 = tf < t1 ? tf : t1;
  }
  t_near = t0;
  return t0 <= t1;
}

template <class Int>
inline bool box_test_impl(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t tmin, int64_t tlim,
                          int64_t& t_near) {
  int64_t dl[3], dh[3];
  for (int a = 0; a < 3; ++a) {
    dl[a] = (lo[a] << r.frac) - r.o[a];
    dh[a] = (hi[a] << r.frac) - r.o[a];
  }
  return box_test_delta<Int>(r, dl, dh, tmin, tlim, t_near);
}

// The box test on grid boxes [lo, hi]; the 64-bit path when the format is narrow (same function).
inline bool box_test(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t tmin, int64_t tlim,
                     int64_t& t_near) {
  return r.narrow ? box_test_impl<int64_t>(r, lo, hi, tmin, tlim, t_near)
                  : box_test_impl<Wide>(r, lo, hi, tmin, tlim, t_near);
}

// The exact slab test of the same quantized ray and box over [tmin, tlim]: rational comparisons of
// (plane - origin) / d in 128-bit integers, no reciprocal. The checker behind box_false_negatives.
bool box_test_exact(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t tmin, int64_t tlim);

struct FixedPrimHit {
  int64_t t;  // t raw
  float u, v;
};

// The barycentrics of a triangle hit from its edge functions: u = e1 / det, v = e2 / det, each the double quotient
// rounded to float. The one definition, for triangle_test and for a triangle unit's integers (tri_unit.h).
inline void triangle_barycentrics(Wide e1, Wide e2, Wide det, float& u, float& v) {
  const double dd = double(det);
  u = float(double(e1) / dd);
  v = float(double(e2) / dd);
}

// The triangle's plane hit: t = (n . A0) / (n . d) with n = (v1 - v0) x (v2 - v0) and A0 = v0 - o (grid.F),
// rounded to nearest in the ray's t register. False when the ray runs parallel to the plane (n . d = 0).
inline bool triangle_plane_t(const FixedRay& r, const int32_t v[3][3], const int64_t A0[3], int64_t& t) {
  int64_t ea[3], eb[3];
  for (int a = 0; a < 3; ++a) {
    ea[a] = int64_t(v[1][a]) - v[0][a];
    eb[a] = int64_t(v[2][a]) - v[0][a];
  }
  const int64_t n[3] = {ea[1] * eb[2] - ea[2] * eb[1], ea[2] * eb[0] - ea[0] * eb[2],
                        ea[0] * eb[1] - ea[1] * eb[0]};
  const Wide num = Wide(n[0]) * A0[0] + Wide(n[1]) * A0[1] + Wide(n[2]) * A0[2];
  const Wide den = Wide(n[0]) * r.d[0] + Wide(n[1]) * r.d[1] + Wide(n[2]) * r.d[2];
  if (den == 0) return false;
  t = div_shift(num, den, r.t_shift, Round::kNearestEven, r.t_limit);
  return true;
}

// Watertight triangle test on grid vertices. The edge functions e_i = d . (A_j x A_k) of the translated
// vertices A = v - o are exact integers, so a shared edge gives exactly opposite values on its two triangles and
// a ray through it hits at least one of them (both when it passes exactly through the edge). A hit needs all
// three of one sign (zeros allowed) and a non-zero sum. t = N . A0 / N . d (N the grid normal), rounded to
// nearest, in [tmin, tlim]. u, v (barycentrics of v1, v2) are e1 / sum and e2 / sum rounded to float.
// short_known: the caller knows every |A| < 2^(62 - D) (short_edges_known: vertices on the grid, an origin near
// it), which spares the per-triangle magnitude test of the 64-bit path.
inline bool triangle_test(const FixedRay& r, const int32_t v[3][3], int64_t tmin, int64_t tlim, FixedPrimHit& out,
                          bool short_known = false) {
  int64_t A[3][3];
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a) A[i][a] = (int64_t(v[i][a]) << r.frac) - r.o[a];
  // The same integers two ways. In general d . (p x q), the cross product in 128 bits. When every |A| < 2^(62 - D)
  // (vertices near the frame, the common case; only origins far into the guard range exceed it), by the triple
  // product d . (p x q) = p . (q x d): q x d has components |q_y d_z - q_z d_y| < 2^63, exact in 64 bits, and
  // A2 x d serves e0 = A1 . (A2 x d) and e1 = -A0 . (A2 x d), A1 x d serves e2 = A0 . (A1 x d).
  bool short_cross = short_known;
  if (!short_cross) {
    uint64_t mag = 0;
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 3; ++a) mag |= uint64_t(A[i][a] < 0 ? -A[i][a] : A[i][a]);
    short_cross = mag < (uint64_t(1) << (62 - r.dir_bits));  // D <= 30 (FixedFormat::validate)
  }
  auto cross_d = [&](const int64_t* q, int64_t* c) {
    c[0] = q[1] * r.d[2] - q[2] * r.d[1];
    c[1] = q[2] * r.d[0] - q[0] * r.d[2];
    c[2] = q[0] * r.d[1] - q[1] * r.d[0];
  };
  auto dot = [](const int64_t* p, const int64_t* c) {
    return Wide(p[0]) * c[0] + Wide(p[1]) * c[1] + Wide(p[2]) * c[2];
  };
  auto edge = [&](const int64_t* p, const int64_t* q) {
    const Wide cx = Wide(p[1]) * q[2] - Wide(p[2]) * q[1];
    const Wide cy = Wide(p[2]) * q[0] - Wide(p[0]) * q[2];
    const Wide cz = Wide(p[0]) * q[1] - Wide(p[1]) * q[0];
    return cx * r.d[0] + cy * r.d[1] + cz * r.d[2];
  };
  // Two edge functions of strictly opposite signs already decide the miss: the third is not computed.
  Wide e0, e1;
  if (short_cross) {
    int64_t m[3];
    cross_d(A[2], m);
    e0 = dot(A[1], m);
    e1 = -dot(A[0], m);
  } else {
    e0 = edge(A[1], A[2]);
    e1 = edge(A[2], A[0]);
  }
  if ((e0 < 0 && e1 > 0) || (e0 > 0 && e1 < 0)) return false;
  Wide e2;
  if (short_cross) {
    int64_t n[3];
    cross_d(A[1], n);
    e2 = dot(A[0], n);
  } else {
    e2 = edge(A[0], A[1]);
  }
  if ((e0 < 0 || e1 < 0 || e2 < 0) && (e0 > 0 || e1 > 0 || e2 > 0)) return false;
  const Wide det = e0 + e1 + e2;
  if (det == 0) return false;
  int64_t t;
  if (!triangle_plane_t(r, v, A[0], t)) return false;  // cannot fail when det != 0 (det = 2^2F den)
  if (t < tmin || t > tlim || !in_register(t, r)) return false;
  out.t = t;
  triangle_barycentrics(e1, e2, det, out.u, out.v);
  return true;
}

// True when every vertex on the grid [0, 2^B - 1]^3 minus the ray's origin (grid.F) is below 2^(62 - D) in
// magnitude on every axis: then triangle_test's 64-bit path applies to every triangle record of the image (the
// image's validation keeps its vertices on the grid), and triangle_test(..., short_known = true) skips the test.
inline bool short_edges_known(const FixedRay& r, int coord_bits) {
  const int64_t top = ((int64_t(1) << coord_bits) - 1) << r.frac, lim = int64_t(1) << (62 - r.dir_bits);
  for (int a = 0; a < 3; ++a) {
    const int64_t lo = -r.o[a], hi = top - r.o[a];
    if (lo >= lim || lo <= -lim || hi >= lim || hi <= -lim) return false;
  }
  return true;
}

// Sphere test: the closest-approach parameter tca = -(f . d) / (d . d) (f = o - center), the perpendicular
// l = f + tca d, disc = r^2 - |l|^2, half-chord h = sqrt(disc / (d . d)). No b^2 - ac: every value stays
// within the frame's magnitude (the fixed-point form of the stable quadratic; rounding errors are absolute,
// one unit in t or grid.F each). The near root, or the far one when the near is before tmin.
bool sphere_test(const FixedRay& r, const SphereRecord& s, int64_t tmin, int64_t tlim, FixedPrimHit& out);

// Linear swept sphere test (a round linear curve segment, CurveRecord): the first crossing in [tmin, tlim] of
// the union of the end sphere at p1 (and the one at p0 with kRoundCapStart, or when one end sphere holds the
// other) and the lateral surface of the cone tangent to both, between its circles of tangency. The spheres are
// sphere_test's. The cone (K = |e|^2 - dr^2 > 0, e = p1 - p0, dr = r1 - r0), in four steps, each rounding
// once:
//  1. The origin moves along the ray to o' near the point closest to the segment's midpoint (tc, nearest, as
//     sphere_test's tca); a ray whose o' lies outside the segment's bounding sphere misses.
//  2. Positions relative to p0 (g = o' - p0, e, the radii) are shifted right by z so that each is below
//     2^curve_bits (z = 0 unless the segment or its distance to o' exceeds 2^curve_bits grid.F units).
//  3. The quadric |v - s e|^2 = (r0 + s dr)^2 with s = (v . e + r0 dr) / K, multiplied out over K and divided by
//     2^n ~ |e|^2 (n = bit length of |e|^2 - 1): u + t w and rho + t sigma have magnitudes of a position and a
//     direction; |u + t w|^2 - (rho + t sigma)^2 = A t^2 + 2 B t + C, with A, B, C and B^2 - A C exact.
//  4. The roots as the stable quadratic forms them (C / q and q / A, q = -(B + sign(B) sqrt(B^2 - A C))), each
//     kept only where its tangent sphere's s lies in [0, 1] (compared exactly, in the root's own fractions).
// The bits: FixedFormat::curve_limits(). u of the hit is its s (0 and 1 on the end spheres), v is 0.
bool swept_sphere_test(const FixedRay& r, const CurveRecord& c, int64_t tmin, int64_t tlim, FixedPrimHit& out);

// Plane test: t = (w - n . o) / (n . d), nearest; misses when n . d = 0.
bool plane_test(const FixedRay& r, const PlaneRecord& p, int64_t tmin, int64_t tlim, FixedPrimHit& out);

}  // namespace rtu::hw
