// The fixed-point datapath (intersect_fixed.h) and what is built on it, against references that do not share its
// algorithms:
// - formats: every preset validates, bad widths are rejected with the rule they break;
// - the quantization frame with fraction bits: equal to a finer frame, rounding checked in world space (exact);
// - the box test: no false negatives against the exact rational checker on 2M+ randomized cases (ties included:
//   rays aimed exactly at corners and edges, origins on box planes, degenerate boxes), its entry distance never
//   beyond the exact one, and the exact checker itself against long double where long double can decide;
// - the triangle test: watertight on constructed shared edges and vertex fans (exact ties), and hit/miss and t
//   against a long double Moller-Trumbore on the same quantized inputs away from edges; degenerate triangles miss;
// - the sphere and plane tests against long double on the same quantized inputs, with the tolerance derived from
//   the roundings of each test; a plane met beyond the t register's range is no hit inside a shorter interval;
// - ray setup: invalid rays, the guard range, infinite tmax, signed zeros, power-of-two scale invariance;
// - the device image (every decoded child box contains its subtree's records) and FixedTracer against FloatTracer,
//   any-hit against closest-hit, and thread-count independence.
// Every reference works on the quantized values the datapath sees (FixedRay, records), so the comparisons measure
// the datapath's own roundings, not the quantization of the scene. Randomized parts print their seed.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "hwmodel/bvh.h"
#include "hwmodel/device_image.h"
#include "hwmodel/fixed_format.h"
#include "hwmodel/fixed_tracer.h"
#include "hwmodel/float_tracer.h"
#include "hwmodel/geometry.h"
#include "hwmodel/intersect_fixed.h"
#include "hwmodel/quant_frame.h"
#include "hwmodel/rng.h"
#include "hwmodel/timed_engine.h"
#include "timing_checks.h"

using namespace rtu::hw;

namespace {

using LD = long double;
// The references below count on a 64-bit significand (x87 extended precision): unit roundoff 2^-64.
static_assert(std::numeric_limits<LD>::digits >= 64, "the long double references need a 64-bit significand");

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr Round kModes[] = {Round::kDown, Round::kUp, Round::kNearestEven};
constexpr double kPi = 3.14159265358979323846;

// REQUIRE that builds its context message only on failure: the hot loops run millions of cases, and formatting a
// message for every passing one would dominate the run time.
#define REQUIRE_CTX(cond, ctx) \
  do {                         \
    if (!(cond)) {             \
      INFO(ctx);               \
      REQUIRE(cond);           \
    }                          \
  } while (0)

// ---------------------------------------------------------------------------------------------------------------
// Small helpers

uint64_t next_u64(Pcg32& g) {
  const uint64_t hi = g.next_u32();
  return (hi << 32) | g.next_u32();
}
// Uniform integer in [lo, hi]. The modulo bias (span / 2^64) does not matter for a test's coverage.
int64_t rand_int(Pcg32& g, int64_t lo, int64_t hi) {
  return lo + int64_t(next_u64(g) % (uint64_t(hi - lo) + 1));
}
float rand_float(Pcg32& g, float lo, float hi) {
  return lo + (hi - lo) * g.next_float();
}
bool one_in(Pcg32& g, uint32_t n) {
  return g.next_u32() % n == 0;
}
double rand_double(Pcg32& g, double lo, double hi) {
  return lo + (hi - lo) * (double(next_u64(g) >> 11) * 0x1p-53);
}

std::string wide_str(Wide x) {
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

std::string describe(const FixedRay& r) {
  std::ostringstream o;
  o << "o " << r.o[0] << " " << r.o[1] << " " << r.o[2] << " | d " << r.d[0] << " " << r.d[1] << " " << r.d[2]
    << " | zero " << r.zero[0] << r.zero[1] << r.zero[2] << " | rcp_dn " << r.rcp_dn[0] << " " << r.rcp_dn[1]
    << " " << r.rcp_dn[2] << " | rcp_up " << r.rcp_up[0] << " " << r.rcp_up[1] << " " << r.rcp_up[2] << " | tmin "
    << r.tmin << " tmax " << r.tmax << " t_exp " << r.t_exp << " F " << r.frac << " D " << r.dir_bits
    << " box_shift " << r.box_shift << " t_shift " << r.t_shift << " t_limit " << r.t_limit;
  return o.str();
}

std::string describe_box(const int64_t lo[3], const int64_t hi[3], int64_t tmin, int64_t tlim) {
  std::ostringstream o;
  o << "box lo " << lo[0] << " " << lo[1] << " " << lo[2] << " hi " << hi[0] << " " << hi[1] << " " << hi[2]
    << " interval [" << tmin << ", " << tlim << "]";
  return o.str();
}

std::string describe_tri(const int32_t v[3][3]) {
  std::ostringstream o;
  for (int i = 0; i < 3; ++i) o << "v" << i << " " << v[i][0] << " " << v[i][1] << " " << v[i][2] << " ";
  return o.str();
}

// A custom format with a coarse direction and reciprocal (D = 6, R = 4) and no fraction bits, so the box test's
// roundings are as large as any format allows, and small coordinates (B = 10).
FixedFormat coarse_format() {
  FixedFormat f;
  f.name = "coarse";
  f.coord_bits = 10;
  f.child_bits = 4;
  f.guard_bits = 2;
  f.frac_bits = 0;
  f.dir_bits = 6;
  f.rcp_bits = 4;
  f.t_frac_bits = 0;
  f.t_bits = 20;
  return f;
}

// A custom format with positions much finer than t (F = 16, T = 8): the sphere test's rounding of the
// perpendicular to grid.F then costs well under a unit of t (see the sphere test case).
FixedFormat fine_position_format() {
  FixedFormat f;
  f.name = "fine-position";
  f.coord_bits = 16;
  f.guard_bits = 4;
  f.frac_bits = 16;
  f.dir_bits = 24;
  f.rcp_bits = 24;
  f.t_frac_bits = 8;
  f.t_bits = 40;
  return f;
}

// Formats the datapath tests run on: several coordinate widths (10, 16, 24, 28), F from 0 to 10, T > F and T = F.
std::vector<FixedFormat> datapath_formats() {
  return {format_preset("default"), format_preset("compact"), format_preset("precise"), coarse_format()};
}

// A frame with grid step 1 and origin 0: world coordinates are grid coordinates (exact floats below 2^24).
QuantFrame unit_frame(int bits) {
  QuantFrame q;
  q.bits = bits;
  q.step_exp = 0;
  return q;
}

// A frame fitted over random bounds: centered at 0 or anywhere in [-1000, 1000], extents 2^-6 .. 2^6 per axis.
QuantFrame random_frame(Pcg32& rng, int bits) {
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
bool frac_less(const Frac& a, const Frac& b) {
  return a.p * b.q < b.p * a.q;
}

// The distance in t raw units to grid plane `plane` on axis a: ((plane - o) * 2^s) / d, as a fraction.
Frac plane_dist(const FixedRay& r, int a, int64_t plane) {
  Wide p = Wide((plane << r.frac) - r.o[a]) << r.t_shift, q = r.d[a];
  if (q < 0) {
    p = -p;
    q = -q;
  }
  return {p, q};
}

// The exact entry and exit of the slab intersection over [tmin, tlim] (zero axes left out).
Frac exact_entry(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t tmin) {
  Frac best{tmin, 1};
  for (int a = 0; a < 3; ++a) {
    if (r.zero[a]) continue;
    const Frac t = plane_dist(r, a, r.d[a] > 0 ? lo[a] : hi[a]);
    if (frac_less(best, t)) best = t;
  }
  return best;
}
Frac exact_exit(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t tlim) {
  Frac best{tlim, 1};
  for (int a = 0; a < 3; ++a) {
    if (r.zero[a]) continue;
    const Frac t = plane_dist(r, a, r.d[a] > 0 ? hi[a] : lo[a]);
    if (frac_less(t, best)) best = t;
  }
  return best;
}

// The slab test in long double: +1 accept, -1 reject, 0 too close to call. Each distance is one rounding of an
// exact quotient ((plane - o) * 2^s is an integer below 2^80, converted with one rounding, then divided: relative
// error <= 2 * 2^-64); max/min add none, and the final subtraction keeps its sign. So a margin beyond
// 2^-60 (|t0| + |t1|) (a factor 8 above those errors) has the sign of the exact margin.
int box_long_double(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t tmin, int64_t tlim) {
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
TriRef triangle_ref(const FixedRay& r, const int32_t v[3][3]) {
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
Wide edge_function(const FixedRay& r, const int64_t p[3], const int64_t q[3]) {
  Wide A[3], C[3];
  for (int a = 0; a < 3; ++a) {
    A[a] = Wide(p[a] << r.frac) - r.o[a];
    C[a] = Wide(q[a] << r.frac) - r.o[a];
  }
  return r.d[0] * (A[1] * C[2] - A[2] * C[1]) + r.d[1] * (A[2] * C[0] - A[0] * C[2]) +
         r.d[2] * (A[0] * C[1] - A[1] * C[0]);
}

// n . d for the grid normal of triangle v: zero exactly when the ray is parallel to the triangle's plane.
Wide normal_dot_dir(const FixedRay& r, const int64_t v0[3], const int64_t v1[3], const int64_t v2[3]) {
  int64_t e1[3], e2[3];
  for (int a = 0; a < 3; ++a) {
    e1[a] = v1[a] - v0[a];
    e2[a] = v2[a] - v0[a];
  }
  return Wide(e1[1] * e2[2] - e1[2] * e2[1]) * r.d[0] + Wide(e1[2] * e2[0] - e1[0] * e2[2]) * r.d[1] +
         Wide(e1[0] * e2[1] - e1[1] * e2[0]) * r.d[2];
}

void to_record(const int64_t p[3], const int64_t q[3], const int64_t s[3], int32_t out[3][3]) {
  for (int a = 0; a < 3; ++a) {
    out[0][a] = int32_t(p[a]);
    out[1][a] = int32_t(q[a]);
    out[2][a] = int32_t(s[a]);
  }
}

// A ray from grid point `origin` (an exact float below 2^24 in the unit frame) along integer `dir`, scaled by 2^k.
Ray grid_ray(const int64_t origin[3], const int64_t dir[3], int k) {
  Ray r;
  for (int a = 0; a < 3; ++a) {
    r.origin[a] = float(origin[a]);
    r.dir[a] = std::ldexp(float(dir[a]), k);
  }
  r.tmin = 0.0f;
  r.tmax = kInf;
  return r;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------------

TEST_CASE("fixed formats: every preset validates, bad widths are rejected with their rule", "[fixed][format]") {
  REQUIRE_FALSE(format_presets().empty());
  for (const FixedFormat& f : format_presets()) {
    INFO(f.describe());
    CHECK_NOTHROW(f.validate());
    CHECK(format_preset(f.name).describe() == f.describe());
    CHECK(f.edge_function_bits() <= 126);
    CHECK(f.box_product_bits() <= 126);
  }
  CHECK_NOTHROW(coarse_format().validate());
  CHECK_NOTHROW(fine_position_format().validate());

  auto rejects = [](const FixedFormat& f, const char* rule) {
    INFO(f.describe() << " should break: " << rule);
    CHECK_THROWS_AS(f.validate(), std::invalid_argument);
    CHECK_THROWS_WITH(f.validate(), Catch::Contains(rule));
  };
  FixedFormat f;
  f.coord_bits = 31;  // vertices and node origins are stored as int32
  rejects(f, "coord_bits");
  f = FixedFormat{};
  f.width = 3;
  rejects(f, "width");
  // B = 30, G = 16, F = 14: translated values need a = 61 bits, the edge function 2a + D + 3 = 149 > 126. With the
  // default t bits this combination also breaks the t-range rule (t_bits >= B + G + T + 3), which validate()
  // checks first; T = 8 and t_bits = 62 leave the edge function as the only rule broken.
  f = FixedFormat{};
  f.coord_bits = 30;
  f.guard_bits = 16;
  f.frac_bits = 14;
  CHECK_THROWS_AS(f.validate(), std::invalid_argument);
  f.t_frac_bits = 8;
  f.t_bits = 62;
  CHECK(f.edge_function_bits() > 126);
  rejects(f, "edge function");
  f = FixedFormat{};
  f.dir_bits = 30;
  f.rcp_bits = 33;  // the reciprocal would need 64 magnitude bits
  rejects(f, "dir_bits + rcp_bits");
  CHECK_THROWS_AS(format_preset("nope"), std::invalid_argument);
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

TEST_CASE("box test: no false negatives against the exact checker (2M randomized cases, ties included)",
          "[fixed][box]") {
  const uint64_t seed = 20240611;
  INFO("seed " << seed);
  Pcg32 rng(seed);
  constexpr int kFrames = 32, kRaysPerFrame = 1000, kBoxesPerRay = 16;
  uint64_t tests = 0, exact_accepts = 0, fast_accepts = 0, touching = 0, ld_decided = 0, aimed = 0, zero_axes = 0,
           on_plane = 0, degenerate = 0, narrow_checked = 0;
  for (const FixedFormat& f : datapath_formats()) {
    const int B = f.coord_bits, G = f.guard_bits;
    const int64_t box_max = (int64_t(1) << (B + 1)) - 1;  // decoded boxes lie in [0, 2^(B+1)) (fixed_format.cpp)
    const int aim_bits = std::min(f.dir_bits, 24);        // |delta| < 2^D: the direction is exact after setup
    auto clamp_box = [&](int64_t v) { return std::clamp<int64_t>(v, 0, box_max); };
    for (int fi = 0; fi < kFrames; ++fi) {
      const QuantFrame frame = random_frame(rng, B);
      for (int ri = 0; ri < kRaysPerFrame; ++ri) {
        // Origin: a grid point (so that box planes through it and aimed directions are exact) or any float.
        Ray ray;
        int64_t og[3] = {0, 0, 0};
        bool on_grid = !one_in(rng, 3);
        for (int a = 0; a < 3; ++a) {
          double g;
          if (one_in(rng, 8))
            g = rand_double(rng, -0.99, 0.99) * std::ldexp(1.0, B + G);  // anywhere in the guard range
          else
            g = rand_double(rng, -0.25, 2.25) * std::ldexp(1.0, B);
          if (on_grid) {
            // A float near a grid point is a grid point: below 2^24 exactly, above it a multiple of 2^step.
            const float x = float(frame.to_world(int64_t(std::floor(g)), a));
            og[a] = frame.to_grid(x, a, Round::kDown);
            if (frame.to_world(og[a], a) != double(x)) on_grid = false;
            ray.origin[a] = x;
          } else {
            ray.origin[a] = float(frame.to_world(0, a) + frame.step() * g);
          }
        }
        // Direction: aimed exactly at a corner or edge point of a target box, or random with signed zeros and
        // components too small to survive the rounding; then scaled by a power of two (tiny to huge).
        int64_t tlo[3] = {0, 0, 0}, thi[3] = {0, 0, 0}, tdelta[3] = {0, 0, 0};
        bool has_target = false;
        if (on_grid && !one_in(rng, 3)) {
          int64_t c[3], delta[3];
          const int m = int(rand_int(rng, 0, aim_bits - 2));
          bool nonzero = false, fits = true;
          for (int a = 0; a < 3; ++a) {
            c[a] = clamp_box(og[a] + rand_int(rng, -(int64_t(1) << m), int64_t(1) << m));
            delta[a] = c[a] - og[a];
            nonzero = nonzero || delta[a] != 0;
            fits = fits && std::abs(delta[a]) < (int64_t(1) << aim_bits);
          }
          if (nonzero && fits) {
            has_target = true;
            bool boundary = false;
            for (int a = 0; a < 3; ++a) {
              // c on the low plane, on the high plane, inside the slab (an edge or face point), or a flat slab.
              const int role = int(rng.next_u32() % 4);
              const int64_t s1 = rand_int(rng, 1, int64_t(1) << rand_int(rng, 0, B - 2));
              const int64_t s2 = rand_int(rng, 1, int64_t(1) << rand_int(rng, 0, B - 2));
              tlo[a] = role == 0 ? c[a] : (role == 3 ? c[a] : clamp_box(c[a] - s1));
              thi[a] = role == 1 ? c[a] : (role == 3 ? c[a] : clamp_box(c[a] + s2));
              boundary = boundary || role != 2;
            }
            if (!boundary) tlo[0] = c[0];
            for (int a = 0; a < 3; ++a) {
              tdelta[a] = delta[a];
              ray.dir[a] = float(delta[a]);
            }
          }
        }
        if (!has_target) {
          const bool axis_ray = one_in(rng, 8);
          const int main_axis = int(rng.next_u32() % 3);
          for (int a = 0; a < 3; ++a) {
            float v = rand_float(rng, -1.0f, 1.0f);
            if (axis_ray && a != main_axis) v = 0.0f;
            if (one_in(rng, 5)) v = 0.0f;
            if (v == 0.0f && one_in(rng, 2)) v = -0.0f;
            if (one_in(rng, 16)) v = std::ldexp(v, -40);  // rounds to 0 in d unless it is the largest
            ray.dir[a] = v;
          }
          if (ray.dir.x == 0.0f && ray.dir.y == 0.0f && ray.dir.z == 0.0f) ray.dir[main_axis] = -1.0f;
        }
        const int k = int(rand_int(rng, -60, 60));
        for (int a = 0; a < 3; ++a) ray.dir[a] = std::ldexp(ray.dir[a], k);
        ray.tmin = one_in(rng, 4) ? rand_float(rng, -1.0f, 1.0f) * std::ldexp(1.0f, B - k) : 0.0f;
        ray.tmax = one_in(rng, 4) ? rand_float(rng, 0.0f, 2.0f) * std::ldexp(1.0f, B - k) : kInf;

        FixedRay fr;
        const RayStatus st = setup_ray(ray, frame, f, fr);
        auto ray_ctx = [&] {
          std::ostringstream o;
          o << "format " << f.name << " frame step 2^" << frame.step_exp << " ray o " << ray.origin.x << " "
            << ray.origin.y << " " << ray.origin.z << " dir " << ray.dir.x << " " << ray.dir.y << " " << ray.dir.z
            << " tmin " << ray.tmin << " tmax " << ray.tmax << " | " << describe(fr);
          return o.str();
        };
        REQUIRE_CTX(st == RayStatus::kOk, ray_ctx());
        if (has_target) {
          // The aim is exact when the quantized origin is the grid point and d = delta * 2^(D - 1 - ilogb|delta|)
          // (an integer: |delta| < 2^D), i.e. the ray passes exactly through the target point.
          int64_t m = 0;
          for (int a = 0; a < 3; ++a) m = std::max(m, std::abs(tdelta[a]));
          const int j = f.dir_bits - 1 - std::ilogb(double(m));
          bool exact = true;
          for (int a = 0; a < 3; ++a)
            exact = exact && fr.o[a] == (og[a] << f.frac_bits) && fr.d[a] == tdelta[a] * (int64_t(1) << j);
          aimed += uint64_t(exact);
        }
        for (int a = 0; a < 3; ++a) zero_axes += uint64_t(fr.zero[a]);

        for (int bi = 0; bi < kBoxesPerRay; ++bi) {
          int64_t lo[3], hi[3];
          const int kind = int(rng.next_u32() % 6);
          // A point on the ray (grid units) at a random t, for boxes near the ray's path.
          const double tp = std::ldexp(rand_double(rng, 0.0, 1.0), int(rand_int(rng, -4, B + 2)));
          double p[3];
          for (int a = 0; a < 3; ++a)
            p[a] = std::ldexp(double(fr.o[a]), -f.frac_bits) + tp * std::ldexp(double(fr.d[a]), -f.dir_bits);
          if (kind <= 1 && has_target) {
            for (int a = 0; a < 3; ++a) {
              lo[a] = tlo[a];
              hi[a] = thi[a];
            }
            if (kind == 1) {  // a neighbour: shifted by one grid step on one axis, now just missed or entered
              const int a = int(rng.next_u32() % 3);
              const int64_t s = one_in(rng, 2) ? 1 : -1;
              lo[a] = clamp_box(lo[a] + s);
              hi[a] = clamp_box(hi[a] + s);
            }
          } else if (kind == 2) {  // anywhere
            for (int a = 0; a < 3; ++a) {
              lo[a] = rand_int(rng, 0, box_max);
              hi[a] = rand_int(rng, 0, box_max);
              if (lo[a] > hi[a]) std::swap(lo[a], hi[a]);
            }
          } else {  // around the ray's path; some flat (lo == hi), some tiny
            for (int a = 0; a < 3; ++a) {
              const int64_t c = clamp_box(int64_t(std::clamp(std::floor(p[a]), -1.0, double(box_max) + 1.0)));
              const int sz = kind == 5 ? 1 : int(rand_int(rng, 0, B - 1));
              lo[a] = clamp_box(c - rand_int(rng, 0, int64_t(1) << sz));
              hi[a] = clamp_box(c + rand_int(rng, 0, int64_t(1) << sz));
              if (kind == 4 && one_in(rng, 2)) lo[a] = hi[a] = c;
            }
          }
          // A box plane through the origin (grid-point origins only).
          if (on_grid && one_in(rng, 4)) {
            const int a = int(rng.next_u32() % 3);
            if (og[a] >= 0 && og[a] <= box_max) {
              if (one_in(rng, 2)) {
                lo[a] = og[a];
                hi[a] = std::max(hi[a], og[a]);
              } else {
                hi[a] = og[a];
                lo[a] = std::min(lo[a], og[a]);
              }
              ++on_plane;
            }
          }
          for (int a = 0; a < 3; ++a) degenerate += uint64_t(lo[a] == hi[a]);

          // The interval: the ray's own, random, or ending exactly at (the floor or ceiling of) a plane distance.
          int64_t tmin = fr.tmin, tlim = fr.tmax;
          const int ik = int(rng.next_u32() % 4);
          if (ik == 1) {
            auto rand_t = [&]() {
              return int64_t(rand_double(rng, -1.0, 1.0) * std::ldexp(1.0, int(rand_int(rng, 0, 62))));
            };
            tmin = std::clamp<int64_t>(rand_t(), -fr.t_limit, fr.t_limit);
            tlim = std::clamp<int64_t>(rand_t(), -fr.t_limit, fr.t_limit);
          } else if (ik >= 2) {
            const int a = int(rng.next_u32() % 3);
            if (!fr.zero[a]) {
              const Frac tn = plane_dist(fr, a, fr.d[a] > 0 ? lo[a] : hi[a]);
              const Frac tf = plane_dist(fr, a, fr.d[a] > 0 ? hi[a] : lo[a]);
              const Round rr = one_in(rng, 2) ? Round::kDown : Round::kUp;
              if (ik == 2)
                tlim = int64_t(std::clamp<Wide>(div_round(tn.p, tn.q, rr), -fr.t_limit, fr.t_limit));
              else
                tmin = int64_t(std::clamp<Wide>(div_round(tf.p, tf.q, rr), -fr.t_limit, fr.t_limit));
            }
          }

          ++tests;
          int64_t t_near = INT64_MIN;
          const bool fast = box_test(fr, lo, hi, tmin, tlim, t_near);
          const bool exact = box_test_exact(fr, lo, hi, tmin, tlim);
          {
            // The 64-bit path (narrow formats) and the 128-bit path compute the same function: identical bits.
            int64_t tw = INT64_MIN;
            const bool wide = box_test_impl<Wide>(fr, lo, hi, tmin, tlim, tw);
            if (wide != fast || (fast && tw != t_near)) {
              INFO(ray_ctx() << " | " << describe_box(lo, hi, tmin, tlim) << " narrow " << fr.narrow);
              FAIL("the 64-bit and 128-bit box paths differ");
            }
            narrow_checked += uint64_t(fr.narrow);
          }
          exact_accepts += uint64_t(exact);
          fast_accepts += uint64_t(fast);
          if (exact && !fast) {
            INFO(ray_ctx() << " | " << describe_box(lo, hi, tmin, tlim));
            FAIL("box_test rejects a box the exact test accepts");
          }
          if (fast) {
            // The entry distance is rounded down (and clamped to the interval start), so it is never beyond the
            // exact entry: t_near * q <= p, exactly in 128 bits.
            const Frac e = exact_entry(fr, lo, hi, tmin);
            if (Wide(t_near) * e.q > e.p) {
              INFO(ray_ctx() << " | " << describe_box(lo, hi, tmin, tlim) << " t_near " << t_near
                             << " exact entry " << wide_str(e.p) << " / " << wide_str(e.q));
              FAIL("box_test's t_near is beyond the exact entry distance");
            }
          }
          if (exact) {
            const Frac e = exact_entry(fr, lo, hi, tmin), x = exact_exit(fr, lo, hi, tlim);
            touching += uint64_t(!frac_less(e, x));  // entry == exit: the ray touches an edge, corner or face
          }
          const int ld = box_long_double(fr, lo, hi, tmin, tlim);
          if (ld != 0) {
            ++ld_decided;
            if ((ld > 0) != exact) {
              INFO(ray_ctx() << " | " << describe_box(lo, hi, tmin, tlim) << " long double " << ld);
              FAIL("box_test_exact disagrees with a clear long double decision");
            }
          }
        }
      }
    }
  }
  INFO("tests " << tests << " exact accepts " << exact_accepts << " fast accepts " << fast_accepts << " touching "
                << touching << " long double decided " << ld_decided << " exactly aimed rays " << aimed
                << " zero axes " << zero_axes << " origin on a box plane " << on_plane << " flat box axes "
                << degenerate);
  CHECK(tests >= 2000000);
  CHECK(narrow_checked > tests / 4);  // the default and compact formats take the 64-bit path
  // Coverage, not tolerances: both outcomes are common, exact ties (touching boxes) occur by the thousand, and
  // long double decides nearly every case away from ties.
  CHECK(exact_accepts * 10 > tests);
  CHECK((tests - exact_accepts) * 5 > tests);
  CHECK(touching > 1000);
  CHECK(ld_decided * 10 > tests * 9);
  CHECK(aimed > 10000);
  CHECK(zero_axes > 10000);
  CHECK(on_plane > 10000);
}

TEST_CASE("triangle test: rays exactly through a shared edge or vertex hit (watertight)",
          "[fixed][triangle][watertight]") {
  const uint64_t seed = 1234567;
  INFO("seed " << seed);
  Pcg32 rng(seed);
  uint64_t edge_rays = 0, jitter_rays = 0, fan_rays = 0;
  for (const FixedFormat& f :
       {format_preset("default"), format_preset("compact"), format_preset("precise"), fine_position_format()}) {
    INFO("format " << f.describe());
    const QuantFrame frame = unit_frame(f.coord_bits);
    // Coordinates below 2^min(B, 20): inside the grid, and origins on the grid are exact floats.
    const int64_t cmax = int64_t(1) << std::min(f.coord_bits, 20);
    for (int it = 0; it < 400; ++it) {
      // Two triangles sharing the edge P-Q = P + n w, on either side of it (coplanar, or folded along it).
      int64_t P[3], Q[3], w[3], u[3], R1[3], R2[3], z[3];
      const int64_t n = rand_int(rng, 1, 8);
      do {
        for (int a = 0; a < 3; ++a) {
          P[a] = rand_int(rng, cmax / 4, cmax / 2);
          w[a] = rand_int(rng, -16, 16);
          u[a] = rand_int(rng, -16, 16);
        }
        z[0] = w[1] * u[2] - w[2] * u[1];
        z[1] = w[2] * u[0] - w[0] * u[2];
        z[2] = w[0] * u[1] - w[1] * u[0];
      } while (z[0] == 0 && z[1] == 0 && z[2] == 0);  // w and u not parallel (and neither zero)
      const bool folded = one_in(rng, 3);
      const int64_t a1 = rand_int(rng, 0, n), a2 = rand_int(rng, 0, n), b1 = rand_int(rng, 1, 4),
                    b2 = rand_int(rng, 1, 4), c2 = folded ? rand_int(rng, -2, 2) : 0;
      for (int a = 0; a < 3; ++a) {
        Q[a] = P[a] + n * w[a];
        R1[a] = P[a] + a1 * w[a] + b1 * u[a];
        R2[a] = P[a] + a2 * w[a] - b2 * u[a] + c2 * z[a];
      }
      int32_t T1[3][3], T2[3][3];
      to_record(P, Q, R1, T1);  // weights: w of P, u of Q, v of R1
      to_record(Q, P, R2, T2);  // weights: w of Q, u of P, v of R2 (the mesh's opposite winding)
      INFO("T1 " << describe_tri(T1) << " T2 " << describe_tri(T2));

      for (int ri = 0; ri < 6; ++ri) {
        // A point X on the edge (a lattice point P + j w, or the midpoint of P-Q), and a ray exactly through it.
        const int64_t j = rand_int(rng, 0, n);
        int64_t X[3], origin[3], dir[3];
        for (int a = 0; a < 3; ++a) X[a] = P[a] + j * w[a];
        const int kind = ri % 3;
        if (kind == 0) {  // along an axis from directly above (or below) X
          int ax = int(rng.next_u32() % 3);
          const int64_t h = rand_int(rng, 1, 1024) * (one_in(rng, 2) ? 1 : -1);
          for (int a = 0; a < 3; ++a) {
            origin[a] = X[a] + (a == ax ? h : 0);
            dir[a] = a == ax ? -h : 0;
          }
        } else if (kind == 1) {  // oblique, from a lattice point kk steps back along delta
          const int64_t kk = rand_int(rng, 1, 4);
          do {
            for (int a = 0; a < 3; ++a) dir[a] = rand_int(rng, -256, 256);
          } while (dir[0] == 0 && dir[1] == 0 && dir[2] == 0);
          for (int a = 0; a < 3; ++a) origin[a] = X[a] - kk * dir[a];
        } else {  // oblique through the edge's midpoint (P + Q) / 2, a half-integer point: dir = (P + Q) - 2 Y
          for (int a = 0; a < 3; ++a) {
            origin[a] = P[a] + rand_int(rng, -300, 300);
            dir[a] = P[a] + Q[a] - 2 * origin[a];
          }
          if (dir[0] == 0 && dir[1] == 0 && dir[2] == 0) continue;
        }
        FixedRay fr;
        REQUIRE(setup_ray(grid_ray(origin, dir, int(rand_int(rng, -30, 30))), frame, f, fr) == RayStatus::kOk);
        // The construction is exact: the ray meets the line P-Q, so the shared edge's function is exactly 0.
        REQUIRE(edge_function(fr, P, Q) == 0);
        const Wide nd1 = normal_dot_dir(fr, P, Q, R1), nd2 = normal_dot_dir(fr, Q, P, R2);
        FixedPrimHit h1{}, h2{};
        const bool hit1 = triangle_test(fr, T1, fr.tmin, fr.tmax, h1);
        const bool hit2 = triangle_test(fr, T2, fr.tmin, fr.tmax, h2);
        INFO("ray " << describe(fr) << " kind " << kind << " j " << j << " of " << n);
        if (nd1 == 0 && nd2 == 0) continue;  // in the plane of both: nothing to hit
        ++edge_rays;
        REQUIRE((hit1 || hit2));
        // Through the edge exactly (edge function 0): the other two edge functions of each triangle are those of a
        // point of the closed segment, so both triangles hit (unless parallel to the ray), at the same exact
        // point, which gives both the same rounded t.
        if (nd1 != 0) REQUIRE(hit1);
        if (nd2 != 0) REQUIRE(hit2);
        if (hit1 && hit2) REQUIRE(h1.t == h2.t);
      }

      // Near the edge: the origin moved by a few grid.F units, so the edge function is small but not 0. For the
      // coplanar pair, a ray whose reference hit point lies away from the outer edges (every weight of P and Q
      // in both triangles > 1e-6 plus the reference's error) lies inside the union and must hit at least one.
      if (folded) continue;
      for (int ri = 0; ri < 4; ++ri) {
        const int64_t j = rand_int(rng, 1, std::max<int64_t>(1, n - 1));
        int64_t origin[3], dir[3];
        do {
          for (int a = 0; a < 3; ++a) dir[a] = rand_int(rng, -256, 256);
        } while (dir[0] == 0 && dir[1] == 0 && dir[2] == 0);
        for (int a = 0; a < 3; ++a) origin[a] = P[a] + j * w[a] - 2 * dir[a];
        FixedRay fr;
        REQUIRE(setup_ray(grid_ray(origin, dir, 0), frame, f, fr) == RayStatus::kOk);
        for (int a = 0; a < 3; ++a) fr.o[a] += rand_int(rng, -3, 3);
        const TriRef r1 = triangle_ref(fr, T1), r2 = triangle_ref(fr, T2);
        if (!r1.ok || !r2.ok) continue;
        const LD m = 1e-6L;
        if (!(r1.w > m + r1.err_u + r1.err_v && r1.u > m + r1.err_u && r2.w > m + r2.err_u + r2.err_v &&
              r2.u > m + r2.err_u))
          continue;
        FixedPrimHit h1{}, h2{};
        const bool hit1 = triangle_test(fr, T1, fr.tmin, fr.tmax, h1);
        const bool hit2 = triangle_test(fr, T2, fr.tmin, fr.tmax, h2);
        INFO("jittered ray " << describe(fr));
        ++jitter_rays;
        REQUIRE((hit1 || hit2));
      }
    }

    // A fan of triangles (V, W_i, W_i+1) around V: planar, or a cone (W_i lifted off the plane).
    for (int it = 0; it < 200; ++it) {
      int64_t V[3], u[3], w[3], z[3];
      do {
        for (int a = 0; a < 3; ++a) {
          V[a] = rand_int(rng, cmax / 4, cmax / 2);
          u[a] = rand_int(rng, -8, 8);
          w[a] = rand_int(rng, -8, 8);
        }
        z[0] = u[1] * w[2] - u[2] * w[1];
        z[1] = u[2] * w[0] - u[0] * w[2];
        z[2] = u[0] * w[1] - u[1] * w[0];
      } while (z[0] == 0 && z[1] == 0 && z[2] == 0);
      const int count = int(rand_int(rng, 3, 10));
      const double radius = std::ldexp(1.0, int(rand_int(rng, 5, 9)));
      const bool cone = one_in(rng, 2);
      std::vector<std::array<int64_t, 3>> ring(static_cast<size_t>(count));
      for (int i = 0; i < count; ++i) {
        // Angles 2 pi (i + jitter) / count with |jitter| <= 1/4: consecutive points less than 180 degrees apart,
        // far enough apart (R^2 sin(angle) >> the rounding of the integer coordinates) to keep every triangle
        // proper and the ring winding once around V.
        const double th = 2.0 * kPi * (i + rand_double(rng, -0.25, 0.25)) / count;
        const int64_t cu = std::llround(radius * std::cos(th)), cw = std::llround(radius * std::sin(th));
        const int64_t lift = cone ? rand_int(rng, -3, 3) : 0;
        for (int a = 0; a < 3; ++a) ring[size_t(i)][size_t(a)] = V[a] + cu * u[a] + cw * w[a] + lift * z[a];
      }
      for (int ri = 0; ri < 4; ++ri) {
        int64_t dir[3], origin[3];
        do {
          for (int a = 0; a < 3; ++a) dir[a] = rand_int(rng, -200, 200);
        } while (dir[0] * z[0] + dir[1] * z[1] + dir[2] * z[2] == 0);  // not parallel to the fan's base plane
        const int64_t kk = rand_int(rng, 1, 8);
        for (int a = 0; a < 3; ++a) origin[a] = V[a] - kk * dir[a];
        FixedRay fr;
        REQUIRE(setup_ray(grid_ray(origin, dir, int(rand_int(rng, -20, 20))), frame, f, fr) == RayStatus::kOk);
        ++fan_rays;
        int hits = 0;
        int64_t t_first = 0;
        for (int i = 0; i < count; ++i) {
          const int64_t* Wi = ring[size_t(i)].data();
          const int64_t* Wn = ring[size_t((i + 1) % count)].data();
          int32_t tri[3][3];
          to_record(V, Wi, Wn, tri);
          FixedPrimHit h{};
          const bool hit = triangle_test(fr, tri, fr.tmin, fr.tmax, h);
          INFO("fan triangle " << i << " of " << count << ": " << describe_tri(tri) << " ray " << describe(fr));
          // Through V exactly, the two edge functions of the edges at V are 0 and the third decides nothing
          // alone: every triangle not parallel to the ray is hit, all at V's t.
          if (normal_dot_dir(fr, V, Wi, Wn) != 0) REQUIRE(hit);
          if (hit) {
            if (hits > 0) REQUIRE(h.t == t_first);
            t_first = h.t;
            ++hits;
          }
        }
        REQUIRE(hits >= 1);
      }
    }
  }
  CHECK(edge_rays > 5000);
  CHECK(jitter_rays > 1000);
  CHECK(fan_rays > 2000);
}

TEST_CASE("triangle test: hit/miss and t against long double Moller-Trumbore, degenerate triangles miss",
          "[fixed][triangle]") {
  const uint64_t seed = 99991;
  INFO("seed " << seed);
  Pcg32 rng(seed);
  uint64_t compared_hits = 0, compared_misses = 0, near_edge = 0, degenerate_tests = 0;
  for (const FixedFormat& f : datapath_formats()) {
    INFO("format " << f.describe());
    const int B = f.coord_bits;
    const QuantFrame frame = unit_frame(B);
    const int64_t gmax = frame.grid_max();
    LD max_dt = 0;
    for (int it = 0; it < 30000; ++it) {
      // A triangle on the grid: a random center, vertices within 2^s of it.
      int32_t v[3][3];
      const int s = int(rand_int(rng, 1, B - 2));
      for (int a = 0; a < 3; ++a) {
        const int64_t c = rand_int(rng, 0, gmax);
        for (int i = 0; i < 3; ++i)
          v[i][a] = int32_t(std::clamp<int64_t>(c + rand_int(rng, -(int64_t(1) << s), int64_t(1) << s), 0, gmax));
      }
      // A ray from anywhere in the frame (and somewhat outside) toward a point of the triangle's plane with
      // weights in [-0.2, 1.2]: hits and misses, many near the edges.
      const double wu = rand_double(rng, -0.2, 1.2), wv = rand_double(rng, -0.2, 1.2);
      Ray ray;
      for (int a = 0; a < 3; ++a) {
        const double target = v[0][a] + wu * (v[1][a] - v[0][a]) + wv * (v[2][a] - v[0][a]);
        ray.origin[a] = float(rand_double(rng, -0.2, 1.2) * double(gmax));
        ray.dir[a] = float(target - double(ray.origin[a]));
      }
      if (ray.dir.x == 0.0f && ray.dir.y == 0.0f && ray.dir.z == 0.0f) continue;
      // The target is at world t = 1: intervals that start or end before or after it.
      ray.tmin = one_in(rng, 4) ? rand_float(rng, 0.0f, 1.5f) : 0.0f;
      ray.tmax = one_in(rng, 4) ? rand_float(rng, 0.5f, 2.0f) : kInf;
      FixedRay fr;
      REQUIRE(setup_ray(ray, frame, f, fr) == RayStatus::kOk);
      FixedPrimHit h{};
      const bool hit = triangle_test(fr, v, fr.tmin, fr.tmax, h);
      const TriRef ref = triangle_ref(fr, v);
      auto ctx = [&] {
        std::ostringstream o;
        o << describe_tri(v) << " ray " << describe(fr) << " ref u " << double(ref.u) << " v " << double(ref.v)
          << " w " << double(ref.w) << " t " << double(ref.t) << " err t " << double(ref.err_t) << " | got hit "
          << hit << " t " << h.t << " u " << h.u << " v " << h.v;
        return o.str();
      };
      if (!ref.ok) continue;
      // Away from the edges: every weight farther than 1e-9 from 0, beyond the reference's own error bound.
      const LD margin_u = 1e-9L + ref.err_u, margin_v = 1e-9L + ref.err_v, margin_w = margin_u + ref.err_v;
      const bool inside = ref.u > margin_u && ref.v > margin_v && ref.w > margin_w;
      const bool outside = ref.u < -margin_u || ref.v < -margin_v || ref.w < -margin_w;
      if (!inside && !outside) {
        ++near_edge;
        continue;
      }
      if (outside) {
        REQUIRE_CTX(!hit, ctx());
        ++compared_misses;
        continue;
      }
      // Inside: the model's t is one rounding to nearest of the exact quotient (<= 1/2 unit); the reference is
      // within err_t of it. Decide the interval only when both are clear of its ends, and compare t when the
      // reference error is below 1/2 unit, so |t - t_ref| <= 1/2 + 1/2 = 1 unit.
      const LD slack = 0.5L + ref.err_t;
      if (std::fabs(ref.t - LD(fr.tmin)) <= slack || std::fabs(ref.t - LD(fr.tmax)) <= slack) continue;
      const bool ref_hit = ref.t >= LD(fr.tmin) && ref.t <= LD(fr.tmax);
      REQUIRE_CTX(hit == ref_hit, ctx());
      if (!hit) {
        ++compared_misses;
        continue;
      }
      ++compared_hits;
      if (ref.err_t <= 0.5L) {
        const LD dt = std::fabs(LD(h.t) - ref.t);
        max_dt = std::max(max_dt, dt);
        REQUIRE_CTX(dt <= 1.0L, ctx());
      }
      // u, v: e1 / det and e2 / det of exact integers, converted to double (2^-53 each), divided (2^-53) and
      // rounded to float (2^-24 relative): within 2^-23 of the exact weight, itself within err of the reference.
      REQUIRE_CTX(std::fabs(LD(h.u) - ref.u) <= 0x1p-23L + ref.err_u, ctx());
      REQUIRE_CTX(std::fabs(LD(h.v) - ref.v) <= 0x1p-23L + ref.err_v, ctx());
    }
    INFO("largest |t - t_ref| " << double(max_dt));
    CHECK(max_dt <= 1.0L);

    // Degenerate triangles (collinear vertices, two or three equal) have a zero normal, so det = 0: never a hit,
    // whatever the ray, including rays aimed exactly at one of their vertices.
    for (int it = 0; it < 3000; ++it) {
      int64_t p0[3], dw[3];
      for (int a = 0; a < 3; ++a) {
        p0[a] = rand_int(rng, gmax / 4, gmax / 2);
        dw[a] = rand_int(rng, -(gmax / 16), gmax / 16);
      }
      const int kind = it % 3;
      const int64_t ka = kind == 2 ? 0 : rand_int(rng, -3, 3), kb = kind == 0 ? rand_int(rng, -3, 3) : 0;
      int32_t v[3][3];
      for (int a = 0; a < 3; ++a) {
        v[0][a] = int32_t(p0[a]);
        v[1][a] = int32_t(p0[a] + ka * dw[a]);
        v[2][a] = int32_t(p0[a] + kb * dw[a]);
      }
      Ray ray;
      const int target = int(rng.next_u32() % 4);  // a vertex, or (3) a random point
      for (int a = 0; a < 3; ++a) {
        ray.origin[a] = float(rand_int(rng, 0, gmax));
        const double aim = target < 3 ? double(v[target][a]) : rand_double(rng, 0.0, double(gmax));
        ray.dir[a] = float(aim - double(ray.origin[a]));
      }
      if (ray.dir.x == 0.0f && ray.dir.y == 0.0f && ray.dir.z == 0.0f) ray.dir.z = 1.0f;
      ray.tmin = 0.0f;
      ray.tmax = kInf;
      FixedRay fr;
      REQUIRE(setup_ray(ray, frame, f, fr) == RayStatus::kOk);
      FixedPrimHit h{};
      REQUIRE_CTX(!triangle_test(fr, v, fr.tmin, fr.tmax, h),
                  "degenerate " + describe_tri(v) + " ray " + describe(fr));
      ++degenerate_tests;
    }
  }
  INFO("near edge (not compared) " << near_edge);
  CHECK(compared_hits > 20000);
  CHECK(compared_misses > 20000);
  CHECK(degenerate_tests == 12000);
}

TEST_CASE("sphere and plane tests against long double on the same quantized inputs", "[fixed][sphere][plane]") {
  const uint64_t seed = 31337;
  INFO("seed " << seed);
  Pcg32 rng(seed);
  std::vector<FixedFormat> formats = datapath_formats();
  formats.pop_back();  // the coarse format's 6-bit directions are no sphere test; the other three and:
  formats.push_back(fine_position_format());
  for (const FixedFormat& f : formats) {
    INFO("format " << f.describe());
    const int B = f.coord_bits, F = f.frac_bits, T = f.t_frac_bits;
    const QuantFrame frame = unit_frame(B);
    const double gmax = double(frame.grid_max());
    uint64_t sphere_hits = 0, sphere_misses = 0, sphere_skipped = 0, plane_hits = 0, plane_misses = 0,
             plane_beyond = 0;
    LD max_dt = 0, max_tol = 0;
    for (int it = 0; it < 20000; ++it) {
      // A sphere on the grid: radius 2^0 .. 2^(B-3) grid units (at least one grid step), inside the grid.
      SphereRecord s{};
      const double rg = std::ldexp(rand_double(rng, 1.0, 2.0), int(rand_int(rng, 0, B - 4)));
      s.radius = std::llround(std::ldexp(rg, F));
      double cg[3];
      for (int a = 0; a < 3; ++a) {
        cg[a] = rand_double(rng, rg, gmax - rg);
        s.center[a] = std::llround(std::ldexp(cg[a], F));
      }
      // A ray from anywhere toward a point within 1.3 radii of the center; some from inside the sphere.
      Ray ray;
      const bool inside = one_in(rng, 8);
      for (int a = 0; a < 3; ++a) {
        const double target = cg[a] + rg * rand_double(rng, -0.75, 0.75);
        ray.origin[a] =
            float(inside ? cg[a] + rg * rand_double(rng, -0.5, 0.5) : rand_double(rng, -0.2, 1.2) * gmax);
        ray.dir[a] = float(target - double(ray.origin[a]));
      }
      if (ray.dir.x == 0.0f && ray.dir.y == 0.0f && ray.dir.z == 0.0f) continue;
      ray.tmin = one_in(rng, 4) ? rand_float(rng, 0.0f, 1.5f) : 0.0f;
      ray.tmax = one_in(rng, 4) ? rand_float(rng, 0.5f, 2.0f) : kInf;
      FixedRay fr;
      REQUIRE(setup_ray(ray, frame, f, fr) == RayStatus::kOk);

      // Reference: f = o - c, tca = -(f.d)/(d.d), l = f + tca d, disc = r^2 - |l|^2, roots tca -+ sqrt(disc/d.d).
      LD fv[3], d[3], l[3];
      LD dd = 0, fd = 0;
      for (int a = 0; a < 3; ++a) {
        fv[a] = std::ldexp(LD(fr.o[a] - s.center[a]), -F);  // exact
        d[a] = std::ldexp(LD(fr.d[a]), -f.dir_bits);
        dd += d[a] * d[a];
        fd += fv[a] * d[a];
      }
      const LD tca = -fd / dd, r = std::ldexp(LD(s.radius), -F);
      LD ll = 0, nf = 0;
      for (int a = 0; a < 3; ++a) {
        l[a] = fv[a] + tca * d[a];
        ll += l[a] * l[a];
        nf += fv[a] * fv[a];
      }
      nf = std::sqrt(nf);
      const LD nd = std::sqrt(dd), nl = std::sqrt(ll), disc = r * r - ll;
      // The reference's own errors (ray units and grid^2), from a few roundings of 2^-64 each, with slack:
      // tca's numerator is a sum bounded by |f||d|; l adds the rounding of f + tca d; disc that of the squares.
      const LD e_tca = std::ldexp(nf * nd / dd, -60);
      const LD e_l = e_tca * nd + std::ldexp(nf + std::fabs(tca) * nd, -62);
      const LD e_disc = 2 * nl * e_l + e_l * e_l + std::ldexp(r * r + ll, -61);
      // The model's error in disc (grid^2): tca is off by delta <= 1/2 t unit = 2^-(T+1) ray units, and each
      // component of l = f + tca d is rounded to grid.F (|eps_i| <= 2^-(F+1)). As l_exact is perpendicular to d,
      // |l|^2 = |l_exact|^2 + |delta d + eps|^2 + 2 l_exact . eps, so |error| <= (delta |d| + |eps|)^2 +
      // 2 |l_exact| |eps|, with |eps| <= sqrt(3) 2^-(F+1).
      const LD delta = std::ldexp(LD(1), -(T + 1)), eps = std::sqrt(LD(3)) * std::ldexp(LD(1), -(F + 1));
      const LD e_model = (delta * nd + eps) * (delta * nd + eps) + 2 * (nl + e_l) * eps;
      FixedPrimHit h{};
      const bool hit = sphere_test(fr, s, fr.tmin, fr.tmax, h);
      LD t_ref = 0, tol = 0;
      auto ctx = [&] {
        std::ostringstream o;
        o << "sphere c " << s.center[0] << " " << s.center[1] << " " << s.center[2] << " r " << s.radius << " ray "
          << describe(fr) << " ref disc " << double(disc) << " r^2 " << double(r * r) << " t_ref " << double(t_ref)
          << " tol " << double(tol) << " | got hit " << hit << " t " << h.t;
        return o.str();
      };
      const LD unclear = e_model + e_disc;
      if (disc <= -std::max(1e-3L * r * r, unclear)) {  // clearly outside: the model's disc < 0 too
        REQUIRE_CTX(!hit, ctx());
        ++sphere_misses;
        continue;
      }
      if (disc < 1e-3L * r * r || disc <= 2 * unclear) {  // grazing: not compared
        ++sphere_skipped;
        continue;
      }
      // t tolerance in t units:
      // - tca is rounded to nearest: 1/2;
      // - h2 = floor(disc' 2^2s / d.d) is below its exact value by < 1 unit^2, which moves its root by <= 1;
      // - the square root is rounded to nearest: 1/2;
      // - the error e in disc (above) moves h = sqrt(disc) / |d| by <= min(e / sqrt(disc), sqrt(e)) / |d|, as
      //   |sqrt(x) - sqrt(y)| <= |x - y| / sqrt(y) and <= sqrt(|x - y|);
      // - the reference's own errors (tca, h) and a 2^-20 margin for the final long double roundings.
      // The first three give 2 units. The perpendicular's term is small only when positions are finer than t:
      // with disc >= 1e-3 r^2 and |d| >= 1/2 it is at most about 110 * 2^(T - F) units, under 1/2 unit for
      // F >= T + 8 (the fine-position format, whose whole bound stays below 4 units, checked below), but up to
      // 110 * 2^8 units in the default format (T = F + 8). There it is the format's position precision (the
      // perpendicular is one grid.F rounding, amplified near grazing), not a datapath error, so the comparison
      // uses the per-ray bound.
      const LD disc_lo = disc - e_disc;
      const LD e_h_model = std::min(e_model / std::sqrt(disc_lo), std::sqrt(e_model)) / nd;
      const LD h_ref = std::sqrt(disc / dd);
      const LD e_h_ref = e_disc / (nd * std::sqrt(disc_lo)) + std::ldexp(h_ref, -62);
      tol = 0.5L + 1.0L + 0.5L + std::ldexp(e_h_model + e_tca + e_h_ref, T) + 0x1p-20L;
      const LD t0 = std::ldexp(tca - h_ref, T), t1 = std::ldexp(tca + h_ref, T);
      const LD tmin = LD(fr.tmin), tmax = LD(fr.tmax);
      // Root choice and interval: decided only when the reference is clear of the ends by the tolerance.
      if (std::fabs(t0 - tmin) <= tol || std::fabs(t1 - tmin) <= tol || std::fabs(t0 - tmax) <= tol ||
          std::fabs(t1 - tmax) <= tol) {
        ++sphere_skipped;
        continue;
      }
      t_ref = t0 >= tmin ? t0 : t1;
      const bool ref_hit = t_ref >= tmin && t_ref <= tmax;
      REQUIRE_CTX(hit == ref_hit, ctx());
      if (!hit) {
        ++sphere_misses;
        continue;
      }
      ++sphere_hits;
      const LD dt = std::fabs(LD(h.t) - t_ref);
      max_dt = std::max(max_dt, dt);
      max_tol = std::max(max_tol, tol);
      REQUIRE_CTX(dt <= tol, ctx());
    }
    INFO("spheres: hits " << sphere_hits << " misses " << sphere_misses << " skipped " << sphere_skipped
                          << " largest |t - t_ref| " << double(max_dt) << " largest tolerance "
                          << double(max_tol));
    CHECK(sphere_hits > 5000);
    CHECK(sphere_misses > 2000);
    if (f.frac_bits >= f.t_frac_bits + 8) CHECK(max_tol <= 4.0L);

    // Planes: n . x = w with n at D fraction bits (largest component in [1/2, 1]) and w at F, through a random
    // grid point; rays toward random points.
    LD max_dt_plane = 0;
    for (int it = 0; it < 20000; ++it) {
      PlaneRecord p{};
      const int main_axis = int(rng.next_u32() % 3);
      const int64_t big = rand_int(rng, int64_t(1) << (f.dir_bits - 1), int64_t(1) << f.dir_bits);
      for (int a = 0; a < 3; ++a)
        p.normal[a] = int32_t(a == main_axis ? (one_in(rng, 2) ? big : -big) : rand_int(rng, -big, big));
      Wide np = 0;
      for (int a = 0; a < 3; ++a) np += Wide(p.normal[a]) * std::llround(std::ldexp(rand_double(rng, 0, gmax), F));
      p.offset = int64_t(round_shift(np, f.dir_bits, Round::kNearestEven));
      Ray ray;
      for (int a = 0; a < 3; ++a) {
        ray.origin[a] = float(rand_double(rng, -0.2, 1.2) * gmax);
        ray.dir[a] = float(rand_double(rng, -0.2, 1.2) * gmax - double(ray.origin[a]));
      }
      if (ray.dir.x == 0.0f && ray.dir.y == 0.0f && ray.dir.z == 0.0f) continue;
      ray.tmin = one_in(rng, 4) ? rand_float(rng, 0.0f, 1.5f) : 0.0f;
      ray.tmax = one_in(rng, 4) ? rand_float(rng, 0.5f, 2.0f) : kInf;
      FixedRay fr;
      REQUIRE(setup_ray(ray, frame, f, fr) == RayStatus::kOk);
      // Reference t = (w - n.o) / (n.d) in ray units. Inputs are exact; n.o and n.d are sums of three products
      // (n.o's products need up to 69 bits: rounded), each error <= 2^-61 of the sum of magnitudes with slack,
      // and one more rounding in the quotient.
      LD num = std::ldexp(LD(p.offset), -F), den = 0, mag_num = std::fabs(num), mag_den = 0;
      for (int a = 0; a < 3; ++a) {
        const LD n = std::ldexp(LD(p.normal[a]), -f.dir_bits);
        num -= n * std::ldexp(LD(fr.o[a]), -F);
        den += n * std::ldexp(LD(fr.d[a]), -f.dir_bits);
        mag_num += std::fabs(n * std::ldexp(LD(fr.o[a]), -F));
        mag_den += std::fabs(n * std::ldexp(LD(fr.d[a]), -f.dir_bits));
      }
      FixedPrimHit h{};
      const bool hit = plane_test(fr, p, fr.tmin, fr.tmax, h);
      LD t_ref = 0;
      auto ctx = [&] {
        std::ostringstream o;
        o << "plane n " << p.normal[0] << " " << p.normal[1] << " " << p.normal[2] << " w " << p.offset << " ray "
          << describe(fr) << " t_ref " << double(t_ref) << " | got " << hit << " t " << h.t;
        return o.str();
      };
      if (den == 0) {  // exactly parallel (products below 2^64 are exact, so den is the model's den)
        REQUIRE_CTX(!hit, ctx());
        continue;
      }
      const LD t = num / den;
      const LD err =
          std::ldexp((std::ldexp(mag_num, -61) + std::fabs(t) * std::ldexp(mag_den, -61)) / std::fabs(den) +
                         std::ldexp(std::fabs(t), -63),
                     T);
      // One rounding to nearest of the exact quotient (1/2 unit) plus the reference's error: compare when that
      // error is below 1/2 unit (not grazing), so |t - t_ref| <= 1 unit; the interval is decided when t_ref is
      // more than 1 unit from its ends.
      if (err > 0.5L) continue;
      t_ref = std::ldexp(t, T);
      // Beyond the t register's range (|t| >= t_limit: a grazing plane met far outside the frame) the model's t
      // saturates; those rays are the subject of the next test case, not of this comparison.
      if (std::fabs(t_ref) >= LD(fr.t_limit) - 1) {
        ++plane_beyond;
        continue;
      }
      if (std::fabs(t_ref - LD(fr.tmin)) <= 1 || std::fabs(t_ref - LD(fr.tmax)) <= 1) continue;
      const bool ref_hit = t_ref >= LD(fr.tmin) && t_ref <= LD(fr.tmax);
      REQUIRE_CTX(hit == ref_hit, ctx());
      if (!hit) {
        ++plane_misses;
        continue;
      }
      ++plane_hits;
      const LD dt = std::fabs(LD(h.t) - t_ref);
      max_dt_plane = std::max(max_dt_plane, dt);
      REQUIRE_CTX(dt <= 1.0L, ctx());
    }
    INFO("planes: hits " << plane_hits << " misses " << plane_misses << " beyond the t range " << plane_beyond
                         << " largest |t - t_ref| " << double(max_dt_plane));
    CHECK(plane_hits > 5000);
    CHECK(plane_misses > 2000);
  }
}

TEST_CASE("plane test: a plane met beyond the t register's range is no hit inside a shorter interval",
          "[fixed][plane]") {
  // t saturates at t_limit = 2^t_bits - 1 raw, and so does a ray's tmax when its world value lies beyond that.
  // A plane met beyond t_limit (a grazing ground plane, far outside the frame) must still not be reported when
  // the ray's interval ends before it. One triangle fixes the frame ([0,1]^2 x {0}: step 2^-23 at B = 24); the
  // plane is y = 0; the ray starts at y = 1 with slope -1e-6, so it meets the plane near world t = 1e6, while the
  // interval ends at 5e5 and the t register covers world t below t_limit * 2^-t_exp (2^16 here).
  Geometry g;
  g.triangles.push_back({Vec3(0.0f, 0.0f, 0.0f), Vec3(1.0f, 0.0f, 0.0f), Vec3(0.0f, 1.0f, 0.0f)});
  g.planes.push_back({Vec3(0.0f, 1.0f, 0.0f), 0.0f});
  const DeviceImage img = encode_scene(g, format_preset("default"), nullptr);
  const FixedTracer xt(img);
  const FloatTracer ft(g);
  Ray r{Vec3(0.5f, 1.0f, 0.5f), 0.0f, Vec3(1.0f, -1e-6f, 0.0f), 5e5f};
  FixedRay fr;
  REQUIRE(setup_ray(r, xt.frame(), xt.format(), fr) == RayStatus::kOk);
  const PlaneRecord& p = img.planes()[0];
  // The quantized plane and ray meet at t = (w - n.o) / (n.d) (exact here in long double: small integers).
  LD num = std::ldexp(LD(p.offset), -fr.frac), den = 0;
  for (int a = 0; a < 3; ++a) {
    num -= std::ldexp(LD(p.normal[a]) * LD(fr.o[a]), -fr.frac - fr.dir_bits);
    den += std::ldexp(LD(p.normal[a]) * LD(fr.d[a]), -2 * fr.dir_bits);
  }
  const LD t_world = std::ldexp(num / den, fr.t_shift - fr.dir_bits + fr.frac - fr.t_exp);
  const LD limit_world = std::ldexp(LD(fr.t_limit), -fr.t_exp);
  INFO("plane met at world t " << double(t_world) << ", tmax " << r.tmax << ", t register limit (world) "
                               << double(limit_world) << " | " << describe(fr));
  REQUIRE(t_world > LD(r.tmax));      // the plane lies beyond the interval...
  REQUIRE(limit_world < LD(r.tmax));  // ...and the interval's end saturated in the t register
  TraversalStats s;
  REQUIRE_FALSE(ft.trace(r, false, s).hit());
  FixedPrimHit h{};
  const bool hit = plane_test(fr, p, fr.tmin, fr.tmax, h);
  INFO("plane_test: hit " << hit << " t raw " << h.t << " (world " << (hit ? t_to_world(h.t, fr) : 0.0f) << ")");
  CHECK_FALSE(hit);
  CHECK_FALSE(xt.trace(r, false, s).hit());
  // With an unbounded interval the float device hits the plane; the fixed device cannot represent the distance
  // (its t saturates): it reports no hit and counts the saturation.
  r.tmax = kInf;
  CHECK(ft.trace(r, false, s).hit());
  TraversalStats sx;
  CHECK_FALSE(xt.trace(r, false, sx).hit());
  CHECK(sx.saturations == 1);
}

TEST_CASE("ray setup: invalid rays, guard range, infinite tmax, signed zeros, power-of-two scaling",
          "[fixed][ray]") {
  const FixedFormat f = format_preset("default");
  const QuantFrame frame = QuantFrame::fit(Aabb{Vec3(-3.0f), Vec3(5.0f)}, f.coord_bits);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Ray good{Vec3(0.5f, 1.0f, -2.0f), 0.0f, Vec3(0.3f, -0.2f, 0.9f), kInf};
  FixedRay fr;
  REQUIRE(setup_ray(good, frame, f, fr) == RayStatus::kOk);
  auto status = [&](const std::function<void(Ray&)>& edit) {
    Ray r = good;
    edit(r);
    FixedRay out;
    return setup_ray(r, frame, f, out);
  };
  for (int a = 0; a < 3; ++a) {
    INFO("axis " << a);
    CHECK(status([&](Ray& r) { r.origin[a] = nan; }) == RayStatus::kNanOrigin);
    CHECK(status([&](Ray& r) { r.origin[a] = kInf; }) == RayStatus::kInfOrigin);
    CHECK(status([&](Ray& r) { r.origin[a] = -kInf; }) == RayStatus::kInfOrigin);
    CHECK(status([&](Ray& r) { r.dir[a] = nan; }) == RayStatus::kNanDirection);
    CHECK(status([&](Ray& r) { r.dir[a] = kInf; }) == RayStatus::kInfDirection);
    CHECK(status([&](Ray& r) { r.dir[a] = -kInf; }) == RayStatus::kInfDirection);
    CHECK(status([&](Ray& r) { r.origin[a] = 1e30f; }) == RayStatus::kOutOfFrame);
    CHECK(status([&](Ray& r) { r.origin[a] = -1e30f; }) == RayStatus::kOutOfFrame);
  }
  CHECK(status([](Ray& r) { r.dir = Vec3(0.0f); }) == RayStatus::kZeroDirection);
  CHECK(status([](Ray& r) { r.dir = Vec3(-0.0f, 0.0f, -0.0f); }) == RayStatus::kZeroDirection);
  CHECK(status([&](Ray& r) { r.tmin = nan; }) == RayStatus::kNanInterval);
  CHECK(status([&](Ray& r) { r.tmax = nan; }) == RayStatus::kNanInterval);
  CHECK(status([](Ray& r) { r.tmin = kInf; }) == RayStatus::kNanInterval);
  CHECK(status([](Ray& r) { r.tmin = -kInf; }) == RayStatus::kNanInterval);
  CHECK(status([](Ray& r) { r.tmin = 3.0f, r.tmax = 1.0f; }) == RayStatus::kOk);  // empty: valid, misses

  // tmax = +inf -> t_limit (and -inf -> -t_limit); finite ends round outward: tmin down, tmax up (exact checks
  // in long double: t raw values are below 2^57).
  CHECK(fr.tmax == fr.t_limit);
  CHECK(fr.t_limit == int64_t((uint64_t(1) << f.t_bits) - 1));
  {
    Ray r = good;
    r.tmax = -kInf;
    REQUIRE(setup_ray(r, frame, f, fr) == RayStatus::kOk);
    CHECK(fr.tmax == -fr.t_limit);
    Pcg32 rng(5);
    for (int i = 0; i < 1000; ++i) {
      r.tmin = std::ldexp(rand_float(rng, -1.0f, 1.0f), int(rand_int(rng, -30, 20)));
      r.tmax = std::ldexp(rand_float(rng, -1.0f, 1.0f), int(rand_int(rng, -30, 20)));
      REQUIRE(setup_ray(r, frame, f, fr) == RayStatus::kOk);
      INFO("tmin " << r.tmin << " tmax " << r.tmax << " raw " << fr.tmin << " " << fr.tmax << " t_exp "
                   << fr.t_exp);
      REQUIRE(std::ldexp(LD(fr.tmin), -fr.t_exp) <= LD(r.tmin));
      REQUIRE(std::ldexp(LD(fr.tmin + 1), -fr.t_exp) > LD(r.tmin));
      REQUIRE(std::ldexp(LD(fr.tmax), -fr.t_exp) >= LD(r.tmax));
      REQUIRE(std::ldexp(LD(fr.tmax - 1), -fr.t_exp) < LD(r.tmax));
    }
  }

  // The guard range: origins at 2^(B+G) grid units from the frame origin or beyond are out of the frame, origins
  // just inside are accepted. A small format and a frame with origin 0 make the boundary values exact floats:
  // +-(2^(B+G) - 2^-F) needs B + G + F = 20 bits.
  FixedFormat small;
  small.coord_bits = 8;
  small.guard_bits = 4;
  small.frac_bits = 8;
  small.dir_bits = 16;
  small.rcp_bits = 16;
  small.t_frac_bits = 8;
  small.t_bits = 32;
  REQUIRE_NOTHROW(small.validate());
  const int range = small.coord_bits + small.guard_bits;
  const int64_t olim = int64_t(1) << (range + small.frac_bits);
  {
    const QuantFrame q0 = unit_frame(small.coord_bits);
    const float edge = std::ldexp(1.0f, range), inside = edge - std::ldexp(1.0f, -small.frac_bits);
    for (int a = 0; a < 3; ++a) {
      INFO("axis " << a);
      Ray r = good;
      r.origin = Vec3(1.0f);
      r.origin[a] = inside;
      REQUIRE(setup_ray(r, q0, small, fr) == RayStatus::kOk);
      CHECK(fr.o[a] == olim - 1);
      r.origin[a] = -inside;
      REQUIRE(setup_ray(r, q0, small, fr) == RayStatus::kOk);
      CHECK(fr.o[a] == -(olim - 1));
      r.origin[a] = edge;
      CHECK(setup_ray(r, q0, small, fr) == RayStatus::kOutOfFrame);
      r.origin[a] = -edge - std::ldexp(1.0f, -small.frac_bits);
      CHECK(setup_ray(r, q0, small, fr) == RayStatus::kOutOfFrame);
      r.origin[a] = 2.0f * edge;  // between the coarse double test and the grid test
      CHECK(setup_ray(r, q0, small, fr) == RayStatus::kOutOfFrame);
    }
    // A fitted frame away from the world origin: the boundary is the float O + 2^(B+G) steps (exact here), and
    // the float next to it on the inside is accepted, quantized exactly (its distance to the boundary is a
    // multiple of 2^-F grid units).
    const QuantFrame qf = QuantFrame::fit(Aabb{Vec3(1000.0f), Vec3(1001.0f)}, small.coord_bits);
    for (int a = 0; a < 3; ++a) {
      INFO("axis " << a << " frame step 2^" << qf.step_exp << " origin " << qf.origin[a]);
      const double hi = qf.to_world(int64_t(1) << range, a), lo = qf.to_world(-(int64_t(1) << range), a);
      REQUIRE(double(float(hi)) == hi);
      REQUIRE(double(float(lo)) == lo);
      Ray r = good;
      r.origin = Vec3(1000.5f);
      r.origin[a] = float(hi);
      CHECK(setup_ray(r, qf, small, fr) == RayStatus::kOutOfFrame);
      r.origin[a] = std::nextafter(float(hi), 0.0f);
      REQUIRE(setup_ray(r, qf, small, fr) == RayStatus::kOk);
      CHECK(fr.o[a] == olim - int64_t(std::ldexp(hi - double(r.origin[a]), small.frac_bits - qf.step_exp)));
      r.origin[a] = std::nextafter(float(lo), -kInf);
      CHECK(setup_ray(r, qf, small, fr) == RayStatus::kOutOfFrame);
      r.origin[a] = std::nextafter(float(lo), kInf);
      REQUIRE(setup_ray(r, qf, small, fr) == RayStatus::kOk);
      CHECK(fr.o[a] == -olim + int64_t(std::ldexp(double(r.origin[a]) - lo, small.frac_bits - qf.step_exp)));
    }
  }

  // Signed zeros and components that round to 0 set zero[a] (and a zero reciprocal); the others do not.
  {
    Ray r = good;
    r.dir = Vec3(0.0f, -0.0f, -2.0f);
    REQUIRE(setup_ray(r, frame, f, fr) == RayStatus::kOk);
    CHECK(fr.zero[0]);
    CHECK(fr.zero[1]);
    CHECK_FALSE(fr.zero[2]);
    CHECK(fr.d[0] == 0);
    CHECK(fr.rcp_dn[1] == 0);
    CHECK(fr.rcp_up[1] == 0);
    CHECK(fr.d[2] < 0);
    r.dir = Vec3(1e-30f, -0.0f, 1.0f);  // 1e-30 * 2^24 rounds to 0
    REQUIRE(setup_ray(r, frame, f, fr) == RayStatus::kOk);
    CHECK(fr.zero[0]);
    CHECK(fr.zero[1]);
  }

  // Random rays: the direction is the float direction times 2^(D - 1 - ilogb(max |dir|)), rounded to nearest
  // (largest component in [2^(D-1), 2^D]); the reciprocals bracket 2^(D+R) / d within one unit; and scaling the
  // direction by 2^j (j in -10..10) changes nothing but t_exp, by j.
  Pcg32 rng(77);
  for (int i = 0; i < 2000; ++i) {
    Ray r;
    for (int a = 0; a < 3; ++a) {
      r.origin[a] = rand_float(rng, -3.0f, 5.0f);
      r.dir[a] = std::ldexp(rand_float(rng, -1.0f, 1.0f), int(rand_int(rng, -20, 20)));
      if (one_in(rng, 6)) r.dir[a] = one_in(rng, 2) ? 0.0f : -0.0f;
    }
    if (r.dir.x == 0.0f && r.dir.y == 0.0f && r.dir.z == 0.0f) r.dir.y = 0.5f;
    r.tmin = 0.0f;
    r.tmax = kInf;
    FixedRay base;
    REQUIRE(setup_ray(r, frame, f, base) == RayStatus::kOk);
    INFO("dir " << r.dir.x << " " << r.dir.y << " " << r.dir.z << " -> " << describe(base));
    const float m = std::max({std::fabs(r.dir.x), std::fabs(r.dir.y), std::fabs(r.dir.z)});
    const int sh = f.dir_bits - 1 - std::ilogb(m);
    int64_t largest = 0;
    for (int a = 0; a < 3; ++a) {
      REQUIRE(std::fabs(double(base.d[a]) - std::ldexp(double(r.dir[a]), sh)) <= 0.5);  // exact in double
      REQUIRE(base.zero[a] == (base.d[a] == 0));
      largest = std::max(largest, std::abs(base.d[a]));
      if (base.zero[a]) continue;
      const Wide one = Wide(1) << (f.dir_bits + f.rcp_bits);
      // floor and ceil of one / d: rcp_dn <= one / d <= rcp_up, rcp_up - rcp_dn <= 1 (signs handled by |d|).
      const Wide ad = base.d[a] > 0 ? Wide(base.d[a]) : -Wide(base.d[a]), sg = base.d[a] > 0 ? 1 : -1;
      REQUIRE(Wide(base.rcp_dn[a]) * ad <= sg * one);
      REQUIRE(Wide(base.rcp_up[a]) * ad >= sg * one);
      REQUIRE(base.rcp_up[a] - base.rcp_dn[a] <= 1);
    }
    REQUIRE(largest >= (int64_t(1) << (f.dir_bits - 1)));
    REQUIRE(largest <= (int64_t(1) << f.dir_bits));
    for (int j = -10; j <= 10; ++j) {
      Ray s = r;
      s.dir = r.dir * std::ldexp(1.0f, j);
      FixedRay sc;
      REQUIRE(setup_ray(s, frame, f, sc) == RayStatus::kOk);
      INFO("scale 2^" << j);
      for (int a = 0; a < 3; ++a) {
        REQUIRE(sc.o[a] == base.o[a]);
        REQUIRE(sc.d[a] == base.d[a]);
        REQUIRE(sc.zero[a] == base.zero[a]);
        REQUIRE(sc.rcp_dn[a] == base.rcp_dn[a]);
        REQUIRE(sc.rcp_up[a] == base.rcp_up[a]);
      }
      REQUIRE(sc.t_exp == base.t_exp + j);
      REQUIRE(sc.tmin == base.tmin);
      REQUIRE(sc.tmax == base.tmax);
    }
  }
}

namespace {

// A random soup: triangles about 1 unit across in [-10, 10]^3, a few spheres, and a ground plane below them.
Geometry random_scene(uint64_t seed, int tris, int spheres) {
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

std::vector<Ray> random_rays(uint64_t seed, int n) {
  Pcg32 rng(seed);
  std::vector<Ray> rays;
  for (int i = 0; i < n; ++i) {
    Ray r;
    for (int a = 0; a < 3; ++a) {
      r.origin[a] = rand_float(rng, -12.0f, 12.0f);
      r.dir[a] = rand_float(rng, -1.0f, 1.0f);
    }
    if (i % 11 == 0) r.dir = Vec3(i % 2 ? -0.0f : 0.0f, 0.0f, i % 3 ? 1.0f : -1.0f);  // signed zeros
    if (r.dir.x == 0.0f && r.dir.y == 0.0f && r.dir.z == 0.0f) r.dir.x = 1.0f;
    r.tmin = 0.0f;
    r.tmax = kInf;
    if (i == 5000) r.dir.y = std::numeric_limits<float>::quiet_NaN();  // invalid rays, counted by reason
    if (i == 7000) r.origin.x = 1e30f;                                 // out of frame (fixed device only)
    rays.push_back(r);
  }
  return rays;
}

struct RecordBox {
  int64_t lo[3] = {INT64_MAX, INT64_MAX, INT64_MAX};
  int64_t hi[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
  void extend(const RecordBox& b) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], b.lo[a]);
      hi[a] = std::max(hi[a], b.hi[a]);
    }
  }
};

// Walks the image's tree: every decoded child box origin + (q << exp) contains the grid bounds of every record
// below it (a triangle's vertices; a sphere's center -+ radius rounded outward to the grid), offsets fit in k
// bits, boxes stay below 2^(B+1) (the datapath's bound on box planes), and every record is reached once.
template <int N, class Q>
void check_image_boxes(const DeviceImage& img) {
  const ImageHeader& h = img.header();
  const QNode<N, Q>* nodes = img.nodes<QNode<N, Q>>();
  const int F = h.frac_bits;
  std::vector<RecordBox> rec(h.record_count);
  for (uint32_t i = 0; i < h.record_count; ++i) {
    const uint8_t* p = img.record(i);
    if (record_kind(p) == RecordKind::kTriangle) {
      TriangleRecord t;
      std::memcpy(&t, p, sizeof t);
      for (int v = 0; v < 3; ++v) {
        for (int a = 0; a < 3; ++a) {
          rec[i].lo[a] = std::min<int64_t>(rec[i].lo[a], t.v[v][a]);
          rec[i].hi[a] = std::max<int64_t>(rec[i].hi[a], t.v[v][a]);
        }
      }
    } else {
      SphereRecord s;
      std::memcpy(&s, p, sizeof s);
      REQUIRE(s.radius > 0);
      for (int a = 0; a < 3; ++a) {
        rec[i].lo[a] = int64_t(round_shift(Wide(s.center[a]) - s.radius, F, Round::kDown));
        rec[i].hi[a] = int64_t(round_shift(Wide(s.center[a]) + s.radius, F, Round::kUp));
      }
    }
  }
  std::vector<int> seen(h.record_count, 0);
  const int64_t qmax = (int64_t(1) << h.child_bits) - 1, box_limit = int64_t(1) << (h.coord_bits + 1);
  uint64_t boxes = 0;
  std::function<RecordBox(uint32_t)> walk = [&](uint32_t ref) {
    RecordBox all;
    if (is_leaf(ref)) {
      for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) {
        REQUIRE(i < h.record_count);
        ++seen[i];
        all.extend(rec[i]);
      }
      return all;
    }
    REQUIRE(ref < h.node_count);
    const QNode<N, Q>& n = nodes[ref];
    REQUIRE(n.count >= 1);
    REQUIRE(int(n.count) <= N);
    for (int i = 0; i < N; ++i) {
      if (i >= n.count) {
        REQUIRE(n.child[i] == kEmptyChild);
        continue;
      }
      const RecordBox sub = walk(n.child[i]);
      for (int a = 0; a < 3; ++a) {
        REQUIRE(int64_t(n.q[2 * a][i]) <= qmax);
        REQUIRE(int64_t(n.q[2 * a + 1][i]) <= qmax);
        const int64_t lo = int64_t(n.origin[a]) + (int64_t(n.q[2 * a][i]) << n.exp[a]);
        const int64_t hi = int64_t(n.origin[a]) + (int64_t(n.q[2 * a + 1][i]) << n.exp[a]);
        INFO("node " << ref << " child " << i << " axis " << a << " decoded [" << lo << ", " << hi << "] records ["
                     << sub.lo[a] << ", " << sub.hi[a] << "]");
        REQUIRE(lo <= sub.lo[a]);
        REQUIRE(hi >= sub.hi[a]);
        CHECK(lo >= 0);
        CHECK(hi < box_limit);
      }
      ++boxes;
      all.extend(sub);
    }
    return all;
  };
  REQUIRE(h.root_ref != kEmptyChild);
  walk(h.root_ref);
  for (uint32_t i = 0; i < h.record_count; ++i) REQUIRE(seen[i] == 1);
  CHECK(boxes + 1 >= h.node_count);  // every node but the root is some node's child
}

void check_image(const DeviceImage& img) {
  const ImageHeader& h = img.header();
  const bool q8 = h.q_bytes == 1;
  switch (h.width) {
    case 2:
      q8 ? check_image_boxes<2, uint8_t>(img) : check_image_boxes<2, uint16_t>(img);
      break;
    case 4:
      q8 ? check_image_boxes<4, uint8_t>(img) : check_image_boxes<4, uint16_t>(img);
      break;
    default:
      q8 ? check_image_boxes<8, uint8_t>(img) : check_image_boxes<8, uint16_t>(img);
      break;
  }
}

}  // namespace

TEST_CASE("device image: decoded child boxes contain their records, widths 2/4/8, child bits 4/8/12",
          "[fixed][image]") {
  const uint64_t seed = 8;
  INFO("seed " << seed);
  const Geometry g = random_scene(seed, 400, 12);
  for (int width : {2, 4, 8}) {
    BvhBuildParams p;
    p.width = width;
    const Bvh bvh = Bvh::build(g, p);
    for (int k : {4, 8, 12}) {
      FixedFormat f = format_preset("default");
      f.width = width;
      f.child_bits = k;
      INFO("width " << width << " child bits " << k);
      const DeviceImage img = encode_scene(g, f, &bvh);
      const ImageHeader& h = img.header();
      REQUIRE(h.magic == kImageMagic);
      REQUIRE(h.width == width);
      REQUIRE(h.q_bytes == (k <= 8 ? 1 : 2));
      REQUIRE(h.record_count == g.num_bounded());
      REQUIRE(h.plane_count == g.planes.size());
      check_image(img);
    }
  }
}

TEST_CASE("fixed tracer against the float tracer: hits agree, any-hit = closest-hit, thread independence",
          "[fixed][tracer]") {
  const uint64_t seed = 21;
  INFO("seed " << seed);
  const Geometry g = random_scene(seed, 300, 8);
  const std::vector<Ray> rays = random_rays(seed + 1, 20000);
  TracerOptions opt;
  opt.accel = AccelMode::kBvh;
  const FloatTracer ft(g, opt);
  REQUIRE(ft.bvh() != nullptr);
  const FixedFormat f = format_preset("default");
  REQUIRE(ft.bvh()->width() == f.width);
  const DeviceImage img = encode_scene(g, f, ft.bvh());
  FixedTraceOptions fopt;
  fopt.check_boxes = true;
  const FixedTracer xt(img, fopt);

  // Node memory: a default node (4 children, 8-bit offsets) is 56 bytes against the float node's 112, same tree.
  CHECK(double(img.nodes_size()) <= 0.6 * double(ft.bvh()->figures().node_bytes));

  const size_t n = rays.size();
  std::vector<Hit> want(n), got(n), got2(n), any(n);
  TraversalStats fs, s1, s2, sa;
  ft.trace_batch(rays.data(), want.data(), n, false, 1, fs);
  xt.trace_batch(rays.data(), got.data(), n, false, 1, s1);
  xt.trace_batch(rays.data(), got2.data(), n, false, 2, s2);
  xt.trace_batch(rays.data(), any.data(), n, true, 1, sa);

  // Hit/miss: the fixed device sees the scene moved by at most half a grid step (vertices to nearest, sphere
  // centers half a grid.F unit, radii up by less than one), here 2^-25 of the frame (~6e-7 world units), and
  // its tests are exact on those inputs (the box test never culls what the exact test accepts). So a ray can only
  // change hit/miss when it passes within about that distance of a silhouette edge, grazes a sphere, or meets
  // the plane at a comparable angle: with triangles ~1 unit across, ~1e-6 of the rays per silhouette crossed.
  // 99.9% leaves a factor ~100 for rays that cross several silhouettes.
  size_t agree = 0, both_hit = 0, same_prim = 0;
  for (size_t i = 0; i < n; ++i) {
    agree += size_t(got[i].hit() == want[i].hit());
    both_hit += size_t(got[i].hit() && want[i].hit());
    same_prim += size_t(got[i].hit() && got[i].prim == want[i].prim);
  }
  INFO("agree " << agree << " of " << n << ", both hit " << both_hit << ", same primitive " << same_prim);
  CHECK(double(agree) >= 0.999 * double(n));
  CHECK(both_hit * 4 > n);  // the comparison covers many hits
  // The out-of-frame ray (1e30) is invalid on the fixed device only; the NaN ray on both.
  CHECK(s1.invalid_rays == 2);
  CHECK(s1.invalid_by_reason[size_t(RayStatus::kNanDirection)] == 1);
  CHECK(s1.invalid_by_reason[size_t(RayStatus::kOutOfFrame)] == 1);
  CHECK(s1.first_invalid == 5000);
  CHECK(fs.invalid_rays == 1);
  CHECK(s1.box_checks == s1.box_tests);
  CHECK(s1.box_false_negatives == 0);
  CHECK(sa.box_false_negatives == 0);

  // Any-hit finds a hit exactly when closest-hit does: with the interval end at tmax, any-hit's box tests accept a
  // superset of closest-hit's, and both test the same records with the same datapath.
  for (size_t i = 0; i < n; ++i) {
    if (any[i].hit() != got[i].hit()) {
      INFO("ray " << i);
      REQUIRE(any[i].hit() == got[i].hit());
    }
  }
  CHECK(sa.prim_tests <= s1.prim_tests);

  // Thread-count independence: bit-identical hits and identical statistics.
  REQUIRE(std::memcmp(got.data(), got2.data(), n * sizeof(Hit)) == 0);
  CHECK(s1.rays == s2.rays);
  CHECK(s1.hits == s2.hits);
  CHECK(s1.nodes_visited == s2.nodes_visited);
  CHECK(s1.leaves_visited == s2.leaves_visited);
  CHECK(s1.box_tests == s2.box_tests);
  CHECK(s1.prim_tests == s2.prim_tests);
  CHECK(s1.invalid_rays == s2.invalid_rays);
  CHECK(s1.invalid_by_reason == s2.invalid_by_reason);
  CHECK(s1.first_invalid == s2.first_invalid);
  CHECK(s1.first_invalid_reason == s2.first_invalid_reason);
  CHECK(s1.saturations == s2.saturations);
  CHECK(s1.box_checks == s2.box_checks);
  CHECK(s1.box_false_negatives == s2.box_false_negatives);
  CHECK(s1.box_false_positives == s2.box_false_positives);
}

TEST_CASE("recording the stack as a short stack sees it: the timing model's cycles and statistics are unchanged",
          "[fixed][timing]") {
  // Binary BVH over 3,000 triangles: random rays reach stack depths well past the short stacks tried below.
  const Geometry g = random_scene(31, 3000, 8);
  const std::vector<Ray> rays = random_rays(32, 4000);
  FixedFormat f = format_preset("default");
  f.width = 2;
  BvhBuildParams bp;
  bp.width = 2;
  const Bvh bvh = Bvh::build(g, bp);
  const DeviceImage img = encode_scene(g, f, &bvh);
  TimingModel::Layout l;
  l.node_offset = img.header().node_offset;
  l.node_bytes = img.node_bytes();
  l.record_offset = img.header().record_offset;
  l.plane_offset = img.header().plane_offset;
  const FixedTracer raw(img);
  for (int se : {1, 2, 3, 8}) {
    INFO("short stack " << se);
    FixedTraceOptions o;
    o.record_short_stack = se;
    const FixedTracer filtered(img, o);
    std::vector<std::vector<TraceEvent>> ev_raw(rays.size()), ev_short(rays.size());
    uint64_t spill_events = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      TraversalStats s1, s2;
      const Hit a = raw.trace_recorded(rays[i], false, s1, ev_raw[i]);
      const Hit b = filtered.trace_recorded(rays[i], false, s2, ev_short[i]);
      REQUIRE(std::memcmp(&a, &b, sizeof(Hit)) == 0);
      // The same node, record and plane events in the same order; no push or pop left; the spills and refills
      // where the raw stream's depth passes the short stack.
      std::vector<TraceEvent> expect;
      int depth = 0;
      for (const TraceEvent& e : ev_raw[i]) {
        if (e.kind == TraceEvent::kPush) {
          int over = 0;
          for (int j = 0; j < e.count; ++j) over += ++depth > se;
          if (over > 0) expect.push_back(TraceEvent{TraceEvent::kSpill, uint8_t(over), 0, 0, 0});
        } else if (e.kind == TraceEvent::kPop) {
          if (depth-- > se) expect.push_back(TraceEvent{TraceEvent::kRefill, 0, 0, 0, 0});
        } else {
          expect.push_back(e);
        }
      }
      REQUIRE(expect.size() == ev_short[i].size());
      REQUIRE(std::memcmp(expect.data(), ev_short[i].data(), expect.size() * sizeof(TraceEvent)) == 0);
      for (const TraceEvent& e : ev_short[i]) spill_events += e.kind == TraceEvent::kSpill;
    }
    if (se <= 3) CHECK(spill_events > 100);  // the spill path is exercised
    TimingConfig c = timing_preset("rdna2");
    c.stack_entries = se;
    c.ray_slots = 16;
    TimingStats t1, t2;
    TimingModel m1(c, l), m2(c, l);
    m1.begin(rays.size(), t1);
    m1.feed(ev_raw.data(), rays.size());
    const uint64_t c1 = m1.finish();
    m2.begin(rays.size(), t2);
    m2.feed(ev_short.data(), rays.size());
    const uint64_t c2 = m2.finish();
    CHECK(c1 == c2);
    check_same_timing(t1, t2);
    if (se <= 3) CHECK(t1.stack_spills > 0);
  }
}
