// The prefetchers behind the fetch-observer seam (timing/prefetch/): the treelet layout and prefetcher, the
// stack prefetcher, and the demand-first prefetch queue (prefetch_queue). Exact cycles worked by hand on a
// one-line-per-node layout, the treelets' invariants on a real BVH, and hits unchanged on the timed device.
#include <catch2/catch.hpp>

#include <algorithm>
#include <memory>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/node_kinds.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/prefetch/treelets.h"
#include "hwmodel/timing/timing_model.h"
#include "timing_checks.h"

using namespace rtu::hw;

namespace {

// Nodes 0..3 one line each at their own index; treelet {0, 1, 2} rooted at 0, treelet {3} at 3.
TimingModel::Layout layout() {
  TimingModel::Layout l;
  l.node_bytes = 64;
  l.record_offset = 1 << 20;
  l.plane_offset = 2 << 20;
  auto t = std::make_shared<Treelets>();
  t->position = {0, 1, 2, 3};
  t->size = {3, 0, 0, 1};
  t->count = 2;
  l.treelets = t;
  return l;
}

TraceEvent node(uint32_t index) {
  return TraceEvent{TraceEvent::kNode, 4, 0, 0, index};
}

// Node 0 pushes nodes 5, 6, 7 (popped in that order); the ray descends to node 1, then pops 5, 6 and 7.
std::vector<TraceEvent> push_then_pop() {
  return {node(0),
          TraceEvent{TraceEvent::kStackRef, 0, 0, 0, 5},
          TraceEvent{TraceEvent::kStackRef, 1, 0, 0, 6},
          TraceEvent{TraceEvent::kStackRef, 2, 0, 0, 7},
          node(1),
          node(5),
          node(6),
          node(7)};
}

uint64_t run(TimingModel& m, std::vector<TraceEvent> ev, TimingStats& s) {
  m.begin(1, s);
  m.feed(&ev, 1);
  return m.finish();
}

}  // namespace

TEST_CASE("a treelet root's fetch fills the treelet: the next nodes hit or wait for their fill", "[timing]") {
  TimingConfig c = test_config();
  const uint64_t line = 64 / 8;
  const uint64_t enter = c.packet_latency + c.ray_fetch_latency + c.setup_latency;
  const uint64_t miss = c.cache_latency + line + c.dram_latency;
  const uint64_t per_node = c.box_latency + c.traversal_latency;  // 4 children: one issue clock
  const std::vector<TraceEvent> ray = {node(0), node(2), node(1)};
  {
    TimingModel m(c, layout());
    TimingStats s;
    CHECK(run(m, ray, s) == enter + 3 * (miss + per_node) + c.writeback_latency);
    CHECK(s.cache_misses == 3);
  }
  set_timing_key(c, "treelet_bytes", "192");
  set_timing_key(c, "prefetcher", "treelet");
  TimingModel m(c, layout());
  TimingStats s;
  // Node 0 misses at `enter`; its line goes over the channel in [enter + 2, + 8), the fills of lines 1 and 2
  // (asked at the same cycle) after it: line 1 there at enter + 2 + 16 + 100, line 2 at enter + 2 + 24 + 100. Node
  // 2's fetch at enter + miss + per_node = enter + 119 finds its line on the way and waits for it; node 1's fetch
  // comes per_node after node 2's data and hits.
  const uint64_t line2_ready = enter + c.cache_latency + 3 * line + c.dram_latency;
  REQUIRE(enter + miss + per_node < line2_ready);
  CHECK(run(m, ray, s) ==
        line2_ready + c.cache_latency + per_node + c.cache_latency + per_node + c.writeback_latency);
  CHECK(s.cache_misses == 1);
  CHECK(s.cache_hits == 2);
  CHECK(s.prefetch_fills == 2);
  CHECK(s.prefetch_useful == 2);
  CHECK(s.prefetch_late == 1);  // node 2's line was on its way; node 1's had arrived
  CHECK(s.prefetch_unused == 0);
  CHECK(s.dram_bytes == 3 * 64);
  // A root whose treelet is itself fills nothing.
  TimingModel m3(c, layout());
  TimingStats s3;
  run(m3, {node(3)}, s3);
  CHECK(s3.prefetch_fills == 0);
  CHECK(s3.prefetch_redundant == 0);
}

TEST_CASE("queued prefetches wait for an idle memory: demand first, a late fill saves what it covered",
          "[timing]") {
  TimingConfig c = test_config();
  set_timing_key(c, "treelet_bytes", "192");
  set_timing_key(c, "prefetcher", "treelet");
  set_timing_key(c, "prefetch_queue", "4");
  const uint64_t line = 64 / 8;
  const uint64_t enter = c.packet_latency + c.ray_fetch_latency + c.setup_latency;
  const uint64_t miss = c.cache_latency + line + c.dram_latency;
  const uint64_t per_node = c.box_latency + c.traversal_latency;
  // Node 0, node 0 again (a hit), then node 1. At node 0's miss the channel is busy with it, so lines 1 and 2
  // wait. At the hit (enter + miss + per_node) the channel is idle: line 1 goes, asked cache_latency later, there
  // at t1 + miss; line 2 waits again (the channel is busy with line 1). Node 1's fetch, cache_latency + per_node
  // after the hit, finds line 1 on its way and waits for it.
  const uint64_t t1 = enter + miss + per_node;
  const uint64_t t2 = t1 + c.cache_latency + per_node;
  const uint64_t fill_ready = t1 + miss;
  REQUIRE(t2 < fill_ready);
  TimingModel m(c, layout());
  TimingStats s;
  CHECK(run(m, {node(0), node(0), node(1)}, s) == fill_ready + c.cache_latency + per_node + c.writeback_latency);
  // Node 1's fetch hits a line on its way, and the channel is idle again by then (line 1 took it for 8 cycles from
  // t1 + 2, and t2 = t1 + 11): line 2 goes at t2, unused.
  REQUIRE(t1 + c.cache_latency + line <= t2);
  CHECK(s.prefetch_fills == 2);
  CHECK(s.prefetch_useful == 1);
  CHECK(s.prefetch_late == 1);
  CHECK(s.prefetch_dropped == 0);
  // Against no prefetcher, node 1's own miss: the fill saved the cycles between its request and node 1's, less
  // the cache_latency of waiting for a line on its way.
  TimingConfig off = test_config();
  TimingModel o(off, layout());
  TimingStats so;
  const uint64_t without = run(o, {node(0), node(0), node(1)}, so);
  CHECK(without == t2 + miss + per_node + c.writeback_latency);
  CHECK(without - (fill_ready + c.cache_latency + per_node + c.writeback_latency) == (t2 - t1) - c.cache_latency);
  // A demand fetch is never delayed by a queued fill: the same ray without the hit in between (no idle channel at
  // a fetch) takes exactly the cycles of no prefetcher, and its fills wait in the queue.
  TimingModel q(c, layout());
  TimingStats sq;
  TimingModel o2(off, layout());
  TimingStats so2;
  CHECK(run(q, {node(0), node(1)}, sq) == run(o2, {node(0), node(1)}, so2));
  CHECK(sq.prefetch_fills == 0);
  // A queue of one line keeps the newest ask: of lines 1 and 2, line 1 is dropped.
  set_timing_key(c, "prefetch_queue", "1");
  TimingModel d(c, layout());
  TimingStats sd;
  run(d, {node(0)}, sd);
  CHECK(sd.prefetch_dropped == 1);
}

TEST_CASE("a prefetched line evicted before any demand hit counts as unused", "[timing]") {
  TimingConfig c = test_config();  // 16 KiB of 64-byte lines, 4 ways: 64 sets
  set_timing_key(c, "prefetcher", "next_line");
  TimingModel::Layout l;
  l.node_bytes = 64;
  l.record_offset = 1 << 20;
  l.plane_offset = 2 << 20;
  // Node 0's miss fills line 1 (set 1). Nodes 65, 129 and 193 take set 1's other ways, and node 257 evicts the
  // least recent, line 1, never used. The other misses fill lines 66, 130, 194 and 258: set 2's four ways, none
  // evicted and none used.
  TimingModel m(c, l);
  TimingStats s;
  run(m, {node(0), node(65), node(129), node(193), node(257)}, s);
  CHECK(s.cache_misses == 5);
  CHECK(s.prefetch_fills == 5);
  CHECK(s.prefetch_useful == 0);
  CHECK(s.prefetch_unused == 1);
}

TEST_CASE("treelets: a permutation of the nodes, connected pieces within the budget", "[timing][image]") {
  const Geometry g = fixed_checks::random_scene(9, 3000, 20);
  for (int width : {2, 4, 8}) {
    FixedFormat f = format_preset("default");
    f.width = width;
    const DeviceImage img = image_checks::encode(g, f);
    const ImageHeader& h = img.header();
    for (uint64_t budget : {uint64_t(1), uint64_t(256), uint64_t(4096)}) {
      CAPTURE(width, budget);
      const uint64_t stride = img.node_bytes();
      const Treelets t = form_treelets(img, budget, stride);
      REQUIRE(t.position.size() == h.node_count);
      std::vector<uint32_t> seen(h.node_count, 0);
      for (uint32_t p : t.position) ++seen[p];
      CHECK(std::count(seen.begin(), seen.end(), 1u) == h.node_count);  // a permutation
      CHECK(t.position[0] == 0);                                        // the root's treelet first
      uint64_t total = 0;
      for (uint32_t n = 0; n < h.node_count; ++n) {
        total += t.size[n];
        CHECK(uint64_t(t.size[n]) * stride <= std::max(budget, stride));
      }
      CHECK(total == h.node_count);
      if (budget == 1) CHECK(t.count == h.node_count);  // one node each
      // Each treelet's positions are consecutive from its root's and connected: every non-root node's parent
      // lies in the same treelet (its position within the treelet's span).
      std::vector<uint32_t> owner(h.node_count, 0);  // position -> root of its treelet
      for (uint32_t n = 0; n < h.node_count; ++n)
        for (uint32_t k = 0; k < t.size[n]; ++k) owner[t.position[n] + k] = n;
      with_node_kind(node_kind(h), h.width, h.q_bytes, [&](auto kind) {
        using K = decltype(kind);
        const auto* nodes = img.nodes<typename K::Node>();
        for (uint32_t n = 0; n < h.node_count; ++n)
          for (int i = 0; i < K::count(nodes[n]); ++i) {
            const uint32_t c = K::child(nodes[n], i);
            if (is_leaf(c) || t.size[c] > 0) continue;  // a leaf, or the root of another treelet
            CHECK(owner[t.position[c]] == owner[t.position[n]]);
          }
      });
    }
  }
}

TEST_CASE("treelet layouts and prefetchers never change a hit, and refuse what they cannot model", "[timing]") {
  std::vector<Ray> rays;
  Pcg32 rng(3);
  for (int i = 0; i < 3000; ++i) {
    Ray r;
    r.origin = Vec3(fixed_checks::rand_float(rng, -1, 1), fixed_checks::rand_float(rng, -1, 1), -3.0f);
    r.dir = Vec3(fixed_checks::rand_float(rng, -0.3f, 0.3f), fixed_checks::rand_float(rng, -0.3f, 0.3f), 1.0f);
    r.tmin = 0.0f;
    r.tmax = 1e30f;
    rays.push_back(r);
  }
  // compact: the packed layout, whose leaves are pushed beside inner nodes (a push's first inner node may have any
  // rank).
  for (const char* format : {"default", "compact"}) {
    const FixedReference ref = fixed_reference(10, rays, format);
    const std::vector<Hit>& want = ref.hits;
    uint64_t cycles[2] = {0, 0};
    for (const char* pf : {"none", "treelet", "next_line", "stack", "stack_pop", "ttp"})
      for (int q : {0, 16}) {
        CAPTURE(format, pf, q);
        TimingConfig c = timing_preset("rdna2-mem");
        set_timing_key(c, "treelet_bytes", "512");
        set_timing_key(c, "prefetcher", pf);
        set_timing_key(c, "prefetch_queue", std::to_string(q));
        for (int threads : {1, 2}) {
          std::vector<Hit> got;
          cycles[threads - 1] = trace_timed(c, ref.bytes, rays, threads, got);
          size_t differ = 0;
          for (size_t i = 0; i < rays.size(); ++i) differ += got[i].prim != want[i].prim || got[i].t != want[i].t;
          CHECK(differ == 0);
        }
        CHECK(cycles[0] == cycles[1]);  // the same cycles on 1 and 2 host threads
      }
  }
  const std::vector<uint8_t> bytes = fixed_reference(10, rays).bytes;
  TimingConfig c = timing_preset("rdna2");
  set_timing_key(c, "prefetcher", "treelet");
  {
    TimedEngine none(EngineOptions{}, c);
    CHECK_THROWS_WITH(none.bind(bytes.data(), bytes.size()), Catch::Contains("needs treelet_bytes > 0"));
  }
  set_timing_key(c, "treelet_bytes", "512");
  TimedEngine timed(EngineOptions{}, c);
  SampleOptions so;
  so.fraction = 0.1;
  CHECK_THROWS_WITH(timed.set_sampling(so), Catch::Contains("warming does not model prefetched lines"));
}

TEST_CASE("a stack prefetch at the push turns the popped node's miss into a hit", "[timing]") {
  TimingConfig c = test_config();
  const uint64_t line = 64 / 8;
  const uint64_t enter = c.packet_latency + c.ray_fetch_latency + c.setup_latency;
  const uint64_t miss = c.cache_latency + line + c.dram_latency;
  const uint64_t per_node = c.box_latency + c.traversal_latency;
  // Node 0, whose test pushes node 5 (rank 0, popped first) and node 6 (rank 1); the ray goes on to node 1, then
  // pops node 5.
  const std::vector<TraceEvent> ray = {node(0), TraceEvent{TraceEvent::kStackRef, 0, 0, 0, 5},
                                       TraceEvent{TraceEvent::kStackRef, 1, 0, 0, 6}, node(1), node(5)};
  TimingModel::Layout l = layout();
  l.treelets.reset();
  const uint64_t t1 = enter + miss + per_node;  // node 0's result: the push, and node 1's fetch
  TimingStats so;
  TimingModel off(c, l);
  CHECK(run(off, ray, so) == t1 + miss + per_node + miss + per_node + c.writeback_latency);
  set_timing_key(c, "prefetcher", "stack");
  TimingModel m(c, l);
  TimingStats s;
  // At t1 the push fills node 5's line first (channel [t1 + 2, + 8), there at t1 + miss); node 1's miss, asked at
  // the same cycle, waits for the channel: there at t1 + 2 + 2 * 8 + 100. Node 5's fetch per_node later hits.
  const uint64_t node1_ready = t1 + c.cache_latency + 2 * line + c.dram_latency;
  const uint64_t t2 = node1_ready + per_node;
  REQUIRE(t1 + miss <= t2);
  CHECK(run(m, ray, s) == t2 + c.cache_latency + per_node + c.writeback_latency);
  CHECK(s.prefetch_fills == 1);  // prefetch_degree 1: rank 1 (node 6) is not filled
  CHECK(s.prefetch_useful == 1);
  CHECK(s.cache_misses == 2);
}

TEST_CASE("a stack prefetch on the second of two pops fills the entry then on top", "[timing]") {
  TimingConfig c = test_config();
  const uint64_t enter = c.packet_latency + c.ray_fetch_latency + c.setup_latency;
  const uint64_t miss = c.cache_latency + 64 / 8 + c.dram_latency;
  const uint64_t per_node = c.box_latency + c.traversal_latency;
  const std::vector<TraceEvent> ray = push_then_pop();
  TimingModel::Layout l = layout();
  l.treelets.reset();
  TimingStats so;
  TimingModel off(c, l);
  const uint64_t without = run(off, ray, so);
  CHECK(without == enter + 5 * (miss + per_node) + c.writeback_latency);
  set_timing_key(c, "prefetcher", "stack_pop");
  TimingModel m(c, l);
  TimingStats s;
  // Node 5 is the first pop (after the descent to node 1): no fill. Node 6 is the second: node 7, then on top, is
  // filled behind node 6's own miss on the channel (there 2 + 16 + 100 after node 6's fetch) and node 7's fetch,
  // miss + per_node after node 6's, hits. The fill saves node 7's miss less the hit's latency.
  CHECK(run(m, ray, s) == without - (miss - c.cache_latency));
  CHECK(s.prefetch_fills == 1);
  CHECK(s.prefetch_useful == 1);
  CHECK(s.prefetch_late == 0);
  CHECK(s.cache_misses == 4);
  // A new ray in the slot starts with an empty stack: one slot, a ray that pushes 5, 6, 7 and ends, then a ray
  // that fetches them. Without the reset, 5 and 6 would be two pops and fill 7.
  c.ray_slots = 1;
  TimingModel m2(c, l);
  TimingStats s2;
  std::vector<std::vector<TraceEvent>> rays = {
      {node(0), TraceEvent{TraceEvent::kStackRef, 0, 0, 0, 5}, TraceEvent{TraceEvent::kStackRef, 1, 0, 0, 6},
       TraceEvent{TraceEvent::kStackRef, 2, 0, 0, 7}},
      {node(5), node(6), node(7)}};
  m2.begin(2, s2);
  m2.feed(rays.data(), 2);
  m2.finish();
  CHECK(s2.prefetch_fills == 0);
}

TEST_CASE("TTP fills 1, 2, 16 entries at consecutive pops, leaves included, each entry once", "[timing]") {
  TimingConfig c = test_config();
  const uint64_t enter = c.packet_latency + c.ray_fetch_latency + c.setup_latency;  // 38
  const uint64_t miss = c.cache_latency + 64 / 8 + c.dram_latency;                  // 110
  const uint64_t per_node = c.box_latency + c.traversal_latency;                    // 9
  const std::vector<TraceEvent> ray = push_then_pop();
  TimingModel::Layout l = layout();
  l.treelets.reset();
  set_timing_key(c, "prefetcher", "ttp");
  TimingModel m(c, l);
  TimingStats s;
  // Node 0 at 38, a miss: nothing on the stack yet. Node 1 at 38 + 119 = 157 is a descent (counter 1): it fills
  // the top entry, node 5, behind its own miss on the channel: ready at 157 + 2 + 16 + 100 = 275; node 1's data at
  // 267, node 5's fetch at 276 hits (data 278). That pop is the second (counter 2): it fills nodes 6 and 7, the
  // channel idle: ready at 276 + 110 = 386 and 394. Node 6 at 278 + 9 = 287, the third pop (16 entries: node 7,
  // already filled, is skipped), waits for its fill: data at 386 + 2 = 388. Node 7 at 397 hits; its result at
  // 399 + 9, the write-back 5 more: 413, against 38 + 5 x 119 + 5 = 638 without.
  CHECK(run(m, ray, s) == 413);
  CHECK(enter + 5 * (miss + per_node) + c.writeback_latency == 638);
  CHECK(s.prefetch_fills == 3);
  CHECK(s.prefetch_useful == 3);
  CHECK(s.prefetch_late == 1);
  CHECK(s.cache_misses == 2);
  // A leaf on the stack: node 0 pushes node 5 and the leaf of records 2 and 3 (popped second). Node 5's visit
  // from the stack is a second pop: it fills the entry then on top, the leaf's record lines; the leaf's first
  // record then hits, and its second record is no visit (no further fill).
  TimingModel::Layout lr = l;
  const std::vector<TraceEvent> leafy = {
      node(0), TraceEvent{TraceEvent::kStackRef, 0, 0, 0, 5}, TraceEvent{TraceEvent::kStackRef, 1, 2, 0, 2},
      node(5), TraceEvent{TraceEvent::kPrim, 0, 0, 0, 2},     TraceEvent{TraceEvent::kPrim, 0, 0, 0, 3}};
  TimingModel ml(c, lr);
  TimingStats sl;
  run(ml, leafy, sl);
  // Records 2 and 3 are 40 bytes each at record_offset (2^20): bytes 80..159 of it, lines 16385 and 16386.
  CHECK(sl.prefetch_fills == 2);
  CHECK(sl.prefetch_useful == 2);
  // One part switched off at a time (ttp_off). Without leaves the leaf is not on the stack: nothing to fill.
  set_timing_key(c, "ttp_off", "leaves");
  TimingModel ml2(c, lr);
  TimingStats sl2;
  run(ml2, leafy, sl2);
  CHECK(sl2.prefetch_fills == 0);
  // Without descents node 1's visit fills nothing and starts no run: node 5 is the first pop (node 6), node 6
  // the second (node 7, the last entry).
  set_timing_key(c, "ttp_off", "descents");
  TimingModel md(c, l);
  TimingStats sd;
  run(md, ray, sd);
  CHECK(sd.prefetch_fills == 2);
  CHECK(sd.cache_misses == 3);  // nodes 0, 1 and 5
  // The key applies to ttp only: another prefetcher beside it is refused.
  CHECK_THROWS_WITH(set_timing_key(c, "prefetcher", "stack_pop"),
                    Catch::Contains("ttp_off applies to prefetcher ttp only"));
}

TEST_CASE("a prefetch buffer keeps fills out of the cache: no pollution, a hit moves the line in", "[timing]") {
  TimingConfig c = test_config();
  c.cache_kib = 1;   // 16 lines of 64 bytes,
  c.cache_ways = 1;  // direct mapped: line 16 evicts line 0
  set_timing_key(c, "prefetcher", "next_line");
  TimingModel::Layout l;
  l.node_bytes = 64;
  l.record_offset = 1 << 20;
  l.plane_offset = 2 << 20;
  const uint64_t enter = c.packet_latency + c.ray_fetch_latency + c.setup_latency;
  const uint64_t miss = c.cache_latency + 64 / 8 + c.dram_latency;
  const uint64_t per_node = c.box_latency + c.traversal_latency;
  // Node 0, node 15, node 0 again. Each miss fills its next line behind its own on the channel, long before the
  // next fetch. Into the cache, node 15's fill (line 16) evicts line 0: node 0 misses again.
  const std::vector<TraceEvent> ray = {node(0), node(15), node(0)};
  TimingModel polluted(c, l);
  TimingStats sp;
  CHECK(run(polluted, ray, sp) == enter + 3 * (miss + per_node) + c.writeback_latency);
  CHECK(sp.cache_misses == 3);
  CHECK(sp.prefetch_unused == 1);  // line 16, evicted unused by node 0's second miss
  // Into a buffer of one line: line 1 goes there, line 16 replaces it (line 1 unused), and node 0 hits.
  set_timing_key(c, "prefetch_buffer", "1");
  TimingModel buffered(c, l);
  TimingStats sb;
  CHECK(run(buffered, ray, sb) ==
        enter + 2 * (miss + per_node) + c.cache_latency + per_node + c.writeback_latency);
  CHECK(sb.cache_misses == 2);
  CHECK(sb.cache_hits == 1);
  CHECK(sb.prefetch_fills == 2);
  CHECK(sb.prefetch_unused == 1);
  CHECK(sb.prefetch_useful == 0);
  // A demand access that finds its line in the buffer: node 0, then node 1 (line 1, filled by node 0's miss) hits
  // in the buffer and moves into the cache; a third access to it hits the cache.
  TimingModel moved(c, l);
  TimingStats sm;
  run(moved, {node(0), node(1), node(1)}, sm);
  CHECK(sm.cache_misses == 1);
  CHECK(sm.cache_hits == 2);
  CHECK(sm.prefetch_useful == 1);
  CHECK(sm.prefetch_late == 0);
}

TEST_CASE("where nothing misses, a prefetcher or a restart trail changes no cycle", "[timing]") {
  // 150 triangles: nodes and records take about 10 KiB, so after a first packet the 64 KiB cache holds all of
  // them and the second packet never misses. A fill of a line the cache holds is redundant and costs nothing
  // (no memory request), and a short stack deeper than any ray's stack never restarts: their overhead here is
  // zero, so the second packet's cycles must equal the baseline's exactly.
  const Geometry g = fixed_checks::random_scene(21, 150, 0);
  const DeviceImage img = image_checks::encode(g, format_preset("default"));
  const std::vector<uint8_t> bytes(img.data(), img.data() + img.size());
  REQUIRE(bytes.size() < 16 * 1024);
  const std::vector<Ray> rays = random_box_rays(4, 2000);
  auto second_packet = [&](const TimingConfig& c, TimingStats& second) {
    TimedEngine timed(EngineOptions{}, c);
    timed.bind(bytes.data(), bytes.size());
    std::vector<Hit> hits(rays.size());
    TraversalStats ts;
    timed.trace_cycles(rays.data(), hits.data(), rays.size(), false, ts, 0, 0);
    const TimingStats first = timed.timing();
    const uint64_t cycles = timed.trace_cycles(rays.data(), hits.data(), rays.size(), false, ts, 0, 0);
    second = timed.timing();
    second.cache_misses -= first.cache_misses;
    second.prefetch_fills -= first.prefetch_fills;
    second.restarts -= first.restarts;
    return cycles;
  };
  TimingConfig base = timing_preset("rdna2");
  base.stack_entries = 64;
  TimingStats sb;
  const uint64_t want = second_packet(base, sb);
  REQUIRE(sb.cache_misses == 0);
  for (const char* lever : {"prefetcher=next_line", "prefetcher=stack", "prefetcher=stack_pop", "prefetcher=ttp",
                            "prefetcher=treelet", "stack_mode=restart"}) {
    CAPTURE(lever);
    TimingConfig c = base;
    const std::string kv = lever;
    set_timing_key(c, kv.substr(0, kv.find('=')), kv.substr(kv.find('=') + 1));
    if (kv == "prefetcher=treelet") set_timing_key(c, "treelet_bytes", "512");
    TimingStats s;
    CHECK(second_packet(c, s) == want);
    CHECK(s.cache_misses == 0);
    CHECK(s.prefetch_fills == 0);
    CHECK(s.restarts == 0);
  }
}
