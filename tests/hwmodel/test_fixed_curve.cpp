// The fixed-point linear swept sphere test (swept_sphere_test, intersect_fixed.h) against the exact union of the
// record's spheres, in long double on the same quantized inputs (the FixedRay's origin and direction, the
// record's grid end points and grid.F radii). The test moves the surface by at most eps grid.F units:
//  - the origin moved along the ray is rounded to grid.F: the ray through o' lies within sqrt(3)/2 of the ray;
//  - positions are shifted right by z (0 unless the segment or its distance exceeds 2^curve_bits): 2^z units;
//  - u and rho are rounded after the division by 2^n: half a unit each of a quantity scaled by K / 2^n >= K / E2
//    (E2 = |e|^2 >= 2^n), so up to (sqrt(3)/2 + 1/2) E2 / K units of the surface;
//  - w and sigma likewise, in direction units (2^-Dc, Dc = max(D, 54 - C), of |d| >= 1/2): times the reach of
//    the ray inside the segment's bounding sphere (< 2^(C+1) after the shift), about 2^(C+2-Dc) (sqrt(3)/2 + 1/2)
//    E2 / K units;
//  - t is rounded to the t register (one unit each for the quotient and the square root): |d| 2^(F-T) each.
// eps = 2^z (1 + (1.4 + 1.4 * 2^(C+2-Dc)) E2 / K) + 2 sqrt(3) 2^(F-T) + 1, with slack; the end spheres are
// sphere_test's (a few units, within it). So:
//  - every hit lies within eps of the union's surface;
//  - a ray that comes within -eps (inside the union by eps) hits, at or after its entry into the union grown by
//    eps and no later than its entry into the union shrunk by eps;
//  - a ray that stays eps away misses.
// Rays that only graze (between -eps and eps) may do either. Randomized; prints its seed.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/hw_format.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

namespace {

// The record in grid units (long double, exact).
struct ExactSegment {
  LD p0[3], p1[3], r0, r1;
};

// Where f, convex on [lo, hi], is least, to `steps` steps of a ternary search: the middle of the last interval.
template <class F>
LD ternary_argmin(const F& f, LD lo, LD hi, int steps) {
  for (int k = 0; k < steps; ++k) {
    const LD m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
    if (f(m1) < f(m2))
      hi = m2;
    else
      lo = m1;
  }
  return (lo + hi) / 2;
}

// Signed distance (grid units) from x to the union of the spheres c(s), r(s), s in [0, 1]: min over s of
// |x - c(s)| - r(s), convex in s, found by a ternary search.
LD union_distance(const ExactSegment& sg, const LD x[3]) {
  auto g = [&](LD s) {
    LD q = 0;
    for (int i = 0; i < 3; ++i) {
      const LD c = sg.p0[i] + s * (sg.p1[i] - sg.p0[i]);
      q += (x[i] - c) * (x[i] - c);
    }
    return std::sqrt(q) - (sg.r0 + s * (sg.r1 - sg.r0));
  };
  return std::min({g(0), g(1), g(ternary_argmin(g, 0, 1, 80))});
}

// The first t in [0, t_far] (ray units) where the ray's point comes within `level` of the union (distance <=
// level); +inf when it never does. The union is the convex hull of its end spheres and union_distance is convex
// (a norm of an affine function minus an affine one, minimized over s), so it is convex along the ray: a ternary
// search finds its minimum, and on [0, that minimum] it decreases, so a bisection finds the crossing.
LD first_within(const ExactSegment& sg, const LD o[3], const LD d[3], LD level, LD t_far) {
  auto at = [&](LD t) {
    LD x[3];
    for (int i = 0; i < 3; ++i) x[i] = o[i] + t * d[i];
    return union_distance(sg, x) - level;
  };
  if (at(0) <= 0) return 0;
  LD tm = ternary_argmin(at, 0, t_far, 110);
  if (at(tm) > 0) return std::numeric_limits<LD>::infinity();
  LD a = 0;
  for (int k = 0; k < 100; ++k) {
    const LD m = (a + tm) / 2;
    if (at(m) <= 0)
      tm = m;
    else
      a = m;
  }
  return tm;
}

}  // namespace

TEST_CASE("fixed swept spheres against the exact union of their spheres", "[fixed][curve][scale]") {
  const uint64_t seed = 4242;
  INFO("seed " << seed);
  Pcg32 rng(seed);
  std::vector<FixedFormat> formats = {format_preset("default"), format_preset("compact"), format_preset("precise"),
                                      fine_position_format()};
  for (const FixedFormat& f : formats) {
    INFO("format " << f.describe());
    REQUIRE(f.curve_limits().empty());
    const int B = f.coord_bits, F = f.frac_bits, T = f.t_frac_bits, D = f.dir_bits, C = f.curve_bits;
    const QuantFrame frame = unit_frame(B);
    const double gmax = double(frame.grid_max());
    uint64_t hits = 0, misses = 0, grazes = 0, deep = 0;
    LD max_eps = 0, max_off = 0;
    for (int it = 0; it < 400; ++it) {
      // Radius 2^1 .. 2^(B-7) grid units; length 0 (one in 16) or 2^-3 .. 2^5 radii; tapers, zero-radius tips.
      const double rg = std::ldexp(rand_double(rng, 1.0, 2.0), int(rand_int(rng, 1, B - 7)));
      const double len = one_in(rng, 16) ? 0.0 : rg * std::ldexp(1.0, int(rand_int(rng, -3, 5)));
      double r0 = rg, r1 = rg;
      if (one_in(rng, 2)) r1 = rg * rand_double(rng, 0.0, 2.0);
      if (one_in(rng, 8)) (one_in(rng, 2) ? r0 : r1) = 0.0;
      CurveRecord c{};
      double axis[3], p0g[3];
      double an = 0;
      for (int a = 0; a < 3; ++a) {
        axis[a] = rand_double(rng, -1.0, 1.0);
        an += axis[a] * axis[a];
      }
      an = std::sqrt(an);
      const double margin = len + 3 * rg + 2;
      for (int a = 0; a < 3; ++a) {
        p0g[a] = rand_double(rng, margin, gmax - margin);
        c.p0[a] = int32_t(std::llround(p0g[a]));
        c.p1[a] = int32_t(std::llround(p0g[a] + len * axis[a] / an));
      }
      c.r0 = curve_radius_field(std::llround(std::ldexp(r0, F)));
      c.r1 = curve_radius_field(std::llround(std::ldexp(r1, F)));
      c.round = kRoundCurve | kRoundCapStart;
      if (c.r0 == 0 && c.r1 == 0) continue;
      ExactSegment sg;
      for (int a = 0; a < 3; ++a) {
        sg.p0[a] = c.p0[a];
        sg.p1[a] = c.p1[a];
      }
      sg.r0 = std::ldexp(LD(curve_radius(c.r0)), -F);
      sg.r1 = std::ldexp(LD(curve_radius(c.r1)), -F);
      LD E2 = 0;
      for (int a = 0; a < 3; ++a) E2 += std::ldexp((sg.p1[a] - sg.p0[a]) * (sg.p1[a] - sg.p0[a]), 2 * F);
      const LD dr = std::ldexp(sg.r1 - sg.r0, F), K = E2 - dr * dr;
      const LD L = std::sqrt(E2), rmax = std::ldexp(std::max(sg.r0, sg.r1), F);
      // z bound: the largest local position is below the reach L + rmax + 4 (grid.F) or the segment itself.
      const int z = std::max(0, int(std::ceil(std::log2(double(L + 2 * rmax + 8)))) + 1 - C);
      const LD ratio = K > 0 ? E2 / K : 0;
      const int Dc = std::max(D, 54 - C);
      const LD eps_u = std::ldexp(LD(1), z) * (1 + (1.4L + 1.4L * std::ldexp(LD(1), C + 2 - Dc)) * ratio) +
                       2 * std::sqrt(LD(3)) * std::ldexp(LD(1), F - T) + 1;
      // Sphere-only segments (K <= 0) and the end spheres: sphere_test's perpendicular rounding, a few units.
      const LD eps = std::ldexp(std::max(eps_u, LD(4)), -F);  // grid units
      max_eps = std::max(max_eps, eps);

      for (int k = 0; k < 4; ++k) {
        // Aimed at a point near the segment: from outside, or nearly along its axis (one in 4).
        Ray ray;
        const double s = rand_double(rng, -0.1, 1.1), spread = 1.3 * std::max(r0, r1) + 1.0;
        double target[3], dirv[3];
        for (int a = 0; a < 3; ++a)
          target[a] = p0g[a] + s * len * axis[a] / an + rand_double(rng, -spread, spread);
        const bool along = k == 3 && len > 0;
        const double dist = rand_double(rng, 3.0, 40.0) * (spread + len);
        double dn = 0;
        for (int a = 0; a < 3; ++a) {
          dirv[a] = along ? axis[a] / an + rand_double(rng, -0.02, 0.02) : rand_double(rng, -1.0, 1.0);
          dn += dirv[a] * dirv[a];
        }
        dn = std::sqrt(dn);
        if (dn == 0) continue;
        const double scale = rand_double(rng, 0.5, 4.0);
        for (int a = 0; a < 3; ++a) {
          ray.origin[a] = float(target[a] - dist * dirv[a] / dn);
          ray.dir[a] = float(dirv[a] / dn * scale);
        }
        ray.tmin = 0.0f;
        ray.tmax = kInf;
        FixedRay fr;
        if (setup_ray(ray, frame, f, fr) != RayStatus::kOk) continue;  // an origin beyond the guard range
        LD o[3], d[3], nd = 0;
        for (int a = 0; a < 3; ++a) {
          o[a] = std::ldexp(LD(fr.o[a]), -F);
          d[a] = std::ldexp(LD(fr.d[a]), -D);
          nd += d[a] * d[a];
        }
        nd = std::sqrt(nd);
        if (union_distance(sg, o) <= 2 * eps) continue;  // starts (nearly) inside: not this test's case
        FixedPrimHit h{};
        const bool hit = swept_sphere_test(fr, c, fr.tmin, fr.tmax, h);
        LD reach = 0;  // beyond |o| + the grid's diagonal the ray is past the segment
        for (int a = 0; a < 3; ++a) reach += o[a] * o[a];
        const LD t_far = (std::sqrt(reach) + 2 * LD(gmax)) / nd;
        const LD t_grown = first_within(sg, o, d, eps, t_far);
        const LD t_shrunk = std::isinf(t_grown) ? t_grown : first_within(sg, o, d, -eps, t_far);
        const LD unit = std::ldexp(LD(1), -T);  // one t unit in ray units
        auto ctx = [&] {
          std::ostringstream os;
          os << "segment p0 " << c.p0[0] << " " << c.p0[1] << " " << c.p0[2] << " p1 " << c.p1[0] << " " << c.p1[1]
             << " " << c.p1[2] << " r " << c.r0 << " " << c.r1 << " ray " << describe(fr) << " eps " << double(eps)
             << " t_grown " << double(t_grown) << " t_shrunk " << double(t_shrunk) << " | hit " << hit << " t "
             << double(LD(h.t) * unit);
          return os.str();
        };
        if (std::isinf(t_grown)) {
          REQUIRE_CTX(!hit, ctx());
          ++misses;
          continue;
        }
        if (!std::isinf(t_shrunk)) {
          REQUIRE_CTX(hit, ctx());
          ++deep;
        }
        if (!hit) {
          ++grazes;
          continue;
        }
        ++hits;
        const LD th = LD(h.t) * unit;
        REQUIRE_CTX(th >= t_grown - unit, ctx());
        if (!std::isinf(t_shrunk)) REQUIRE_CTX(th <= t_shrunk + unit, ctx());
        LD x[3];
        for (int a = 0; a < 3; ++a) x[a] = o[a] + th * d[a];
        const LD off = std::fabs(union_distance(sg, x)) - nd * unit;
        max_off = std::max(max_off, off / eps);
        REQUIRE_CTX(off <= eps, ctx());
      }
    }
    INFO("hits " << hits << " (inside by eps " << deep << ") misses " << misses << " grazes " << grazes
                 << " largest eps " << double(max_eps) << " grid, largest |distance| / eps " << double(max_off));
    CHECK(hits > 400);
    CHECK(misses > 250);
    CHECK(max_off <= 1.0L);
  }
}
