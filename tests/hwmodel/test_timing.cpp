// The timing model (hwmodel/device/timed_engine.h): exact cycles of microbenchmarks built from synthetic datapath
// events, feeding in chunks changes nothing, and the timed engine's hits are the fixed device's bit for bit.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cstring>
#include <memory>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/scene/bvh.h"
#include "timing_checks.h"

using rtu::hw::TimingConfig;
using rtu::hw::TimingModel;
using rtu::hw::TimingStats;
using rtu::hw::TraceEvent;

namespace {

TimingModel::Layout layout() {
  TimingModel::Layout l;
  l.node_offset = 0;
  l.node_bytes = 64;  // one line per node
  l.record_offset = 1 << 20;
  l.plane_offset = 2 << 20;
  return l;
}

TraceEvent node(uint32_t index, uint8_t children) {
  return TraceEvent{TraceEvent::kNode, children, 0, 0, index};
}
TraceEvent tri(uint32_t record) {
  return TraceEvent{TraceEvent::kPrim, uint8_t(rtu::hw::RecordKind::kTriangle), 0, 0, record};
}

// Ray i of a sweep: fetches of the top of a tree (16 hot nodes) and of a window of 600 nodes drifting by 2 per
// ray, as camera rays sweeping an image make, and a triangle; x is the generator's state.
std::vector<TraceEvent> sweep_ray(uint32_t& x, int i) {
  std::vector<TraceEvent> ev;
  for (int j = 0; j < 4; ++j) {
    x = x * 1664525u + 1013904223u;
    ev.push_back(node(x % 16, 4));
    ev.push_back(node(uint32_t(16 + 2 * i + int(x >> 8) % 600), 4));
  }
  ev.push_back(tri(uint32_t(3 * i + (x >> 20) % 64)));
  return ev;
}

uint64_t run(TimingModel& m, std::vector<std::vector<TraceEvent>> rays, TimingStats& s, size_t chunk = 0) {
  m.begin(rays.size(), s);  // a copy: feed() takes the event lists
  if (chunk == 0) chunk = rays.size();
  for (size_t i = 0; i < rays.size(); i += chunk) m.feed(rays.data() + i, std::min(chunk, rays.size() - i));
  return m.finish();
}

}  // namespace

TEST_CASE("one ray through an empty unit takes the sum of its stage latencies", "[timing]") {
  const TimingConfig c = test_config();
  TimingModel m(c, layout());
  TimingStats s;
  const uint64_t cycles = run(m, {{node(0, 4), tri(0)}}, s);
  const uint64_t line = 64 / 8;  // cycles to transfer a line
  const uint64_t miss = c.cache_latency + line + c.dram_latency;
  const uint64_t expected = c.packet_latency + c.ray_fetch_latency + c.setup_latency  // into a slot
                            + miss + c.box_latency + c.traversal_latency              // node: fetch, box unit
                            + miss + c.tri_latency + c.traversal_latency              // record, triangle unit
                            + c.writeback_latency;
  CHECK(cycles == expected);
  CHECK(s.cache_misses == 2);
  CHECK(s.box_tests == 4);
  CHECK(s.tri_tests == 1);
  CHECK(s.dram_bytes == 128);

  // The same ray again: both lines hit now.
  TimingStats s2;
  const uint64_t again = run(m, {{node(0, 4), tri(0)}}, s2);
  CHECK(again == expected - 2 * (line + c.dram_latency));
  CHECK(s2.cache_hits == 2);
}

TEST_CASE("a box-bound stream reaches the box unit's rate", "[timing]") {
  // One box unit testing one box per clock, nodes of 4 children: 4 clocks per ray. Rays enter at one per clock
  // and the node hits in the cache after the first ray, so from the first box issue on the unit never idles:
  // the last ray's box issue is exactly 4 (N - 1) clocks after the first.
  TimingConfig c = test_config();
  c.box_rate = 1;
  TimingModel m(c, layout());
  const size_t n = 1000;
  std::vector<std::vector<TraceEvent>> rays(n, std::vector<TraceEvent>{node(0, 4)});
  TimingStats s;
  const uint64_t cycles = run(m, rays, s);
  const uint64_t first_issue =
      c.packet_latency + c.ray_fetch_latency + c.setup_latency + c.cache_latency + 8 + c.dram_latency;
  const uint64_t expected =
      first_issue + 4 * (n - 1) + (c.box_latency + 3) + c.traversal_latency + c.writeback_latency;
  CHECK(cycles == expected);  // not done a clock earlier
  CHECK(s.box_issue_cycles == 4 * n);
  CHECK(s.cache_misses == 1);
}

TEST_CASE("a DRAM-bound stream reaches the configured bandwidth", "[timing]") {
  // No cache, every ray fetches a node of its own: 64 bytes per ray through 8 bytes per clock. The channel is
  // busy 8 clocks per ray; the stream finishes within the latency of one ray after the last transfer.
  TimingConfig c = test_config();
  c.cache_kib = 0;
  c.ray_slots = 256;
  c.queue_depth = 256;
  TimingModel m(c, layout());
  const size_t n = 20000;
  std::vector<std::vector<TraceEvent>> rays;
  for (size_t i = 0; i < n; ++i) rays.push_back({node(uint32_t(i), 2)});
  TimingStats s;
  const uint64_t cycles = run(m, rays, s);
  CHECK(s.dram_busy_cycles == 8 * n);
  // Exactly: the first request reaches the channel when the first ray leaves setup; from then on a request is
  // always waiting (a slot frees ~120 clocks after its ray entered, long before the channel gets to the next
  // ray), so the transfers run back to back and the last one ends 8 n clocks later; its ray then pays the DRAM
  // latency, the box unit, the scheduler and the write-back.
  const uint64_t first_request = c.packet_latency + c.ray_fetch_latency + c.setup_latency;
  const uint64_t expected =
      first_request + 8 * n + c.dram_latency + c.box_latency + c.traversal_latency + c.writeback_latency;
  CHECK(cycles == expected);
  const double bandwidth = double(s.dram_bytes) / double(cycles);
  CHECK(bandwidth >= 0.99 * c.dram_bytes_per_cycle);
  CHECK(bandwidth <= c.dram_bytes_per_cycle);
  // Half the bandwidth: twice the transfer time per line, the rest unchanged.
  c.dram_bytes_per_cycle = 4.0;
  TimingModel slow(c, layout());
  TimingStats s2;
  CHECK(run(slow, rays, s2) ==
        first_request + 16 * n + c.dram_latency + c.box_latency + c.traversal_latency + c.writeback_latency);
}

TEST_CASE("stack entries beyond the short stack spill and refill through DRAM", "[timing]") {
  TimingConfig c = test_config();  // 4 stack entries
  TimingModel m(c, layout());
  std::vector<TraceEvent> ev;
  ev.push_back(TraceEvent{TraceEvent::kPush, 6, 0, 0, 0});                             // depth 6: two spills
  for (int i = 0; i < 6; ++i) ev.push_back(TraceEvent{TraceEvent::kPop, 0, 0, 0, 0});  // two refills
  TimingStats s;
  const uint64_t cycles = run(m, {ev}, s);
  CHECK(s.stack_spills == 2);
  CHECK(s.stack_refills == 2);
  CHECK(s.dram_bytes == 32);
  // The spills leave without waiting but hold the DRAM channel for a clock each (8 bytes at 8 per clock), so the
  // first refill starts 2 clocks late; each refill waits its transfer (1 clock) and the DRAM latency.
  const uint64_t expected = c.packet_latency + c.ray_fetch_latency + c.setup_latency + 2 +
                            2 * (1 + c.dram_latency) + c.writeback_latency;
  CHECK(cycles == expected);
}

TEST_CASE("feeding rays in chunks gives the same cycles, runs repeat exactly", "[timing]") {
  TimingConfig c = test_config();
  c.ray_slots = 7;
  c.queue_depth = 3;
  std::vector<std::vector<TraceEvent>> rays;
  uint32_t x = 12345;
  for (int i = 0; i < 3000; ++i) {
    std::vector<TraceEvent> ev;
    const int nodes = 1 + int(x % 7);
    for (int j = 0; j < nodes; ++j) {
      x = x * 1664525u + 1013904223u;
      ev.push_back(node(x % 4096, uint8_t(1 + x % 4)));
      if (x % 3 == 0) ev.push_back(TraceEvent{TraceEvent::kPush, uint8_t(1 + x % 3), 0, 0, 0});
      if (x % 5 == 0) ev.push_back(tri(x % 10000));
    }
    if (i % 11 == 0) ev.clear();  // rejected at setup
    rays.push_back(ev);
  }
  uint64_t reference = 0;
  for (size_t chunk : {size_t(0), size_t(1), size_t(5), size_t(64), size_t(1000)}) {
    CAPTURE(chunk);
    TimingModel m(c, layout());
    TimingStats s;
    const uint64_t cycles = run(m, rays, s, chunk);
    if (reference == 0) reference = cycles;
    CHECK(cycles == reference);
    CHECK(s.rays == rays.size());
  }
  CHECK(reference > 0);
}

TEST_CASE("unit requests served at their fetch give the cycles of requests each served at its own cycle",
          "[timing]") {
  // Streams that mix hot lines (hits), a wide footprint (misses), lines still in flight, planes, spheres and stack
  // traffic, on configurations from one slot to many, one unit to several, with and without a cache: the model
  // with early requests (the default) and without must agree on every cycle and every statistic.
  std::vector<std::vector<TraceEvent>> rays;
  uint32_t x = 777;
  auto next = [&] { return x = x * 1664525u + 1013904223u; };
  for (int i = 0; i < 2500; ++i) {
    std::vector<TraceEvent> ev;
    const int steps = 1 + int(next() % 9);
    for (int j = 0; j < steps; ++j) {
      const uint32_t r = next();
      const uint32_t idx = r % 8 < 5 ? (r >> 8) % 24 : (r >> 8) % 20000;  // 5 in 8 hot
      ev.push_back(node(idx, uint8_t(1 + (r >> 4) % 8)));
      if (r % 3 == 0) ev.push_back(TraceEvent{TraceEvent::kPush, uint8_t(1 + (r >> 3) % 3), 0, 0, 0});
      if (r % 5 == 0) ev.push_back(tri((r >> 7) % (r % 2 ? 40 : 30000)));
      if (r % 13 == 0) ev.push_back(TraceEvent{TraceEvent::kPrim, uint8_t(rtu::hw::RecordKind::kSphere), 0, 0, 7});
      if (r % 17 == 0) ev.push_back(TraceEvent{TraceEvent::kPlane, 0, 0, 0, r % 3});
      if (r % 4 == 0) ev.push_back(TraceEvent{TraceEvent::kPop, 0, 0, 0, 0});
    }
    if (i % 23 == 0) ev.clear();
    rays.push_back(ev);
  }
  struct Variant {
    int slots, box_units, tri_units, tri_rate, cache_kib, cache_latency, dram_latency;
    double bandwidth;
  };
  const Variant variants[] = {{64, 1, 1, 1, 16, 2, 100, 8.0}, {1, 1, 1, 1, 16, 2, 100, 8.0},
                              {7, 2, 3, 1, 1, 1, 40, 64.0},   {200, 1, 1, 2, 4, 5, 300, 2.0},
                              {33, 3, 1, 1, 0, 2, 20, 16.0},  {16, 1, 2, 1, 64, 1, 0, 64.0}};
  for (const Variant& v : variants) {
    TimingConfig c = test_config();
    c.ray_slots = v.slots;
    c.box_units = v.box_units;
    c.tri_units = v.tri_units;
    c.tri_rate = v.tri_rate;
    c.cache_kib = v.cache_kib;
    c.cache_latency = v.cache_latency;
    c.dram_latency = v.dram_latency;
    c.dram_bytes_per_cycle = v.bandwidth;
    c.stack_entries = 2;
    c.queue_depth = 8;
    CAPTURE(v.slots, v.box_units, v.tri_units, v.tri_rate, v.cache_kib, v.cache_latency, v.dram_latency);
    TimingModel early(c, layout()), late(c, layout());
    late.set_early_requests(false);
    std::vector<uint64_t> done_early, done_late;
    early.record_done(&done_early);
    late.record_done(&done_late);
    TimingStats a, b;
    uint64_t ca = 0, cb = 0;
    for (int packet = 0; packet < 2; ++packet) {  // the second packet starts from the first one's cache
      ca += run(early, rays, a, 100);
      cb += run(late, rays, b, 100);
    }
    CHECK(ca == cb);
    CHECK(done_early == done_late);
    check_same_timing(a, b);
    // Both kinds of fetch occur, so both paths are taken.
    CHECK(a.cache_misses > 100);
    if (v.cache_kib > 0) CHECK(a.cache_hits > 1000);
  }
}

TEST_CASE("a backward walk fixes the cache the simulated rays meet: warming with it gives their cycles exactly",
          "[timing][sample]") {
  // Rays that touch the top of a tree (16 hot lines) and a drifting window of 600 lines, as camera rays sweeping
  // an image do: the 256-line cache (16 KiB, 4 ways) holds the hot lines and part of the window.
  const TimingConfig c = test_config();
  uint32_t x = 777;
  auto ray = [&](int i) { return sweep_ray(x, i); };
  std::vector<std::vector<TraceEvent>> history, future;
  for (int i = 0; i < 3000; ++i) history.push_back(ray(i));
  for (int i = 3000; i < 3400; ++i) future.push_back(ray(i));

  // Reference: warmed with every earlier ray.
  TimingModel full(c, layout());
  full.warm(history.data(), history.size());
  TimingStats sf;
  const uint64_t reference = run(full, future, sf);

  // The walk: chunks of 20 rays backwards from the future's first ray until no line of the future is open.
  TimingModel walk(c, layout());
  walk.walk_begin(future.data(), future.size());
  const size_t lines = walk.walk_lines();
  CHECK(lines > 256);  // more than the cache holds: what is in it at the start matters
  size_t walked = 0, open = lines;
  std::vector<size_t> opens;
  while (open > 0 && walked < history.size()) {
    walked += 20;
    walk.walk_add(history.data() + (history.size() - walked), 20);
    open = walk.walk_open();
    CHECK(open <= (opens.empty() ? lines : opens.back()));  // never rises
    opens.push_back(open);
  }
  REQUIRE(open == 0);
  CHECK(opens.size() >= 2);            // one chunk was not enough
  CHECK(walked < history.size() / 2);  // and far fewer than the history were
  // Whatever the cache held before (here: lines no ray touches), warming with the walked rays gives the
  // simulated rays the reference's cycles and hits.
  std::vector<std::vector<TraceEvent>> other;
  for (uint32_t i = 0; i < 400; ++i) other.push_back({node(100000 + 7 * i, 4)});
  for (bool stale : {false, true}) {
    CAPTURE(stale);
    TimingModel m(c, layout());
    if (stale) m.warm(other.data(), other.size());
    m.warm(history.data() + (history.size() - walked), walked);
    TimingStats s;
    CHECK(run(m, future, s) == reference);
    CHECK(s.cache_hits == sf.cache_hits);
    CHECK(s.cache_misses == sf.cache_misses);
  }
  // Stopping one chunk early leaves lines open, and the cycles are then not the reference's (a cold cache even
  // less so): the walk's length is what it takes, not a margin.
  TimingModel early(c, layout()), cold(c, layout());
  early.warm(history.data() + (history.size() - walked + 20), walked - 20);
  TimingStats se, sc;
  CHECK(run(early, future, se) != reference);
  CHECK(run(cold, future, sc) > reference);
}

TEST_CASE("walk_install leaves the cache that warming forward with the rays walked leaves, whatever the chunks",
          "[timing][sample]") {
  // Nodes of 56 bytes straddle lines, so a fetch touches two lines; with one set of 64 ways (the second
  // configuration) their order within the fetch matters too. The cache starts with stale contents, some of them
  // lines the future touches: where the walk stops before every line is determined (enough > 0), the old lines
  // and their LRU order decide those.
  TimingConfig one_set = test_config();
  one_set.cache_kib = 4;
  one_set.cache_ways = 64;
  for (const TimingConfig& c : {test_config(), one_set}) {
    CAPTURE(c.cache_ways);
    TimingModel::Layout l = layout();
    l.node_bytes = 56;
    uint32_t x = 4242;
    auto ray = [&](int i) { return sweep_ray(x, i); };
    std::vector<std::vector<TraceEvent>> stale, history, future;
    for (uint32_t i = 0; i < 300; ++i) stale.push_back({node(100000 + 7 * i, 4), node(6016 + 5 * i, 4)});
    for (int i = 0; i < 3000; ++i) history.push_back(ray(i));
    for (int i = 3000; i < 3400; ++i) future.push_back(ray(i));

    TimingModel full(c, l);
    full.warm(stale.data(), stale.size());
    full.warm(history.data(), history.size());
    TimingStats sf;
    const uint64_t reference = run(full, future, sf);

    size_t lines = 0;
    {
      TimingModel m(c, l);
      m.walk_begin(future.data(), future.size());
      lines = m.walk_lines();
    }
    REQUIRE(lines > size_t(c.cache_kib) * 1024 / 64);  // more than the cache holds
    for (size_t enough : {size_t(0), lines / 20, lines / 4}) {
      size_t taken_first = 0;
      for (size_t chunk : {1, 7, 20, 64}) {
        CAPTURE(enough, chunk);
        TimingModel walk(c, l), warm(c, l);
        walk.warm(stale.data(), stale.size());
        warm.warm(stale.data(), stale.size());
        walk.walk_begin(future.data(), future.size());
        size_t traced = 0, taken = 0;
        while (traced < history.size() && walk.walk_open() > enough) {
          const size_t n = std::min(chunk, history.size() - traced);
          const size_t t = walk.walk_add(history.data() + (history.size() - traced - n), n, enough);
          REQUIRE(t <= n);
          traced += n;
          taken += t;
          if (t < n) break;
        }
        CHECK(walk.walk_open() <= enough);
        // Where the walk stops does not depend on the chunks: it is the first ray (backwards) that brings the
        // undetermined lines down to `enough`.
        if (taken_first == 0) taken_first = taken;
        CHECK(taken == taken_first);
        CHECK(taken < history.size() / 2);
        walk.walk_install();
        warm.warm(history.data() + (history.size() - taken), taken);
        TimingStats s1, s2;
        const uint64_t c1 = run(walk, future, s1), c2 = run(warm, future, s2);
        CHECK(c1 == c2);
        CHECK(s1.cache_hits == s2.cache_hits);
        CHECK(s1.cache_misses == s2.cache_misses);
        if (enough == 0) {
          CHECK(c1 == reference);
          CHECK(s1.cache_misses == sf.cache_misses);
        }
      }
    }
  }
}

TEST_CASE("walk_install: a fetch's lines in the order it touches them, and a set's old lines below the walk's",
          "[timing][sample]") {
  // One set of 16 ways. Nodes of 128 bytes: node k is lines 2k and 2k + 1. Records start at line 101 (record 0
  // is on line 101 only, record 10 on line 107 only).
  TimingConfig c = test_config();
  c.cache_kib = 1;
  c.cache_ways = 16;
  TimingModel::Layout l = layout();
  l.node_bytes = 128;
  l.record_offset = 101 * 64;
  const std::vector<std::vector<TraceEvent>> future{{tri(0)}};

  // Forward: lines 100, 101, then 15 others: the set keeps 101 and drops 100. Backwards the walk meets the 15,
  // then node 50's lines last first: 101 is the 16th. Taking them first first would keep 100 instead.
  const std::vector<std::vector<TraceEvent>> history{
      {node(50, 4)},
      {node(60, 4), node(61, 4), node(62, 4), node(63, 4), node(64, 4), node(65, 4), node(66, 4), tri(10)}};
  TimingModel warm(c, l), walk(c, l);
  warm.warm(history.data(), history.size());
  walk.walk_begin(future.data(), future.size());
  CHECK(walk.walk_add(history.data(), history.size()) == 2);
  CHECK(walk.walk_open() == 0);
  walk.walk_install();
  TimingStats s1, s2;
  CHECK(run(warm, future, s1) == run(walk, future, s2));
  CHECK(s1.cache_hits == 1);
  CHECK(s2.cache_hits == 1);

  // A set the walk does not fill keeps its old lines below the walked ones: record 0 (line 101) from before.
  const std::vector<std::vector<TraceEvent>> short_history{{node(60, 4)}};
  TimingModel warm2(c, l), walk2(c, l);
  warm2.warm(future.data(), future.size());
  walk2.warm(future.data(), future.size());
  warm2.warm(short_history.data(), short_history.size());
  walk2.walk_begin(future.data(), future.size());
  walk2.walk_add(short_history.data(), short_history.size());
  CHECK(walk2.walk_open() == 1);  // not seen, and the set is not full
  walk2.walk_install();
  TimingStats s3, s4;
  CHECK(run(warm2, future, s3) == run(walk2, future, s4));
  CHECK(s3.cache_hits == 1);
  CHECK(s4.cache_hits == 1);
}

TEST_CASE("a next-line prefetch that arrives in time turns the next node's miss into a hit", "[timing]") {
  // One ray fetching node 0 and then node 1, one 64-byte line each (lines 0 and 1).
  TimingConfig c = test_config();
  const uint64_t line = 64 / 8;  // cycles to transfer a line
  const uint64_t enter = c.packet_latency + c.ray_fetch_latency + c.setup_latency;
  const uint64_t miss = c.cache_latency + line + c.dram_latency;
  const uint64_t per_node = c.box_latency + c.traversal_latency;  // a node of 4 children issues for one clock
  {
    TimingModel m(c, layout());
    TimingStats s;
    CHECK(run(m, {{node(0, 4), node(1, 4)}}, s) ==
          enter + miss + per_node + miss + per_node + c.writeback_latency);
    CHECK(s.cache_misses == 2);
    CHECK(s.prefetch_fills == 0);
  }
  rtu::hw::set_timing_key(c, "prefetcher", "next_line");
  TimingModel m(c, layout());
  TimingStats s;
  // Node 0 misses at `enter`: its line asked of DRAM cache_latency later, transferred [enter + 2, + 8). The miss
  // triggers a fill of line 1 at the same cycle, asked at enter + 2 too, which waits for the channel: transferred
  // [enter + 10, + 8), there at enter + 118. Node 0's data is there at enter + 110, its box result and the next
  // request 9 clocks later: node 1's fetch at enter + 119 hits the line that arrived at enter + 118, and its data
  // is there cache_latency later.
  const uint64_t fill_ready = enter + c.cache_latency + 2 * line + c.dram_latency;
  const uint64_t second_fetch = enter + miss + per_node;
  REQUIRE(second_fetch >= fill_ready);
  CHECK(run(m, {{node(0, 4), node(1, 4)}}, s) == second_fetch + c.cache_latency + per_node + c.writeback_latency);
  CHECK(s.cache_misses == 1);
  CHECK(s.cache_hits == 1);
  CHECK(s.prefetch_fills == 1);
  CHECK(s.prefetch_useful == 1);
  CHECK(s.prefetch_redundant == 0);
  CHECK(s.dram_bytes == 128);

  // A fill arriving after the demand fetch is waited for, not fetched twice: with a one-cycle box unit and no
  // scheduler delay, node 1's fetch comes at enter + 110 + 1, before the fill's data (enter + 118).
  TimingConfig fast = c;
  fast.box_latency = 1;
  fast.traversal_latency = 0;
  TimingModel f(fast, layout());
  TimingStats fs;
  const uint64_t early_fetch = enter + miss + 1;
  REQUIRE(early_fetch < fill_ready);
  CHECK(run(f, {{node(0, 4), node(1, 4)}}, fs) == fill_ready + fast.cache_latency + 1 + fast.writeback_latency);
  CHECK(fs.cache_hits == 1);
  CHECK(fs.dram_bytes == 128);
}

TEST_CASE("a prefetcher changes when data is there, never what is fetched or tested", "[timing]") {
  // The sweep of camera-like rays with and without next-line prefetching of 2 lines: the same demand accesses and
  // unit work; fills only add DRAM traffic and cache hits.
  std::vector<std::vector<TraceEvent>> rays;
  uint32_t x = 12345;
  for (int i = 0; i < 2000; ++i) rays.push_back(sweep_ray(x, i));
  TimingConfig c = test_config();
  c.cache_kib = 4;  // small enough that the window does not fit
  TimingModel off(c, layout());
  TimingStats so;
  run(off, rays, so);
  rtu::hw::set_timing_key(c, "prefetcher", "next_line");
  rtu::hw::set_timing_key(c, "prefetch_degree", "2");
  TimingModel on(c, layout());
  TimingStats sp;
  run(on, rays, sp);
  CHECK(sp.cache_hits + sp.cache_misses == so.cache_hits + so.cache_misses);
  CHECK(sp.node_fetches == so.node_fetches);
  CHECK(sp.box_tests == so.box_tests);
  CHECK(sp.tri_tests == so.tri_tests);
  CHECK(sp.prefetch_fills > 0);
  CHECK(sp.prefetch_useful <= sp.prefetch_fills);
  CHECK(sp.dram_bytes == 64 * (sp.cache_misses + sp.prefetch_fills));  // line reads only: no stack events
  CHECK(so.dram_bytes == 64 * so.cache_misses);
  CHECK_THROWS_WITH(
      rtu::hw::set_timing_key(c, "prefetcher", "stride"),
      Catch::Contains("prefetcher = 'stride' must be none, next_line, treelet, stack, stack_pop or ttp"));
}

namespace {

// An observer that fills the line after every fetch, hit or miss: its fills reach the shared memory at fetches
// that would otherwise stay inside the unit.
class FillAfterEveryFetch final : public rtu::hw::FetchObserver {
 public:
  void on_fetch(const rtu::hw::LineFetch& f, rtu::hw::LinePort& port) override { port.fill(f.last_line + 1); }
};

// Runs a chip's units, each begun on its rays (rays[u]) with its statistics in stats[u], in step on `threads` host
// threads, giving each unit its rays `chunk` at a time. Returns the chip's cycles; the statistics summed in `s`.
uint64_t run_given(const std::vector<std::unique_ptr<TimingModel>>& units,
                   std::vector<std::vector<std::vector<TraceEvent>>>& rays, const std::vector<TimingStats>& stats,
                   size_t chunk, int threads, TimingStats& s) {
  std::vector<TimingModel*> ptrs;
  for (const auto& u : units) ptrs.push_back(u.get());
  std::vector<size_t> given(units.size(), 0);
  const uint64_t end = rtu::hw::run_units_in_step(
      ptrs, 0,
      [&](size_t u) {
        const size_t m = std::min(chunk, rays[u].size() - given[u]);
        units[u]->add_rays(rays[u].data() + given[u], m);
        given[u] += m;
      },
      threads);
  for (const TimingStats& us : stats) s.add(us);
  return end;
}

// Three units sharing one memory run a packet of swept rays each, given in chunks of 50; every unit has a
// FillAfterEveryFetch observer. Returns the chip's cycles; the units' statistics summed in `s`.
uint64_t run_observed_chip(bool ahead, TimingStats& s) {
  TimingConfig c = test_config();
  c.cache_kib = 4;
  c.ray_slots = 8;
  rtu::hw::MemorySystem mem(c);
  std::vector<std::unique_ptr<TimingModel>> units;
  std::vector<std::vector<std::vector<TraceEvent>>> rays(3);
  std::vector<TimingStats> stats(3);
  for (uint32_t u = 0; u < 3; ++u) {
    units.push_back(std::make_unique<TimingModel>(c, layout(), &mem, u));
    units.back()->set_fetch_observer(std::make_unique<FillAfterEveryFetch>());
    units.back()->set_run_ahead(ahead);
    uint32_t x = 777 + u;
    for (int i = 0; i < 300; ++i) rays[u].push_back(sweep_ray(x, i + 100 * int(u)));
    units.back()->begin(rays[u].size(), stats[u]);
  }
  return run_given(units, rays, stats, 50, 1, s);
}

}  // namespace

TEST_CASE("chip: a fetch observer's fills keep run-ahead exact (units stop before every fetch)", "[timing]") {
  TimingStats ahead, in_step;
  const uint64_t a = run_observed_chip(true, ahead);
  const uint64_t b = run_observed_chip(false, in_step);
  CHECK(a == b);
  check_same_timing(ahead, in_step);
  CHECK(ahead.prefetch_fills > 0);
  CHECK(ahead.prefetch_redundant > 0);
}

namespace {

// Four units sharing one memory (with an L2 of 8 KiB, or the DRAM channel alone) run a packet of swept rays each,
// given in chunks of 40, on `threads` host threads; 2-entry stacks, so that spills and refills reach the shared
// memory too. Returns the chip's cycles; the units' statistics summed in `s`, their memory's timeline in
// `l2_bytes`.
uint64_t run_chip_on(int threads, bool l2, bool observed, TimingStats& s, std::vector<uint64_t>& l2_bytes) {
  TimingConfig c = test_config();
  c.cache_kib = 4;
  c.ray_slots = 8;
  c.stack_entries = 2;
  if (l2) {
    c.l2_kib = 8;
    c.l2_slices = 2;
    c.l2_latency = 25;
  }
  rtu::hw::MemorySystem mem(c);
  std::vector<std::unique_ptr<TimingModel>> units;
  std::vector<std::vector<std::vector<TraceEvent>>> rays(4);
  std::vector<TimingStats> stats(4);
  for (uint32_t u = 0; u < 4; ++u) {
    units.push_back(std::make_unique<TimingModel>(c, layout(), &mem, u));
    if (observed) units.back()->set_fetch_observer(std::make_unique<FillAfterEveryFetch>());
    uint32_t x = 4242 + u;
    for (int i = 0; i < 250; ++i) {
      // A sweep's ray whose traversal pushes 4 entries after its first node (2 spill) and pops them at its end.
      std::vector<TraceEvent> ev = sweep_ray(x, i + 70 * int(u));
      ev.insert(ev.begin() + 1, TraceEvent{TraceEvent::kPush, 4, 0, 0, 0});
      for (int j = 0; j < 4; ++j) ev.insert(ev.end() - 1, TraceEvent{TraceEvent::kPop, 0, 0, 0, 0});
      rays[u].push_back(std::move(ev));
    }
    units.back()->begin(rays[u].size(), stats[u]);
  }
  const uint64_t end = run_given(units, rays, stats, 40, threads, s);
  l2_bytes = mem.timeline().l2_bytes;
  return end;
}

}  // namespace

TEST_CASE("chip: units on several host threads give the cycles and counters of units in step on one",
          "[timing][chip]") {
  for (const bool l2 : {true, false}) {
    CAPTURE(l2);
    TimingStats one;
    std::vector<uint64_t> one_l2;
    const uint64_t cycles = run_chip_on(1, l2, false, one, one_l2);
    CHECK(one.stack_spills > 0);
    CHECK(one.stack_refills > 0);
    CHECK(one.mem_wait_cycles > 0);  // queueing in the shared memory, counted per fetch
    CHECK((one.l2_misses > 0) == l2);
    for (const int threads : {2, 3, 4, 9}) {
      CAPTURE(threads);
      TimingStats many;
      std::vector<uint64_t> many_l2;
      CHECK(run_chip_on(threads, l2, false, many, many_l2) == cycles);
      check_same_timing(one, many);
      CHECK(many_l2 == one_l2);
    }
  }
  // The lookahead is the memory's fewest answer cycles: l2_latency in front of the DRAM, or dram_latency alone.
  TimingConfig c = test_config();
  CHECK(rtu::hw::MemorySystem(c).min_answer_cycles() == 100);
  c.l2_kib = 8;
  c.l2_latency = 25;
  CHECK(rtu::hw::MemorySystem(c).min_answer_cycles() == 25);
}

TEST_CASE("chip: units with a fetch observer stay on one host thread, with the same cycles", "[timing][chip]") {
  // A prefetcher's fills depend on the shared memory's state at each fetch (drain_prefetches): such units cannot
  // hold their requests for a window (can_defer), so run_units_in_step keeps them in step on the calling thread.
  TimingStats one, two;
  std::vector<uint64_t> a, b;
  CHECK(run_chip_on(1, true, true, one, a) == run_chip_on(3, true, true, two, b));
  check_same_timing(one, two);
  CHECK(one.prefetch_fills > 0);
  TimingConfig c = test_config();
  rtu::hw::MemorySystem mem(c);
  TimingModel alone(c, layout()), shared(c, layout(), &mem, 0);
  CHECK_FALSE(alone.can_defer());  // its own memory: nothing to share
  CHECK(shared.can_defer());
  shared.set_fetch_observer(std::make_unique<FillAfterEveryFetch>());
  CHECK_FALSE(shared.can_defer());
  CHECK_THROWS_WITH(shared.defer(true), Catch::Contains("cannot defer"));
}
