// The shared L2 (l2_kib > 0), a level in front of the DRAM of the memory behind a unit's node cache
// (memory_system.cpp composes it).
//
// L2 (l2_kib > 0): l2_slices slices, a line's slice its line number modulo the slices; each slice
// l2_kib / l2_slices KiB, l2_ways-way set associative, LRU. Each slice has a port that moves
// l2_bytes_per_cycle bytes per clock (0: unlimited): an access occupies it ceil(line_bytes / that) clocks from
// max(request, port free). A hit's data is there l2_latency after its transfer ends (or when the line arrives,
// for a line still in flight); a miss asks DRAM for the line l2_latency after the access starts (the tag
// check) and the data is there when DRAM delivers it.
// Stack words (a ray slot's entries beyond its short stack, 8 bytes each) go through the same slices as lines do,
// as a unit's spills go through the cache hierarchy: an access holds the slice's port ceil(8 / l2_bytes_per_cycle)
// clocks. A spill is a write: a hit marks the line dirty; a miss allocates the line without reading it (the
// slices keep byte masks, so a partial write needs no fill) and marks it dirty. A refill is a read: a hit's data
// is there l2_latency after its transfer; a miss reads the line from DRAM as a line fill does. A dirty line
// evicted by any access is written back to DRAM (a line's transfer, bandwidth only) when the access starts.
// Left out: the L2's own MSHR limit, replacement other than LRU, write-back of dirty lines still there at the
// end of a packet.
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/timing/memory/pending.h"
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
  // A dirty victim is written back through `writeback(line, t)` first.
  template <class Dram, class Writeback>
  uint64_t access(uint64_t line, uint64_t t, Dram&& dram, Writeback&& writeback, TimingStats& s);
  // A stack word in `line` at cycle t: a spill (write) or a refill (read), as above. Returns the cycle a refill's
  // data is there (for a spill, the cycle the write is done; nobody waits for it).
  template <class Dram, class Writeback>
  uint64_t word(uint64_t line, bool write, uint64_t t, Dram&& dram, Writeback&& writeback, TimingStats& s);
  // Functional warming: the line is taken (most recently used) with no time and no count; a line already there
  // keeps its arrival cycle.
  void warm(uint64_t line);
  // The fewest cycles a line read takes, when DRAM takes at least `dram_min`.
  uint64_t min_cycles(uint64_t dram_min) const { return m_latency + (m_xfer < dram_min ? m_xfer : dram_min); }
  uint64_t latency() const { return m_latency; }  // l2_latency
  // A queued DRAM behind it (dram_scheduler.h): a line's arrival may be a pending cycle of this table.
  void set_pending(PendingTable* p) { m_pending = p; }

 private:
  struct Line {
    uint64_t tag = ~uint64_t(0);
    uint64_t stamp = 0;  // LRU: larger is more recent
    uint64_t ready = 0;  // the cycle its data is there
    bool dirty = false;  // holds spilled stack words not yet written back
  };
  // The way of `line`'s set that holds it (most recent now), or null with `victim` set to the least recent way
  // (written back first if dirty, then holding `line`, clean, most recent).
  template <class Writeback>
  Line* lookup(uint64_t line, uint64_t start, Line*& victim, Writeback&& writeback, TimingStats& s);
  // The slice's port taken for `xfer` clocks from max(t, port free): the cycle the access starts.
  uint64_t take_port(uint32_t slice, uint64_t xfer, uint64_t t, bool counted_wait, TimingStats& s);
  uint64_t m_latency, m_xfer, m_word_xfer;
  uint32_t m_slices, m_sets, m_ways;
  std::vector<Line> m_lines;          // slice, set, way
  std::vector<uint64_t> m_port_free;  // per slice
  uint64_t m_stamp = 0;
  PendingTable* m_pending = nullptr;
  // max(ready, a line's arrival), which may be pending; a line's arrival from DRAM, watched while pending.
  uint64_t at_least(uint64_t ready, uint64_t arrival) {
    if (is_pending(arrival)) [[unlikely]]
      return m_pending->after(arrival, ready, 0);
    return ready > arrival ? ready : arrival;
  }
  void arrives(Line& l, uint64_t ready) {
    l.ready = ready;
    if (is_pending(ready)) [[unlikely]]
      m_pending->watch(&l.ready);
  }
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
  victim->dirty = false;
}

inline uint64_t L2Cache::take_port(uint32_t slice, uint64_t xfer, uint64_t t, bool counted_wait, TimingStats& s) {
  const uint64_t start = t > m_port_free[slice] ? t : m_port_free[slice];
  m_port_free[slice] = start + xfer;
  s.l2_port_cycles += xfer;
  if (counted_wait) s.mem_wait_cycles += start - t;
  return start;
}

template <class Writeback>
L2Cache::Line* L2Cache::lookup(uint64_t line, uint64_t start, Line*& victim, Writeback&& writeback,
                               TimingStats& s) {
  Line* ways = &m_lines[(uint64_t(line % m_slices) * m_sets + (line / m_slices) % m_sets) * m_ways];
  victim = ways;
  for (uint32_t w = 0; w < m_ways; ++w) {
    if (ways[w].tag == line) {
      ways[w].stamp = ++m_stamp;
      return &ways[w];
    }
    if (ways[w].stamp < victim->stamp) victim = &ways[w];
  }
  if (victim->dirty) {
    ++s.l2_writebacks;
    writeback(victim->tag, start);
  }
  victim->tag = line;
  victim->stamp = ++m_stamp;
  victim->dirty = false;
  return nullptr;
}

template <class Dram, class Writeback>
uint64_t L2Cache::access(uint64_t line, uint64_t t, Dram&& dram, Writeback&& writeback, TimingStats& s) {
  const uint64_t start = take_port(uint32_t(line % m_slices), m_xfer, t, true, s);
  Line* victim = nullptr;
  if (Line* l = lookup(line, start, victim, writeback, s)) {
    ++s.l2_hits;
    return at_least(start + m_xfer + m_latency, l->ready);
  }
  ++s.l2_misses;
  arrives(*victim, dram(line, start + m_latency));
  return victim->ready;
}

template <class Dram, class Writeback>
uint64_t L2Cache::word(uint64_t line, bool write, uint64_t t, Dram&& dram, Writeback&& writeback, TimingStats& s) {
  // A spill's wait is not a ray's (it leaves the slot at once); a refill's is.
  const uint64_t start = take_port(uint32_t(line % m_slices), m_word_xfer, t, !write, s);
  Line* victim = nullptr;
  Line* l = lookup(line, start, victim, writeback, s);
  if (l) {
    ++s.l2_stack_hits;
  } else {
    ++s.l2_stack_misses;
    l = victim;
    // A write allocates without a fill: its bytes are there when the port has moved them.
    arrives(*l, write ? start + m_word_xfer : dram(line, start + m_latency));
  }
  l->dirty |= write;
  const uint64_t ready = start + m_word_xfer + m_latency;
  return write ? ready : at_least(ready, l->ready);
}

}  // namespace rtu::hw
