// What is built on the fixed-point datapath: the device image (every decoded child box contains its subtree's
// records), FixedTracer against FloatTracer (hit/miss agreement, any-hit against closest-hit, thread-count
// independence), and the short-stack recording of a trace, which leaves the timing model's cycles and statistics
// unchanged. Randomized parts print their seed.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/node_kinds.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/scene/geometry.h"
#include "timing_checks.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

namespace {

std::vector<Ray> random_rays(uint64_t seed, int n) {
  Pcg32 rng(seed);
  std::vector<Ray> rays;
  for (int i = 0; i < n; ++i) {
    Ray r;
    for (int a = 0; a < 3; ++a) {
      r.origin[a] = rand_float(rng, -12.0f, 12.0f);
      r.dir[a] = rand_float(rng, -1.0f, 1.0f);
    }
    if (i % 11 == 0) r.dir = Vec3(i % 2 ? -0.0f : 0.0f, 0.0f, i % 3 ? 1.0f : -1.0f);  // signed zeros
    if (r.dir.x == 0.0f && r.dir.y == 0.0f && r.dir.z == 0.0f) r.dir.x = 1.0f;
    r.tmin = 0.0f;
    r.tmax = kInf;
    if (i == 5000) r.dir.y = std::numeric_limits<float>::quiet_NaN();  // invalid rays, counted by reason
    if (i == 7000) r.origin.x = 1e30f;                                 // out of frame (fixed device only)
    rays.push_back(r);
  }
  return rays;
}

using RecordBox = GridBox;  // grid bounds of what lies below a child (format/node_kind.h)

// Walks the image's tree: every decoded child box origin + (q << exp) contains the grid bounds of every record
// below it (a triangle's vertices; a sphere's center -+ radius rounded outward to the grid), offsets fit in k
// bits, boxes stay below 2^(B+1) (the datapath's bound on box planes), and every record is reached once.
template <int N, class Q>
void check_image_boxes(const DeviceImage& img) {
  const ImageHeader& h = img.header();
  const QNode<N, Q>* nodes = img.nodes<QNode<N, Q>>();
  const int F = h.frac_bits;
  std::vector<RecordBox> rec(h.record_count);
  for (uint32_t i = 0; i < h.record_count; ++i) {
    const uint8_t* p = img.record(i);
    if (record_kind(p) == RecordKind::kTriangle) {
      TriangleRecord t;
      std::memcpy(&t, p, sizeof t);
      for (int v = 0; v < 3; ++v) {
        for (int a = 0; a < 3; ++a) {
          rec[i].lo[a] = std::min<int64_t>(rec[i].lo[a], t.v[v][a]);
          rec[i].hi[a] = std::max<int64_t>(rec[i].hi[a], t.v[v][a]);
        }
      }
    } else {
      SphereRecord s;
      std::memcpy(&s, p, sizeof s);
      REQUIRE(s.radius > 0);
      for (int a = 0; a < 3; ++a) {
        rec[i].lo[a] = int64_t(round_shift(Wide(s.center[a]) - s.radius, F, Round::kDown));
        rec[i].hi[a] = int64_t(round_shift(Wide(s.center[a]) + s.radius, F, Round::kUp));
      }
    }
  }
  std::vector<int> seen(h.record_count, 0);
  const int64_t qmax = (int64_t(1) << h.child_bits) - 1, box_limit = int64_t(1) << (h.coord_bits + 1);
  uint64_t boxes = 0;
  std::function<RecordBox(uint32_t)> walk = [&](uint32_t ref) {
    RecordBox all;
    if (is_leaf(ref)) {
      for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) {
        REQUIRE(i < h.record_count);
        ++seen[i];
        all.extend(rec[i]);
      }
      return all;
    }
    REQUIRE(ref < h.node_count);
    const QNode<N, Q>& n = nodes[ref];
    REQUIRE(n.count >= 1);
    REQUIRE(int(n.count) <= N);
    for (int i = 0; i < N; ++i) {
      if (i >= n.count) {
        REQUIRE(n.child[i] == kEmptyChild);
        continue;
      }
      const RecordBox sub = walk(n.child[i]);
      for (int a = 0; a < 3; ++a) {
        REQUIRE(int64_t(n.q[2 * a][i]) <= qmax);
        REQUIRE(int64_t(n.q[2 * a + 1][i]) <= qmax);
        const int64_t lo = int64_t(n.origin[a]) + (int64_t(n.q[2 * a][i]) << n.exp[a]);
        const int64_t hi = int64_t(n.origin[a]) + (int64_t(n.q[2 * a + 1][i]) << n.exp[a]);
        INFO("node " << ref << " child " << i << " axis " << a << " decoded [" << lo << ", " << hi << "] records ["
                     << sub.lo[a] << ", " << sub.hi[a] << "]");
        REQUIRE(lo <= sub.lo[a]);
        REQUIRE(hi >= sub.hi[a]);
        CHECK(lo >= 0);
        CHECK(hi < box_limit);
      }
      ++boxes;
      all.extend(sub);
    }
    return all;
  };
  REQUIRE(h.root_ref != kEmptyChild);
  walk(h.root_ref);
  for (uint32_t i = 0; i < h.record_count; ++i) REQUIRE(seen[i] == 1);
  CHECK(boxes + 1 >= h.node_count);  // every node but the root is some node's child
}

void check_image(const DeviceImage& img) {
  const ImageHeader& h = img.header();
  with_node_kind(node_kind(h), h.width, h.q_bytes, [&](auto kind) {
    using Node = typename decltype(kind)::Node;
    constexpr int N = decltype(kind)::kWidth;
    check_image_boxes<N, std::remove_cvref_t<decltype(Node::q[0][0])>>(img);
  });
}

}  // namespace

TEST_CASE("device image: decoded child boxes contain their records, widths 2/4/6/8, child bits 4/8/12",
          "[fixed][image]") {
  const uint64_t seed = 8;
  INFO("seed " << seed);
  const Geometry g = random_scene(seed, 400, 12);
  for (int width : {2, 4, 6, 8}) {
    BvhBuildParams p;
    p.width = width;
    const Bvh bvh = Bvh::build(g, p);
    for (int k : {4, 8, 12}) {
      FixedFormat f = format_preset("default");
      f.width = width;
      f.child_bits = k;
      INFO("width " << width << " child bits " << k);
      const DeviceImage img = encode_scene(g, f, &bvh);
      const ImageHeader& h = img.header();
      REQUIRE(h.magic == kImageMagic);
      REQUIRE(h.width == width);
      REQUIRE(h.q_bytes == (k <= 8 ? 1 : 2));
      REQUIRE(h.record_count == g.num_bounded());
      REQUIRE(h.plane_count == g.planes.size());
      check_image(img);
    }
  }
}

TEST_CASE("fixed tracer against the float tracer: hits agree, any-hit = closest-hit, thread independence",
          "[fixed][tracer]") {
  const uint64_t seed = 21;
  INFO("seed " << seed);
  const Geometry g = random_scene(seed, 300, 8);
  const std::vector<Ray> rays = random_rays(seed + 1, 20000);
  TracerOptions opt;
  opt.accel = AccelMode::kBvh;
  const FloatTracer ft(g, opt);
  REQUIRE(ft.bvh() != nullptr);
  const FixedFormat f = format_preset("default");
  REQUIRE(ft.bvh()->width() == f.width);
  const DeviceImage img = encode_scene(g, f, ft.bvh());
  FixedTraceOptions fopt;
  fopt.check_boxes = true;
  const FixedTracer xt(img, fopt);

  // Node memory: a default node (4 children, 8-bit offsets) is 56 bytes against the float node's 112, same tree.
  CHECK(double(img.nodes_size()) <= 0.6 * double(ft.bvh()->figures().node_bytes));

  const size_t n = rays.size();
  std::vector<Hit> want(n), got(n), got2(n), any(n);
  TraversalStats fs, s1, s2, sa;
  ft.trace_batch(rays.data(), want.data(), n, false, 1, fs);
  xt.trace_batch(rays.data(), got.data(), n, false, 1, s1);
  xt.trace_batch(rays.data(), got2.data(), n, false, 2, s2);
  xt.trace_batch(rays.data(), any.data(), n, true, 1, sa);

  // Hit/miss: the fixed device sees the scene moved by at most half a grid step (vertices to nearest, sphere
  // centers half a grid.F unit, radii up by less than one), here 2^-25 of the frame (~6e-7 world units), and
  // its tests are exact on those inputs (the box test never culls what the exact test accepts). So a ray can only
  // change hit/miss when it passes within about that distance of a silhouette edge, grazes a sphere, or meets
  // the plane at a comparable angle: with triangles ~1 unit across, ~1e-6 of the rays per silhouette crossed.
  // 99.9% leaves a factor ~100 for rays that cross several silhouettes.
  size_t agree = 0, both_hit = 0, same_prim = 0;
  for (size_t i = 0; i < n; ++i) {
    agree += size_t(got[i].hit() == want[i].hit());
    both_hit += size_t(got[i].hit() && want[i].hit());
    same_prim += size_t(got[i].hit() && got[i].prim == want[i].prim);
  }
  INFO("agree " << agree << " of " << n << ", both hit " << both_hit << ", same primitive " << same_prim);
  CHECK(double(agree) >= 0.999 * double(n));
  CHECK(both_hit * 4 > n);  // the comparison covers many hits
  // The out-of-frame ray (1e30) is invalid on the fixed device only; the NaN ray on both.
  CHECK(s1.invalid_rays == 2);
  CHECK(s1.invalid_by_reason[size_t(RayStatus::kNanDirection)] == 1);
  CHECK(s1.invalid_by_reason[size_t(RayStatus::kOutOfFrame)] == 1);
  CHECK(s1.first_invalid == 5000);
  CHECK(fs.invalid_rays == 1);
  CHECK(s1.box_checks == s1.box_tests);
  CHECK(s1.box_false_negatives == 0);
  CHECK(sa.box_false_negatives == 0);

  // Any-hit finds a hit exactly when closest-hit does: with the interval end at tmax, any-hit's box tests accept a
  // superset of closest-hit's, and both test the same records with the same datapath.
  for (size_t i = 0; i < n; ++i) {
    if (any[i].hit() != got[i].hit()) {
      INFO("ray " << i);
      REQUIRE(any[i].hit() == got[i].hit());
    }
  }
  CHECK(sa.prim_tests <= s1.prim_tests);

  // Thread-count independence: bit-identical hits and identical statistics.
  REQUIRE(std::memcmp(got.data(), got2.data(), n * sizeof(Hit)) == 0);
  CHECK(s1.rays == s2.rays);
  CHECK(s1.hits == s2.hits);
  CHECK(s1.nodes_visited == s2.nodes_visited);
  CHECK(s1.leaves_visited == s2.leaves_visited);
  CHECK(s1.box_tests == s2.box_tests);
  CHECK(s1.prim_tests == s2.prim_tests);
  CHECK(s1.invalid_rays == s2.invalid_rays);
  CHECK(s1.invalid_by_reason == s2.invalid_by_reason);
  CHECK(s1.first_invalid == s2.first_invalid);
  CHECK(s1.first_invalid_reason == s2.first_invalid_reason);
  CHECK(s1.saturations == s2.saturations);
  CHECK(s1.box_checks == s2.box_checks);
  CHECK(s1.box_false_negatives == s2.box_false_negatives);
  CHECK(s1.box_false_positives == s2.box_false_positives);
}

TEST_CASE(
    "width 6: the same hits as widths 4 and 8, fast node kernels equal the reference path, no false negative",
    "[fixed][tracer][bvh]") {
  const uint64_t seed = 41;
  INFO("seed " << seed);
  const Geometry g = random_scene(seed, 2000, 8);
  const std::vector<Ray> rays = random_rays(seed + 1, 20000);
  const size_t n = rays.size();
  std::map<int, std::vector<Hit>> float_hits, fixed_hits;
  for (int width : {4, 6, 8}) {
    INFO("width " << width);
    TracerOptions opt;
    opt.accel = AccelMode::kBvh;
    opt.bvh.width = width;
    const FloatTracer ft(g, opt);
    REQUIRE(ft.bvh() != nullptr);
    REQUIRE(ft.bvh()->width() == width);
    std::vector<Hit>& fh = float_hits[width];
    fh.resize(n);
    TraversalStats fs;
    ft.trace_batch(rays.data(), fh.data(), n, false, 2, fs);

    FixedFormat f = format_preset("default");
    f.width = width;
    const DeviceImage img = encode_scene(g, f, ft.bvh());
    REQUIRE(img.header().width == width);
    CHECK(img.node_bytes() == qnode_bytes(width, 1));  // 76 bytes at width 6
    // Checking every box test exactly takes the reference path (expand_impl); without it the node kernels
    // (box_node.h, AVX-512 where the CPU has it) decide: the same hits and the same work, bit for bit.
    FixedTraceOptions checked;
    checked.check_boxes = true;
    const FixedTracer reference(img, checked), fast(img);
    std::vector<Hit> hr(n);
    std::vector<Hit>& hf = fixed_hits[width];
    hf.resize(n);
    TraversalStats sr, sf;
    reference.trace_batch(rays.data(), hr.data(), n, false, 2, sr);
    fast.trace_batch(rays.data(), hf.data(), n, false, 2, sf);
    REQUIRE(std::memcmp(hr.data(), hf.data(), n * sizeof(Hit)) == 0);
    CHECK(sr.nodes_visited == sf.nodes_visited);
    CHECK(sr.box_tests == sf.box_tests);
    CHECK(sr.prim_tests == sf.prim_tests);
    CHECK(sr.box_checks == sr.box_tests);
    CHECK(sr.box_false_negatives == 0);
    CHECK(sr.hits * 4 > n);  // many hits compared
  }
  // Another tree, the same primitives: the closest t is the same at every width (float: the same primitive tests
  // in another order; fixed: conservative boxes never drop the closest record). The primitive may differ only on
  // an exact tie in t.
  for (int width : {4, 8}) {
    INFO("width 6 against width " << width);
    size_t float_diff = 0, fixed_diff = 0;
    for (size_t i = 0; i < n; ++i) {
      const Hit &a = float_hits[6][i], &b = float_hits[width][i];
      float_diff += a.hit() != b.hit() || (a.hit() && a.t != b.t);
      const Hit &c = fixed_hits[6][i], &d = fixed_hits[width][i];
      fixed_diff += c.hit() != d.hit() || (c.hit() && c.t != d.t);
    }
    CHECK(float_diff == 0);
    CHECK(fixed_diff == 0);
  }
}

TEST_CASE("recording the stack as a short stack sees it: the timing model's cycles and statistics are unchanged",
          "[fixed][timing]") {
  // Binary BVH over 3,000 triangles: random rays reach stack depths well past the short stacks tried below.
  const Geometry g = random_scene(31, 3000, 8);
  const std::vector<Ray> rays = random_rays(32, 4000);
  FixedFormat f = format_preset("default");
  f.width = 2;
  BvhBuildParams bp;
  bp.width = 2;
  const Bvh bvh = Bvh::build(g, bp);
  const DeviceImage img = encode_scene(g, f, &bvh);
  TimingModel::Layout l;
  l.node_offset = img.header().node_offset;
  l.node_bytes = img.node_bytes();
  l.record_offset = img.header().record_offset;
  l.plane_offset = img.header().plane_offset;
  const FixedTracer raw(img);
  for (int se : {1, 2, 3, 8}) {
    INFO("short stack " << se);
    FixedTraceOptions o;
    o.record_short_stack = se;
    const FixedTracer filtered(img, o);
    std::vector<std::vector<TraceEvent>> ev_raw(rays.size()), ev_short(rays.size());
    uint64_t spill_events = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      TraversalStats s1, s2;
      const Hit a = raw.trace_recorded(rays[i], false, s1, ev_raw[i]);
      const Hit b = filtered.trace_recorded(rays[i], false, s2, ev_short[i]);
      REQUIRE(std::memcmp(&a, &b, sizeof(Hit)) == 0);
      // The same node, record and plane events in the same order; no push or pop left; the spills and refills
      // where the raw stream's depth passes the short stack.
      std::vector<TraceEvent> expect;
      int depth = 0;
      for (const TraceEvent& e : ev_raw[i]) {
        if (e.kind == TraceEvent::kPush) {
          int over = 0;
          for (int j = 0; j < e.count; ++j) over += ++depth > se;
          if (over > 0) expect.push_back(TraceEvent{TraceEvent::kSpill, uint8_t(over), 0, 0, 0});
        } else if (e.kind == TraceEvent::kPop) {
          if (depth-- > se) expect.push_back(TraceEvent{TraceEvent::kRefill, 0, 0, 0, 0});
        } else {
          expect.push_back(e);
        }
      }
      REQUIRE(expect.size() == ev_short[i].size());
      REQUIRE(std::memcmp(expect.data(), ev_short[i].data(), expect.size() * sizeof(TraceEvent)) == 0);
      for (const TraceEvent& e : ev_short[i]) spill_events += e.kind == TraceEvent::kSpill;
    }
    if (se <= 3) CHECK(spill_events > 100);  // the spill path is exercised
    TimingConfig c = timing_preset("rdna2");
    c.stack_entries = se;
    c.ray_slots = 16;
    TimingStats t1, t2;
    TimingModel m1(c, l), m2(c, l);
    m1.begin(rays.size(), t1);
    m1.feed(ev_raw.data(), rays.size());
    const uint64_t c1 = m1.finish();
    m2.begin(rays.size(), t2);
    m2.feed(ev_short.data(), rays.size());
    const uint64_t c2 = m2.finish();
    CHECK(c1 == c2);
    check_same_timing(t1, t2);
    if (se <= 3) CHECK(t1.stack_spills > 0);
  }
}
