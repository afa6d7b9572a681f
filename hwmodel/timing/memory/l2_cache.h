// The shared L2 (l2_kib > 0), a level in front of the DRAM of the memory behind a unit's node cache
// (memory_system.cpp composes it).
//
// L2 (l2_kib > 0): l2_slices slices, a line's slice its line number modulo the slices; each slice
// l2_kib / l2_slices KiB, l2_ways-way set associative, LRU. Each slice has a port that moves
// l2_bytes_per_cycle bytes per clock (0: unlimited): an access occupies it ceil(line_bytes / that) clocks from
// max(request, port free). A hit's data is there l2_latency after its transfer ends (or when the line arrives,
// for a line still in flight); a miss asks DRAM for the line l2_latency after the access starts (the tag
// check) and the data is there when DRAM delivers it. Line fills only: stack spills and refills bypass the L2.
// Left out: the L2's own MSHR limit, replacement other than LRU.
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

// The shared L2 (l2_kib > 0): slices of set-associative LRU lines in front of the DRAM.
class L2Cache {
 public:
  explicit L2Cache(const TimingConfig& c);
  // Bytes an L2 of configuration c holds (its lines and ports; 0 without an L2).
  static uint64_t state_bytes(const TimingConfig& c);
  // A line read at cycle t: returns the cycle its data is there; a miss reads it through `dram(line, t)`.
  template <class Dram>
  uint64_t access(uint64_t line, uint64_t t, Dram&& dram, TimingStats& s);
  // Functional warming: the line is taken (most recently used) with no time and no count; a line already there
  // keeps its arrival cycle.
  void warm(uint64_t line);
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

inline void L2Cache::warm(uint64_t line) {
  const uint64_t in_slice = line / m_slices;
  Line* ways = &m_lines[(uint64_t(line % m_slices) * m_sets + in_slice % m_sets) * m_ways];
  Line* victim = ways;
  for (uint32_t w = 0; w < m_ways; ++w) {
    if (ways[w].tag == line) {
      ways[w].stamp = ++m_stamp;
      return;
    }
    if (ways[w].stamp < victim->stamp) victim = &ways[w];
  }
  victim->tag = line;
  victim->stamp = ++m_stamp;
  victim->ready = 0;
}

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

}  // namespace rtu::hw
