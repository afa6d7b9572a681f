// The fixed-point box test (intersect_fixed.h) against the exact rational checker: no false negatives on 2M+
// randomized cases (ties included: rays aimed exactly at corners and edges, origins on box planes, degenerate
// boxes), its entry distance never beyond the exact one, the 64-bit and 128-bit paths bit-identical, and the exact
// checker itself against long double where long double can decide. The references (fixed_checks.h) work on the
// quantized ray the datapath sees. The test prints its seed.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>

#include "fixed_checks.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

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
