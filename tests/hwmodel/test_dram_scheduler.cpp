// The FR-FCFS DRAM scheduler (memory/dram_scheduler.h): exact cycles worked by hand on tiny request sequences,
// the cap, the keys' refusals, and the equivalences that tie the queued memory to the default one.
#include <catch2/catch.hpp>
#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "hwmodel/timing/memory/dram_scheduler.h"
#include "hwmodel/timing/memory/memory_system.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_model.h"
#include "hwmodel/timing/timing_stats.h"

using rtu::hw::MemorySystem;
using rtu::hw::TimingConfig;
using rtu::hw::TimingStats;

namespace {

// One channel of one bank, 256-byte rows (lines 0-3 are row 0, lines 4-7 row 1, ...), 64 bytes a clock (a line's
// transfer: 1 clock), latency 100, activate 20, precharge 15.
TimingConfig one_bank(const std::string& scheduler, int cap = 16) {
  TimingConfig c;
  c.line_bytes = 64;
  c.dram_latency = 100;
  c.dram_bytes_per_cycle = 64;
  c.dram_channels = 1;
  c.dram_banks = 1;
  c.dram_row_bytes = 256;
  c.dram_activate_cycles = 20;
  c.dram_precharge_cycles = 15;
  set_timing_key(c, "dram_scheduler", scheduler);
  c.dram_frfcfs_cap = cap;
  c.validate();
  return c;
}

// Collects the cycles a queued memory resolves its reads to, by tag.
struct Collect final : rtu::hw::PendingWaiter {
  std::map<uint32_t, uint64_t> at;
  void woken(uint32_t tag, uint64_t cycle, uint64_t /*wait*/) override { at[tag] = cycle; }
};

// Line reads (line, cycle) in this order; the cycle each one's data is there. A synchronous memory answers at
// once; a queued one decides once every request is in, which gives what deciding between them would: a decision
// at cycle D takes only the requests that arrived by D (the next test case holds it to that).
std::vector<uint64_t> reads(MemorySystem& m, const std::vector<std::pair<uint64_t, uint64_t>>& seq,
                            TimingStats& s) {
  Collect col;
  std::vector<uint64_t> ready;
  for (uint32_t i = 0; i < seq.size(); ++i) {
    ready.push_back(m.read_line(seq[i].first, seq[i].second, s));
    if (rtu::hw::is_pending(ready.back())) m.pending()->notify(ready.back(), &col, i);
  }
  m.drain();
  for (auto& [i, c] : col.at) ready[i] = c;
  return ready;
}

}  // namespace

TEST_CASE("dram scheduler: a row hit overtakes an older row miss under FR-FCFS, not under FCFS",
          "[memory][frfcfs]") {
  // A: line 0 (row 0) at 0; B: line 4 (row 1) at 1; C: line 1 (row 0) at 2.
  const std::vector<std::pair<uint64_t, uint64_t>> seq = {{0, 0}, {4, 1}, {1, 2}};
  SECTION("fcfs (the default, synchronous): in the order they come") {
    // A: empty bank, activate: command 0 + 20, transfer 20-21, data 121.
    // B: the bank takes it at 20 (A's transfer started); row 0 open: precharge and activate 20 + 35 = 55,
    //    transfer 55-56, data 156. Waited 20 - 1 = 19.
    // C: the bank takes it at 55; row 1 open: 55 + 35 = 90, data 191. Waited 55 - 2 = 53.
    MemorySystem m(one_bank("fcfs"));
    CHECK(m.pending() == nullptr);
    TimingStats s;
    CHECK(reads(m, seq, s) == std::vector<uint64_t>{121, 156, 191});
    CHECK(s.dram_row_hits == 0);
    CHECK(s.dram_row_misses == 3);
    CHECK(s.mem_wait_cycles == 19 + 53);
    CHECK(s.dram_reordered == 0);
  }
  SECTION("frfcfs: C, a hit on A's row, goes before B") {
    // Decision at 0 (the bank idle, A arrived): A only; activate, transfer 20-21, data 121.
    // Decision at 20 (the bank takes a command when A's transfer starts): B and C have arrived; row 0 is open and
    //   C hits it: C's command at 20, the bus free at 21: transfer 21-22, data 122. B is passed over once.
    // Decision at 21: B; precharge and activate 21 + 35 = 56, transfer 56-57, data 157.
    // Waits: C (20 - 2) + (21 - 20) = 19; B (21 - 1) = 20.
    MemorySystem m(one_bank("frfcfs"));
    REQUIRE(m.pending() != nullptr);
    TimingStats s;
    Collect col;
    std::vector<uint64_t> r;
    for (uint32_t i = 0; i < seq.size(); ++i) {
      r.push_back(m.read_line(seq[i].first, seq[i].second, s));
      REQUIRE(rtu::hw::is_pending(r.back()));
      m.pending()->notify(r.back(), &col, i);
    }
    // The decisions come at the cycles the bank is free, one at a time.
    CHECK(m.next_decision() == 0);
    m.decide();
    CHECK(col.at == std::map<uint32_t, uint64_t>{{0, 121}});
    CHECK(m.next_decision() == 20);
    m.decide();
    CHECK(col.at.at(2) == 122);
    CHECK(m.next_decision() == 21);
    m.decide();
    CHECK(col.at.at(1) == 157);
    CHECK(m.next_decision() == rtu::hw::kNoDecision);
    CHECK(s.dram_row_hits == 1);
    CHECK(s.dram_row_misses == 2);
    CHECK(s.dram_reordered == 1);
    CHECK(s.dram_capped == 0);
    CHECK(s.mem_wait_cycles == 19 + 20);
    CHECK(s.dram_bytes == 3 * 64);
  }
  SECTION("frfcfs with cap 0 is FCFS: the oldest first, the same cycles as the default") {
    // Decision at 0: A (121). At 20: B is oldest and passed over 0 >= 0 times: 20 + 35 = 55, data 156. At 55: C,
    // 55 + 35 = 90, data 191. The cap chose twice where C's row hit would have gone (at 20; at 55 C is alone).
    MemorySystem m(one_bank("frfcfs", 0));
    TimingStats s;
    CHECK(reads(m, seq, s) == std::vector<uint64_t>{121, 156, 191});
    CHECK(s.dram_reordered == 0);
    CHECK(s.dram_capped == 1);
    CHECK(s.mem_wait_cycles == 19 + 53);
  }
}

TEST_CASE("dram scheduler: only requests that have arrived when the bank is free compete", "[memory][frfcfs]") {
  // A: line 0 at 0; B: line 4 (row 1) at 1; C: line 1 (row 0) at 25, after the decision at 20.
  MemorySystem m(one_bank("frfcfs"));
  TimingStats s;
  Collect col;
  m.pending()->notify(m.read_line(0, 0, s), &col, 0);
  m.pending()->notify(m.read_line(4, 1, s), &col, 1);
  // Time passes to 25: the decisions at 0 (A) and 20 (B: the only one there; 20 + 35 = 55, data 156).
  while (m.next_decision() < 25) m.decide();
  CHECK(col.at == std::map<uint32_t, uint64_t>{{0, 121}, {1, 156}});
  // C at 25: the bank takes it at 55 (B's transfer), row 1 open: 55 + 35 = 90, data 191.
  m.pending()->notify(m.read_line(1, 25, s), &col, 2);
  CHECK(m.next_decision() == 55);
  m.drain();
  CHECK(col.at.at(2) == 191);
  CHECK(s.dram_reordered == 0);
}

TEST_CASE("dram scheduler: the cap stops a stream of row hits starving a row miss", "[memory][frfcfs]") {
  // A: line 0 at 0; B: line 4 (row 1) at 1; C: line 1 at 2; E: line 2 at 3 (C and E hit row 0).
  const std::vector<std::pair<uint64_t, uint64_t>> seq = {{0, 0}, {4, 1}, {1, 2}, {2, 3}};
  // seq on one bank under FR-FCFS with `cap`: the cycle each read's data is there, and the scheduler's counts.
  const auto check = [&](int cap, const std::vector<uint64_t>& data, uint64_t reordered, uint64_t capped,
                         uint64_t row_hits) {
    MemorySystem m(one_bank("frfcfs", cap));
    TimingStats s;
    CHECK(reads(m, seq, s) == data);
    CHECK(s.dram_reordered == reordered);
    CHECK(s.dram_capped == capped);
    CHECK(s.dram_row_hits == row_hits);
  };
  SECTION("cap 16: both hits go first") {
    // 0: A (121). 20: C hits (bus at 21: data 122), B passed once. 21: E hits (bus at 22: data 123), B passed
    // twice. 22: B, 22 + 35 = 57, data 158.
    check(16, {121, 158, 122, 123}, 2, 0, 2);
  }
  SECTION("cap 1: B goes once it has been passed over once") {
    // 0: A (121). 20: C hits (122), B passed once. 21: B has been passed over 1 >= 1 times: served before E's
    // hit, 21 + 35 = 56, transfer 56-57, data 157. 56: E, row 1 now open: 56 + 35 = 91, data 192.
    check(1, {121, 157, 122, 192}, 1, 1, 1);
  }
}

TEST_CASE("dram scheduler: keys are refused where the model is not built, naming them",
          "[memory][frfcfs][config]") {
  TimingConfig c;
  CHECK(c.dram_scheduler == rtu::hw::DramScheduler::kFcfs);  // off by default
  CHECK(c.dram_frfcfs_cap == 16);
  c.dram_scheduler = rtu::hw::DramScheduler::kFrFcfs;
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("dram_banks > 0"));
  c.dram_banks = 4;
  c.validate();
  set_timing_key(c, "prefetcher", "none");
  c.prefetcher = rtu::hw::PrefetcherId{1};  // next_line: set_timing_key would refuse it here
  CHECK_THROWS_WITH(c.validate(), Catch::Contains("prefetcher = next_line"));
  c.prefetcher = rtu::hw::PrefetcherId::kNone;
  CHECK_THROWS_WITH(set_timing_key(c, "dram_scheduler", "fifo"), Catch::Contains("must be fcfs or frfcfs"));
  CHECK_THROWS_WITH(rtu::hw::set_timing_key(c, "dram_frfcfs_cap", "-1"), Catch::Contains("dram_frfcfs_cap"));
}

namespace {

// Random rays over 256 nodes of a line each (one line per fetch), four node fetches a ray.
std::vector<std::vector<rtu::hw::TraceEvent>> random_event_rays(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<std::vector<rtu::hw::TraceEvent>> rays(n);
  for (auto& r : rays)
    for (int i = 0; i < 4; ++i)
      r.push_back(rtu::hw::TraceEvent{rtu::hw::TraceEvent::kNode, 4, 0, 0, uint32_t(rng() % 256)});
  return rays;
}

rtu::hw::TimingModel::Layout lines_layout() {
  rtu::hw::TimingModel::Layout l;
  l.node_bytes = 64;
  l.total_bytes = 64 * 256;
  return l;
}

// A chip of `units` units sharing one memory (units = 1: the unit's own memory), 16 slots each, a 1 KiB node
// cache; each unit gets its share of `rays` (waves of 16). Returns the summed statistics.
TimingStats run(const TimingConfig& c, int units, std::vector<std::vector<rtu::hw::TraceEvent>> rays) {
  using rtu::hw::TimingModel;
  TimingStats total;
  if (units == 1) {
    TimingModel u(c, lines_layout());
    u.begin(rays.size(), total);
    u.feed(rays.data(), rays.size());
    u.finish();
    return total;
  }
  MemorySystem mem(c);
  std::vector<std::unique_ptr<TimingModel>> own;
  std::vector<TimingModel*> ptr;
  const size_t n = size_t(units);
  std::vector<TimingStats> s(n);
  std::vector<std::vector<std::vector<rtu::hw::TraceEvent>>> mine(n);
  for (size_t i = 0; i < rays.size(); ++i) mine[(i / 16) % n].push_back(rays[i]);
  for (int u = 0; u < units; ++u) {
    own.push_back(std::make_unique<TimingModel>(c, lines_layout(), &mem, uint32_t(u)));
    ptr.push_back(own.back().get());
    own.back()->begin(mine[size_t(u)].size(), s[size_t(u)]);
  }
  std::vector<bool> given(n, false);
  const uint64_t end = rtu::hw::run_units_in_step(ptr, 0, [&](size_t u) {
    REQUIRE(!given[u]);
    given[u] = true;
    ptr[u]->add_rays(mine[u].data(), mine[u].size());
  });
  for (const TimingStats& x : s) total.add(x);
  total.cycles = end;
  return total;
}

TimingConfig small_unit(const std::string& scheduler, int cap, bool l2) {
  TimingConfig c = one_bank(scheduler, cap);
  c.ray_slots = 16;
  c.cache_kib = 1;  // 16 lines: most fetches miss
  c.stack_entries = 64;
  if (l2) {
    c.l2_kib = 4;  // 64 lines of the 256: misses reach the DRAM
    c.l2_slices = 1;
    c.l2_ways = 4;
    c.l2_latency = 10;
    c.l2_bytes_per_cycle = 0;  // unlimited: every DRAM request arrives cache_latency + 10 after its fetch
  }
  c.validate();
  return c;
}

}  // namespace

TEST_CASE("dram scheduler: queued FCFS (cap 0) gives the default's cycles through the timing model",
          "[memory][frfcfs][chip]") {
  // With one bank and requests arriving in the order they are made (one line per fetch, no stack traffic, an L2
  // whose port never waits), the oldest-first queue serves what the synchronous FCFS serves, at the same cycles,
  // whatever the slot waits and wake-ups in between: one unit on its own memory, and two units through an L2.
  for (int units : {1, 2}) {
    CAPTURE(units);
    const bool l2 = units > 1;
    const auto rays = random_event_rays(200, 11);
    const TimingStats a = run(small_unit("fcfs", 16, l2), units, rays);
    const TimingStats b = run(small_unit("frfcfs", 0, l2), units, rays);
    CHECK(a.cycles > 0);
    for (const rtu::hw::TimingCounter& k : rtu::hw::timing_counters()) {
      if (k.member == &TimingStats::dram_capped) continue;  // the cap's own count
      CAPTURE(k.name);
      CHECK(a.*k.member == b.*k.member);
    }
    // FR-FCFS proper on the same rays: hits on open rows go first, and the run is another.
    const TimingStats f = run(small_unit("frfcfs", 16, l2), units, rays);
    CHECK(f.dram_reordered > 0);
    CHECK(f.dram_row_hits > a.dram_row_hits);
    CHECK(f.rays == a.rays);
    CHECK(f.box_tests == a.box_tests);
  }
}
