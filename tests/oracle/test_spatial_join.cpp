// Spatial joins on the unit (hwmodel/datapath/spatial_join.h) against CGAL's exact predicates (Epick: exact
// predicates on the float inputs, as double): segment intersection pairs and point-in-polygon sets equal CGAL's
// by brute force, on random segments, segments through shared end points, collinear overlaps, axis-parallel edges,
// points on edges, vertices and on the polygons' vertex lines (the half-open rule's cases), at 24 and 8 coordinate
// bits. And the orientation predicate itself against CGAL on near-degenerate triples.
#include <catch2/catch.hpp>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2_algorithms.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "hwmodel/datapath/box_index.h"
#include "hwmodel/datapath/spatial_join.h"
#include "hwmodel/numeric/rng.h"

using namespace rtu;
using hw::Point2;
using hw::Segment2;
using K = CGAL::Exact_predicates_inexact_constructions_kernel;

namespace {

K::Point_2 cg(const Point2& p) {
  return K::Point_2(double(p.x), double(p.y));
}

// Random segments on a coarse lattice (many shared end points, collinear overlaps, axis-parallel ones) and some
// at random float positions.
std::vector<Segment2> segments(uint64_t seed, size_t n) {
  hw::Pcg32 rng(seed);
  const auto lattice = [&] {
    return Point2{float(rng.next_u32() % 21) * 0.5f, float(rng.next_u32() % 21) * 0.5f};
  };
  std::vector<Segment2> v(n);
  for (size_t i = 0; i < n; ++i) {
    if (i % 3 == 0) {
      const Point2 a{rng.next_float() * 10.0f, rng.next_float() * 10.0f};
      v[i] = Segment2{a, Point2{a.x + rng.next_float() - 0.5f, a.y + rng.next_float() - 0.5f}};
    } else {
      Point2 a = lattice(), b = lattice();
      if (i % 7 == 0) b.y = a.y;  // horizontal
      v[i] = Segment2{a, b};
    }
  }
  return v;
}

}  // namespace

TEST_CASE("spatial join: orientation is exact on near-degenerate triples", "[queries][join]") {
  hw::Pcg32 rng(7);
  for (int i = 0; i < 200000; ++i) {
    const Point2 a{rng.next_float() * 1e3f, rng.next_float()},
        b{rng.next_float() * 1e-3f, rng.next_float() * 1e6f};
    // c on the line through a and b up to a float rounding, or exactly on it.
    const float s = rng.next_float();
    Point2 c{float(a.x + s * (b.x - a.x)), float(a.y + s * (b.y - a.y))};
    if (i % 4 == 0) c = i % 8 ? a : b;
    const CGAL::Orientation o = CGAL::orientation(cg(a), cg(b), cg(c));
    REQUIRE(hw::exact_orient2d(a, b, c) == (o == CGAL::LEFT_TURN ? 1 : o == CGAL::RIGHT_TURN ? -1 : 0));
  }
}

TEST_CASE("spatial join: segment intersections equal CGAL's, brute force", "[queries][join]") {
  const std::vector<Segment2> A = segments(1, 1500), B = segments(2, 1500);
  std::vector<std::pair<uint32_t, uint32_t>> want;
  for (uint32_t i = 0; i < A.size(); ++i)
    for (uint32_t j = 0; j < B.size(); ++j)
      if (CGAL::do_intersect(K::Segment_2(cg(A[i].a), cg(A[i].b)), K::Segment_2(cg(B[j].a), cg(B[j].b))))
        want.emplace_back(i, j);
  REQUIRE(want.size() > 1000);
  for (const char* spec : {"default", "default:coord_bits=8"}) {
    hw::QueryStats s1, s2;
    const auto got = hw::segment_join(A, B, hw::format_from_spec(spec), 1, s1);
    INFO(spec << ": " << want.size() << " pairs, " << s1.candidates << " candidates");
    CHECK(got == want);
    CHECK(hw::segment_join(A, B, hw::format_from_spec(spec), 3, s2) == want);
    CHECK(s1.candidates == s2.candidates);
    // The index prunes: long lattice segments (10% of the pairs meet) leave 24% of the pairs as candidates.
    CHECK(s1.candidates < A.size() * B.size() / 3);
  }
}

TEST_CASE("spatial join: point in polygon equals CGAL's, boundaries and vertex lines included",
          "[queries][join]") {
  // Star-shaped polygons on the lattice (simple by construction: vertices by angle around a center), some
  // sharing edges and vertices with others.
  hw::Pcg32 rng(3);
  std::vector<hw::Polygon2> polys;
  for (int k = 0; k < 60; ++k) {
    const float cx = float(rng.next_u32() % 17 + 2), cy = float(rng.next_u32() % 17 + 2);
    const int n = 3 + int(rng.next_u32() % 9);
    hw::Polygon2 p;
    for (int v = 0; v < n; ++v) {
      const double ang = 6.283185307179586 * (v + 0.5 * rng.next_float()) / n;
      const float r = float(1 + rng.next_u32() % 4) * 0.5f;
      p.push_back(Point2{cx + std::round(float(r * std::cos(ang)) * 4.0f) / 4.0f,
                         cy + std::round(float(r * std::sin(ang)) * 4.0f) / 4.0f});
    }
    p.erase(std::unique(p.begin(), p.end()), p.end());
    if (p.size() < 3 || p.front() == p.back()) continue;
    std::vector<K::Point_2> c;
    for (const Point2& q : p) c.push_back(cg(q));
    if (CGAL::is_simple_2(c.begin(), c.end(), K())) polys.push_back(p);
  }
  REQUIRE(polys.size() > 30);
  // Points: on the quarter lattice (vertices, edges, vertex lines), and random.
  std::vector<Point2> pts;
  for (int i = 0; i < 6000; ++i)
    pts.push_back(i % 2 ? Point2{float(rng.next_u32() % 81) * 0.25f, float(rng.next_u32() % 81) * 0.25f}
                        : Point2{rng.next_float() * 20.0f, rng.next_float() * 20.0f});
  for (const hw::Polygon2& p : polys) pts.insert(pts.end(), p.begin(), p.end());
  std::vector<std::vector<uint32_t>> want(pts.size());
  uint64_t inside = 0, on = 0;
  for (uint32_t k = 0; k < polys.size(); ++k) {
    std::vector<K::Point_2> c;
    for (const Point2& q : polys[k]) c.push_back(cg(q));
    for (size_t j = 0; j < pts.size(); ++j) {
      const CGAL::Bounded_side b = CGAL::bounded_side_2(c.begin(), c.end(), cg(pts[j]), K());
      if (b != CGAL::ON_UNBOUNDED_SIDE) want[j].push_back(k);
      inside += b == CGAL::ON_BOUNDED_SIDE;
      on += b == CGAL::ON_BOUNDARY;
    }
  }
  INFO(pts.size() << " points, " << polys.size() << " polygons: " << inside << " inside, " << on
                  << " on a boundary");
  REQUIRE(on > 500);
  for (const char* spec : {"default", "default:coord_bits=8"}) {
    hw::QueryStats s;
    const auto got = hw::point_in_polygons(polys, pts, hw::format_from_spec(spec), 2, s);
    size_t differ = 0;
    for (size_t j = 0; j < pts.size(); ++j) differ += got[j] != want[j];
    INFO(spec << ": " << differ << " points differ, " << s.candidates << " candidate edges");
    CHECK(differ == 0);
  }
  hw::QueryStats s;
  CHECK_THROWS_WITH(hw::point_in_polygons({{Point2{0, 0}, Point2{1, 1}}}, pts, hw::format_preset("default"), 1, s),
                    Catch::Contains("fewer than 3"));
  CHECK_THROWS_WITH(hw::segment_join({Segment2{{0, 0}, {NAN, 1}}}, {Segment2{{0, 0}, {1, 1}}},
                                     hw::format_preset("default"), 1, s),
                    Catch::Contains("segment 0"));
}

TEST_CASE("box overlap: every indexed box a query box meets, and only candidates that can meet",
          "[queries][join]") {
  hw::Pcg32 rng(11);
  const auto box = [&](float size) {
    const hw::Vec3 c = hw::Vec3(rng.next_float(), rng.next_float(), rng.next_float()) * 50.0f;
    const hw::Vec3 e = hw::Vec3(rng.next_float(), rng.next_float(), rng.next_float()) * size;
    // Some boxes flat on an axis, some sharing a face with a lattice plane.
    hw::Aabb b{c - e, c + e};
    if (rng.next_u32() % 4 == 0) b.hi.y = b.lo.y;
    if (rng.next_u32() % 4 == 0) b.lo.x = std::floor(b.lo.x), b.hi.x = std::floor(b.hi.x) + 1.0f;
    return b;
  };
  std::vector<hw::Aabb> boxes, queries;
  for (int i = 0; i < 5000; ++i) boxes.push_back(box(2.0f));
  for (int i = 0; i < 2000; ++i) queries.push_back(box(4.0f));
  for (int i = 0; i < 200; ++i) queries.push_back(boxes[size_t(i) * 7]);  // exactly an indexed box
  const auto meet = [](const hw::Aabb& a, const hw::Aabb& b) {
    for (int k = 0; k < 3; ++k)
      if (a.lo[k] > b.hi[k] || b.lo[k] > a.hi[k]) return false;
    return true;
  };
  for (const char* spec : {"default", "default:coord_bits=8"}) {
    const hw::BoxIndex index(boxes, hw::format_from_spec(spec));
    hw::QueryStats s;
    uint64_t found = 0;
    for (const hw::Aabb& q : queries) {
      std::vector<uint32_t> got;
      index.box_candidates(
          q,
          [&](uint32_t i) {
            if (meet(boxes[i], q)) got.push_back(i);
          },
          s, nullptr);
      std::sort(got.begin(), got.end());
      std::vector<uint32_t> want;
      for (uint32_t i = 0; i < boxes.size(); ++i)
        if (meet(boxes[i], q)) want.push_back(i);
      REQUIRE(got == want);
      found += want.size();
    }
    INFO(spec << ": " << found << " overlaps, " << s.candidates << " candidates");
    CHECK(found > queries.size());
    CHECK(s.candidates < 2 * found + queries.size() * 2);  // the grid rounding adds few candidates
  }
}
