// The fixed-point triangle test (intersect_fixed.h): watertight on constructed shared edges and vertex fans (exact
// ties: rays exactly through an edge or a vertex hit every triangle not parallel to them, at the same t), and
// hit/miss, t, u and v against a long double Moller-Trumbore (fixed_checks.h) on the same quantized inputs away
// from the edges; degenerate triangles never hit. Randomized parts print their seed.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

namespace {

// A corner P in the middle of the grid (coordinates in [cmax / 4, cmax / 2]) and two integer edge vectors a and b
// (components in [-spread, spread]) that are not parallel (neither zero); z = a x b. Drawn per axis in that order.
void random_corner(Pcg32& rng, int64_t cmax, int64_t spread, int64_t P[3], int64_t a[3], int64_t b[3],
                   int64_t z[3]) {
  do {
    for (int i = 0; i < 3; ++i) {
      P[i] = rand_int(rng, cmax / 4, cmax / 2);
      a[i] = rand_int(rng, -spread, spread);
      b[i] = rand_int(rng, -spread, spread);
    }
    z[0] = a[1] * b[2] - a[2] * b[1];
    z[1] = a[2] * b[0] - a[0] * b[2];
    z[2] = a[0] * b[1] - a[1] * b[0];
  } while (z[0] == 0 && z[1] == 0 && z[2] == 0);
}

}  // namespace

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
      random_corner(rng, cmax, 16, P, w, u, z);
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
      random_corner(rng, cmax, 8, V, u, w, z);
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
      random_interval(rng, ray);
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
