// Fixed-point ray setup (setup_ray, intersect_fixed.h): invalid rays and their reasons, the guard range, infinite
// tmax, interval ends rounded outward, signed zeros and components that round to 0, the direction and reciprocal
// roundings, and power-of-two scale invariance.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>

#include "fixed_checks.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/scene/geometry.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

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
  REQUIRE_NOTHROW(
      small = format_from_spec(
          "default:coord_bits=8:guard_bits=4:frac_bits=8:dir_bits=16:rcp_bits=16:t_frac_bits=8:t_bits=32"));
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
