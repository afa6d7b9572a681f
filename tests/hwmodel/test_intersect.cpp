// Float reference intersection tests against hand-computed cases.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

#include "hwmodel/datapath/intersect_float.h"

using namespace rtu::hw;

namespace {
const float kInfinity = std::numeric_limits<float>::infinity();
Ray make_ray(Vec3 o, Vec3 d, float tmin = 0.0f, float tmax = kInfinity) {
  return Ray{o, tmin, d, tmax};
}
}  // namespace

TEST_CASE("slab test: hand-computed entry distances", "[float][box]") {
  const Aabb box{Vec3(-1.0f), Vec3(1.0f)};
  float t;
  SECTION("head-on along +x enters at x = -1") {
    RayPrecomp r(make_ray({-5, 0, 0}, {1, 0, 0}));
    REQUIRE(intersect_box(box, r, 0.0f, kInfinity, t));
    CHECK(t == 4.0f);
  }
  SECTION("origin inside: entry is tmin") {
    RayPrecomp r(make_ray({0, 0, 0}, {0.3f, -0.2f, 1}));
    REQUIRE(intersect_box(box, r, 0.0f, kInfinity, t));
    CHECK(t == 0.0f);
  }
  SECTION("box behind the ray misses") {
    RayPrecomp r(make_ray({5, 0, 0}, {1, 0, 0}));
    CHECK_FALSE(intersect_box(box, r, 0.0f, kInfinity, t));
  }
  SECTION("interval ends before the box") {
    RayPrecomp r(make_ray({-5, 0, 0}, {1, 0, 0}));
    CHECK_FALSE(intersect_box(box, r, 0.0f, 3.9f, t));
  }
  SECTION("zero direction components of both signs, origin inside the slabs") {
    for (float zero : {0.0f, -0.0f}) {
      RayPrecomp r(make_ray({-5, 0.5f, -0.5f}, {1, zero, zero}));
      REQUIRE(intersect_box(box, r, 0.0f, kInfinity, t));
      CHECK(t == 4.0f);
    }
  }
  SECTION("zero direction component, origin outside that slab misses for both signs of zero") {
    for (float zero : {0.0f, -0.0f}) {
      RayPrecomp r(make_ray({-5, 1.5f, 0}, {1, zero, 0}));
      CHECK_FALSE(intersect_box(box, r, 0.0f, kInfinity, t));
      RayPrecomp q(make_ray({-5, -1.5f, 0}, {1, zero, 0}));
      CHECK_FALSE(intersect_box(box, q, 0.0f, kInfinity, t));
    }
  }
  SECTION("zero direction component with the origin exactly on a face plane: closed box, accepted") {
    for (float zero : {0.0f, -0.0f}) {
      RayPrecomp r(make_ray({-5, 1.0f, 0}, {1, zero, 0}));
      CHECK(intersect_box(box, r, 0.0f, kInfinity, t));
      RayPrecomp q(make_ray({-5, -1.0f, 0}, {1, zero, 0}));
      CHECK(intersect_box(box, q, 0.0f, kInfinity, t));
    }
  }
  SECTION("ray grazing an edge of a flat box is accepted (margin)") {
    const Aabb flat{Vec3(0, 0, 0), Vec3(1, 1, 0)};
    RayPrecomp r(make_ray({-1, -1, 0}, {1, 1, 0}));
    CHECK(intersect_box(flat, r, 0.0f, kInfinity, t));
  }
  SECTION("an empty (inverted) box is never accepted") {
    const Aabb empty;
    for (Vec3 d : {Vec3(1, 0, 0), Vec3(-1, -0.0f, 0), Vec3(0.3f, 0.5f, -0.1f)}) {
      RayPrecomp r(make_ray({0, 0, 0}, d));
      CHECK_FALSE(intersect_box(empty, r, 0.0f, kInfinity, t));
    }
  }
}

TEST_CASE("watertight triangle test: hand-computed hits and misses", "[float][triangle]") {
  const Triangle tri{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  PrimHit h{};
  SECTION("perpendicular hit inside: t and barycentrics") {
    RayPrecomp r(make_ray({0.25f, 0.5f, 2}, {0, 0, -1}));
    REQUIRE(intersect_triangle(tri, r, 0.0f, kInfinity, h));
    CHECK(h.t == 2.0f);
    CHECK(h.u == 0.25f);  // weight of v1 = x
    CHECK(h.v == 0.5f);   // weight of v2 = y
  }
  SECTION("back face is hit too, t scales with |d|") {
    RayPrecomp r(make_ray({0.25f, 0.25f, -3}, {0, 0, 2}));
    REQUIRE(intersect_triangle(tri, r, 0.0f, kInfinity, h));
    CHECK(h.t == 1.5f);
  }
  SECTION("outside the hypotenuse misses") {
    RayPrecomp r(make_ray({0.6f, 0.6f, 1}, {0, 0, -1}));
    CHECK_FALSE(intersect_triangle(tri, r, 0.0f, kInfinity, h));
  }
  SECTION("exactly on a vertex and on an edge: hit (edge functions zero)") {
    RayPrecomp v(make_ray({0, 0, 1}, {0, 0, -1}));
    CHECK(intersect_triangle(tri, v, 0.0f, kInfinity, h));
    RayPrecomp e(make_ray({0.5f, 0, 1}, {0, 0, -1}));
    CHECK(intersect_triangle(tri, e, 0.0f, kInfinity, h));
  }
  SECTION("parallel ray in the plane misses (det = 0)") {
    RayPrecomp r(make_ray({-1, 0.25f, 0}, {1, 0, 0}));
    CHECK_FALSE(intersect_triangle(tri, r, 0.0f, kInfinity, h));
  }
  SECTION("t interval bounds the hit") {
    RayPrecomp r(make_ray({0.25f, 0.25f, 2}, {0, 0, -1}));
    CHECK_FALSE(intersect_triangle(tri, r, 0.0f, 1.99f, h));
    CHECK_FALSE(intersect_triangle(tri, r, 2.01f, kInfinity, h));
    CHECK(intersect_triangle(tri, r, 2.0f, 2.0f, h));
  }
  SECTION("degenerate (zero-area) triangle never hits") {
    const Triangle line{{0, 0, 0}, {1, 1, 0}, {2, 2, 0}};
    RayPrecomp r(make_ray({1, 1, 1}, {0, 0, -1}));
    CHECK_FALSE(intersect_triangle(line, r, 0.0f, kInfinity, h));
  }
  SECTION("two triangles sharing an edge: a ray through the edge hits at least one") {
    const Triangle other{{1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
    for (float s : {0.1f, 0.3f, 0.5f, 0.7f, 0.9f}) {
      // The point (s, 1-s) is on the shared edge, up to float rounding of 1-s; aim at it obliquely.
      const Vec3 target(s, 1.0f - s, 0.0f);
      const Vec3 o(0.3f, -0.7f, 1.3f);
      RayPrecomp r(make_ray(o, target - o));
      PrimHit h1, h2;
      const bool a = intersect_triangle(tri, r, 0.0f, kInfinity, h1);
      const bool b = intersect_triangle(other, r, 0.0f, kInfinity, h2);
      CHECK((a || b));
    }
  }
}

TEST_CASE("sphere: the quadratic's discriminant cases", "[float][sphere]") {
  const Vec3 c(0, 0, 0);
  PrimHit h{};
  SECTION("disc > 0: two roots, the nearer is reported; from inside the far one") {
    RayPrecomp r(make_ray({0, 0, -5}, {0, 0, 1}));
    REQUIRE(intersect_sphere(c, 2.0f, r, 0.0f, kInfinity, h));
    CHECK(h.t == 3.0f);
    RayPrecomp in(make_ray({0, 0, 0}, {0, 0, 2}));
    REQUIRE(intersect_sphere(c, 2.0f, in, 0.0f, kInfinity, h));
    CHECK(h.t == 1.0f);  // |d| = 2: t = r / |d|
  }
  SECTION("disc = 0: tangent ray touches at t = 5") {
    RayPrecomp r(make_ray({-5, 2, 0}, {1, 0, 0}));
    REQUIRE(intersect_sphere(c, 2.0f, r, 0.0f, kInfinity, h));
    CHECK(h.t == 5.0f);
  }
  SECTION("disc < 0: passes beside") {
    RayPrecomp r(make_ray({-5, 2.001f, 0}, {1, 0, 0}));
    CHECK_FALSE(intersect_sphere(c, 2.0f, r, 0.0f, kInfinity, h));
  }
  SECTION("sphere behind the ray misses") {
    RayPrecomp r(make_ray({0, 0, 5}, {0, 0, 1}));
    CHECK_FALSE(intersect_sphere(c, 2.0f, r, 0.0f, kInfinity, h));
  }
  SECTION("far origin and a tiny sphere: no cancellation (disc from the distance to the line)") {
    // Distance from the line to the center is 0.5 * r: t = 1e6 - r sqrt(3)/2 exactly in reals.
    const float rad = 1.0f;
    RayPrecomp r(make_ray({-1e6f, 0.5f, 0}, {1, 0, 0}));
    REQUIRE(intersect_sphere(c, rad, r, 0.0f, kInfinity, h));
    const double exact = 1e6 - std::sqrt(3.0) / 2.0;
    CHECK(std::abs(h.t - exact) <= 0.0625 * 2);  // 2 ulps of float at 1e6 (ulp = 0.0625)
    RayPrecomp miss(make_ray({-1e6f, 1.0001f, 0}, {1, 0, 0}));
    CHECK_FALSE(intersect_sphere(c, rad, miss, 0.0f, kInfinity, h));
  }
  SECTION("sphere uv: poles and equator") {
    float u, v;
    sphere_uv(c, {0, 1, 0}, u, v);
    CHECK(v == 0.0f);
    sphere_uv(c, {0, -1, 0}, u, v);
    CHECK(v == Approx(1.0f));
    sphere_uv(c, {1, 0, 0}, u, v);
    CHECK(u == 0.0f);
    CHECK(v == Approx(0.5f));
  }
}

TEST_CASE("plane: t = (c - p.n)/(d.n)", "[float][plane]") {
  PrimHit h{};
  SECTION("axis-aligned plane z = c: t = (c - p_z)/d_z") {
    const Plane p{{0, 0, 1}, 3.0f};
    RayPrecomp r(make_ray({1, 2, -1}, {0.5f, 0.25f, 2}));
    REQUIRE(intersect_plane(p, r, 0.0f, kInfinity, h));
    CHECK(h.t == (3.0f - -1.0f) / 2.0f);
  }
  SECTION("oblique normal") {
    const Plane p{{1, 1, 0}, 2.0f};  // x + y = 2
    RayPrecomp r(make_ray({0, 0, 0}, {1, 0, 0}));
    REQUIRE(intersect_plane(p, r, 0.0f, kInfinity, h));
    CHECK(h.t == 2.0f);
  }
  SECTION("parallel rays miss, whether in the plane or not") {
    const Plane p{{0, 0, 1}, 0.0f};
    RayPrecomp off(make_ray({0, 0, 1}, {1, 0, 0}));
    CHECK_FALSE(intersect_plane(p, off, 0.0f, kInfinity, h));
    RayPrecomp in(make_ray({0, 0, 0}, {1, 1, 0}));
    CHECK_FALSE(intersect_plane(p, in, 0.0f, kInfinity, h));
  }
  SECTION("plane behind the ray misses") {
    const Plane p{{0, 0, 1}, -1.0f};
    RayPrecomp r(make_ray({0, 0, 0}, {0, 0, 1}));
    CHECK_FALSE(intersect_plane(p, r, 0.0f, kInfinity, h));
  }
}

TEST_CASE("ray validation rejects NaN/Inf and zero directions with a reason", "[float][ray]") {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  CHECK(validate_ray(make_ray({0, 0, 0}, {1, 0, 0})) == RayStatus::kOk);
  CHECK(validate_ray(make_ray({nan, 0, 0}, {1, 0, 0})) == RayStatus::kNanOrigin);
  CHECK(validate_ray(make_ray({0, kInfinity, 0}, {1, 0, 0})) == RayStatus::kInfOrigin);
  CHECK(validate_ray(make_ray({0, 0, 0}, {1, nan, 0})) == RayStatus::kNanDirection);
  CHECK(validate_ray(make_ray({0, 0, 0}, {0, 0, -kInfinity})) == RayStatus::kInfDirection);
  CHECK(validate_ray(make_ray({0, 0, 0}, {0, -0.0f, 0})) == RayStatus::kZeroDirection);
  CHECK(validate_ray(make_ray({0, 0, 0}, {1, 0, 0}, nan)) == RayStatus::kNanInterval);
  CHECK(validate_ray(make_ray({0, 0, 0}, {1, 0, 0}, 0.0f, nan)) == RayStatus::kNanInterval);
  CHECK(validate_ray(make_ray({0, 0, 0}, {1, 0, 0}, 5.0f, 1.0f)) == RayStatus::kOk);  // empty: misses
}
