// Neighbour queries on the unit (hwmodel/datapath/point_query.h) against exact oracles: GMP rationals decide every
// distance (independent of the unit's own exact check, exact_compare.h), nanoflann's k-d tree finds the candidates
// of large sets. Inputs: uniform, clustered, points on a lattice whose spacing is the radius (distances exactly r,
// on the grid's cell boundaries), duplicates, radii near zero and near the scene's extent. 0 missed and 0 false
// answers, on formats from 8 to 24 coordinate bits.
#include <gmpxx.h>
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nanoflann.hpp>
#include <vector>

#include "hwmodel/datapath/exact_compare.h"
#include "hwmodel/datapath/point_query.h"
#include "hwmodel/numeric/rng.h"

using namespace rtu;
using hw::Vec3;

namespace {

// |p - q|^2 as an exact rational.
mpq_class dist2(const Vec3& p, const Vec3& q) {
  mpq_class s = 0;
  for (int a = 0; a < 3; ++a) {
    const mpq_class d = mpq_class(double(p[a])) - mpq_class(double(q[a]));
    s += d * d;
  }
  return s;
}

struct Cloud {
  std::vector<Vec3> pts;
  size_t kdtree_get_point_count() const { return pts.size(); }
  double kdtree_get_pt(size_t i, size_t d) const { return double(pts[i][int(d)]); }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
using KdTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 3, uint32_t>;

// The exact answer: candidates from nanoflann within a radius inflated by 1e-6 relative (its double distances
// are off by far less), decided by GMP; sorted by id.
std::vector<uint32_t> oracle_radius(const KdTree& tree, const Cloud& c, const Vec3& q, float r) {
  const double qq[3] = {q.x, q.y, q.z};
  const double r2 = double(r) * double(r) * (1.0 + 1e-6) + 1e-300;
  std::vector<std::pair<uint32_t, double>> found;  // nanoflann 1.4 (Debian 12)
  nanoflann::SearchParams params;
  tree.radiusSearch(qq, r2, found, params);
  const mpq_class rr = mpq_class(double(r)) * mpq_class(double(r));
  std::vector<uint32_t> ids;
  for (const auto& f : found)
    if (dist2(c.pts[f.first], q) <= rr) ids.push_back(f.first);
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::vector<Vec3> uniform(uint64_t seed, size_t n, float extent) {
  hw::Pcg32 rng(seed);
  std::vector<Vec3> v(n);
  for (Vec3& p : v) p = Vec3(rng.next_float(), rng.next_float(), rng.next_float()) * extent;
  return v;
}

// Points in 12 clusters of random sizes (the clusters' centers from seed 99: data and queries share them).
std::vector<Vec3> clustered(uint64_t seed, size_t n) {
  hw::Pcg32 rng(seed);
  std::vector<Vec3> centers = uniform(99, 12, 100.0f), v(n);
  for (size_t i = 0; i < n; ++i) {
    const Vec3 c = centers[rng.next_u32() % centers.size()];
    const float s = 0.02f + 2.0f * rng.next_float() * rng.next_float();
    v[i] = c + s * (Vec3(rng.next_float(), rng.next_float(), rng.next_float()) - Vec3(0.5f));
  }
  return v;
}

// Checks every kind of query on `queries` against the oracle.
void check_queries(const std::vector<Vec3>& pts, const std::vector<Vec3>& queries, float r, const char* what,
                   const hw::FixedFormat& f) {
  const hw::PointIndex index(pts, r, f);
  Cloud cloud{pts};
  KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  hw::QueryStats s;
  const std::vector<hw::PointAnswer> got = index.query_batch(queries, {hw::PointQuery::kRadius, 1u << 20}, 0, s);
  hw::QueryStats sc;
  const std::vector<hw::PointAnswer> counts = index.query_batch(queries, {hw::PointQuery::kCount, 0}, 2, sc);
  uint64_t results = 0, missed = 0, wrong = 0;
  for (size_t i = 0; i < queries.size(); ++i) {
    const std::vector<uint32_t> want = oracle_radius(tree, cloud, queries[i], r);
    results += want.size();
    std::vector<uint32_t> extra, lost;
    std::set_difference(got[i].ids.begin(), got[i].ids.end(), want.begin(), want.end(), std::back_inserter(extra));
    std::set_difference(want.begin(), want.end(), got[i].ids.begin(), got[i].ids.end(), std::back_inserter(lost));
    missed += lost.size();
    wrong += extra.size();
    REQUIRE(counts[i].count == want.size());
    // k nearest, k = 3: the oracle's within-radius set by exact distance, ties by id.
    if (i % 7 == 0) {
      std::vector<uint32_t> byd = want;
      std::sort(byd.begin(), byd.end(), [&](uint32_t a, uint32_t b) {
        const int c = cmp(dist2(pts[a], queries[i]), dist2(pts[b], queries[i]));
        return c < 0 || (c == 0 && a < b);
      });
      byd.resize(std::min<size_t>(3, byd.size()));
      hw::QueryStats sk;
      REQUIRE(index.query(queries[i], {hw::PointQuery::kNearest, 3}, sk).ids == byd);
    }
  }
  INFO(what << " (" << f.describe() << "), r " << r << ": " << queries.size() << " queries, " << results
            << " neighbours, " << s.candidates << " candidates, " << missed << " missed, " << wrong << " false");
  std::printf("queries, %s (%s), r %g: %zu queries, %llu neighbours, %llu candidates, %llu missed, %llu false\n",
              what, f.describe().c_str(), double(r), queries.size(), (unsigned long long)results,
              (unsigned long long)s.candidates, (unsigned long long)missed, (unsigned long long)wrong);
  CHECK(missed == 0);
  CHECK(wrong == 0);
  CHECK(s.results == results);
  CHECK(s.candidates >= results);
  CHECK(sc.candidates == s.candidates);  // the same traversal, on 2 threads and on all
  CHECK(s.overflows == 0);
}

}  // namespace

TEST_CASE("queries: the exact distance check agrees with GMP rationals at and around the radius", "[queries]") {
  hw::Pcg32 rng(3);
  uint64_t on = 0;
  for (int i = 0; i < 200000; ++i) {
    const Vec3 p(rng.next_float() * 8.0f - 4.0f, rng.next_float() * 1e-3f, float(rng.next_u32() % 5));
    Vec3 q(rng.next_float() * 8.0f - 4.0f, rng.next_float() * 1e-3f, float(rng.next_u32() % 5));
    // Some pairs exactly r apart on one axis, some an ulp off.
    float r = rng.next_float() * 4.0f;
    if (i % 3 == 0) {
      q = p;
      q.z = p.z + 3.0f;
      r = i % 2 ? 3.0f : std::nextafter(3.0f, 0.0f);
    }
    if (i % 5 == 0) r = float(std::sqrt(double((p - q).x * (p - q).x)));
    const mpq_class d = dist2(p, q), rr = mpq_class(double(r)) * mpq_class(double(r));
    REQUIRE(hw::exact_within(p, q, r) == (d <= rr));
    REQUIRE(hw::exact_distance_sign(p, q, r) == sgn(d - rr));
    on += d == rr;
    const Vec3 b(rng.next_float(), rng.next_float(), float(rng.next_u32() % 5));
    REQUIRE(hw::exact_compare_distance(q, p, b) == sgn(dist2(q, p) - dist2(q, b)));
  }
  CHECK(on > 10000);  // many pairs exactly at the radius
  // Extreme magnitudes: differences of floats 2^100 apart, tiny values, squares near 2^256.
  const Vec3 big(0x1p62f, -0x1p62f, 1e-30f), tiny(1e-38f, 0.0f, -1e-38f);
  CHECK(hw::exact_within(big, tiny, 0x1p62f) == (dist2(big, tiny) <= mpq_class(0x1p62) * mpq_class(0x1p62)));
  CHECK(hw::exact_distance_sign(tiny, tiny, 0.0f) == 0);
}

TEST_CASE("queries: radius, count and k nearest equal the exact oracle on hard inputs, every format",
          "[queries]") {
  const std::vector<Vec3> u = uniform(1, 20000, 100.0f), c = clustered(2, 20000);
  const std::vector<Vec3> qu = uniform(3, 3000, 100.0f), qc = clustered(4, 300);
  for (const char* spec : {"default", "compact", "default:coord_bits=8:frac_bits=2"}) {
    const hw::FixedFormat f = hw::format_from_spec(spec);
    check_queries(u, qu, 2.5f, "uniform", f);
    check_queries(c, qc, 0.3f, "clustered", f);
  }
  // A lattice with spacing r: every neighbour exactly at distance r (or sqrt 2 r, ...), queries on lattice points,
  // on cell boundaries (half steps) and on the data points; duplicates of every tenth point.
  std::vector<Vec3> lattice;
  for (int x = 0; x < 20; ++x)
    for (int y = 0; y < 20; ++y)
      for (int z = 0; z < 10; ++z) lattice.push_back(Vec3(float(x), float(y), float(z)) * 0.75f);
  for (size_t i = 0; i < lattice.size(); i += 10) lattice.push_back(lattice[i]);
  std::vector<Vec3> lq;
  for (int i = 0; i < 2000; ++i) {
    const float h = 0.375f;
    lq.push_back(Vec3(float(i % 20), float((i / 20) % 20), float(i % 10)) * 0.75f +
                 (i % 3 == 0 ? Vec3(0.0f) : Vec3(h * float(i % 2), h * float(i % 4 / 2), h)));
  }
  for (const char* spec : {"default", "default:coord_bits=8"}) {
    check_queries(lattice, lq, 0.75f, "lattice", hw::format_from_spec(spec));
    check_queries(lattice, lq, std::nextafter(0.75f, 0.0f), "lattice, radius an ulp short",
                  hw::format_from_spec(spec));
  }
  // Radii near zero (duplicates still found) and near the extent (everything).
  check_queries(lattice, lattice, 1e-30f, "tiny radius", hw::format_preset("default"));
  const std::vector<Vec3> few(u.begin(), u.begin() + 500);
  check_queries(few, uniform(5, 200, 100.0f), 200.0f, "radius beyond the extent", hw::format_preset("default"));
}

TEST_CASE("queries: the output bound, far queries, and refusals", "[queries][errors]") {
  const std::vector<Vec3> u = uniform(1, 5000, 10.0f);
  const hw::PointIndex index(u, 1.0f, hw::format_preset("default"));
  hw::QueryStats s;
  const hw::PointAnswer all = index.query(Vec3(5.0f), {hw::PointQuery::kRadius, 100000}, s);
  REQUIRE(all.count > 20);
  const hw::PointAnswer few = index.query(Vec3(5.0f), {hw::PointQuery::kRadius, 5}, s);
  CHECK(few.overflow);
  CHECK(few.count == all.count);
  CHECK(few.ids.size() == 5);
  CHECK(std::includes(all.ids.begin(), all.ids.end(), few.ids.begin(), few.ids.end()));
  CHECK(s.overflows == 1);
  // A query far beyond the frame's guard range (the ray setup refuses it): no neighbour, no error.
  CHECK(index.query(Vec3(4e18f), {}, s).count == 0);
  CHECK_THROWS_WITH(index.query(Vec3(NAN, 0, 0), {}, s), Catch::Contains("not finite"));
  CHECK_THROWS_WITH(index.query_batch({Vec3(0.0f), Vec3(INFINITY)}, {}, 1, s), Catch::Contains("query 1"));
  CHECK_THROWS_WITH(index.query(Vec3(0.0f), {hw::PointQuery::kNearest, 0}, s), Catch::Contains("k >= 1"));
  CHECK_THROWS_WITH(hw::PointIndex(u, 0.0f, hw::format_preset("default")), Catch::Contains("radius"));
  CHECK_THROWS_WITH(hw::PointIndex(u, NAN, hw::format_preset("default")), Catch::Contains("radius"));
  CHECK_THROWS_WITH(hw::PointIndex({}, 1.0f, hw::format_preset("default")), Catch::Contains("at least one point"));
  std::vector<Vec3> bad = u;
  bad[17].y = INFINITY;
  CHECK_THROWS_WITH(hw::PointIndex(bad, 1.0f, hw::format_preset("default")), Catch::Contains("point 17"));
}
