// Guards the float reference against the compiler: contraction of a*b - c*d into an FMA would break the exact
// antisymmetry of shared edge functions (watertightness), and a vectorizer that skips a rounding (seen with
// GCC 12's SLP vectorizer on double->float->double) would change results bit-wise. The reference below computes
// each operation through a volatile, which no optimization may fuse or skip; the production code must agree bit
// for bit on rays aimed at vertices and edges, where every rounding matters.
#include <catch2/catch.hpp>

#include <cstring>
#include <random>

#include "hwmodel/datapath/intersect_float.h"

using namespace rtu::hw;

namespace {

double rd(double x) {
  volatile double v = x;
  return v;
}
float rf(double x) {
  volatile float v = float(x);
  return v;
}

// Woop et al.'s test, one rounding per operation, in the operation order of intersect_triangle.
bool stepped_triangle(const Triangle& t, const Ray& ray, PrimHit& out) {
  const RayPrecomp r(ray);
  const double ox = r.origin[r.kx], oy = r.origin[r.ky], oz = r.origin[r.kz];
  const double sx = r.sx, sy = r.sy, sz = r.sz;
  const Vec3* v[3] = {&t.v0, &t.v1, &t.v2};
  double x[3], y[3], z[3];
  for (int i = 0; i < 3; ++i) {
    z[i] = rd(double((*v[i])[r.kz]) - oz);
    x[i] = rd(rd(double((*v[i])[r.kx]) - ox) - rd(sx * z[i]));
    y[i] = rd(rd(double((*v[i])[r.ky]) - oy) - rd(sy * z[i]));
  }
  const double u = rd(rd(x[2] * y[1]) - rd(y[2] * x[1]));
  const double vv = rd(rd(x[0] * y[2]) - rd(y[0] * x[2]));
  const double w = rd(rd(x[1] * y[0]) - rd(y[1] * x[0]));
  if ((u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0)) return false;
  const double det = rd(rd(u + vv) + w);
  if (det == 0.0) return false;
  const double tt = rd(rd(rd(rd(rd(u * z[0]) + rd(vv * z[1])) + rd(w * z[2])) * sz) / det);
  out.t = rf(tt);
  out.u = rf(rd(vv / det));
  out.v = rf(rd(w / det));
  return true;
}

bool same_bits(float a, float b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

}  // namespace

TEST_CASE("triangle test rounds every operation as written (no FMA, no skipped rounding)", "[float][rounding]") {
  const uint32_t seed = 20261122;
  INFO("seed " << seed);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(-1.0f, 1.0f);
  int at_vertex = 0, hits = 0;
  for (int i = 0; i < 200000; ++i) {
    const float scale = (i % 3 == 0) ? 1e4f : 1.0f;
    Triangle t{{U(rng) * scale, U(rng) * scale, U(rng)},
               {U(rng) * scale, U(rng), U(rng) * scale},
               {U(rng), U(rng) * scale, U(rng) * scale}};
    // Aim at a vertex or at a point on an edge, so edge functions are near or exactly zero.
    const float s = (i % 2) ? 0.0f : std::abs(U(rng));
    const Vec3 target = t.v0 + s * (t.v1 - t.v0);
    const Vec3 o(U(rng) * 3 * scale, U(rng) * 3 * scale, U(rng) * 3 * scale);
    const Ray ray{o, 0.0f, target - o, std::numeric_limits<float>::infinity()};
    PrimHit got{}, want{};
    const bool g = intersect_triangle(t, RayPrecomp(ray), -1e30f, 1e30f, got);
    const bool w = stepped_triangle(t, ray, want);
    const bool want_in_range = w && want.t >= -1e30f && want.t <= 1e30f;
    INFO("case " << i);
    REQUIRE(g == want_in_range);
    if (g) {
      ++hits;
      REQUIRE(same_bits(got.t, want.t));
      REQUIRE(same_bits(got.u, want.u));
      REQUIRE(same_bits(got.v, want.v));
    }
    at_vertex += (s == 0.0f);
  }
  CHECK(hits > 50000);
  CHECK(at_vertex > 50000);
}
