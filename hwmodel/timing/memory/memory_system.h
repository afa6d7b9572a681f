// What lies behind a unit's node cache: the memory its line fills and stack spills and refills go to.
//
// Without an L2 (l2_kib = 0) and without DRAM banks (dram_banks = 0) it is the one DRAM channel of
// dram_channel.h, and the unit's cycles are what they always were. Otherwise:
// - L2 (l2_kib > 0): l2_slices slices, a line's slice its line number modulo the slices; each slice
//   l2_kib / l2_slices KiB, l2_ways-way set associative, LRU. Each slice has a port that moves
//   l2_bytes_per_cycle bytes per clock (0: unlimited): an access occupies it ceil(line_bytes / that) clocks from
//   max(request, port free). A hit's data is there l2_latency after its transfer ends (or when the line arrives,
//   for a line still in flight); a miss asks DRAM for the line l2_latency after the access starts (the tag
//   check) and the data is there when DRAM delivers it. Line fills only: stack spills and refills bypass the L2.
// - DRAM with channels or banks (dram_channels > 1 or dram_banks > 0): dram_channels channels, each with
//   dram_banks banks and an open-page row buffer of dram_row_bytes (dram_banks = 0: no rows, no activates). Lines
//   are interleaved over the channels (channel = line XOR line >> 6 XOR line >> 12, mod channels: consecutive
//   lines alternate, strided streams spread); within a channel consecutive lines fill a row, and rows rotate over
//   the banks. The channels share dram_bytes_per_cycle equally. An access to a bank whose open row is the line's
//   is a row hit; to a bank with no open row it first activates the row (dram_activate_cycles); to a bank with
//   another row open it precharges and activates (dram_precharge_cycles + dram_activate_cycles). The transfer then
//   takes the channel's data bus for ceil(bytes / channel bandwidth) clocks from max(the bank's command, bus
//   free), and the data is there dram_latency after the transfer ends, as on the single channel. A bank takes its
//   next command when the previous one's transfer has started.
// Every request is served at its own cycle in the order the unit makes them (the unit's requests come in
// cycle order), so the result is deterministic.
// Left out: refresh, read/write turnaround, request reordering (FR-FCFS), bank groups, the L2's own MSHR limit.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hwmodel/timing/memory/dram_channel.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

// DRAM with channels and open-page banks (dram_channels > 1 or dram_banks > 0; no rows without banks).
class BankedDram {
 public:
  explicit BankedDram(const TimingConfig& c);
  // A transfer of `bytes` at byte address `addr` requested at cycle t: returns the cycle its data is there.
  // Counts bytes, busy cycles and row hits and misses.
  uint64_t transfer(uint64_t addr, uint64_t bytes, uint64_t t, TimingStats& s);
  // The fewest cycles a line read can take (a row hit on an idle channel).
  uint64_t min_line_cycles() const { return m_line_cycles + m_latency; }
  uint64_t free_at() const;  // the latest cycle a channel's data bus is busy until
  // Where an address falls (for tests and the watchdog's dump).
  struct Place {
    uint32_t channel, bank;
    uint64_t row;
  };
  Place place(uint64_t addr) const;

 private:
  struct Bank {
    uint64_t open_row = ~uint64_t(0);  // none
    uint64_t ready = 0;                // next command no earlier than this
  };
  uint64_t m_latency, m_activate, m_precharge;
  double m_bytes_per_cycle;  // per channel
  uint64_t m_line_bytes, m_line_cycles, m_lines_per_row;
  uint32_t m_channels, m_banks;
  bool m_rows;                       // dram_banks > 0: open-page rows
  std::vector<Bank> m_bank;          // channel * banks + bank
  std::vector<uint64_t> m_bus_free;  // per channel
};

// The shared L2 (l2_kib > 0): slices of set-associative LRU lines in front of the DRAM.
class L2Cache {
 public:
  explicit L2Cache(const TimingConfig& c);
  bool enabled() const { return !m_lines.empty(); }
  // A line read at cycle t: returns the cycle its data is there; a miss reads it through `dram(line, t)`.
  template <class Dram>
  uint64_t access(uint64_t line, uint64_t t, Dram&& dram, TimingStats& s);
  // The fewest cycles a line read takes, when DRAM takes at least `dram_min`.
  uint64_t min_cycles(uint64_t dram_min) const { return m_latency + (m_xfer < dram_min ? m_xfer : dram_min); }

 private:
  struct Line {
    uint64_t tag = ~uint64_t(0);
    uint64_t stamp = 0;  // LRU: larger is more recent
    uint64_t ready = 0;  // the cycle its data is there
  };
  uint64_t m_latency, m_xfer;
  uint32_t m_slices, m_sets, m_ways;
  std::vector<Line> m_lines;          // slice, set, way
  std::vector<uint64_t> m_port_free;  // per slice
  uint64_t m_stamp = 0;
};

template <class Dram>
uint64_t L2Cache::access(uint64_t line, uint64_t t, Dram&& dram, TimingStats& s) {
  const uint32_t slice = uint32_t(line % m_slices);
  const uint64_t in_slice = line / m_slices;
  Line* ways = &m_lines[(uint64_t(slice) * m_sets + in_slice % m_sets) * m_ways];
  const uint64_t start = t > m_port_free[slice] ? t : m_port_free[slice];
  m_port_free[slice] = start + m_xfer;
  s.mem_wait_cycles += start - t;
  Line* victim = ways;
  for (uint32_t w = 0; w < m_ways; ++w) {
    if (ways[w].tag == line) {
      ++s.l2_hits;
      ways[w].stamp = ++m_stamp;
      const uint64_t ready = start + m_xfer + m_latency;
      return ready > ways[w].ready ? ready : ways[w].ready;
    }
    if (ways[w].stamp < victim->stamp) victim = &ways[w];
  }
  ++s.l2_misses;
  victim->tag = line;
  victim->stamp = ++m_stamp;
  victim->ready = dram(line, start + m_latency);
  return victim->ready;
}

// Bytes moved over time: DRAM bytes by the cycle their transfer ends, L2 line accesses (hits and misses, a line
// each) by the cycle they are asked for, in bins of bin_cycles from cycle 0 (the device's cycles since bind). The
// bins start kTimelineBin wide and double (pairs merged) whenever a cycle falls beyond kTimelineBins bins, so the
// series stays at most that long however long the run.
struct MemoryTimeline {
  static constexpr uint64_t kTimelineBin = 256;
  static constexpr size_t kTimelineBins = 4096;
  uint64_t bin_cycles = kTimelineBin;
  std::vector<uint64_t> dram_bytes, l2_bytes;
  void add(std::vector<uint64_t>& series, uint64_t cycle, uint64_t bytes);
};

// The memory behind one unit's node cache.
class MemorySystem {
 public:
  explicit MemorySystem(const TimingConfig& c);
  // A line read at cycle t (a node cache fill): the cycle its data is there.
  uint64_t read_line(uint64_t line, uint64_t t, TimingStats& s);
  // An 8-byte stack entry at byte address `addr`: a spill (bandwidth only) and a refill (its data's cycle).
  void write_word(uint64_t addr, uint64_t t, TimingStats& s);
  uint64_t read_word(uint64_t addr, uint64_t t, TimingStats& s);
  // The fewest cycles a line read takes (a lower bound the timing model's early requests rely on).
  uint64_t min_line_cycles() const;
  uint64_t free_at() const;  // the cycle the DRAM is free for the next transfer (the watchdog's dump)
  bool simple() const { return !m_banked && !m_l2.enabled(); }
  const MemoryTimeline& timeline() const { return m_timeline; }

 private:
  uint64_t dram_line(uint64_t line, uint64_t t, TimingStats& s);
  uint64_t m_line_bytes;
  bool m_banked;
  DramChannel m_channel;  // dram_banks = 0
  BankedDram m_dram;      // dram_channels > 1 or dram_banks > 0
  L2Cache m_l2;
  uint64_t m_latency;  // dram_latency: a transfer ends this long before its data is there
  MemoryTimeline m_timeline;
  uint64_t dram(uint64_t addr, uint64_t bytes, uint64_t t, TimingStats& s);  // one transfer, on the timeline
};

}  // namespace rtu::hw
