// The fixed-point sphere and plane tests (intersect_fixed.h) against long double on the same quantized inputs,
// with the tolerance derived from the roundings of each test; and a plane met beyond the t register's range is no
// hit inside a shorter interval (the fixed tracer counts the saturation). Randomized parts print their seed.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/scene/geometry.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

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
      random_interval(rng, ray);
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
      random_interval(rng, ray);
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
