#include "hwmodel/timing/memory/node_cache.h"

#include <algorithm>

namespace rtu::hw {

NodeCache::NodeCache(const TimingConfig& c)
    : m_ways(uint64_t(c.cache_ways)), m_line_bytes(uint64_t(c.line_bytes)), m_latency(uint64_t(c.cache_latency)) {
  if (c.cache_kib > 0) {
    const uint64_t lines = uint64_t(c.cache_kib) * 1024 / m_line_bytes;
    m_sets = lines / m_ways;
    if ((m_sets & (m_sets - 1)) == 0) m_set_mask = m_sets - 1;
    m_lines.assign(lines, Line{});
    m_buffer.assign(size_t(c.prefetch_buffer), Line{});
  }
}

uint64_t NodeCache::state_bytes(const TimingConfig& c, bool walk) {
  if (c.cache_kib <= 0) return 0;
  const uint64_t lines = uint64_t(c.cache_kib) * 1024 / uint64_t(c.line_bytes),
                 sets = lines / uint64_t(c.cache_ways);
  uint64_t b = lines * (sizeof(Line) + sizeof(uint8_t)) + uint64_t(c.prefetch_buffer) * sizeof(Line);
  if (walk) b += lines * sizeof(uint64_t) + sets * (sizeof(uint8_t) + sizeof(uint32_t) + sizeof(uint32_t));
  return b;
}

void NodeCache::warm(uint64_t line) {
  if (m_lines.empty()) return;
  Line* ways = set_ways(line);
  const int w = find_way(ways, line);
  if (w >= 0) {
    ways[w].stamp = ++m_stamp;
    return;
  }
  Line* victim = lru_way(ways);
  *victim = Line{line, ++m_stamp, 0};  // in the cache, no time spent
  if (!m_prefetched.empty()) m_prefetched[size_t(victim - m_lines.data())] = 0;
}

uint64_t NodeCache::from_buffer(Line& b, Line* victim, uint64_t t, TimingStats& s) {
  ++s.prefetch_useful;
  s.prefetch_late += b.ready > t;
  if (!m_prefetched.empty()) evict_prefetched(victim, s);
  *victim = Line{b.tag, ++m_stamp, b.ready};
  b = Line{};
  return std::max(t, victim->ready) + m_latency;
}

void NodeCache::prefetch(uint64_t line, uint64_t t, MemorySystem& mem, TimingStats& s) {
  if (m_lines.empty()) return;
  Line* ways = set_ways(line);
  if (find_way(ways, line) >= 0 || (!m_buffer.empty() && buffered(line) >= 0)) {
    ++s.prefetch_redundant;
    return;
  }
  if (!m_buffer.empty()) {
    Line* victim = &m_buffer[0];
    for (Line& b : m_buffer)
      if (b.stamp < victim->stamp) victim = &b;
    s.prefetch_unused += victim->stamp != 0;  // a buffered line is one no demand access has hit
    ++s.prefetch_fills;
    *victim = Line{line, ++m_stamp, mem.read_line(line, t + m_latency, s)};
    return;
  }
  Line* victim = lru_way(ways);
  ++s.prefetch_fills;
  if (!m_prefetched.empty()) evict_prefetched(victim, s);
  victim->tag = line;
  victim->stamp = ++m_stamp;
  victim->ready = mem.read_line(line, t + m_latency, s);
  if (!m_prefetched.empty()) m_prefetched[size_t(victim - m_lines.data())] = 1;
}

void NodeCache::walk_reset() {
  for (uint64_t line : m_walk_need) m_walk_mark[size_t(line)] = 0;  // the previous walk's marks
  m_walk_need.clear();
  m_walk_undetermined = 0;
}

void NodeCache::walk_need(uint64_t line) {
  if (line >= m_walk_mark.size()) m_walk_mark.resize(size_t(line) + 1, 0);  // lines of the image: bounded
  if (!m_walk_mark[size_t(line)]) {
    m_walk_mark[size_t(line)] = 1;
    m_walk_need.push_back(line);
  }
}

void NodeCache::walk_start() {
  m_walk_lines.assign(m_lines.size(), 0);
  m_walk_count.assign(size_t(m_sets), 0);
  m_walk_sets.clear();
  m_walk_open.assign(size_t(m_sets), 0);
  for (uint64_t line : m_walk_need) ++m_walk_open[size_t(set_of(line))];
  m_walk_undetermined = m_walk_need.size();
}

void NodeCache::walk_see(uint64_t line) {
  // A set's lines are kept in the order they are seen (most recent first), the order warming forward leaves them.
  const size_t W = size_t(m_ways);
  const size_t set = size_t(set_of(line));
  uint8_t& c = m_walk_count[set];
  if (c == W) return;
  uint64_t* seen = &m_walk_lines[set * W];
  for (size_t w = 0; w < c; ++w)
    if (seen[w] == line) return;
  if (c == 0) m_walk_sets.push_back(uint32_t(set));
  seen[c] = line;
  if (line < m_walk_mark.size() && m_walk_mark[size_t(line)]) {  // a needed line: in the cache at the point
    --m_walk_open[set];
    --m_walk_undetermined;
  }
  if (++c == W) {  // the set is full: its needed lines not seen are not in the cache at the point
    m_walk_undetermined -= m_walk_open[set];
    m_walk_open[set] = 0;
  }
}

void NodeCache::walk_install() {
  if (m_lines.empty()) return;
  const size_t W = size_t(m_ways);
  // Warming forward with the lines seen would touch each set's seen lines in the order opposite to the walk's and
  // leave, per set, those lines (the most recent first) over the lines it held before and were not touched, in
  // their old order, cut to cache_ways; a line already held keeps its ready cycle, a new one is ready at 0.
  // Written directly: stamps above every stamp so far, in that order (LRU compares stamps within a set only, and
  // which way holds a line is not observable: a line is in at most one way, and empty ways are all alike).
  const uint64_t base = m_stamp;
  m_walk_fresh.resize(W);
  for (uint32_t set : m_walk_sets) {
    const size_t c = m_walk_count[set];
    const uint64_t* seen = &m_walk_lines[size_t(set) * W];
    Line* ways = &m_lines[size_t(set) * W];
    if (!m_prefetched.empty()) std::fill_n(&m_prefetched[size_t(set) * W], W, uint8_t(0));
    size_t k = 0;
    for (size_t j = 0; j < c; ++j) {
      const int w = find_way(ways, seen[j]);
      m_walk_fresh[k++] = Line{seen[j], base + uint64_t(c - j), w >= 0 ? ways[w].ready : 0};
    }
    // The old lines not touched, most recent first (a set's stamps are distinct; empty ways have stamp 0).
    std::sort(ways, ways + W, [](const Line& a, const Line& b) { return a.stamp > b.stamp; });
    for (size_t w = 0; w < W && k < W; ++w) {
      if (ways[w].stamp == 0) break;
      bool touched = false;
      for (size_t j = 0; j < c; ++j) touched = touched || seen[j] == ways[w].tag;
      if (!touched) m_walk_fresh[k++] = ways[w];
    }
    for (size_t w = 0; w < W; ++w) ways[w] = w < k ? m_walk_fresh[w] : Line{};
  }
  m_stamp = base + W;
}

}  // namespace rtu::hw
