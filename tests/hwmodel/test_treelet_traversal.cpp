// Treelet-first order (traversal = treelet_first, datapath/traverse.h): the events of a small tree worked by
// hand, each treelet finished before the ray leaves it, one treelet holding the tree giving depth-first's events
// bit for bit, the nodes of a ray that hits nothing the same, hits the same but for equal-t ties, and the timed
// device's hits and cycles the same on 1 and 2 host threads.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <map>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/node_kinds.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/prefetch/treelets.h"
#include "image_checks.h"
#include "timing_checks.h"

using namespace rtu::hw;

namespace {

FixedTraceOptions treelet_order(const Treelets& t, int short_stack) {
  FixedTraceOptions o;
  o.record_short_stack = short_stack;
  o.treelets = TreeletMap{t.id.data(), uint32_t(t.id.size())};
  return o;
}

// Four triangles in the planes x = 0, 10, 20, 30, one a leaf, in a binary tree (the root, A over the first two, B
// over the last two; the tests REQUIRE its three nodes).
DeviceImage four_triangle_tree() {
  Geometry g;
  for (float x : {0.0f, 10.0f, 20.0f, 30.0f})
    g.triangles.push_back({Vec3(x, 0.0f, 0.0f), Vec3(x, 1.0f, 0.0f), Vec3(x, 0.0f, 1.0f)});
  FixedFormat f = format_preset("default");
  f.width = 2;
  return image_checks::encode(g, f, 1);
}

std::vector<uint8_t> kinds(const std::vector<TraceEvent>& ev) {
  std::vector<uint8_t> out;
  for (const TraceEvent& e : ev) out.push_back(e.kind);
  return out;
}

}  // namespace

TEST_CASE("treelet-first order on a tree worked by hand: the other treelets' stack spills first",
          "[fixed][timing]") {
  // Four triangles in the planes x = 0, 10, 20, 30, one a leaf; a binary tree: the root, node A over the first
  // two, node B over the last two. The ray runs along x inside every box and misses every triangle (y + z > 1),
  // so nothing is culled and both orders visit everything.
  const DeviceImage img = four_triangle_tree();
  REQUIRE(img.header().node_count == 3);
  Ray r;
  r.origin = Vec3(-5.0f, 0.9f, 0.9f);
  r.dir = Vec3(1.0f, 0.0f, 0.0f);
  r.tmin = 0.0f;
  r.tmax = 1e30f;
  // One node a treelet (a budget of one byte): the root's children A and B are both in other treelets.
  const Treelets t = form_treelets(img, 1, img.node_bytes());
  REQUIRE(t.count == 3);
  using E = TraceEvent;
  std::vector<TraceEvent> dfs, tf;
  TraversalStats s1, s2;
  const Hit a = FixedTracer(img,
                            [] {
                              FixedTraceOptions o;
                              o.record_short_stack = 1;
                              return o;
                            }())
                    .trace_recorded(r, false, s1, dfs);
  const Hit b = FixedTracer(img, treelet_order(t, 1)).trace_recorded(r, false, s2, tf);
  CHECK(a.prim == kMissPrim);
  CHECK(b.prim == kMissPrim);
  // Depth-first with a one-entry short stack: the root pushes B (1 entry) and descends to A; A pushes its far
  // leaf (2 entries: one spilled) and tests the near one; the pop of the far leaf reads the spilled entry back;
  // the pop of B is within the short stack; B pushes its far leaf (1 entry) and tests the near one, then the far.
  CHECK(kinds(dfs) == std::vector<uint8_t>{E::kNode, E::kNode, E::kSpill, E::kPrim, E::kRefill, E::kPrim, E::kNode,
                                           E::kPrim, E::kPrim});
  // Treelet-first: the root's children go to the other treelets' stack, B then A (2 entries: one spilled); the
  // ray takes A from it (the spilled entry read back) and is in A's treelet; A's leaves are its treelet's: the
  // near one tested, the far one pushed on the treelet's own stack (1 entry) and popped; then B from the other
  // stack (within its short stack), whose leaves go as A's did.
  CHECK(kinds(tf) == std::vector<uint8_t>{E::kNode, E::kSpill, E::kRefill, E::kNode, E::kPrim, E::kPrim, E::kNode,
                                          E::kPrim, E::kPrim});
  CHECK(s1.nodes_visited == 3);
  CHECK(s2.nodes_visited == 3);
  CHECK(s1.leaves_visited == 4);
  CHECK(s2.leaves_visited == 4);
  // Node order the same here: root, A (nearer), B.
  std::vector<uint32_t> n1, n2;
  for (const TraceEvent& e : dfs)
    if (e.kind == E::kNode) n1.push_back(e.index);
  for (const TraceEvent& e : tf)
    if (e.kind == E::kNode) n2.push_back(e.index);
  CHECK(n1 == n2);
  // With two entries a stack nothing spills in either order.
  std::vector<TraceEvent> tf2;
  TraversalStats s3;
  (void)FixedTracer(img, treelet_order(t, 2)).trace_recorded(r, false, s3, tf2);
  CHECK(kinds(tf2) == std::vector<uint8_t>{E::kNode, E::kNode, E::kPrim, E::kPrim, E::kNode, E::kPrim, E::kPrim});
}

TEST_CASE("treelet-first order: a treelet finished before the ray leaves it, hits the same but for ties",
          "[fixed][timing]") {
  const Geometry g = fixed_checks::random_scene(31, 3000, 8);
  const std::vector<Ray> rays = image_checks::rays(33, 3000);
  for (int width : {2, 4, 8}) {
    FixedFormat f = format_preset("default");
    f.width = width;
    const DeviceImage img = image_checks::encode(g, f);
    const uint64_t stride = img.node_bytes();
    FixedTraceOptions plain;
    plain.record_short_stack = -1;
    const FixedTracer dfs(img, plain);
    for (uint64_t budget : {uint64_t(1), uint64_t(512), uint64_t(2048), uint64_t(1) << 40}) {
      CAPTURE(width, budget);
      const Treelets t = form_treelets(img, budget, stride);
      const FixedTracer tf(img, treelet_order(t, -1));
      uint64_t ties = 0, misses = 0, runs = 0;
      std::vector<TraceEvent> e1, e2;
      for (const Ray& r : rays) {
        TraversalStats s1, s2;
        e1.clear();
        e2.clear();
        const Hit a = dfs.trace_recorded(r, false, s1, e1);
        const Hit b = tf.trace_recorded(r, false, s2, e2);
        // The same t always; the same primitive unless another was hit at that t.
        REQUIRE(a.t == b.t);
        if (a.prim != b.prim) ++ties;
        if (budget == uint64_t(1) << 40) {  // one treelet: depth-first's events, bit for bit
          REQUIRE(e1.size() == e2.size());
          REQUIRE(std::memcmp(e1.data(), e2.data(), e1.size() * sizeof(TraceEvent)) == 0);
        }
        std::vector<uint32_t> n1, n2;
        for (const TraceEvent& e : e1)
          if (e.kind == TraceEvent::kNode) n1.push_back(e.index);
        for (const TraceEvent& e : e2)
          if (e.kind == TraceEvent::kNode) n2.push_back(e.index);
        if (a.prim == kMissPrim) {  // nothing culls: the same nodes, in another order
          ++misses;
          std::vector<uint32_t> s1n = n1, s2n = n2;
          std::sort(s1n.begin(), s1n.end());
          std::sort(s2n.begin(), s2n.end());
          REQUIRE(s1n == s2n);
        }
        // Each treelet's nodes in one run of the visits: once left, a treelet is never entered again.
        std::map<uint32_t, bool> left;
        for (size_t i = 0; i < n2.size(); ++i) {
          const uint32_t id = t.id[n2[i]];
          REQUIRE(!left[id]);
          if (i + 1 < n2.size() && t.id[n2[i + 1]] != id) {
            left[id] = true;
            ++runs;
          }
        }
      }
      CHECK(misses > 300);
      if (budget < 2048) CHECK(runs > rays.size());  // rays do cross treelets
      // Random triangles in general position: no two hit at the same t.
      CHECK(ties == 0);
    }
  }
}

TEST_CASE("traversal treelet_first on the timed device: the fixed hits but for ties, the same cycles on threads",
          "[timing]") {
  const std::vector<Ray> rays = random_box_rays(5, 2000);
  const FixedReference ref = fixed_reference(12, rays);
  for (const char* pf : {"none", "treelet"}) {
    CAPTURE(pf);
    TimingConfig c = timing_preset("rdna2-mem");
    set_timing_key(c, "treelet_bytes", "512");
    set_timing_key(c, "prefetcher", pf);
    set_timing_key(c, "traversal", "treelet_first");
    uint64_t cycles[2] = {0, 0};
    TimingStats ts[2];
    for (int threads : {1, 2}) {
      std::vector<Hit> got;
      cycles[threads - 1] = trace_timed(c, ref.bytes, rays, threads, got, &ts[threads - 1]);
      size_t differ = 0;
      for (size_t i = 0; i < rays.size(); ++i)
        differ += got[i].prim != ref.hits[i].prim || got[i].t != ref.hits[i].t;
      CHECK(differ == 0);
    }
    CHECK(cycles[0] == cycles[1]);
    check_same_timing(ts[0], ts[1]);
  }
  // Refused where it cannot be modelled.
  const std::vector<uint8_t>& bytes = ref.bytes;
  TimingConfig c = timing_preset("rdna2");
  set_timing_key(c, "traversal", "treelet_first");
  {
    TimedEngine none(EngineOptions{}, c);
    CHECK_THROWS_WITH(none.bind(bytes.data(), bytes.size()), Catch::Contains("needs treelet_bytes > 0"));
  }
  set_timing_key(c, "treelet_bytes", "512");
  for (const char* key : {"stack_mode=restart", "prefetcher=ttp", "prefetcher=stack_pop"}) {
    CAPTURE(key);
    TimingConfig d = c;
    const std::string k(key);
    const size_t eq = k.find('=');
    CHECK_THROWS_WITH(set_timing_key(d, k.substr(0, eq), k.substr(eq + 1)),
                      Catch::Contains("treelet_first keeps two stacks"));
  }
}

TEST_CASE("child_order slot: a node's children in slot order, the same t as nearest-first", "[fixed][timing]") {
  // The four-triangle tree above (A over x = 0 and 10, B over 20 and 30), rays along +x and along -x through every
  // box, missing every triangle.
  const DeviceImage img = four_triangle_tree();
  REQUIRE(img.header().node_count == 3);
  uint32_t slot[2] = {0, 0};
  with_node_kind(node_kind(img.header()), 2, img.header().q_bytes, [&](auto kind) {
    using K = decltype(kind);
    const auto& root = img.nodes<typename K::Node>()[img.header().root_ref];
    for (int i = 0; i < 2; ++i) slot[i] = K::child(root, i);
  });
  auto nodes = [&](bool slot_order, float from, float dx) {
    Ray r;
    r.origin = Vec3(from, 0.9f, 0.9f);
    r.dir = Vec3(dx, 0.0f, 0.0f);
    r.tmin = 0.0f;
    r.tmax = 1e30f;
    FixedTraceOptions o;
    o.slot_order = slot_order;
    std::vector<TraceEvent> ev;
    TraversalStats s;
    (void)FixedTracer(img, o).trace_recorded(r, false, s, ev);
    std::vector<uint32_t> n;
    for (const TraceEvent& e : ev)
      if (e.kind == TraceEvent::kNode) n.push_back(e.index);
    return n;
  };
  const uint32_t root = img.header().root_ref;
  const std::vector<uint32_t> slots = {root, slot[0], slot[1]};
  // Nearest first: the forward ray (from x = -5) takes A first, the reversed ray (from x = 35) takes B first.
  const std::vector<uint32_t> fwd = nodes(false, -5.0f, 1.0f), rev = nodes(false, 35.0f, -1.0f);
  REQUIRE(fwd.size() == 3);
  REQUIRE(rev.size() == 3);
  CHECK(fwd[1] == rev[2]);
  CHECK(fwd[2] == rev[1]);
  CHECK(fwd[1] != fwd[2]);
  // Slot order: the same for both rays, the root's slots in order, so different from one of the two above.
  CHECK(nodes(true, -5.0f, 1.0f) == slots);
  CHECK(nodes(true, 35.0f, -1.0f) == slots);
  CHECK((fwd != slots || rev != slots));
  // On the soup: every t the same, in both traversal orders.
  const Geometry soup = fixed_checks::random_scene(31, 3000, 8);
  const std::vector<Ray> rays = image_checks::rays(35, 2000);
  const DeviceImage simg = image_checks::encode(soup, format_preset("default"));
  const Treelets t = form_treelets(simg, 512, simg.node_bytes());
  FixedTraceOptions so;
  so.slot_order = true;
  FixedTraceOptions tso = treelet_order(t, 8);
  tso.slot_order = true;
  const FixedTracer a(simg), b(simg, so), c(simg, tso);
  size_t differ = 0;
  for (const Ray& ray : rays) {
    TraversalStats s1, s2, s3;
    const Hit h1 = a.trace(ray, false, s1), h2 = b.trace(ray, false, s2), h3 = c.trace(ray, false, s3);
    REQUIRE(h1.t == h2.t);
    REQUIRE(h1.t == h3.t);
    differ += h1.prim != h2.prim || h1.prim != h3.prim;
  }
  CHECK(differ == 0);  // no two soup triangles hit at the same t
}
