// Shared by the fixed-point datapath tests (test_fixed_box.cpp, test_fixed_triangle.cpp,
// test_fixed_sphere_plane.cpp, test_ray_setup.cpp, test_fixed_tracer.cpp, test_fixed_format.cpp and the
// fraction-bits case of test_quant_frame.cpp): random generators, the custom formats and frames the cases run on,
// descriptions of rays, boxes and triangles for failure messages, and the references that do not share the
// datapath's algorithms:
// - the exact rational slab test (Frac, plane_dist, exact_entry, exact_exit) and the same test in long double
//   (box_long_double), which can say "too close to call";
// - a long double Moller-Trumbore with bounds on its own rounding error (triangle_ref);
// - the exact edge function and n . d of grid triangles (edge_function, normal_dot_dir).
// Every reference works on the quantized values the datapath sees (FixedRay, records), so the comparisons measure
// the datapath's own roundings, not the quantization of the scene.
#pragma once

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/scene/geometry.h"

// REQUIRE that builds its context message only on failure: the hot loops run millions of cases, and formatting a
// message for every passing one would dominate the run time.
#define REQUIRE_CTX(cond, ctx) \
  do {                         \
    if (!(cond)) {             \
      INFO(ctx);               \
      REQUIRE(cond);           \
    }                          \
  } while (0)

namespace rtu::hw::fixed_checks {

using LD = long double;
// The references below count on a 64-bit significand (x87 extended precision): unit roundoff 2^-64.
static_assert(std::numeric_limits<LD>::digits >= 64, "the long double references need a 64-bit significand");

inline constexpr float kInf = std::numeric_limits<float>::infinity();
inline constexpr Round kModes[] = {Round::kDown, Round::kUp, Round::kNearestEven};
inline constexpr double kPi = 3.14159265358979323846;

// ---------------------------------------------------------------------------------------------------------------
// Small helpers

inline uint64_t next_u64(Pcg32& g) {
  const uint64_t hi = g.next_u32();
  return (hi << 32) | g.next_u32();
}
// Uniform integer in [lo, hi]. The modulo bias (span / 2^64) does not matter for a test's coverage.
inline int64_t rand_int(Pcg32& g, int64_t lo, int64_t hi) {
  return lo + int64_t(next_u64(g) % (uint64_t(hi - lo) + 1));
}
inline float rand_float(Pcg32& g, float lo, float hi) {
  return lo + (hi - lo) * g.next_float();
}

// A random soup: triangles about 1 unit across in [-10, 10]^3, a few spheres, and a ground plane below them.
inline Geometry random_scene(uint64_t seed, int tris, int spheres) {
  Pcg32 rng(seed);
  Geometry g;
  for (int i = 0; i < tris; ++i) {
    Vec3 c, v[3];
    for (int a = 0; a < 3; ++a) c[a] = rand_float(rng, -10.0f, 10.0f);
    for (Vec3& p : v)
      for (int a = 0; a < 3; ++a) p[a] = c[a] + rand_float(rng, -0.6f, 0.6f);
    g.triangles.push_back({v[0], v[1], v[2]});
  }
  for (int i = 0; i < spheres; ++i) {
    Vec3 c;
    for (int a = 0; a < 3; ++a) c[a] = rand_float(rng, -9.0f, 9.0f);
    g.spheres.push_back({c, rand_float(rng, 0.2f, 1.5f)});
  }
  g.planes.push_back({Vec3(0.05f, 1.0f, -0.1f), -11.0f});
  return g;
}
inline bool one_in(Pcg32& g, uint32_t n) {
  return g.next_u32() % n == 0;
}
// A random t interval around t = 1 (a ray aimed at a target there): it may start or end before or after it.
inline void random_interval(Pcg32& g, Ray& ray) {
  ray.tmin = one_in(g, 4) ? rand_float(g, 0.0f, 1.5f) : 0.0f;
  ray.tmax = one_in(g, 4) ? rand_float(g, 0.5f, 2.0f) : kInf;
}
inline double rand_double(Pcg32& g, double lo, double hi) {
  return lo + (hi - lo) * (double(next_u64(g) >> 11) * 0x1p-53);
}

inline std::string wide_str(Wide x) {
  if (x == 0) return "0";
  const bool neg = x < 0;
  std::string s;
  while (x != 0) {
    const int digit = int(x % 10);
    s += char('0' + (digit < 0 ? -digit : digit));
    x /= 10;
  }
  if (neg) s += '-';
  return std::string(s.rbegin(), s.rend());
}

inline std::string describe(const FixedRay& r) {
  std::ostringstream o;
  o << "o " << r.o[0] << " " << r.o[1] << " " << r.o[2] << " | d " << r.d[0] << " " << r.d[1] << " " << r.d[2]
    << " | zero " << r.zero[0] << r.zero[1] << r.zero[2] << " | rcp_dn " << r.rcp_dn[0] << " " << r.rcp_dn[1]
    << " " << r.rcp_dn[2] << " | rcp_up " << r.rcp_up[0] << " " << r.rcp_up[1] << " " << r.rcp_up[2] << " | tmin "
    << r.tmin << " tmax " << r.tmax << " t_exp " << r.t_exp << " F " << r.frac << " D " << r.dir_bits
    << " box_shift " << r.box_shift << " t_shift " << r.t_shift << " t_limit " << r.t_limit;
  return o.str();
}

inline std::string describe_box(const int64_t lo[3], const int64_t hi[3], int64_t tmin, int64_t tlim) {
  std::ostringstream o;
  o << "box lo " << lo[0] << " " << lo[1] << " " << lo[2] << " hi " << hi[0] << " " << hi[1] << " " << hi[2]
    << " interval [" << tmin << ", " << tlim << "]";
  return o.str();
}

inline std::string describe_tri(const int32_t v[3][3]) {
  std::ostringstream o;
  for (int i = 0; i < 3; ++i) o << "v" << i << " " << v[i][0] << " " << v[i][1] << " " << v[i][2] << " ";
  return o.str();
}

// A custom format with a coarse direction and reciprocal (D = 6, R = 4) and no fraction bits, so the box test's
// roundings are as large as any format allows, and small coordinates (B = 10).
inline FixedFormat coarse_format() {
  FixedFormat f = format_from_spec(
      "default:coord_bits=10:child_bits=4:guard_bits=2:frac_bits=0:dir_bits=6:rcp_bits=4:t_frac_bits=0:t_bits=20");
  f.name = "coarse";
  return f;
}

// A custom format with positions much finer than t (F = 16, T = 8): the sphere test's rounding of the
// perpendicular to grid.F then costs well under a unit of t (see the sphere test case).
inline FixedFormat fine_position_format() {
  FixedFormat f = format_from_spec(
      "default:coord_bits=16:guard_bits=4:frac_bits=16:dir_bits=24:rcp_bits=24:t_frac_bits=8:t_bits=40");
  f.name = "fine-position";
  return f;
}

// Formats the datapath tests run on: several coordinate widths (10, 16, 24, 28), F from 0 to 10, T > F and T = F.
inline std::vector<FixedFormat> datapath_formats() {
  return {format_preset("default"), format_preset("compact"), format_preset("precise"), coarse_format()};
}

// A frame with grid step 1 and origin 0: world coordinates are grid coordinates (exact floats below 2^24).
inline QuantFrame unit_frame(int bits) {
  QuantFrame q;
  q.bits = bits;
  q.step_exp = 0;
  return q;
}

// A frame fitted over random bounds: centered at 0 or anywhere in [-1000, 1000], extents 2^-6 .. 2^6 per axis.
inline QuantFrame random_frame(Pcg32& rng, int bits) {
  Vec3 c, h;
  for (int a = 0; a < 3; ++a) {
    c[a] = one_in(rng, 3) ? 0.0f : rand_float(rng, -1000.0f, 1000.0f);
    h[a] = std::ldexp(rand_float(rng, 0.5f, 1.0f), int(rand_int(rng, -6, 6)));
  }
  return QuantFrame::fit(Aabb{c - h, c + h}, bits);
}

// A non-negative fraction p / q, q > 0, compared exactly by cross-multiplication (every use stays below 2^110).
struct Frac {
  Wide p, q;
};
inline bool frac_less(const Frac& a, const Frac& b) {
  return a.p * b.q < b.p * a.q;
}

// The distance in t raw units to grid plane `plane` on axis a: ((plane - o) * 2^s) / d, as a fraction.
inline Frac plane_dist(const FixedRay& r, int a, int64_t plane) {
  Wide p = Wide((plane << r.frac) - r.o[a]) << r.t_shift, q = r.d[a];
  if (q < 0) {
    p = -p;
    q = -q;
  }
  return {p, q};
}

// The exact entry (the latest plane the ray enters, no earlier than `from`) or exit (the earliest plane it leaves,
// no later than `from`) of the slab intersection, zero axes left out.
inline Frac exact_slab_end(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t from, bool entry) {
  Frac best{from, 1};
  for (int a = 0; a < 3; ++a) {
    if (r.zero[a]) continue;
    const Frac t = plane_dist(r, a, (r.d[a] > 0) == entry ? lo[a] : hi[a]);
    if (entry ? frac_less(best, t) : frac_less(t, best)) best = t;
  }
  return best;
}

// The exact entry and exit of the slab intersection over [tmin, tlim] (zero axes left out).
inline Frac exact_entry(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t tmin) {
  return exact_slab_end(r, lo, hi, tmin, true);
}
inline Frac exact_exit(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t tlim) {
  return exact_slab_end(r, lo, hi, tlim, false);
}

// The slab test in long double: +1 accept, -1 reject, 0 too close to call. Each distance is one rounding of an
// exact quotient ((plane - o) * 2^s is an integer below 2^80, converted with one rounding, then divided: relative
// error <= 2 * 2^-64); max/min add none, and the final subtraction keeps its sign. So a margin beyond
// 2^-60 (|t0| + |t1|) (a factor 8 above those errors) has the sign of the exact margin.
inline int box_long_double(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t tmin,
                           int64_t tlim) {
  LD t0 = LD(tmin), t1 = LD(tlim);
  for (int a = 0; a < 3; ++a) {
    const int64_t dl = (lo[a] << r.frac) - r.o[a], dh = (hi[a] << r.frac) - r.o[a];
    if (r.zero[a]) {
      if (dl > 0 || dh < 0) return -1;
      continue;
    }
    const LD tl = std::ldexp(LD(dl), r.t_shift) / LD(r.d[a]), th = std::ldexp(LD(dh), r.t_shift) / LD(r.d[a]);
    t0 = std::max(t0, std::min(tl, th));
    t1 = std::min(t1, std::max(tl, th));
  }
  const LD margin = t1 - t0, err = std::ldexp(std::fabs(t0) + std::fabs(t1), -60);
  return margin > err ? 1 : (margin < -err ? -1 : 0);
}

// Long double Moller-Trumbore on the quantized ray and grid vertices: u, v weights of v1, v2, w = 1 - u - v of v0,
// t in t raw units, with bounds on the reference's own rounding error.
struct TriRef {
  bool ok = false;  // det != 0
  LD u = 0, v = 0, w = 0, t = 0;
  LD err_u = 0, err_v = 0, err_t = 0;
};
inline TriRef triangle_ref(const FixedRay& r, const int32_t v[3][3]) {
  LD o[3], d[3], e1[3], e2[3], s[3];
  for (int a = 0; a < 3; ++a) {
    o[a] = std::ldexp(LD(r.o[a]), -r.frac);  // exact: every input has at most 64 significant bits
    d[a] = std::ldexp(LD(r.d[a]), -r.dir_bits);
    e1[a] = LD(int64_t(v[1][a]) - v[0][a]);
    e2[a] = LD(int64_t(v[2][a]) - v[0][a]);
    s[a] = o[a] - LD(v[0][a]);  // exact: B + G + F < 64 bits
  }
  auto cross = [](const LD* x, const LD* y, LD* out) {
    out[0] = x[1] * y[2] - x[2] * y[1];
    out[1] = x[2] * y[0] - x[0] * y[2];
    out[2] = x[0] * y[1] - x[1] * y[0];
  };
  auto dot = [](const LD* x, const LD* y) { return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]; };
  auto norm = [&](const LD* x) { return std::sqrt(dot(x, x)); };
  LD pvec[3], qvec[3];
  cross(d, e2, pvec);
  TriRef ref;
  const LD det = dot(e1, pvec);
  if (det == 0) return ref;
  cross(s, e1, qvec);
  ref.ok = true;
  ref.u = dot(s, pvec) / det;
  ref.v = dot(d, qvec) / det;
  ref.w = 1 - ref.u - ref.v;
  const LD t = dot(e2, qvec) / det;
  // Each numerator and det is a triple product of exact vectors formed with at most 5 roundings of relative size
  // 2^-64, each bounded by the product of the three norms (|x . (y x z)| <= |x||y||z| termwise); a quotient adds
  // one more. 2^-56 leaves a factor 256 over the at most ~12 roundings per result.
  const LD k = std::ldexp(LD(1), -56), ad = std::fabs(det);
  const LD nd = norm(d), n1 = norm(e1), n2 = norm(e2), ns = norm(s), vol = n1 * nd * n2;
  ref.err_u = k * (ns * nd * n2 + std::fabs(ref.u) * vol) / ad;
  ref.err_v = k * (nd * ns * n1 + std::fabs(ref.v) * vol) / ad;
  ref.t = std::ldexp(t, r.t_shift - r.dir_bits + r.frac);  // ray units -> t raw (2^T)
  ref.err_t = std::ldexp(k * (n2 * ns * n1 + std::fabs(t) * vol) / ad, r.t_shift - r.dir_bits + r.frac);
  return ref;
}

// The edge function d . (A_p x A_q) of grid points p, q for the ray, exactly (A = p - o in grid.F).
inline Wide edge_function(const FixedRay& r, const int64_t p[3], const int64_t q[3]) {
  Wide A[3], C[3];
  for (int a = 0; a < 3; ++a) {
    A[a] = Wide(p[a] << r.frac) - r.o[a];
    C[a] = Wide(q[a] << r.frac) - r.o[a];
  }
  return r.d[0] * (A[1] * C[2] - A[2] * C[1]) + r.d[1] * (A[2] * C[0] - A[0] * C[2]) +
         r.d[2] * (A[0] * C[1] - A[1] * C[0]);
}

// n . d for the grid normal of triangle v: zero exactly when the ray is parallel to the triangle's plane.
inline Wide normal_dot_dir(const FixedRay& r, const int64_t v0[3], const int64_t v1[3], const int64_t v2[3]) {
  int64_t e1[3], e2[3];
  for (int a = 0; a < 3; ++a) {
    e1[a] = v1[a] - v0[a];
    e2[a] = v2[a] - v0[a];
  }
  return Wide(e1[1] * e2[2] - e1[2] * e2[1]) * r.d[0] + Wide(e1[2] * e2[0] - e1[0] * e2[2]) * r.d[1] +
         Wide(e1[0] * e2[1] - e1[1] * e2[0]) * r.d[2];
}

inline void to_record(const int64_t p[3], const int64_t q[3], const int64_t s[3], int32_t out[3][3]) {
  for (int a = 0; a < 3; ++a) {
    out[0][a] = int32_t(p[a]);
    out[1][a] = int32_t(q[a]);
    out[2][a] = int32_t(s[a]);
  }
}

// A ray from grid point `origin` (an exact float below 2^24 in the unit frame) along integer `dir`, scaled by 2^k.
inline Ray grid_ray(const int64_t origin[3], const int64_t dir[3], int k) {
  Ray r;
  for (int a = 0; a < 3; ++a) {
    r.origin[a] = float(origin[a]);
    r.dir[a] = std::ldexp(float(dir[a]), k);
  }
  r.tmin = 0.0f;
  r.tmax = kInf;
  return r;
}

}  // namespace rtu::hw::fixed_checks
