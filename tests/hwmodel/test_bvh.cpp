// BVH builder invariants and BVH traversal against brute force.
#include <catch2/catch.hpp>

#include <cstring>
#include <random>

#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/traverse.h"

using namespace rtu::hw;

namespace {

Geometry random_soup(uint32_t seed, int tris, int spheres) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-10.0f, 10.0f), off(-0.6f, 0.6f), rad(0.05f, 0.5f);
  Geometry g;
  for (int i = 0; i < tris; ++i) {
    Vec3 c(pos(rng), pos(rng), pos(rng));
    g.triangles.push_back({c + Vec3(off(rng), off(rng), off(rng)), c + Vec3(off(rng), off(rng), off(rng)),
                           c + Vec3(off(rng), off(rng), off(rng))});
  }
  for (int i = 0; i < spheres; ++i) g.spheres.push_back({Vec3(pos(rng), pos(rng), pos(rng)), rad(rng)});
  return g;
}

std::vector<Ray> random_rays(uint32_t seed, int n, float extent) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-extent, extent), dir(-1.0f, 1.0f);
  std::vector<Ray> rays;
  for (int i = 0; i < n; ++i) {
    Vec3 d(dir(rng), dir(rng), dir(rng));
    if (i % 7 == 0) d = Vec3(0.0f, i % 2 ? -0.0f : 0.0f, 1.0f);  // axis-parallel with signed zeros
    rays.push_back({Vec3(pos(rng), pos(rng), pos(rng)), 0.0f, d, std::numeric_limits<float>::infinity()});
  }
  return rays;
}

template <int N>
void check_invariants(const WideBvh<N>& t, const Geometry& g, const BvhBuildParams& p) {
  std::vector<int> seen(g.num_bounded(), 0);
  struct Item {
    uint32_t ref;
    Aabb box;
  };
  std::vector<Item> stack{{t.root_ref, t.bounds}};
  while (!stack.empty()) {
    Item it = stack.back();
    stack.pop_back();
    if (is_leaf(it.ref)) {
      REQUIRE(int(leaf_count(it.ref)) <= p.max_leaf_size);
      for (uint32_t i = leaf_first(it.ref); i < leaf_first(it.ref) + leaf_count(it.ref); ++i) {
        const uint32_t prim = t.prim_ids.at(i);
        ++seen.at(prim);
        REQUIRE(it.box.contains(g.prim_bounds(prim)));
      }
      continue;
    }
    const WideNode<N>& n = t.nodes.at(it.ref);
    int used = 0;
    for (int i = 0; i < N; ++i) {
      if (n.child[i] == kEmptyChild) continue;
      ++used;
      REQUIRE(it.box.contains(n.child_box(i)));
      stack.push_back({n.child[i], n.child_box(i)});
    }
    REQUIRE(used >= 2);
  }
  for (int s : seen) REQUIRE(s == 1);
}

}  // namespace

TEST_CASE("BVH: every primitive in exactly one leaf, boxes nest, widths 2/4/6/8", "[bvh]") {
  const Geometry g = random_soup(7, 3000, 200);
  for (int width : {2, 4, 6, 8}) {
    for (int leaf : {1, 4, 16}) {
      BvhBuildParams p;
      p.width = width;
      p.max_leaf_size = leaf;
      const Bvh b = Bvh::build(g, p);
      REQUIRE(b.width() == width);
      b.visit([&](const auto& t) { check_invariants(t, g, p); });
      const BvhFigures f = b.figures();
      CHECK(f.prims == g.num_bounded());
      CHECK(f.max_leaf <= leaf);
      CHECK(f.sah_cost > 0.0);
      CHECK(f.sah_cost < double(g.num_bounded()));  // far cheaper than testing everything
    }
  }
}

TEST_CASE("BVH: the collapse fills nodes of every width, 6 (not a power of two) too", "[bvh]") {
  // A node is full, or every child it holds is a leaf (nothing was left to expand); occupied slots come first.
  const Geometry g = random_soup(13, 4000, 100);
  uint64_t prev_nodes = 0;
  for (int width : {8, 6, 4}) {
    BvhBuildParams p;
    p.width = width;
    p.max_leaf_size = 4;
    const Bvh b = Bvh::build(g, p);
    REQUIRE(b.width() == width);
    uint64_t full = 0, partial = 0;
    b.visit([&](const auto& t) {
      constexpr int N = std::decay_t<decltype(t)>::kWidth;
      for (const WideNode<N>& n : t.nodes) {
        int used = 0;
        bool all_leaves = true;
        for (int i = 0; i < N; ++i) {
          if (n.child[i] == kEmptyChild) continue;
          REQUIRE(used == i);  // no gap before an occupied slot
          ++used;
          all_leaves = all_leaves && is_leaf(n.child[i]);
        }
        if (used == N) {
          ++full;
        } else {
          ++partial;
          REQUIRE(all_leaves);
        }
      }
    });
    INFO("width " << width << ": " << full << " full and " << partial << " partial nodes");
    CHECK(full > 0);
    // Wider nodes absorb more binary nodes: fewer of them.
    const BvhFigures f = b.figures();
    CHECK(f.inner_nodes > prev_nodes);
    prev_nodes = f.inner_nodes;
  }
}

TEST_CASE("BVH build is deterministic", "[bvh]") {
  const Geometry g = random_soup(11, 5000, 0);
  const Bvh a = Bvh::build(g), b = Bvh::build(g);
  const BvhFigures fa = a.figures(), fb = b.figures();
  CHECK(fa.inner_nodes == fb.inner_nodes);
  CHECK(fa.sah_cost == fb.sah_cost);
  a.visit([&](const auto& ta) {
    b.visit([&](const auto& tb) {
      if constexpr (std::is_same_v<decltype(ta), decltype(tb)>) {
        REQUIRE(ta.prim_ids == tb.prim_ids);
        REQUIRE(ta.nodes.size() == tb.nodes.size());
        REQUIRE(std::memcmp(ta.nodes.data(), tb.nodes.data(), ta.nodes.size() * sizeof(ta.nodes[0])) == 0);
      }
    });
  });
}

TEST_CASE("BVH depth stays bounded on degenerate input", "[bvh]") {
  Geometry g;
  // 5000 identical triangles (no SAH split possible) and a geometric series (SAH peels one at a time).
  for (int i = 0; i < 5000; ++i) g.triangles.push_back({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
  for (int i = 0; i < 200; ++i) {
    const float x = std::ldexp(1.0f, -i / 2);
    g.triangles.push_back({{x, 0, 0}, {x * 1.0001f, 0, 0}, {x, x * 1e-3f, 0}});
  }
  for (int width : {2, 6, 8}) {
    BvhBuildParams p;
    p.width = width;
    const Bvh b = Bvh::build(g, p);
    const BvhFigures f = b.figures();
    CHECK(f.depth <= p.max_sah_depth + 27);
    CHECK(f.depth * (width - 1) + 1 <= kTraversalStackSize);
    b.visit([&](const auto& t) { check_invariants(t, g, p); });
  }
}

TEST_CASE("BVH traversal equals brute force, closest and any hit, every width", "[bvh][float]") {
  const Geometry g = random_soup(3, 4000, 300);
  const std::vector<Ray> rays = random_rays(5, 20000, 12.0f);
  TracerOptions brute_opt;
  brute_opt.accel = AccelMode::kBrute;
  const FloatTracer brute(g, brute_opt);
  REQUIRE_FALSE(brute.uses_bvh());
  std::vector<Hit> want(rays.size());
  TraversalStats bs;
  brute.trace_batch(rays.data(), want.data(), rays.size(), false, 1, bs);
  CHECK(bs.prim_tests == uint64_t(rays.size()) * g.num_bounded());
  for (int width : {2, 4, 6, 8}) {
    TracerOptions opt;
    opt.accel = AccelMode::kBvh;
    opt.bvh.width = width;
    const FloatTracer bvh(g, opt);
    REQUIRE(bvh.uses_bvh());
    std::vector<Hit> got(rays.size());
    TraversalStats s;
    bvh.trace_batch(rays.data(), got.data(), rays.size(), false, 2, s);
    int mismatches = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      // Same primitive tests in another order: the closest t is the same float; the primitive may differ
      // only on an exact tie in t.
      if (got[i].t != want[i].t && !(std::isinf(got[i].t) && std::isinf(want[i].t))) ++mismatches;
    }
    CHECK(mismatches == 0);
    CHECK(s.prim_tests * 20 < bs.prim_tests);  // the BVH must actually cull
    CHECK(s.box_tests > 0);
    CHECK(s.hits == bs.hits);

    std::vector<Hit> any(rays.size());
    TraversalStats as;
    bvh.trace_batch(rays.data(), any.data(), rays.size(), true, 1, as);
    for (size_t i = 0; i < rays.size(); ++i) REQUIRE(any[i].hit() == want[i].hit());
    CHECK(as.prim_tests <= s.prim_tests);
  }
}

TEST_CASE("statistics and hits do not depend on the thread count", "[bvh][float]") {
  const Geometry g = random_soup(9, 2000, 50);
  const std::vector<Ray> rays = random_rays(10, 30000, 12.0f);
  const FloatTracer t(g);
  std::vector<Hit> h1(rays.size()), h2(rays.size());
  TraversalStats s1, s2;
  t.trace_batch(rays.data(), h1.data(), rays.size(), false, 1, s1);
  t.trace_batch(rays.data(), h2.data(), rays.size(), false, 2, s2);
  REQUIRE(std::memcmp(h1.data(), h2.data(), h1.size() * sizeof(Hit)) == 0);
  CHECK(s1.nodes_visited == s2.nodes_visited);
  CHECK(s1.box_tests == s2.box_tests);
  CHECK(s1.prim_tests == s2.prim_tests);
}

TEST_CASE("tiny scenes use brute force automatically, planes stay out of the BVH", "[bvh][float]") {
  Geometry g;
  g.triangles.push_back({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
  g.spheres.push_back({{0, 0, -3}, 1.0f});
  g.planes.push_back({{0, 1, 0}, -2.0f});
  const FloatTracer t(g);
  CHECK_FALSE(t.uses_bvh());
  TraversalStats s;
  Hit h = t.trace(Ray{{0.25f, 0.25f, 5}, 0.0f, {0, 0, -1}, 1e30f}, false, s);
  CHECK(h.prim == 0);
  CHECK(h.t == 5.0f);  // exact: every intermediate is a small dyadic rational
  h = t.trace(Ray{{0, 0, 5}, 0.0f, {0, -1, -2}, 1e30f}, false, s);
  CHECK(h.prim == 2);  // plane y = -2 at t = 2 (the sphere and triangle are missed)
  CHECK(h.t == 2.0f);
  CHECK(s.nodes_visited == 0);

  CHECK(s.prim_tests == 2 * 3);  // brute force: every primitive, planes included, for each ray

  // Just over one leaf, but spread out: the SAH decides.
  CHECK(FloatTracer(random_soup(1, 500, 0)).uses_bvh());
  Geometry pair;
  for (int i = 0; i < 12; ++i) pair.triangles.push_back({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
  const FloatTracer stacked(pair);  // 12 coincident triangles: no split can cull anything
  CHECK_FALSE(stacked.uses_bvh());
  CHECK(stacked.bvh_cost() >= stacked.brute_cost());
}

TEST_CASE("invalid rays miss and are counted by reason", "[float][ray]") {
  const Geometry g = random_soup(2, 100, 0);
  const FloatTracer t(g);
  TraversalStats s;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Hit h = t.trace(Ray{{nan, 0, 0}, 0.0f, {1, 0, 0}, 1e30f}, false, s);
  CHECK_FALSE(h.hit());
  CHECK(std::isinf(h.t));
  t.trace(Ray{{0, 0, 0}, 0.0f, {0, 0, 0}, 1e30f}, false, s);
  CHECK(s.invalid_rays == 2);
  CHECK(s.rays == 0);
  CHECK(s.invalid_by_reason[size_t(RayStatus::kNanOrigin)] == 1);
  CHECK(s.invalid_by_reason[size_t(RayStatus::kZeroDirection)] == 1);
}
