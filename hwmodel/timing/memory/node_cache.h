// The timed device's node cache: node, primitive record and plane fetches go through it into the memory behind it
// (memory_system.h: the DRAM channel, or an L2 and banked DRAM).
//
// Models: cache_kib of line_bytes lines, cache_ways-way set associative, LRU replacement; a hit's data is there
// cache_latency cycles after the access (or when the line arrives, for a line still in flight: it is waited for,
// not fetched twice); a miss asks the memory for the line cache_latency cycles after the access. The set
// is the line number modulo the number of sets. cache_kib = 0: no cache, every access goes to DRAM.
// Any number of accesses per cycle (no port or bank conflicts); no MSHR limit.
// Left out: write-allocate of stack spills (they bypass the cache), replacement other than LRU. Prefetch fills
// come from a fetch observer (prefetch/fetch_observer.h), off by default.
//
// Sampled timing warms the cache without simulating time: warm() takes lines in order (what forward functional
// warming does); the backward walk (walk_*) finds how few of the lines before a point fix the cache the rays after
// it meet, and installs them as warm() would (timing_model.h says how the timing model drives it).
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/timing/memory/memory_system.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

// The TimingStats fields an access counts its hit or miss in, a template argument of access() so that the choice
// costs the timing loop nothing: the node cache's, or those of the micromaps' own cache (omm_cache_kib).
struct NodeCacheCounters {
  static constexpr uint64_t TimingStats::*hits = &TimingStats::cache_hits;
  static constexpr uint64_t TimingStats::*misses = &TimingStats::cache_misses;
};
struct OmmCacheCounters {
  static constexpr uint64_t TimingStats::*hits = &TimingStats::omm_cache_hits;
  static constexpr uint64_t TimingStats::*misses = &TimingStats::omm_cache_misses;
};

class NodeCache {
 public:
  explicit NodeCache(const TimingConfig& c);
  // Bytes a cache of configuration c holds: its lines, prefetch buffer and prefetch marks; with `walk`, also the
  // backward walk's scratch (walk_start: a seen line per way, a count and an open count per set). Not the walk's
  // marks, which grow with the image's lines.
  static uint64_t state_bytes(const TimingConfig& c, bool walk);
  bool enabled() const { return !m_lines.empty(); }
  uint64_t latency() const { return m_latency; }

  // An access to `line` at cycle t: returns the cycle its data is there. Counts a hit or a miss in Counters'.
  template <class Counters = NodeCacheCounters>
  uint64_t access(uint64_t line, uint64_t t, MemorySystem& mem, TimingStats& s) {
    if (m_lines.empty()) {
      ++(s.*Counters::misses);
      return mem.read_line(line, t, s);
    }
    Line* ways = set_ways(line);
    const int w = find_way(ways, line);
    if (w >= 0) {
      Line& l = ways[w];
      ++(s.*Counters::hits);
      l.stamp = ++m_stamp;
      if (!m_prefetched.empty() && m_prefetched[size_t(&l - m_lines.data())]) [[unlikely]] {
        ++s.prefetch_useful;
        s.prefetch_late += l.ready > t;  // on its way: it saves only the part of the latency it covered
        m_prefetched[size_t(&l - m_lines.data())] = 0;
      }
      if (is_pending(l.ready)) [[unlikely]]
        return mem.pending()->after(l.ready, t + m_latency, m_latency);
      return std::max(t, l.ready) + m_latency;
    }
    Line* victim = lru_way(ways);
    if (!m_buffer.empty()) [[unlikely]] {
      if (const int b = buffered(line); b >= 0) {
        ++(s.*Counters::hits);
        return from_buffer(m_buffer[size_t(b)], victim, t, s);
      }
    }
    ++(s.*Counters::misses);
    if (!m_prefetched.empty()) evict_prefetched(victim, s);
    victim->tag = line;
    victim->stamp = ++m_stamp;
    victim->ready = mem.read_line(line, t + m_latency, s);
    if (is_pending(victim->ready)) [[unlikely]]
      mem.pending()->watch(&victim->ready);  // a queued DRAM decides it later (dram_scheduler.h)
    return victim->ready;
  }

  // A prefetcher's fill at cycle t (prefetch/fetch_observer.h): unless the line is there or on its way, it is
  // brought in as the most recent of its set, asked of the memory cache_latency after t as a miss would be; with a
  // prefetch buffer (prefetch_buffer lines), into the buffer's least recent entry instead, and a demand access
  // that misses the cache and finds it there is a hit that moves it into the cache. Counts prefetch_fills or
  // prefetch_redundant, never a hit or a miss. Without a cache: nothing.
  void prefetch(uint64_t line, uint64_t t, MemorySystem& mem, TimingStats& s);
  // Marks prefetched lines from now on, for prefetch_useful (a unit with a prefetcher calls it once).
  void track_prefetches() { m_prefetched.assign(m_lines.size(), 0); }

  // Whether the line is in the cache (or on its way): an access to it now would hit. Changes nothing.
  bool holds(uint64_t line) const {
    if (m_lines.empty()) return false;
    if (find_way(&m_lines[set_of(line) * m_ways], line) >= 0) return true;
    return !m_buffer.empty() && buffered(line) >= 0;
  }

  // Functional warming: the line is made the most recent of its set (brought in, ready at once, if absent).
  void warm(uint64_t line);

  // The backward walk. An LRU cache's contents at a point are, in each set, the cache_ways most recent distinct
  // lines touched before it. walk_need() names the lines the rays after the point touch (in any order, repeats
  // allowed); walk_start() begins the walk; walk_see() then takes the lines before the point from the latest
  // backwards. A needed line is determined once it is seen (it is in the cache at the point) or its set has
  // cache_ways other lines seen (it is not). walk_install() puts into the cache what warming forward with the seen
  // lines would: the same contents and LRU order, in time proportional to the sets touched.
  void walk_reset();  // forgets the previous walk (call before walk_need)
  void walk_need(uint64_t line);
  void walk_start();
  void walk_see(uint64_t line);
  size_t walk_needed() const { return m_walk_need.size(); }  // distinct lines named by walk_need
  size_t walk_open() const { return m_walk_undetermined; }   // of them, not yet determined
  void walk_install();

 private:
  struct Line {
    uint64_t tag = ~uint64_t(0);
    uint64_t stamp = 0;  // LRU: larger is more recent; 0: never used
    uint64_t ready = 0;  // cycle the data is in the cache
  };
  uint64_t set_of(uint64_t line) const { return m_set_mask ? line & m_set_mask : line % m_sets; }
  Line* set_ways(uint64_t line) { return &m_lines[set_of(line) * m_ways]; }
  // The way of a set holding line, or -1. Every way is compared, without an early exit: which way holds the line
  // is data (a bit mask), not a branch; a line is in at most one way.
  int find_way(const Line* ways, uint64_t line) const {
    uint64_t match = 0;
    if (m_ways == 4) {  // the presets' associativity: unrolled
      match = uint64_t(ways[0].tag == line) | uint64_t(ways[1].tag == line) << 1 |
              uint64_t(ways[2].tag == line) << 2 | uint64_t(ways[3].tag == line) << 3;
    } else {
      for (uint64_t w = 0; w < m_ways; ++w) match |= uint64_t(ways[w].tag == line) << w;
    }
    return match != 0 ? __builtin_ctzll(match) : -1;
  }
  Line* lru_way(Line* ways) const {
    Line* victim = ways;  // the first of the least recent; never-used lines have stamp 0
    for (uint64_t w = 1; w < m_ways; ++w)
      if (ways[w].stamp < victim->stamp) victim = &ways[w];
    return victim;
  }

  uint64_t m_ways, m_line_bytes, m_latency;
  std::vector<Line> m_lines;
  uint64_t m_sets = 0, m_stamp = 0;
  uint64_t m_set_mask = 0;  // m_sets - 1 when m_sets is a power of two (else 0: a division)
  // Per way, 1 for a line a prefetcher brought in that no demand access has hit yet (empty: not tracked).
  std::vector<uint8_t> m_prefetched;
  // The prefetch buffer (prefetch_buffer > 0): fully associative, LRU by stamp.
  std::vector<Line> m_buffer;
  // The buffer entry holding line, or -1.
  int buffered(uint64_t line) const {
    for (size_t i = 0; i < m_buffer.size(); ++i)
      if (m_buffer[i].tag == line) return int(i);
    return -1;
  }
  // A demand access at t that missed the cache found its line in the buffer (a hit, counted by the caller): the
  // line moves into the cache's victim way.
  uint64_t from_buffer(Line& b, Line* victim, uint64_t t, TimingStats& s);
  // The victim's line leaves: a prefetched line no demand access hit counts as unused.
  void evict_prefetched(const Line* victim, TimingStats& s) {
    uint8_t& p = m_prefetched[size_t(victim - m_lines.data())];
    s.prefetch_unused += p;
    p = 0;
  }

  // The walk: per set the distinct lines seen so far (at most cache_ways) and how many; the needed lines, per set
  // how many of them are undetermined, and in all.
  std::vector<uint64_t> m_walk_lines;
  std::vector<uint8_t> m_walk_count;
  std::vector<uint64_t> m_walk_need;  // in the order first named
  std::vector<uint8_t> m_walk_mark;   // by line number: 1 for the lines in m_walk_need
  std::vector<uint32_t> m_walk_open;
  std::vector<uint32_t> m_walk_sets;  // the sets the walk has seen a line of
  std::vector<Line> m_walk_fresh;     // walk_install's scratch: a set's new contents
  size_t m_walk_undetermined = 0;
};

}  // namespace rtu::hw
