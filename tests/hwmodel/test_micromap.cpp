// Opacity micromaps: the micro-triangle index of barycentrics (hwmodel/format/micromap.h), at edges, vertices and
// inside, against the geometry of the subdivision; packing.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <random>
#include <set>
#include <vector>

#include "hwmodel/format/micromap.h"

using rtu::hw::micro_corners;
using rtu::hw::micro_index;
using rtu::hw::Micromap;
using rtu::hw::MicroState;

namespace {

// Whether (u, v) lies in the closed micro-triangle with corners c (barycentric coordinates of the corners in
// the micro-triangle, all >= -eps).
bool inside(const double c[3][2], double u, double v, double eps) {
  const double d = (c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[2][0] - c[0][0]) * (c[1][1] - c[0][1]);
  const double a = ((c[1][0] - u) * (c[2][1] - v) - (c[2][0] - u) * (c[1][1] - v)) / d;
  const double b = ((c[2][0] - u) * (c[0][1] - v) - (c[0][0] - u) * (c[2][1] - v)) / d;
  return a >= -eps && b >= -eps && 1.0 - a - b >= -eps;
}

}  // namespace

TEST_CASE("micromap: the micro-triangles tile the triangle, numbered 0 .. 4^L - 1 row by row", "[micromap]") {
  for (int level = 0; level <= 5; ++level) {
    CAPTURE(level);
    const uint32_t n = uint32_t(1) << (2 * level);
    double area = 0.0;
    std::set<uint32_t> seen;
    for (uint32_t i = 0; i < n; ++i) {
      double c[3][2];
      micro_corners(level, i, c);
      // Each is 1/4^L of the triangle's area (1/2 in (u, v)), inside it.
      const double a =
          0.5 * std::fabs((c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[2][0] - c[0][0]) * (c[1][1] - c[0][1]));
      CHECK(a == std::ldexp(0.5, -2 * level));
      area += a;
      for (const auto& p : c) CHECK((p[0] >= 0.0 && p[1] >= 0.0 && p[0] + p[1] <= 1.0));
      // Its centroid looks up to it.
      const float cu = float((c[0][0] + c[1][0] + c[2][0]) / 3.0), cv = float((c[0][1] + c[1][1] + c[2][1]) / 3.0);
      CHECK(micro_index(level, cu, cv) == i);
      seen.insert(i);
    }
    CHECK(area == 0.5);
    CHECK(seen.size() == n);
  }
}

TEST_CASE("micromap: a point on an edge or a vertex goes to a micro-triangle whose closed region holds it",
          "[micromap]") {
  // Every grid point (vertices of the subdivision) and points along every grid line (edges), and random points:
  // the micro-triangle looked up holds the point (exactly: corners and the points are multiples of 2^-12).
  for (int level = 0; level <= 6; ++level) {
    CAPTURE(level);
    const int N = 1 << level;
    auto check = [&](double u, double v) {
      const uint32_t i = micro_index(level, float(u), float(v));
      REQUIRE(i < uint32_t(N) * uint32_t(N));
      double c[3][2];
      micro_corners(level, i, c);
      CAPTURE(u, v, i);
      CHECK(inside(c, u, v, 0.0));
    };
    const int steps = 4 * N;
    for (int a = 0; a <= steps; ++a)
      for (int b = 0; a + b <= steps; ++b) check(double(a) / steps, double(b) / steps);
    std::mt19937 rng(uint32_t(17 + level));
    std::uniform_real_distribution<double> d(0.0, 1.0);
    for (int k = 0; k < 20000; ++k) {
      double u = d(rng), v = d(rng);
      if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
      const float fu = float(u), fv = float(v);
      const uint32_t i = micro_index(level, fu, fv);
      double c[3][2];
      micro_corners(level, i, c);
      // The float point itself (the value the stage would get); its fraction sum may round at the diagonal:
      // within 2^-22 of the region.
      CHECK(inside(c, double(fu), double(fv), std::ldexp(1.0, -22 + level)));
    }
  }
  // Outside the triangle (rounding) and NaN: a micro-triangle of the grid, no out-of-range index.
  CHECK(micro_index(3, 0.7f, 0.7f) < 64);
  CHECK(micro_index(3, -0.1f, 1.2f) < 64);
  CHECK(micro_index(3, std::nanf(""), 0.5f) < 64);
  CHECK(micro_index(0, 0.3f, 0.3f) == 0);
}

TEST_CASE("micromap: states pack at 1 bit when all are known, else 2, and read back", "[micromap]") {
  std::vector<MicroState> s(16);
  for (size_t i = 0; i < s.size(); ++i) s[i] = i % 3 ? MicroState::kOpaque : MicroState::kTransparent;
  const Micromap two = Micromap::pack(2, s);
  CHECK(two.bits == 1);
  CHECK(two.bytes() == 2);
  for (uint32_t i = 0; i < 16; ++i) CHECK(two.state(i) == s[i]);
  s[5] = MicroState::kUnknownTransparent;
  s[11] = MicroState::kUnknownOpaque;
  const Micromap four = Micromap::pack(2, s);
  CHECK(four.bits == 2);
  CHECK(four.bytes() == 4);
  for (uint32_t i = 0; i < 16; ++i) CHECK(four.state(i) == s[i]);
  rtu::hw::MicromapSet set;
  set.maps = {two, four};
  set.map_of = {0, rtu::hw::MicromapSet::kNoMap, 1};
  CHECK(set.check().empty());
  CHECK(set.bytes() == 2 + 4 + 8);
  CHECK(set.lookup(1, 0.1f, 0.1f) == MicroState::kUnknownOpaque);  // no map: unknown
  CHECK(set.lookup(7, 0.1f, 0.1f) == MicroState::kUnknownOpaque);  // beyond the table: unknown
  set.map_of[1] = 9;
  CHECK_THAT(set.check(), Catch::Contains("out of range"));
}
