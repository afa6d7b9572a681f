// The memory behind a unit's node cache (memory_system.h): exact cycles of the L2 and the banked DRAM on small
// hand-worked configurations, and the equivalences that tie the new models to the single channel.
#include <catch2/catch.hpp>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "hwmodel/timing/memory/dram_channel.h"
#include "hwmodel/timing/memory/memory_system.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_model.h"
#include "hwmodel/timing/timing_stats.h"

using namespace rtu::hw;

namespace {

// DRAM of `channels` channels with 2 banks each, 256-byte rows (4 lines of 64 bytes), latency 100, activate 20,
// precharge 15, 64 bytes per clock in all.
TimingConfig banked(int channels) {
  TimingConfig c;
  c.line_bytes = 64;
  c.dram_latency = 100;
  c.dram_bytes_per_cycle = 64;
  c.dram_channels = channels;
  c.dram_banks = 2;
  c.dram_row_bytes = 256;
  c.dram_activate_cycles = 20;
  c.dram_precharge_cycles = 15;
  c.validate();
  return c;
}

// A 1 KiB L2 (16 lines of 64 bytes: 2 slices of 4 sets of 2 ways, latency 10) whose ports move
// `l2_bytes_per_cycle` a clock, in front of one DRAM channel of 64 bytes a clock and latency 100.
TimingConfig small_l2(double l2_bytes_per_cycle) {
  TimingConfig c;
  c.line_bytes = 64;
  c.dram_latency = 100;
  c.dram_bytes_per_cycle = 64;
  c.l2_kib = 1;
  c.l2_slices = 2;
  c.l2_ways = 2;
  c.l2_latency = 10;
  c.l2_bytes_per_cycle = l2_bytes_per_cycle;
  c.validate();
  return c;
}

}  // namespace

TEST_CASE("banked DRAM: row hits, empty banks and row conflicts cost what the open-page model says", "[memory]") {
  const TimingConfig c = banked(1);
  BankedDram d(c);
  TimingStats s;
  // Line 0: bank 0 row 0, no row open: activate (20), then one clock of transfer, then the latency (100).
  CHECK(d.place(0).bank == 0);
  CHECK(d.transfer(0 * 64, 64, 0, s) == 20 + 1 + 100);
  // Line 1, the same row: a row hit; the bank's command at 20, the bus free at 21.
  CHECK(d.transfer(1 * 64, 64, 0, s) == 21 + 1 + 100);
  // Line 4: the next row, bank 1 (rows rotate over the banks), empty: activate from 0, the bus free at 22.
  CHECK(d.place(4 * 64).bank == 1);
  CHECK(d.place(4 * 64).row == 0);
  CHECK(d.transfer(4 * 64, 64, 0, s) == 22 + 1 + 100);
  // Line 8: bank 0 again, row 1, while row 0 is open: precharge and activate after the bank's last command (21).
  CHECK(d.place(8 * 64).bank == 0);
  CHECK(d.place(8 * 64).row == 1);
  CHECK(d.transfer(8 * 64, 64, 0, s) == 21 + 15 + 20 + 1 + 100);
  CHECK(s.dram_row_hits == 1);
  CHECK(s.dram_row_misses == 3);
  CHECK(s.dram_bytes == 4 * 64);
  CHECK(s.dram_busy_cycles == 4);
}

TEST_CASE("banked DRAM: two channels move lines in parallel at half the bandwidth each", "[memory]") {
  BankedDram two(banked(2));
  BankedDram one(banked(1));
  TimingStats s2, s1;
  // Lines 0 and 1 on two channels: both activate at 0 and transfer for 2 clocks (32 bytes per clock each).
  CHECK(two.place(0).channel == 0);
  CHECK(two.place(64).channel == 1);
  CHECK(two.transfer(0, 64, 0, s2) == 20 + 2 + 100);
  CHECK(two.transfer(64, 64, 0, s2) == 20 + 2 + 100);
  // On one channel the second line waits for the bus: one clock each, one after the other.
  CHECK(one.transfer(0, 64, 0, s1) == 20 + 1 + 100);
  CHECK(one.transfer(64, 64, 0, s1) == 21 + 1 + 100);
}

TEST_CASE("banked DRAM without row costs on one channel is the single channel, transfer for transfer",
          "[memory]") {
  TimingConfig c = banked(1);
  c.dram_activate_cycles = c.dram_precharge_cycles = 0;
  BankedDram b(c);
  DramChannel ch(c);
  TimingStats sb, sc;
  // Requests in cycle order, as a unit makes them: lines scattered over rows and banks, 8-byte words between.
  uint64_t t = 0;
  for (uint64_t i = 0; i < 2000; ++i) {
    t += (i * 7919) % 5;
    const uint64_t addr = ((i * 104729) % 4096) * 64;
    const uint64_t bytes = i % 3 == 0 ? 8 : 64;
    CAPTURE(i);
    REQUIRE(b.transfer(addr, bytes, t, sb) == ch.transfer(bytes, t, sc));
  }
  CHECK(sb.dram_bytes == sc.dram_bytes);
  CHECK(sb.dram_busy_cycles == sc.dram_busy_cycles);
}

TEST_CASE("L2: a miss goes to DRAM after the tag check, a hit costs its port and latency, in-flight lines wait",
          "[memory]") {
  const TimingConfig c = small_l2(32);  // 2 clocks per line
  MemorySystem m(c);
  TimingStats s;
  // Miss: the port from 0 (2 clocks), the tag check ends at 10, DRAM from 10: 1 clock and 100.
  CHECK(m.read_line(0, 0, s) == 10 + 1 + 100);
  // The same line at 50, still in flight: the hit's own time (50 + 2 + 10) is earlier than the line: wait for it.
  CHECK(m.read_line(0, 50, s) == 111);
  // At 200: a hit, port and latency.
  CHECK(m.read_line(0, 200, s) == 200 + 2 + 10);
  // Two hits on one slice in the same clock: the second waits for the port.
  CHECK(m.read_line(0, 300, s) == 300 + 2 + 10);
  CHECK(m.read_line(0, 300, s) == 302 + 2 + 10);
  // Line 1 is on the other slice: its port is free.
  CHECK(m.read_line(1, 300, s) == 300 + 10 + 1 + 100);
  CHECK(s.l2_hits == 4);
  CHECK(s.l2_misses == 2);
  CHECK(s.dram_bytes == 2 * 64);
  // LRU within a set: lines 0, 8, 16 share slice 0's set 0 (2 ways); after 8 and 16, 0 is gone.
  CHECK(m.read_line(8, 1000, s) > 1000 + 100);
  CHECK(m.read_line(16, 1000, s) > 1000 + 100);
  const uint64_t misses = s.l2_misses;
  m.read_line(0, 2000, s);
  CHECK(s.l2_misses == misses + 1);
  // Unlimited bandwidth (0) and no latency: a hit is there at once.
  TimingConfig z = c;
  z.l2_latency = 0;
  z.l2_bytes_per_cycle = 0;
  MemorySystem mz(z);
  TimingStats sz;
  CHECK(mz.read_line(5, 0, sz) == 0 + 1 + 100);
  CHECK(mz.read_line(5, 500, sz) == 500);
  CHECK(mz.min_line_cycles() == 0);
}

TEST_CASE("L2: stack words are written without a fill, read back from the L2, and dirty lines written back",
          "[memory]") {
  MemorySystem m(small_l2(4));  // a line holds the port 16 clocks, a word 2
  TimingStats s;
  // A spill at 0 to line 0 (byte 0): a miss that allocates without reading DRAM; it holds slice 0's port 2 clocks.
  m.write_word(0, 0, s);
  CHECK(s.l2_stack_misses == 1);
  CHECK(s.dram_bytes == 0);
  CHECK(s.mem_wait_cycles == 0);
  // A second spill at 0, byte 8 of the same line: a hit, after the first word's 2 clocks (a write's wait is not a
  // ray's: not counted).
  m.write_word(8, 0, s);
  CHECK(s.l2_stack_hits == 1);
  CHECK(s.mem_wait_cycles == 0);
  CHECK(s.l2_port_cycles == 4);
  // Its refill at 50: a hit, the word's 2 clocks and the latency. No DRAM, unlike a unit without an L2.
  CHECK(m.read_word(8, 50, s) == 50 + 2 + 10);
  CHECK(s.l2_stack_hits == 2);
  CHECK(s.dram_bytes == 0);
  // A refill of a word whose line is not there (line 2, slice 0, set 1): read from DRAM as a fill is.
  CHECK(m.read_word(2 * 64, 100, s) == 100 + 10 + 1 + 100);
  CHECK(s.l2_stack_misses == 2);
  CHECK(s.dram_bytes == 64);
  // Lines 8 and 16 share set 0 of slice 0 with the dirty line 0: the second of them evicts it, which writes it
  // back (a line to DRAM, bandwidth only) when its access starts.
  m.read_line(8, 1000, s);
  CHECK(s.l2_writebacks == 0);
  const uint64_t bytes = s.dram_bytes;
  m.read_line(16, 2000, s);
  CHECK(s.l2_writebacks == 1);
  CHECK(s.dram_bytes == bytes + 64 + 64);  // the write-back and line 16's fill
  // Line 0 is clean once gone: reading it again is a miss, and evicting it later writes nothing.
  CHECK(m.read_word(0, 3000, s) > 3000 + 100);
  m.read_line(8, 4000, s);
  m.read_line(16, 5000, s);
  CHECK(s.l2_writebacks == 1);
}

TEST_CASE("without an L2 stack words go to DRAM as before", "[memory]") {
  TimingConfig c;
  c.line_bytes = 64;
  c.dram_latency = 100;
  c.dram_bytes_per_cycle = 8;
  c.validate();
  MemorySystem m(c);
  TimingStats s;
  m.write_word(0, 0, s);
  CHECK(m.read_word(0, 0, s) == 1 + 1 + 100);  // after the spill's clock on the channel
  CHECK(s.dram_bytes == 16);
  CHECK(s.l2_stack_hits + s.l2_stack_misses + s.l2_port_cycles == 0);
}

TEST_CASE("DRAM channels without banks: lines interleave, no rows", "[memory]") {
  // 2 channels sharing 8 bytes per clock: 4 each, so a 64-byte line holds its channel's bus 16 clocks; data 50
  // clocks after the transfer. Lines 0 and 1 fall on channels 0 and 1 (the hash leaves small line numbers alone),
  // line 2 on channel 0 again.
  TimingConfig c;
  c.dram_channels = 2;
  c.dram_banks = 0;
  c.dram_bytes_per_cycle = 8.0;
  c.dram_latency = 50;
  c.dram_activate_cycles = 30;  // no rows: never paid
  rtu::hw::MemorySystem m(c);
  TimingStats s;
  CHECK(m.read_line(0, 0, s) == 16 + 50);
  CHECK(m.read_line(1, 0, s) == 16 + 50);  // its own channel: in parallel
  CHECK(m.read_line(2, 0, s) == 32 + 50);  // behind line 0 on channel 0
  CHECK(s.dram_row_hits + s.dram_row_misses == 0);
  CHECK(s.dram_bytes == 3 * 64);
}

TEST_CASE("memory keys: ranges and rules are checked, naming the key", "[memory][config]") {
  auto bad = [](const char* key, const char* value) {
    TimingConfig c;
    return rtu::hw::set_timing_key(c, key, value);
  };
  CHECK_THROWS_WITH(bad("l2_kib", "3"), Catch::Contains("l2_kib"));  // not a whole number of sets per slice
  CHECK_THROWS_WITH(bad("dram_channels", "0"), Catch::Contains("dram_channels"));
  CHECK_THROWS_WITH(bad("dram_row_bytes", "100"), Catch::Contains("dram_row_bytes"));
  CHECK_THROWS_WITH(bad("l2_bytes_per_cycle", "-1"), Catch::Contains("l2_bytes_per_cycle"));
  CHECK_THROWS_WITH(bad("dram_banks", "65"), Catch::Contains("dram_banks"));
  TimingConfig c;
  CHECK_NOTHROW(rtu::hw::set_timing_key(c, "l2_kib", "4096"));
  CHECK_NOTHROW(rtu::hw::set_timing_key(c, "dram_banks", "16"));
}

namespace {

// A unit reduced to its memory path: no cache, one slot, no pipeline latencies but a 1-clock box unit; 64-byte
// nodes, one line each; DRAM 100 cycles behind an 8-byte-per-clock channel (8 clocks per line).
TimingConfig bare() {
  TimingConfig c = rtu::hw::timing_preset("rdna2");
  c.cache_kib = 0;
  c.ray_slots = 1;
  c.queue_depth = 1;
  c.packet_latency = c.ray_fetch_latency = c.setup_latency = c.traversal_latency = c.writeback_latency = 0;
  c.box_latency = 1;
  c.dram_latency = 100;
  c.dram_bytes_per_cycle = 8;
  c.validate();
  return c;
}

rtu::hw::TimingModel::Layout node_layout() {
  rtu::hw::TimingModel::Layout l;
  l.node_bytes = 64;
  l.total_bytes = 64 * 16;
  return l;
}

// One ray that fetches node `node` and tests its 4 children.
std::vector<rtu::hw::TraceEvent> one_node(uint32_t node) {
  return {rtu::hw::TraceEvent{rtu::hw::TraceEvent::kNode, 4, 0, 0, node}};
}

// One packet of `rays` (each a list of events) on one unit with a memory of its own, over node_layout(): the
// packet's cycles; its statistics in `s`.
uint64_t run_packet(const TimingConfig& c, std::vector<std::vector<rtu::hw::TraceEvent>> rays, TimingStats& s) {
  rtu::hw::TimingModel u(c, node_layout());
  u.begin(rays.size(), s);
  u.feed(rays.data(), rays.size());
  return u.finish();
}

}  // namespace

TEST_CASE("chip: two units contending for one DRAM channel, cycle by cycle", "[memory][chip]") {
  using rtu::hw::TimingModel;
  const TimingConfig c = bare();
  // Alone: the line from 0 (8 clocks, then 100), the box test at 108 (1 clock), its hit written at 109.
  {
    TimingStats s;
    CHECK(run_packet(c, {one_node(0)}, s) == 109);
  }
  // Two units on one memory, each fetching a line in the same clock: unit 0 first (ties go to the lower unit), so
  // unit 1's line waits 8 clocks for the channel: 117 for the chip. The same two units on their own memories: 109.
  for (bool shared : {true, false}) {
    CAPTURE(shared);
    MemorySystem mem(c);
    TimingModel u0(c, node_layout(), shared ? &mem : nullptr, 0), u1(c, node_layout(), shared ? &mem : nullptr, 1);
    std::vector<std::vector<rtu::hw::TraceEvent>> e0 = {one_node(0)}, e1 = {one_node(5)};
    TimingStats s0, s1;
    u0.begin(1, s0);
    u1.begin(1, s1);
    std::vector<TimingModel*> units = {&u0, &u1};
    int gave = 0;
    const uint64_t end = rtu::hw::run_units_in_step(units, 0, [&](size_t u) {
      ++gave;
      (u == 0 ? u0 : u1).add_rays(u == 0 ? e0.data() : e1.data(), 1);
    });
    CHECK(gave == 2);
    CHECK(end == (shared ? 117u : 109u));
    CHECK(u0.end_cycle() == 109);
    CHECK(u1.end_cycle() == (shared ? 117u : 109u));
    CHECK(s0.dram_bytes + s1.dram_bytes == 128);
  }
}

TEST_CASE("chip: an L2 hit against a miss, cycle by cycle", "[memory][chip]") {
  TimingConfig c = bare();
  // Two rays fetching the same node, one after the other (one slot).
  std::vector<std::vector<rtu::hw::TraceEvent>> ev = {one_node(3), one_node(3)};
  {
    // Without an L2 both go to DRAM: ray 0 as above (its hit written at 109, the slot free at 110); ray 1 enters
    // at 110, its line arrives at 110 + 108 = 218, the test takes a clock, its hit is written at 219.
    TimingStats s;
    CHECK(run_packet(c, ev, s) == 219);
    CHECK(s.l2_hits + s.l2_misses == 0);
  }
  c.l2_kib = 1;  // 16 lines: one slice, one set of 16 ways
  c.l2_slices = 1;
  c.l2_ways = 16;
  c.l2_latency = 20;
  c.l2_bytes_per_cycle = 64;  // 1 clock per line
  c.validate();
  TimingStats s;
  // Ray 0 misses: the tag check until 20, DRAM from 20 (8 + 100): 128, the test, the hit at 129, the slot free at
  // 130. Ray 1 enters at 130 and hits: 1 clock of port and 20 of latency: 151, the test, the hit at 152.
  CHECK(run_packet(c, ev, s) == 152);
  CHECK(s.l2_misses == 1);
  CHECK(s.l2_hits == 1);
}

namespace {

// A packet of `rays` rays, each `nodes` visits of one node (4 children, or `children`) followed by `tris` triangle
// tests, everything in one cache line after the first: the units, not memory, set the pace.
rtu::hw::TimingStats rate_run(const TimingConfig& c, int rays, int nodes, int tris, int children = 4) {
  rtu::hw::TimingModel::Layout l;
  l.node_bytes = 64;
  l.total_bytes = 4096;
  rtu::hw::TimingModel m(c, l);
  std::vector<std::vector<rtu::hw::TraceEvent>> ev(static_cast<size_t>(rays));
  for (auto& e : ev) {
    for (int i = 0; i < nodes; ++i)
      e.push_back(rtu::hw::TraceEvent{rtu::hw::TraceEvent::kNode, uint8_t(children), 0, 0, 0});
    for (int i = 0; i < tris; ++i) e.push_back(rtu::hw::TraceEvent{rtu::hw::TraceEvent::kPrim, 0, 0, 0, 0});
  }
  TimingStats s;
  m.begin(ev.size(), s);
  m.feed(ev.data(), ev.size());
  m.finish();
  return s;
}

}  // namespace

TEST_CASE("the per-clock rates the presets promise, measured on saturating streams", "[memory][chip][rates]") {
  // 2,000 rays of 50 steps: 100,000 tests. What is not at the unit's rate is the start (packet decode, ray fetch
  // and setup: tens of cycles) and the tail, where the last rays alone cannot keep the unit busy: at most one
  // ray's serial time, 50 steps of about 20 cycles (cache hit, latency, scheduler) = 1,000 cycles. So the rate
  // measured is within 1,100 / 100,000, about 1%, of the unit's: 2% is the bound.
  for (const char* preset : {"rdna2", "embedded"}) {
    CAPTURE(preset);
    const TimingConfig c = rtu::hw::timing_preset(preset);
    const TimingStats s = rate_run(c, 2000, 50, 0);
    const double per_clock = double(s.box_tests) / double(s.cycles);
    // rdna2: 4 box tests per clock (a 4-wide node a clock); embedded: 2 (a node in two clocks).
    CHECK(per_clock <= double(c.box_rate));
    CHECK(per_clock >= 0.98 * double(c.box_rate));
  }
  {
    const TimingConfig c = rtu::hw::timing_preset("rdna2");
    const TimingStats s = rate_run(c, 2000, 1, 50);
    const double per_clock = double(s.tri_tests) / double(s.cycles);  // 1 triangle test per clock
    CHECK(per_clock <= 1.0);
    CHECK(per_clock >= 0.98);
  }
  {
    // intel: two box units of rate 6, each a 6-wide node a clock: 12 box tests per clock, and 1 triangle.
    const TimingConfig c = rtu::hw::timing_preset("intel");
    const TimingStats s = rate_run(c, 2000, 50, 0, 6);
    const double per_clock = double(s.box_tests) / double(s.cycles);
    CHECK(per_clock <= 12.0);
    CHECK(per_clock >= 0.98 * 12.0);
    const TimingStats t = rate_run(c, 2000, 1, 50, 6);
    const double tri_per_clock = double(t.tri_tests) / double(t.cycles);
    CHECK(tri_per_clock <= 1.0);
    CHECK(tri_per_clock >= 0.98);
  }
}
