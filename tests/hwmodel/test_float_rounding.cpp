// Guards the float reference against the compiler: contraction into FMA, or a vectorizer that keeps a value in
// double where the code rounds it to float (seen with GCC 12's SLP vectorizer), would change results bit-wise
// and break the watertightness argument. The reference below computes each operation through a volatile float,
// which no optimization may skip; the production code must agree bit for bit on rays near edges and vertices,
// where the double fallback and the rounding of every product matter.
#include <catch2/catch.hpp>

#include <cstring>
#include <random>

#include "hwmodel/intersect_float.h"

using namespace rtu::hw;

namespace {

float rd(float x) {
  volatile float v = x;
  return v;
}

// Woop et al.'s test, one rounding per line, the same operation order as intersect_triangle.
bool stepped_triangle(const Triangle& t, const Ray& ray, PrimHit& out) {
  const RayPrecomp r(ray);
  Vec3 a, b, c;
  for (int i = 0; i < 3; ++i) {
    a[i] = rd(t.v0[i] - ray.origin[i]);
    b[i] = rd(t.v1[i] - ray.origin[i]);
    c[i] = rd(t.v2[i] - ray.origin[i]);
  }
  const float az = a[r.kz], bz = b[r.kz], cz = c[r.kz];
  const float ax = rd(a[r.kx] - rd(r.sx * az)), ay = rd(a[r.ky] - rd(r.sy * az));
  const float bx = rd(b[r.kx] - rd(r.sx * bz)), by = rd(b[r.ky] - rd(r.sy * bz));
  const float cx = rd(c[r.kx] - rd(r.sx * cz)), cy = rd(c[r.ky] - rd(r.sy * cz));
  float u = rd(rd(cx * by) - rd(cy * bx));
  float v = rd(rd(ax * cy) - rd(ay * cx));
  float w = rd(rd(bx * ay) - rd(by * ax));
  if (u == 0.0f || v == 0.0f || w == 0.0f) {
    volatile double du = double(cx) * double(by) - double(cy) * double(bx);
    volatile double dv = double(ax) * double(cy) - double(ay) * double(cx);
    volatile double dw = double(bx) * double(ay) - double(by) * double(ax);
    u = rd(float(du));
    v = rd(float(dv));
    w = rd(float(dw));
  }
  if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f)) return false;
  const float det = rd(rd(u + v) + w);
  if (det == 0.0f) return false;
  const float t_scaled = rd(rd(rd(u * rd(r.sz * az)) + rd(v * rd(r.sz * bz))) + rd(w * rd(r.sz * cz)));
  const float inv_det = rd(1.0f / det);
  out.t = rd(t_scaled * inv_det);
  out.u = rd(v * inv_det);
  out.v = rd(w * inv_det);
  return true;
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

TEST_CASE("float triangle test rounds every operation to float (no FMA, no kept double)", "[float][rounding]") {
  const uint32_t seed = 20261122;
  INFO("seed " << seed);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> U(-1.0f, 1.0f);
  int fallbacks = 0, hits = 0;
  for (int i = 0; i < 200000; ++i) {
    const float scale = (i % 3 == 0) ? 1e4f : 1.0f;
    Triangle t{{U(rng) * scale, U(rng) * scale, U(rng)}, {U(rng) * scale, U(rng), U(rng) * scale},
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
    fallbacks += (s == 0.0f);
  }
  CHECK(hits > 50000);
  CHECK(fallbacks > 50000);
}
