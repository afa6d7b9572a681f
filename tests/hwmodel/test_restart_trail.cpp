// The short stack with a restart trail (stack_mode = restart, datapath/restart_trail.h): what the recorder adds
// against an independent reading of the full stack's events, the cost of a restart worked by hand, and hits and
// cycles unchanged by the host's threads, a chip or sampling.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/timing_model.h"
#include "timing_checks.h"

using namespace rtu::hw;

namespace {

// What a short stack of `k` entries with a restart trail adds to a full-stack recording (kPush, kPop events),
// read from that recording alone: a node event is followed by a descent unless a pop (or the end) comes next (a
// node with no accepted child); entries pushed lie one level below the node that pushed them; a pop below the
// entries the short stack holds re-visits the nodes above the popped entry, and the stack then holds the k top
// entries again.
std::vector<TraceEvent> expected_restarts(const std::vector<TraceEvent>& raw, int k) {
  std::vector<TraceEvent> out, path;
  std::vector<int> entry_level;
  int level = 0, held_lo = 0;
  for (size_t i = 0; i < raw.size(); ++i) {
    const TraceEvent& e = raw[i];
    if (e.kind == TraceEvent::kPush) {
      for (int j = 0; j < e.count; ++j) entry_level.push_back(level);
      held_lo = std::max(held_lo, int(entry_level.size()) - k);
    } else if (e.kind == TraceEvent::kPop) {
      const int l = entry_level.back();
      entry_level.pop_back();
      const int depth = int(entry_level.size());
      if (depth < held_lo) {
        out.push_back(TraceEvent{TraceEvent::kRestart, uint8_t(std::min(l, 255)), 0, 0, uint32_t(l)});
        out.insert(out.end(), path.begin(), path.begin() + l);
        held_lo = std::max(0, depth - k);
      }
      level = l;
    } else {
      out.push_back(e);
      if (e.kind == TraceEvent::kNode) {
        path.resize(size_t(level) + 1);
        path[size_t(level)] = e;
        if (i + 1 < raw.size() && raw[i + 1].kind != TraceEvent::kPop) ++level;
      }
    }
  }
  return out;
}

// Rays from a box around the soup toward points inside it: long paths through many nodes.
std::vector<Ray> random_rays(uint64_t seed, int n) {
  Pcg32 rng(seed);
  std::vector<Ray> rays;
  for (int i = 0; i < n; ++i) {
    Ray r;
    Vec3 to;
    for (int a = 0; a < 3; ++a) {
      r.origin[a] = fixed_checks::rand_float(rng, -14.0f, 14.0f);
      to[a] = fixed_checks::rand_float(rng, -10.0f, 10.0f);
    }
    r.dir = to - r.origin;
    r.tmin = 0.0f;
    r.tmax = 1e30f;
    rays.push_back(r);
  }
  return rays;
}

TraceEvent node(uint32_t index) {
  return TraceEvent{TraceEvent::kNode, 4, 0, 0, index};
}

}  // namespace

TEST_CASE("a restart trail re-visits the nodes above each dropped entry and never changes a hit",
          "[fixed][timing]") {
  // Binary BVH over 3,000 triangles: random rays reach stack depths well past the short stacks tried.
  const Geometry g = fixed_checks::random_scene(31, 3000, 8);
  const std::vector<Ray> rays = random_rays(32, 3000);
  for (int width : {2, 4}) {
    FixedFormat f = format_preset("default");
    f.width = width;
    const DeviceImage img = image_checks::encode(g, f);
    const FixedTracer raw(img);
    for (int k : {1, 2, 3, 8, 64}) {
      CAPTURE(width, k);
      FixedTraceOptions o;
      o.record_short_stack = k;
      o.record_restart = true;
      const FixedTracer restart(img, o);
      uint64_t restarts = 0, revisits = 0, nodes = 0;
      std::vector<TraceEvent> ev_raw, ev_restart;
      for (const Ray& r : rays) {
        TraversalStats s1, s2;
        ev_raw.clear();
        ev_restart.clear();
        const Hit a = raw.trace_recorded(r, false, s1, ev_raw);
        const Hit b = restart.trace_recorded(r, false, s2, ev_restart);
        REQUIRE(std::memcmp(&a, &b, sizeof(Hit)) == 0);
        REQUIRE(s1.nodes_visited == s2.nodes_visited);  // the traversal is the full stack's
        const std::vector<TraceEvent> want = expected_restarts(ev_raw, k);
        REQUIRE(want.size() == ev_restart.size());
        REQUIRE(std::memcmp(want.data(), ev_restart.data(), want.size() * sizeof(TraceEvent)) == 0);
        for (const TraceEvent& e : ev_restart)
          if (e.kind == TraceEvent::kRestart) {
            ++restarts;
            revisits += e.index;
          }
        nodes += s1.nodes_visited;
      }
      if (k == 64) {
        CHECK(restarts == 0);  // deeper than any stack these rays build
      } else {
        CHECK(restarts > (k <= 3 ? 100u : 0u));  // the restart path is exercised
        CHECK(revisits >= restarts);
      }
      if (k == 1) CHECK(revisits > nodes / 10);  // one entry: restarts are a large share of the work
    }
  }
}

TEST_CASE("a restart costs exactly the nodes it re-visits", "[timing]") {
  TimingConfig c = test_config();
  set_timing_key(c, "stack_mode", "restart");
  TimingModel::Layout l;
  l.node_bytes = 64;
  l.record_offset = 1 << 20;
  l.plane_offset = 2 << 20;
  const uint64_t line = 64 / 8;
  const uint64_t enter = c.packet_latency + c.ray_fetch_latency + c.setup_latency;
  const uint64_t miss = c.cache_latency + line + c.dram_latency;
  const uint64_t per_node = c.box_latency + c.traversal_latency;  // 4 children: one issue clock
  auto run = [&](std::vector<TraceEvent> ev, TimingStats& s) {
    TimingModel m(c, l);
    m.begin(1, s);
    m.feed(&ev, 1);
    return m.finish();
  };
  TimingStats plain, restarted;
  // Nodes 0 and 1, then the entry dropped from the short stack: the restart fetches and tests the root again (a
  // cache hit) and node 1 (its parent; a hit too) before node 2.
  const uint64_t a = run({node(0), node(1), node(2)}, plain);
  CHECK(a == enter + 3 * (miss + per_node) + c.writeback_latency);
  const uint64_t b =
      run({node(0), node(1), TraceEvent{TraceEvent::kRestart, 2, 0, 0, 2}, node(0), node(1), node(2)}, restarted);
  CHECK(b == a + 2 * (c.cache_latency + per_node));
  CHECK(restarted.restarts == 1);
  CHECK(restarted.restart_nodes == 2);
  CHECK(restarted.node_fetches == plain.node_fetches + 2);
  CHECK(restarted.box_tests == plain.box_tests + 8);
  CHECK(restarted.dram_bytes == plain.dram_bytes);  // no spill traffic, no new line
  CHECK(restarted.stack_spills == 0);
}

TEST_CASE("stack_mode restart: hits equal the fixed device's, cycles the same on threads, chips and sampling",
          "[timing]") {
  const std::vector<Ray> rays = random_rays(5, 3000);
  const FixedReference ref = fixed_reference(10, rays);
  const std::vector<uint8_t>& bytes = ref.bytes;
  const std::vector<Hit>& want = ref.hits;
  for (const char* preset : {"rdna2-mem", "rdna2-chip"}) {
    TimingConfig c = timing_preset(preset);
    set_timing_key(c, "stack_entries", "2");
    std::vector<Hit> got;
    const uint64_t spill_cycles = trace_timed(c, bytes, rays, 1, got);
    set_timing_key(c, "stack_mode", "restart");
    uint64_t cycles[2] = {0, 0};
    for (int threads : {1, 2}) {
      CAPTURE(preset, threads);
      TimingStats ts;
      cycles[threads - 1] = trace_timed(c, bytes, rays, threads, got, &ts);
      CHECK(std::memcmp(got.data(), want.data(), want.size() * sizeof(Hit)) == 0);
      CHECK(ts.restarts > 0);
      CHECK(ts.stack_spills == 0);
    }
    CHECK(cycles[0] == cycles[1]);
    CHECK(cycles[0] != spill_cycles);  // the mode is in effect
    // Sampled timing keeps working: the restarts are node events that warming sees as any other.
    if (c.units == 1) {
      TimedEngine timed(EngineOptions{}, c);
      SampleOptions so;
      so.fraction = 0.2;
      timed.set_sampling(so);
      timed.bind(bytes.data(), bytes.size());
      std::vector<Hit> got(rays.size());
      TraversalStats ts;
      timed.trace_cycles(rays.data(), got.data(), rays.size(), false, ts, 0, 0);
      CHECK(std::memcmp(got.data(), want.data(), want.size() * sizeof(Hit)) == 0);
      CHECK(timed.timing().restarts > 0);
    }
  }
  TimingConfig c;
  CHECK_THROWS_WITH(set_timing_key(c, "stack_mode", "drop"), Catch::Contains("must be spill or restart"));
}
