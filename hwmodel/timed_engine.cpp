#include "hwmodel/timed_engine.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <future>
#include <iterator>
#include <stdexcept>
#include <string>

#include "hwmodel/batch.h"
#include "hwmodel/regs.h"
#include "hwmodel/rng.h"

namespace rtu::hw {

void TimingStats::add(const TimingStats& o) {
  packets += o.packets;
  cycles += o.cycles;
  rays += o.rays;
  box_tests += o.box_tests;
  tri_tests += o.tri_tests;
  sphere_tests += o.sphere_tests;
  plane_tests += o.plane_tests;
  box_issue_cycles += o.box_issue_cycles;
  tri_issue_cycles += o.tri_issue_cycles;
  node_fetches += o.node_fetches;
  prim_fetches += o.prim_fetches;
  cache_hits += o.cache_hits;
  cache_misses += o.cache_misses;
  dram_bytes += o.dram_bytes;
  dram_busy_cycles += o.dram_busy_cycles;
  stream_bytes += o.stream_bytes;
  stack_spills += o.stack_spills;
  stack_refills += o.stack_refills;
  queue_stall_cycles += o.queue_stall_cycles;
  slot_busy_cycles += o.slot_busy_cycles;
}

TimingModel::TimingModel(const TimingConfig& c, const Layout& layout) : m_c(c), m_layout(layout) {
  c.validate();
  if (c.cache_kib > 0) {
    const uint64_t lines = uint64_t(c.cache_kib) * 1024 / uint64_t(c.line_bytes);
    m_sets = lines / uint64_t(c.cache_ways);
    if ((m_sets & (m_sets - 1)) == 0) m_set_mask = m_sets - 1;
    m_cache.assign(lines, Line{});
  }
  m_box_free.assign(size_t(c.box_units), 0);
  m_tri_free.assign(size_t(c.tri_units) * size_t(c.tri_rate), 0);  // a unit of rate r: r issue slots per clock
  m_slots.resize(size_t(c.ray_slots));
  m_recent.assign(size_t(c.queue_depth), 0);
  while ((uint64_t(1) << m_line_shift) < uint64_t(c.line_bytes)) ++m_line_shift;
  m_line_xfer = xfer_cycles(uint64_t(c.line_bytes));
  m_word_xfer = xfer_cycles(8);
  m_min_fetch = m_cache.empty() ? m_line_xfer + uint64_t(c.dram_latency) : uint64_t(c.cache_latency);
  m_waiting.reserve(size_t(c.ray_slots));
  // A node takes at least one issue clock, even one without children (the RTL unit's sequencer does the same).
  for (uint64_t k = 0; k < m_box_issue.size(); ++k)
    m_box_issue[k] = std::max<uint64_t>(1, (k + uint64_t(c.box_rate) - 1) / uint64_t(c.box_rate));
}

uint64_t TimingModel::xfer_cycles(uint64_t bytes) const {
  return uint64_t(std::ceil(double(bytes) / m_c.dram_bytes_per_cycle));
}

uint64_t TimingModel::dram(uint64_t bytes, uint64_t t) {
  const uint64_t xfer =
      bytes == uint64_t(m_c.line_bytes) ? m_line_xfer : (bytes == 8 ? m_word_xfer : xfer_cycles(bytes));
  const uint64_t start = std::max(t, m_dram_free);
  m_dram_free = start + xfer;
  m_s->dram_bytes += bytes;
  m_s->dram_busy_cycles += xfer;
  return start + xfer + uint64_t(m_c.dram_latency);
}

int TimingModel::find_way(const Line* ways, uint64_t line) const {
  // Every way compared, without an early exit: which way holds the line is data (a bit mask), not a branch; a
  // line is in at most one way.
  uint64_t match = 0;
  if (m_c.cache_ways == 4) {  // the presets' associativity: unrolled
    match = uint64_t(ways[0].tag == line) | uint64_t(ways[1].tag == line) << 1 |
            uint64_t(ways[2].tag == line) << 2 | uint64_t(ways[3].tag == line) << 3;
  } else {
    for (int w = 0; w < m_c.cache_ways; ++w) match |= uint64_t(ways[w].tag == line) << w;
  }
  return match != 0 ? __builtin_ctzll(match) : -1;
}

TimingModel::Line* TimingModel::lru_way(Line* ways) const {
  Line* victim = ways;  // the first of the least recent; never-used lines have stamp 0
  for (int w = 1; w < m_c.cache_ways; ++w)
    if (ways[w].stamp < victim->stamp) victim = &ways[w];
  return victim;
}

uint64_t TimingModel::line_access(uint64_t line, uint64_t t) {
  if (m_cache.empty()) {
    ++m_s->cache_misses;
    return dram(uint64_t(m_c.line_bytes), t);
  }
  const uint64_t set = set_of(line);
  Line* ways = &m_cache[set * uint64_t(m_c.cache_ways)];
  const int w = find_way(ways, line);
  if (w >= 0) {
    Line& l = ways[w];
    ++m_s->cache_hits;
    l.stamp = ++m_stamp;
    return std::max(t, l.ready) + uint64_t(m_c.cache_latency);
  }
  Line* victim = lru_way(ways);
  ++m_s->cache_misses;
  victim->tag = line;
  victim->stamp = ++m_stamp;
  victim->ready = dram(uint64_t(m_c.line_bytes), t + uint64_t(m_c.cache_latency));
  return victim->ready;
}

template <bool Reverse, class F>
void TimingModel::for_each_line(const TraceEvent& e, F&& f) const {
  uint64_t addr, bytes;
  if (e.kind == TraceEvent::kNode) {
    addr = m_layout.node_offset + uint64_t(e.index) * m_layout.node_bytes;
    bytes = m_layout.node_bytes;
  } else if (e.kind == TraceEvent::kPrim) {
    addr = m_layout.record_offset + uint64_t(e.index) * kRecordBytes;
    bytes = kRecordBytes;
  } else if (e.kind == TraceEvent::kPlane) {
    addr = m_layout.plane_offset + uint64_t(e.index) * sizeof(PlaneRecord);
    bytes = sizeof(PlaneRecord);
  } else {
    return;
  }
  const uint64_t lo = addr >> m_line_shift, hi = (addr + bytes - 1) >> m_line_shift;
  if constexpr (Reverse) {
    for (uint64_t line = hi + 1; line-- > lo;) f(line);
  } else {
    for (uint64_t line = lo; line <= hi; ++line) f(line);
  }
}

void TimingModel::warm(const std::vector<TraceEvent>* events, size_t m) {
  if (m_cache.empty()) return;
  for (size_t i = 0; i < m; ++i)
    for (const TraceEvent& e : events[i])
      for_each_line<false>(e, [&](uint64_t line) {
        Line* ways = &m_cache[set_of(line) * uint64_t(m_c.cache_ways)];
        const int w = find_way(ways, line);
        if (w >= 0) {
          ways[w].stamp = ++m_stamp;
          return;
        }
        *lru_way(ways) = Line{line, ++m_stamp, 0};  // in the cache, no time spent
      });
}

void TimingModel::walk_begin(const std::vector<TraceEvent>* events, size_t m) {
  for (uint64_t line : m_walk_need) m_walk_mark[size_t(line)] = 0;  // the previous walk's marks
  m_walk_need.clear();
  m_walk_undetermined = 0;
  if (m_cache.empty()) return;  // nothing to warm
  for (size_t i = 0; i < m; ++i)
    for (const TraceEvent& e : events[i])
      for_each_line<false>(e, [&](uint64_t line) {
        if (line >= m_walk_mark.size()) m_walk_mark.resize(size_t(line) + 1, 0);  // lines of the image: bounded
        if (!m_walk_mark[size_t(line)]) {
          m_walk_mark[size_t(line)] = 1;
          m_walk_need.push_back(line);
        }
      });
  m_walk_lines.assign(m_cache.size(), 0);
  m_walk_count.assign(size_t(m_sets), 0);
  m_walk_sets.clear();
  m_walk_open.assign(size_t(m_sets), 0);
  for (uint64_t line : m_walk_need) ++m_walk_open[size_t(set_of(line))];
  m_walk_undetermined = m_walk_need.size();
}

size_t TimingModel::walk_add(const std::vector<TraceEvent>* events, size_t m, size_t enough) {
  if (m_cache.empty()) return m;
  const size_t W = size_t(m_c.cache_ways);
  // Backwards, ray by ray and fetch by fetch from the last: a set's lines are kept in the order of their last
  // touch before the point (most recent first), which is the order warming forward would leave them in.
  for (size_t i = m; i-- > 0;) {
    const std::vector<TraceEvent>& ev = events[i];
    for (size_t j = ev.size(); j-- > 0;)
      for_each_line<true>(ev[j], [&](uint64_t line) {
        const size_t set = size_t(set_of(line));
        uint8_t& c = m_walk_count[set];
        if (c == W) return;
        uint64_t* seen = &m_walk_lines[set * W];
        for (size_t w = 0; w < c; ++w)
          if (seen[w] == line) return;
        if (c == 0) m_walk_sets.push_back(uint32_t(set));
        seen[c] = line;
        // A simulated ray's line: in the cache at the point.
        if (line < m_walk_mark.size() && m_walk_mark[size_t(line)]) {
          --m_walk_open[set];
          --m_walk_undetermined;
        }
        if (++c == W) {  // the set is full: its lines not seen are not in the cache at the point
          m_walk_undetermined -= m_walk_open[set];
          m_walk_open[set] = 0;
        }
      });
    if (m_walk_undetermined <= enough) return m - i;
  }
  return m;
}

void TimingModel::walk_install() {
  if (m_cache.empty()) return;
  const size_t W = size_t(m_c.cache_ways);
  // Warming forward with the rays walked would touch each set's walked lines in the order opposite to the walk's
  // and leave, per set, those lines (the most recent first) over the lines it held before and were not touched,
  // in their old order, cut to cache_ways; a line already held keeps its ready cycle, a new one is ready at 0.
  // Written directly: stamps above every stamp so far, in that order (LRU compares stamps within a set only, and
  // which way holds a line is not observable: a line is in at most one way, and empty ways are all alike).
  const uint64_t base = m_stamp;
  m_walk_fresh.resize(W);
  for (uint32_t set : m_walk_sets) {
    const size_t c = m_walk_count[set];
    const uint64_t* seen = &m_walk_lines[size_t(set) * W];
    Line* ways = &m_cache[size_t(set) * W];
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

uint64_t TimingModel::unit(std::vector<uint64_t>& next_free, uint64_t issue, uint64_t latency, uint64_t t) {
  size_t best = 0;
  for (size_t j = 1; j < next_free.size(); ++j)
    if (next_free[j] < next_free[best]) best = j;
  const uint64_t start = std::max(t, next_free[best]);
  next_free[best] = start + issue;
  const uint64_t wait = start - t;
  if (wait > uint64_t(m_c.queue_depth)) m_s->queue_stall_cycles += wait - uint64_t(m_c.queue_depth);
  return start + latency + issue - 1;
}

void TimingModel::begin(size_t n, TimingStats& s) {
  m_s = &s;
  m_n = n;
  m_next = 0;
  m_queue.reset(uint32_t(m_c.ray_slots));
  m_waiting.clear();
  m_t0 = m_base + uint64_t(m_c.packet_latency);
  m_setup_free = m_wb_free = 0;
  m_end = m_t0;
  std::fill(m_recent.begin(), m_recent.end(), 0);
  ++s.packets;
  // Every slot is free when the packet is decoded; they take rays as the rays are fed.
  m_free_slots.clear();
  for (uint32_t k = 0; k < uint32_t(m_c.ray_slots); ++k) m_free_slots.push_back({m_t0, k});
  for (Slot& sl : m_slots) sl.busy = false;
  m_age.clear();
  m_watch_deadline = kNoDeadline;
}

void TimingModel::admit(uint32_t k, uint64_t free_at) {
  const size_t i = m_next++;
  uint64_t fetch = m_t0 + i;
  const size_t D = m_recent.size();
  if (i >= D) fetch = std::max(fetch, m_recent[i % D]);  // the prefetch queue holds D rays
  const uint64_t arrive = fetch + uint64_t(m_c.ray_fetch_latency);
  const uint64_t enter = std::max({arrive, free_at, m_setup_free});
  m_setup_free = enter + 1;
  m_recent[i % D] = enter;
  m_s->stream_bytes += kRayBytesStream;
  ++m_s->rays;
  Slot& sl = m_slots[k];
  sl.ev.swap(m_feed[i - m_feed_first]);
  sl.pos = 0;
  sl.depth = 0;
  sl.spilled = 0;
  sl.unit_phase = false;
  sl.entered = enter;
  sl.ray = i;
  sl.busy = true;
  if (m_c.watchdog_cycles > 0) {
    if (m_watch_deadline == kNoDeadline) m_watch_deadline = enter + uint64_t(m_c.watchdog_cycles);
    m_age.push_back({enter, k});
  }
  if (m_trace) m_trace->add(k, "setup", enter, enter + uint64_t(m_c.setup_latency));
  m_queue.push(enter + uint64_t(m_c.setup_latency), k);
  __builtin_prefetch(sl.ev.data());
}

void TimingModel::spill(Slot& sl, uint64_t t) {
  ++sl.spilled;
  ++m_s->stack_spills;
  dram(8, t);  // bandwidth only: the write leaves the slot
}

uint64_t TimingModel::refill(Slot& sl, uint32_t k, uint64_t t) {
  --sl.spilled;
  ++m_s->stack_refills;
  const uint64_t ready = dram(8, t);
  if (m_trace) m_trace->add(k, "stack refill", t, ready);
  return ready;
}

uint64_t TimingModel::unit_request(const TraceEvent& e, uint32_t k, uint64_t t) {
  uint64_t done;
  if (e.kind == TraceEvent::kNode) {
    // The configured rate and depth, or the clocks the box unit that tested the node reported (box_unit.h).
    const uint64_t issue = e.unit_issue ? e.unit_issue : m_box_issue[e.count];
    const uint64_t latency = e.unit_issue ? uint64_t(e.unit_result) - issue + 1 : uint64_t(m_c.box_latency);
    done = unit(m_box_free, issue, latency, t);
    if (m_trace) m_trace->add(k, "box", t, done);
    m_s->box_tests += e.count;
    m_s->box_issue_cycles += issue;
    return done;
  }
  uint64_t lat = uint64_t(m_c.plane_latency);
  if (e.kind == TraceEvent::kPrim && e.count == uint8_t(RecordKind::kTriangle)) {
    lat = uint64_t(m_c.tri_latency);
    ++m_s->tri_tests;
  } else if (e.kind == TraceEvent::kPrim) {
    lat = uint64_t(m_c.sphere_latency);
    ++m_s->sphere_tests;
  } else {
    ++m_s->plane_tests;
  }
  done = unit(m_tri_free, 1, lat, t);
  if (m_trace)
    m_trace->add(
        k, e.kind == TraceEvent::kPlane ? "plane" : (lat == uint64_t(m_c.tri_latency) ? "triangle" : "sphere"), t,
        done);
  ++m_s->tri_issue_cycles;
  return done;
}

uint64_t TimingModel::pop_waiting() {
  const uint64_t key = m_waiting.front();
  std::pop_heap(m_waiting.begin(), m_waiting.end(), std::greater<>());
  m_waiting.pop_back();
  return key;
}

void TimingModel::serve_waiting() {
  const uint64_t key = pop_waiting();
  const uint32_t w = uint32_t(key & ((uint64_t(1) << SlotQueue::kSlotBits) - 1));
  Slot& sl = m_slots[w];
  const uint64_t done = unit_request(sl.ev[sl.pos], w, key >> SlotQueue::kSlotBits);
  ++sl.pos;
  sl.unit_phase = false;
  m_queue.requeue(w, done + uint64_t(m_c.traversal_latency));
}

void TimingModel::simulate() {
  const uint64_t SE = uint64_t(m_c.stack_entries);
  for (;;) {
    // Free slots take the next rays, earliest free first (ties: lowest slot).
    while (!m_free_slots.empty() && m_next < m_n) {
      const auto [free_at, k] = m_free_slots.front();
      if (!m_queue.empty() && m_queue.top_cycle() < free_at) break;  // a busy slot acts first
      if (m_next >= m_feed_first + m_feed_count) return;             // its ray is not fed yet
      std::pop_heap(m_free_slots.begin(), m_free_slots.end(), std::greater<>());
      m_free_slots.pop_back();
      admit(k, free_at);
    }
    if (m_queue.empty()) return;
    // The earliest slot acts, until it knows its next cycle (replace_top: it waits again) or leaves (pop).
    const uint64_t t = m_queue.top_cycle();
    const uint32_t k = m_queue.top_slot();
    if (t > m_watch_deadline) watchdog(t);
    Slot& sl = m_slots[k];
    uint64_t next_t = 0;
    bool waiting = false;
    while (!waiting) {
      if (sl.pos == sl.ev.size()) {  // hit write-back; the slot is free the clock after
        const uint64_t st = std::max(t, m_wb_free);
        if (m_c.watchdog_cycles > 0 && st + 1 - sl.entered > uint64_t(m_c.watchdog_cycles))
          fire(k, sl.entered + uint64_t(m_c.watchdog_cycles) + 1);
        m_wb_free = st + 1;
        sl.busy = false;
        // Rays that left are dropped from the age queue's front (the watchdog skips them; this keeps it short).
        while (!m_age.empty() && (!m_slots[m_age.front().second].busy ||
                                  m_slots[m_age.front().second].entered != m_age.front().first))
          m_age.pop_front();
        m_end = std::max(m_end, st + uint64_t(m_c.writeback_latency));
        if (m_done) {
          m_done->push_back(st + uint64_t(m_c.writeback_latency));
          if (m_entered) m_entered->push_back(sl.entered);
        }
        if (m_trace) m_trace->add(k, "write-back", st, st + 1);  // the slot hands its hit to the write-back pipe
        m_s->stream_bytes += kHitBytesStream;
        m_s->slot_busy_cycles += st + 1 - sl.entered;
        m_free_slots.push_back({st + 1, k});
        std::push_heap(m_free_slots.begin(), m_free_slots.end(), std::greater<>());
        m_queue.pop();
        break;
      }
      const TraceEvent& e = sl.ev[sl.pos];
      switch (e.kind) {
        case TraceEvent::kPush:
          for (int j = 0; j < e.count; ++j)
            if (uint64_t(++sl.depth) > SE) spill(sl, t);
          ++sl.pos;
          continue;
        case TraceEvent::kPop:
          ++sl.pos;
          if (uint64_t(sl.depth--) > SE) {
            next_t = refill(sl, k, t);
            waiting = true;
          }
          continue;
        case TraceEvent::kSpill:  // the recorder left out the stack traffic within the short stack
          for (int j = 0; j < e.count; ++j) spill(sl, t);
          ++sl.pos;
          continue;
        case TraceEvent::kRefill:
          ++sl.pos;
          next_t = refill(sl, k, t);
          waiting = true;
          continue;
        default:
          break;
      }
      if (!sl.unit_phase) {  // fetch the data the unit needs: ready when its last line is
        ++(e.kind == TraceEvent::kNode ? m_s->node_fetches : m_s->prim_fetches);
        next_t = t;
        for_each_line<false>(e, [&](uint64_t line) { next_t = std::max(next_t, line_access(line, t)); });
        if (m_trace) m_trace->add(k, e.kind == TraceEvent::kNode ? "node fetch" : "record fetch", t, next_t);
        // The unit request at next_t. Requests reach the units in the order of (cycle, slot), and only they
        // touch the units' state, so a request may be served before its cycle if no request can come before it.
        // A fetch from now on is at t or later and takes at least m_min_fetch, so where this one took that long,
        // every later fetch's request comes after this one's (at t itself, slots served later are higher), and
        // so does every request still waiting once those before it (m_waiting, earliest first) are served: all
        // are served now and the slot skips a wake-up, with every cycle as if each had waited for its own.
        const uint64_t key = next_t << SlotQueue::kSlotBits | k;
        if (!m_early || next_t != t + m_min_fetch) {
          m_waiting.push_back(key);
          std::push_heap(m_waiting.begin(), m_waiting.end(), std::greater<>());
          sl.unit_phase = true;
          waiting = true;
          continue;
        }
        while (!m_waiting.empty() && m_waiting.front() < key) serve_waiting();
        next_t = unit_request(e, k, next_t) + uint64_t(m_c.traversal_latency);
      } else {
        // This slot's request is the earliest waiting one (the queue serves in the same order).
        if (m_waiting.empty() || m_waiting.front() != (t << SlotQueue::kSlotBits | k)) [[unlikely]]
          throw std::logic_error("timing model: unit requests out of order");
        pop_waiting();
        next_t = unit_request(e, k, t) + uint64_t(m_c.traversal_latency);
        sl.unit_phase = false;
      }
      ++sl.pos;
      waiting = true;
    }
    if (waiting) {
      m_queue.replace_top(next_t);
      // The slot's next event is read when it comes up again, after other slots' events: start the load now.
      __builtin_prefetch(sl.ev.data() + sl.pos);
    }
  }
}

void TimingModel::watchdog(uint64_t t) {
  // Entry cycles rise with admission, so the oldest ray still in a slot is the first valid entry.
  while (!m_age.empty()) {
    const auto [entered, k] = m_age.front();
    if (!m_slots[k].busy || m_slots[k].entered != entered) {
      m_age.pop_front();
      continue;
    }
    // Every event before t has been served, and this ray's own next event is at t or later: at cycle
    // entered + watchdog_cycles + 1 it is still in its slot.
    m_watch_deadline = entered + uint64_t(m_c.watchdog_cycles);
    if (t > m_watch_deadline) fire(k, m_watch_deadline + 1);
    return;
  }
  m_watch_deadline = kNoDeadline;  // no ray in a slot; admit() sets the next
}

void TimingModel::fire(uint32_t k, uint64_t cycle) {
  const Slot& stuck = m_slots[k];
  auto u = [](uint64_t v) { return std::to_string(v); };
  auto event_name = [](const Slot& sl) -> std::string {
    if (sl.pos >= sl.ev.size()) return "hit write-back";
    const TraceEvent& e = sl.ev[sl.pos];
    const std::string what = e.kind == TraceEvent::kNode    ? "node "
                             : e.kind == TraceEvent::kPrim  ? "record "
                             : e.kind == TraceEvent::kPlane ? "plane "
                                                            : "stack entry ";
    // unit_phase: its fetch is under way and the unit's test comes next; else the previous step is finishing.
    return (sl.unit_phase ? "waiting for the data of " : "next: ") + what + std::to_string(e.index);
  };
  auto backlog = [&](const std::vector<uint64_t>& next_free) {
    uint64_t queued = 0;
    for (uint64_t f : next_free) queued += f > cycle ? f - cycle : 0;
    return queued;
  };
  std::string d = "timed device watchdog: ray " + u(stuck.ray) + " of " + u(m_n) + " has been in ray slot " +
                  u(k) + " for more than watchdog_cycles = " + std::to_string(m_c.watchdog_cycles) +
                  " cycles (entered at cycle " + u(stuck.entered) + ")\n";
  d += "unit state at cycle " + u(cycle) + " since bind (" + u(cycle - m_base) + " into this TRACE):\n";
  size_t busy = 0;
  for (const Slot& sl : m_slots) busy += sl.busy;
  const uint64_t remaining = uint64_t(m_n - m_next);
  d += "  rays: " + u(m_next) + " of " + u(m_n) + " taken from the ray buffer, " + u(busy) + " in slots, " +
       u(m_next - busy) +
       " done; ray prefetch queue: " + u(std::min<uint64_t>(remaining, uint64_t(m_c.queue_depth))) + " of " +
       std::to_string(m_c.queue_depth) + " rays\n";
  d += "  ray slots: " + u(busy) + " busy of " + std::to_string(m_c.ray_slots) + "\n";
  size_t listed = 0;
  for (uint32_t j = 0; j < m_slots.size(); ++j) {
    const Slot& sl = m_slots[j];
    if (!sl.busy) continue;
    if (++listed > 64) {
      d += "    ... " + u(busy - 64) + " more busy slots\n";
      break;
    }
    d += "    slot " + u(j) + ": ray " + u(sl.ray) + ", entered " + u(sl.entered) + ", event " + u(sl.pos) +
         " of " + u(sl.ev.size()) + " (" + event_name(sl) + "), stack entries spilled to memory " +
         std::to_string(sl.spilled) + "\n";
  }
  d += "  box units: " + u(backlog(m_box_free)) +
       " cycles of queued work; triangle units: " + u(backlog(m_tri_free)) + " cycles; DRAM channel busy for " +
       u(m_dram_free > cycle ? m_dram_free - cycle : 0) + " more cycles; write-back free at " + u(m_wb_free) +
       "\n";
  d += "  this TRACE so far: cache hits " + u(m_s->cache_hits) + ", misses " + u(m_s->cache_misses) +
       ", DRAM bytes " + u(m_s->dram_bytes) + ", stack spills " + u(m_s->stack_spills) + ", queue stall cycles " +
       u(m_s->queue_stall_cycles);
  throw WatchdogError(d, cycle - m_base);
}

void TimingModel::feed(std::vector<TraceEvent>* events, size_t m) {
  m_feed = events;
  m_feed_first = m_next;
  m_feed_count = m;
  simulate();
  m_feed = nullptr;
}

uint64_t TimingModel::finish() {
  m_feed_count = 0;
  m_feed_first = m_next;
  simulate();
  const uint64_t cycles = m_end - m_base;
  m_base = m_end;
  m_s->cycles += cycles;
  return cycles;
}

TimedEngine::TimedEngine(const EngineOptions& o, const TimingConfig& c, std::unique_ptr<BoxUnit> unit)
    : m_opt(o), m_c(c), m_box_unit(std::move(unit)) {
  m_c.validate();
  if (m_c.box_unit == "rtl" && !m_box_unit)
    throw std::invalid_argument("timing config " + m_c.name + ": box_unit = rtl, but no RTL box unit is attached");
  if (m_c.box_unit != "rtl" && m_box_unit)
    throw std::invalid_argument("timing config " + m_c.name +
                                ": a box unit is attached, but box_unit = " + m_c.box_unit);
}

uint32_t TimedEngine::caps() const {
  return reg::kCapTriangles | reg::kCapSpheres | reg::kCapPlanes | reg::kCapAnyHit | reg::kCapFixed |
         reg::kCapTimed;
}

void TimedEngine::bind(const uint8_t* data, size_t bytes) {
  unbind();
  DeviceImage img = DeviceImage::from_bytes(data, bytes);
  auto image = std::make_unique<DeviceImage>(std::move(img));
  FixedTraceOptions to;
  to.max_steps = m_opt.max_steps;
  to.record_short_stack = m_c.stack_entries;  // the model charges only for entries beyond it
  to.box_unit = m_box_unit.get();
  auto tracer = std::make_unique<FixedTracer>(*image, to);  // throws when the box unit cannot take the format
  m_image = std::move(image);
  m_tracer = std::move(tracer);
  const ImageHeader& h = m_image->header();
  TimingModel::Layout l;
  l.node_offset = h.node_offset;
  l.node_bytes = m_image->node_bytes();
  l.record_offset = h.record_offset;
  l.plane_offset = h.plane_offset;
  m_model = std::make_unique<TimingModel>(m_c, l);
  m_model->set_trace(m_trace);
  m_slot_time.clear();  // another scene, other streams
}

void TimedEngine::unbind() {
  m_model.reset();
  m_tracer.reset();
  m_image.reset();
}

void TimedEngine::trace(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s) const {
  TraversalStats local;
  m_tracer->trace_batch(rays, hits, n, any_hit, m_opt.threads, local);
  if (local.watchdog_rays > 0)
    throw WatchdogError(m_tracer->watchdog_report(rays, n, any_hit, local.watchdog_rays), 0);
  s.add(local);
}

uint64_t TimedEngine::packet_cycles(uint8_t opcode) const {
  const uint64_t p = uint64_t(m_c.packet_latency);
  return opcode == uint8_t(cmd::Opcode::kFence) ? p + uint64_t(m_c.fence_latency) : p;
}

void TimedEngine::record(const Ray* rays, Hit* hits, size_t first, size_t count, bool any_hit, TraversalStats& s,
                         std::vector<std::vector<TraceEvent>>& events, size_t at) const {
  TraversalStats local;
  const int threads = m_box_unit ? 1 : m_opt.threads;  // a box unit is not thread-safe (box_unit.h)
  run_batch(count, threads, local, [&](size_t i, TraversalStats& st) {
    std::vector<TraceEvent>& ev = events[at + i];
    ev.clear();
    const Hit h = m_tracer->trace_recorded(rays[first + i], any_hit, st, ev);
    if (hits) hits[first + i] = h;
  });
  if (local.watchdog_rays > 0)
    throw WatchdogError(m_tracer->watchdog_report(rays + first, count, any_hit, local.watchdog_rays), 0);
  if (local.first_invalid != UINT64_MAX) local.first_invalid += first;
  s.add(local);
}

uint64_t TimedEngine::trace_cycles(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                   uint8_t ray_type, uint8_t bounce) {
  TimingStats ts;
  uint64_t cycles;
  ++m_sample_stats.packets;
  m_sample_stats.rays += n;
  const size_t U = m_sample.unit_rays;
  size_t k = m_sample.fraction > 0.0 ? size_t(std::llround(1.0 / m_sample.fraction)) : 1;
  SlotTime& stream = m_slot_time[uint32_t(ray_type) << 8 | bounce];  // what this stream's rays showed so far
  if (k >= 2 && (n <= U || (n - 1) / U < 10 * k)) {
    // Fewer than 10 units to measure at every k-th: every k'-th for the largest k' that gives 10, if the
    // measured units with their warm-up and tail rays are then at most half of the packet's rays.
    const size_t k10 = n <= U ? 0 : (n - 1) / U / 10;
    const size_t per_unit = warmup_rays(stream) + U + 2 * size_t(m_c.ray_slots);
    k = k10 * U >= 2 * per_unit ? k10 : 1;
  }
  try {
    if (k >= 2) {
      cycles = trace_cycles_sampled(rays, hits, n, any_hit, s, ts, k, stream);
    } else {
      // Chunks of rays: traced (and recorded) on the worker threads, then replayed through the model in order.
      // With more than one thread the next chunk is recorded while the model replays this one (two event
      // buffers): the datapath and the model are independent work, so both cores run. The order in which the
      // model sees the events, and so every cycle, is the same either way.
      constexpr size_t kChunk = 4096;
      const size_t buffers = m_opt.threads == 1 || n <= kChunk ? 1 : 2;
      std::vector<std::vector<TraceEvent>> events[2];
      for (size_t b = 0; b < buffers; ++b) events[b].resize(std::min(n, kChunk));
      TraversalStats next_stats;  // the chunk being recorded in the background
      auto record_chunk = [&](size_t first, std::vector<std::vector<TraceEvent>>& ev, TraversalStats& st) {
        record(rays, hits, first, std::min(kChunk, n - first), any_hit, st, ev);
      };
      m_model->begin(n, ts);
      record_chunk(0, events[0], s);
      for (size_t first = 0, b = 0; first < n; first += kChunk, b = (b + 1) % buffers) {
        const size_t after = first + kChunk;
        std::future<void> next;  // the next chunk, recorded into the other buffer meanwhile
        if (after < n && buffers == 2)
          next =
              std::async(std::launch::async, record_chunk, after, std::ref(events[b ^ 1]), std::ref(next_stats));
        try {
          m_model->feed(events[b].data(), std::min(kChunk, n - first));
        } catch (...) {
          if (next.valid()) next.wait();  // the recording thread uses this frame's buffers
          throw;
        }
        if (next.valid()) {
          next.get();  // rethrows a watchdog error of the datapath
          s.add(next_stats);
          next_stats = TraversalStats{};
        } else if (after < n) {
          // One buffer: the model is done with it (feed swapped out what it keeps).
          record_chunk(after, events[b], s);
        }
      }
      cycles = m_model->finish();
      m_sample_stats.rays_simulated += n;
    }
  } catch (const WatchdogError&) {
    // The packet never finished: a fresh model (empty cache, clock at 0) for whatever comes after a reset.
    m_model = std::make_unique<TimingModel>(m_c, TimingModel::Layout(m_model->layout()));
    m_model->set_trace(m_trace);
    throw;
  }
  m_total.add(ts);
  if (ray_type < cmd::kRayTypeCount) m_by_type[ray_type].add(ts);
  m_by_bounce[bounce].add(ts);
  return cycles;
}

void TimedEngine::set_sampling(const SampleOptions& o) {
  if (!(o.fraction >= 0.0 && o.fraction <= 1.0))
    throw std::invalid_argument("sampled timing: the fraction must be in [0, 1]");
  if (o.unit_rays == 0) throw std::invalid_argument("sampled timing: a unit needs at least one ray");
  m_sample = o;
}

double SampleStats::ci95() const {
  return 1.96 * std::sqrt(variance);
}

size_t TimedEngine::warmup_rays(const SlotTime& st) const {
  // The detailed warm-up before a measured unit (SampleOptions::warmup_rays = 0: chosen here, from what the
  // stream's measured units showed). A segment starts with every ray slot free, but in the full simulation some
  // slots are held at that point by rays that entered long before: a stream's slowest rays (chains of cache
  // misses) stay in flight while hundreds of others pass, and in steady state they hold a share of the slots'
  // time. After a warm-up of w rays, rays that entered up to w rays before the unit can hold slots in it; the
  // older ones are missing, and the unit runs with more free slots than it would: faster. The share of slot time
  // they would hold: of each measured ray's time in its slot, the part beyond the time w + U/2 rays take to pass
  // at its unit's rate (a ray that entered before the segment and is still in flight at the unit's middle),
  // summed and divided by the rays' total time in slots. From full simulations of the benchmark streams (4M rays,
  // every unit), at w = 256 / 512 / 1024: AC14-FZK-Haus incoherent rays 2.5 / 0.74 / 0.06%, and ~160 measured
  // units' cycles against the same units of the full simulation 3.0 / 0.6 / 0.0% low (sums; three seeds): the
  // share predicts the warm-up's bias. 2CylinderEngine and SuzanneSubdiv_252 incoherent 0.37 / 0.04 / 0 and
  // 0.23 / 0.02 / 0%; camera rays at most 0.1% at 256. The warm-up is the shortest of kWarmupGrid (multiples of
  // ray_slots) whose share, over the measured units of the stream so far (this ray type and bounce since bind),
  // is at most kShare (0.5%: the measured units of those streams came out 0.13-0.43% low, against 0.6% with a
  // fixed 512 on AC14-FZK-Haus incoherent rays); 16 x ray_slots until kSeen rays are seen. No shorter than 8 x
  // ray_slots: with 4 x, AC14-FZK-Haus camera units measured 1.1% slow (a fill transient the share does not see;
  // 2CylinderEngine and SuzanneSubdiv_252 camera units +0.13 / +0.22% at 4 x), with 8 x 0.4%.
  constexpr double kShare = 0.005;
  constexpr uint64_t kSeen = 512;
  const size_t slots = size_t(m_c.ray_slots);
  if (m_sample.warmup_rays > 0) return m_sample.warmup_rays;
  if (st.rays < kSeen) return 16 * slots;
  for (size_t g = 0; g < std::size(kWarmupGrid); ++g)
    if (st.late[g] <= kShare * st.held) return kWarmupGrid[g] * slots;
  return kWarmupGrid[std::size(kWarmupGrid) - 1] * slots;
}

uint64_t TimedEngine::trace_cycles_sampled(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                           TimingStats& ts, size_t k, SlotTime& slot_time) {
  const size_t U = m_sample.unit_rays;
  const size_t units = (n + U - 1) / U;  // unit 0 is simulated from the packet's start; 1 .. units-1 sampled
  // The auxiliary variable of the ratio estimator, per unit: with hits needed the datapath traces every ray
  // (exact hits), and each unit's work rays + box tests / box rate + primitive tests / test rate comes with it,
  // which the cycles follow far more closely than the ray count (primary rays through sky and through geometry
  // differ tenfold in cost). Without hits the same work from a probe, below. A sum, not the throughput bound
  // max(rays, box tests / box rate, primitive tests / test rate) it replaced: the probe's estimate of a sum is
  // unbiased, that of a maximum is not (a maximum of noisy estimates lies above the maximum of their means), and
  // the measured units pair their cycles with exact values while the rest carry the probe's. On the six 4M-ray
  // benchmark rows at F = 0.01, cycles only, ten seeds each (README, "Sampled timing"; before the strata below),
  // the mean |error| went from 1.51 / 1.32 / 2.76 / 0.51 / 2.64 / 0.33% to 1.20 / 0.97 / 1.86 / 0.24 / 2.54 /
  // 0.31% (AC14-FZK-Haus, 2CylinderEngine, SuzanneSubdiv_252; camera / incoherent rays) and the estimates inside
  // their 95% interval from 50 of 60 to 57 of 60.
  std::vector<double> aux(units);
  TraversalStats scratch;
  // Per ray the datapath's box and primitive tests: every ray with hits; without, one ray in each block of
  // kProbe (a cheap functional probe, scaled up) for the auxiliary's total; a measured unit's own value comes from
  // all its rays (below). On 4M camera rays of the three benchmark meshes at F = 0.01 a 1-in-32 probe gave the
  // same errors as 1-in-16 to within 0.15% of the cycles, in about 20% less time. The probed ray of each block of
  // kProbe rays is drawn at random within it (seeded), not its first: a fixed position probes the same image
  // columns in every row when the row is a multiple of kProbe pixels (a 512-pixel row: columns 0, 32, ..., 480),
  // and on AC14-FZK-Haus's camera at 512 x 384 those columns' work is 3.7% below the image's, a bias of every
  // estimate that no number of measured units removes.
  constexpr size_t kProbe = 32;
  const size_t stride = m_sample.need_hits ? 1 : kProbe;
  const size_t probes = (n + stride - 1) / stride;
  const uint64_t draw = splitmix64(m_sample.seed + 0x9E3779B97F4A7C15ull * m_sample_stats.packets_sampled);
  std::vector<size_t> probed(probes);  // the ray probed in block q
  for (size_t q = 0; q < probes; ++q) {
    const size_t first = q * stride, len = std::min(stride, n - first);
    probed[q] = len == 1 ? first : first + size_t(splitmix64(draw ^ (0xD1B54A32D192ED03ull * (q + 1))) % len);
  }
  std::vector<uint32_t> box(probes), prim(probes);
  TraversalStats probe_stats;
  run_batch(probes, m_box_unit ? 1 : m_opt.threads, m_sample.need_hits ? s : probe_stats,
            [&](size_t q, TraversalStats& st) {
              const size_t i = probed[q];
              // The hardware prefetcher follows a constant stride, not these: fetch a few rays ahead.
              if (q + 8 < probes) __builtin_prefetch(&rays[probed[q + 8]]);
              const uint64_t b0 = st.box_tests, p0 = st.prim_tests;
              const Hit h = m_tracer->trace(rays[i], any_hit, st);
              if (m_sample.need_hits) hits[i] = h;
              box[q] = uint32_t(st.box_tests - b0);
              prim[q] = uint32_t(st.prim_tests - p0);
            });
  const uint64_t stuck = m_sample.need_hits ? s.watchdog_rays : probe_stats.watchdog_rays;
  if (stuck > 0) throw WatchdogError(m_tracer->watchdog_report(rays, n, any_hit, stuck), 0);
  const double box_rate = double(m_c.box_rate) * m_c.box_units, tri_rate = double(m_c.tri_rate) * m_c.tri_units;
  std::vector<double> unit_box(units), unit_prim(units), unit_probes(units);
  for (size_t q = 0; q < probes; ++q) {
    const size_t j = probed[q] / U;
    unit_box[j] += box[q];
    unit_prim[j] += prim[q];
    unit_probes[j] += 1.0;
  }
  std::vector<uint8_t> tests_prims(units);  // the unit's probed rays test a primitive (the strata, below)
  for (size_t j = 0; j < units; ++j) {
    const double rays_in_unit = double(std::min(n, (j + 1) * U) - j * U),
                 scale = unit_probes[j] > 0.0 ? rays_in_unit / unit_probes[j] : 0.0;
    aux[j] = rays_in_unit + unit_box[j] * scale / box_rate + unit_prim[j] * scale / tri_rate;
    tests_prims[j] = unit_prim[j] > 0.0;
  }
  TraversalStats& seg_stats = m_sample.need_hits ? scratch : s;

  TimingStats sim;  // what the model simulated
  std::vector<std::vector<TraceEvent>> events;
  std::vector<uint64_t> done, entered, written;
  m_model->record_done(&written, &entered);
  uint64_t simulated = 0, warmed = 0;
  // After a segment: done sorted; for a measured unit (w warm-up rays, U rays, t > 0 tail rays) its rays' time in
  // their slots into the stream's account (warmup_rays()), at the unit's rate.
  auto observe = [&](size_t w, size_t u, size_t t) {
    done = written;
    std::sort(done.begin(), done.end());
    if (w == 0 || u != U || t == 0 || m_sample.warmup_rays > 0) return;
    const double per_ray = double(done[w + U - 1] - done[w - 1]) / double(U);
    // The unit's rays: slots take rays in order, each entering after the one before.
    std::vector<uint64_t> in_order(entered);
    std::sort(in_order.begin(), in_order.end());
    const uint64_t lo = in_order[w], hi = in_order[w + U - 1];
    std::array<double, std::size(kWarmupGrid)> after;  // the time w + U/2 rays take, for each w of the grid
    for (size_t g = 0; g < after.size(); ++g)
      after[g] = double(kWarmupGrid[g] * size_t(m_c.ray_slots) + U / 2) * per_ray;
    for (size_t i = 0; i < written.size(); ++i) {
      if (entered[i] < lo || entered[i] > hi) continue;
      const double life = double(written[i] - entered[i]);
      slot_time.held += life;
      for (size_t g = 0; g < after.size(); ++g) slot_time.late[g] += std::max(0.0, life - after[g]);
    }
    slot_time.rays += U;
  };
  // Functional warming of the cache before ray `end` (a detailed warm-up's first), for the `sim` rays simulated
  // from there on (their events in events[0, sim)): the rays before it are walked backwards in chunks (each traced
  // forward, with recording) until the state of nearly every line the simulated rays touch is known
  // (TimingModel::walk_add: the cache then holds for them what warming with every earlier ray of the packet would
  // leave) or cache_warm_rays are walked, then put into the cache as warming with them in forward order would
  // (TimingModel::walk_install, in time proportional to the sets touched). Incoherent rays touch many lines each
  // and fill the cache in a few hundred rays; camera rays find their lines in the previous image row.
  const size_t CW = m_sample.cache_warm_rays;
  std::vector<std::vector<TraceEvent>> walk_events(CW);  // ray end - traced + i at CW - traced + i
  // A walk stops when at most 1 in 10 of those lines is undetermined: lines of sets so rarely used that a few
  // thousand rays do not fill them (the whole image of a small scene fits the cache), where the cache keeps what
  // earlier units left. On the six 4M-ray benchmark rows at F = 0.01 (30 seeds each, the same units measured)
  // 10% against 5% moved the camera rows' estimates by +0.13 / +0.22 / +0.14% on average (AC14-FZK-Haus,
  // 2CylinderEngine, SuzanneSubdiv_252: lines left to the older contents miss where the rows before would have
  // brought them) and the incoherent rows' by under 0.01%, for 10-12% fewer rays walked on camera rays and 33%
  // fewer on AC14-FZK-Haus incoherent ones; at 20% the camera rows moved by up to +1.1%.
  constexpr double kUndetermined = 0.10;
  // The walk stops at the ray with which the count falls to that bound, wherever it lies in the chunk traced:
  // the rays warmed, and so every estimate, do not depend on the chunks, which only decide how many rays are
  // traced beyond that ray and not used. Chunks double from 32 rays up to kWalkChunkMax.
  constexpr size_t kWalkChunkMax = 64;
  auto warm_before = [&](size_t end, size_t sim) {
    const size_t reach = std::min(CW, end);
    m_model->walk_begin(events.data(), sim);
    const size_t enough = size_t(kUndetermined * double(m_model->walk_lines()));
    size_t traced = 0, chunk = 32;
    while (traced < reach && m_model->walk_open() > enough) {
      const size_t c = std::min(chunk, reach - traced);
      TraversalStats other;
      record(rays, nullptr, end - traced - c, c, any_hit, other, walk_events, CW - traced - c);
      const size_t taken = m_model->walk_add(walk_events.data() + (CW - traced - c), c, enough);
      traced += c;
      if (taken < c) break;
      chunk = std::min<size_t>(2 * chunk, kWalkChunkMax);
    }
    m_model->walk_install();
    warmed += traced;
  };
  // Simulates w warm-up rays, the u rays from `first` on and t tail rays after them as one packet (done: the
  // sorted hit-write cycles); returns the datapath statistics of the u rays. The measured rays' cost is read
  // between the w-th and the (w + u)-th hit written: with rays in flight on both sides, in steady state.
  auto segment = [&](size_t first, size_t w, size_t u, size_t t, bool warm) {
    events.resize(std::max(events.size(), w + u + t));
    TraversalStats other, st;
    record(rays, nullptr, first - w, w, any_hit, other, events, 0);
    record(rays, nullptr, first, u, any_hit, st, events, w);
    record(rays, nullptr, first + u, t, any_hit, other, events, w + u);
    if (warm) warm_before(first - w, w + u + t);
    done.clear();
    m_model->begin(w + u + t, sim);
    m_model->feed(events.data(), w + u + t);
    m_model->finish();
    observe(w, u, t);
    written.clear();
    entered.clear();
    simulated += w + u + t;
    return st;
  };
  // Tail rays: enough to keep every slot busy past the measured rays' last hit (once the last measured ray has
  // entered, at most ray_slots - 1 others are in flight); twice that for margin. 4 x ray_slots, as before, gave
  // the same measured cycles to 0.01% on the benchmark scenes.
  const size_t tail = 2 * size_t(m_c.ray_slots);
  const uint64_t start = m_model->clock();
  // The first unit, from the packet's start (its fill), and the last unit, to the packet's end (its drain),
  // exactly; the units between by the sample.
  const size_t last = units - 1, u_last = n - last * U;
  seg_stats.add(segment(0, 0, U, std::min(tail, n - U), false));
  const uint64_t first_cycles = done[U - 1] - start;

  // The units 1 .. units-2 to measure, in strata (below), drawn afresh for each packet (from the seed and the
  // packet's number since the engine was made), so that the packets of one large run, often consecutive rows of
  // one image, are sampled independently and their errors average out.
  struct Stratum {
    std::vector<size_t> units;       // its units, in order
    std::vector<size_t> picked;      // the measured ones among them, in order
    std::vector<double> measured_c;  // their cycles
    double probe_error2 = 0.0;       // sum over them of (probe's auxiliary - exact auxiliary)^2
  };
  std::vector<Stratum> strata;
  {
    // Two strata where both are large: the units whose probed rays test no primitive and those whose rays do
    // (camera rays: sky and geometry, a few units costing ten times the rest). The sample is shared by
    // sqrt(units x total auxiliary) of each stratum (below), at least 2 each, and spread evenly over each
    // stratum's units in order (systematic, from a seeded fraction of a step).
    // Otherwise one stratum of every unit, every k-th from a seeded offset in [1, k] (systematic sampling; the
    // incoherent streams, where nearly every unit tests primitives). Why: on 4M camera rays of the benchmark
    // meshes at F = 0.01 (k = 100), cycles only, 30 seeds each, the systematic sample's error was 1.49 / 3.21 /
    // 3.23% rms on AC14-FZK-Haus / 2CylinderEngine / SuzanneSubdiv_252, the strata's 1.26 / 1.73 / 1.90%, for
    // about 8% more time (geometry units walk further to warm the cache): one in five units tests a primitive
    // there, a systematic sample of ~10 units a packet holds two or three of them, and its step goes in step
    // with the image's rows (replayed offline over every unit's cycles from a full simulation: at every 90th or
    // 99th unit of 256 rays, rows of ~2,300, its error was 9-22% rms). Sharing by total auxiliary instead
    // (n_h ~ X_h) gave the same errors for 10% more time; by unit count (n_h ~ N_h), 1.74 / 2.55 / 2.64%.
    std::vector<size_t> without, with;
    for (size_t j = 1; j < last; ++j) (tests_prims[j] ? with : without).push_back(j);
    if (without.size() >= 2 * k && with.size() >= 2 * k) {
      // Neyman's allocation with costs (Cochran, 5.5): n_h ~ N_h S_h / sqrt(c_h); with a unit's spread S_h and
      // its simulation cost c_h both following its work (mean x_h), n_h ~ N_h sqrt(x_h) = sqrt(N_h X_h).
      double x_without = 0.0, x_with = 0.0;
      for (size_t j : without) x_without += aux[j];
      for (size_t j : with) x_with += aux[j];
      const double share_without = std::sqrt(double(without.size()) * x_without),
                   share_with = std::sqrt(double(with.size()) * x_with);
      const size_t total = std::max<size_t>(4, size_t(std::llround(double(last - 1) / double(k))));
      const size_t n0 = std::clamp<size_t>(
          size_t(std::llround(double(total) * share_without / (share_without + share_with))), 2, total - 2);
      const size_t take[2] = {std::min(n0, without.size()), std::min(total - n0, with.size())};
      strata.resize(2);
      strata[0].units = std::move(without);
      strata[1].units = std::move(with);
      for (size_t h = 0; h < 2; ++h) {
        Stratum& st = strata[h];
        const double step = double(st.units.size()) / double(take[h]);
        const double from = double(splitmix64(draw + h + 1) >> 11) * 0x1p-53 * step;  // in [0, step)
        for (size_t i = 0; i < take[h]; ++i)
          st.picked.push_back(st.units[std::min(st.units.size() - 1, size_t(from + double(i) * step))]);
      }
    } else {
      strata.resize(1);
      for (size_t j = 1; j < last; ++j) strata[0].units.push_back(j);
      for (size_t j = 1 + (draw >> 32) % k; j < last; j += k) strata[0].picked.push_back(j);
    }
  }
  // Measured in the order of the rays (each after its warm-up, the cache carried from the one before).
  std::vector<std::pair<size_t, size_t>> order;  // (unit, stratum)
  for (size_t h = 0; h < strata.size(); ++h)
    for (size_t j : strata[h].picked) order.push_back({j, h});
  std::sort(order.begin(), order.end());
  uint64_t warmup_total = 0;
  for (const auto& [j, h] : order) {
    const size_t u0 = j * U, w = std::min(warmup_rays(slot_time), u0), t = std::min(tail, n - u0 - U);
    warmup_total += w;
    const TraversalStats st = segment(u0, w, U, t, true);
    seg_stats.add(st);
    strata[h].measured_c.push_back(double(done[w + U - 1] - done[w - 1]));
    // A measured unit's rays were all traced: its own work replaces the probe's estimate of it (two-phase
    // sampling: the probe estimates the auxiliary's total, the measured units pair their cycles with the exact
    // value; the same where every ray is probed).
    const double exact = double(U) + double(st.box_tests) / box_rate + double(st.prim_tests) / tri_rate;
    strata[h].probe_error2 += (aux[j] - exact) * (aux[j] - exact);
    aux[j] = exact;
  }
  // The last unit, after the sampled ones (the cache as they and its functional warming leave it).
  const size_t w_last = std::min(warmup_rays(slot_time), last * U);
  seg_stats.add(segment(last * U, w_last, u_last, 0, true));
  const uint64_t last_cycles = done.back() - done[w_last - 1];
  m_model->record_done(nullptr);
  // Each stratum's cycles: the ratio estimate on the work (known for every unit), and its jackknife variance
  // (the ratio recomputed with each measured unit left out; Cochran, "Sampling Techniques", 3rd ed., 6.10),
  // finite-population corrected; the packet's, their sums (separate ratio estimates, Cochran 6.10). The
  // residual formula the jackknife replaced, (total / mean x)^2 s_r^2 / m, runs low with ~10 units a packet and
  // skewed units (camera rays: a few through geometry among many through sky): replaying 50 systematic samples
  // offline from a run that measured every second unit, its 95% intervals held the truth in 78% of the samples
  // of AC14-FZK-Haus and 2CylinderEngine camera rays, the jackknife's in 86-90%.
  // (The plain ray count, the other auxiliary once offered where its variance came out smaller, is gone: the
  // two variances, each from ~10 units, came out nearly equal in packets where the estimates were 2x apart,
  // and in the offline replays above the count's choice never helped: camera rows 1.6-4.0% rms with it, the
  // same or better without; incoherent ones 0.43 -> 0.38%, 0.42 -> 0.41%, 0.73 -> 0.70%.)
  double estimate = double(first_cycles) + double(last_cycles), var = 0.0;
  for (const Stratum& st : strata) {
    const double m = double(st.measured_c.size()), M = double(st.units.size());
    double sum_c = 0.0, sum_x = 0.0, total = 0.0;
    for (size_t q = 0; q < st.picked.size(); ++q) {
      sum_c += st.measured_c[q];
      sum_x += aux[st.picked[q]];
    }
    for (size_t j : st.units) total += aux[j];
    const double ratio = sum_x > 0.0 ? sum_c / sum_x : 0.0;
    estimate += ratio * total;
    if (m > 1) {
      double sum_r = 0.0, sum_r2 = 0.0;
      for (size_t q = 0; q < st.picked.size(); ++q) {
        const double rest = sum_x - aux[st.picked[q]];
        const double r = rest > 0.0 ? (sum_c - st.measured_c[q]) / rest : ratio;
        sum_r += r;
        sum_r2 += r * r;
      }
      const double spread = std::max(0.0, sum_r2 - sum_r * sum_r / m);  // sum of (r_(q) - mean)^2
      var += (m - 1) / m * spread * total * total * std::max(0.0, 1.0 - m / M);
    }
    // The probe's error in the work's total: each unit not measured carries its own, whose variance the measured
    // units show (their probe value against their exact one); the estimate scales it by the ratio.
    if (m > 0) var += ratio * ratio * (M - m) * (st.probe_error2 / m);
  }
  const uint64_t cycles = uint64_t(std::llround(estimate));
  m_model->advance_to(start + cycles);

  // The packet's statistics: the simulated rays' counters scaled to the packet, the estimated cycles.
  const double scale = double(n) / double(simulated);
  auto scaled = [&](uint64_t v) { return uint64_t(std::llround(double(v) * scale)); };
  ts = sim;
  ts.packets = 1;
  ts.cycles = cycles;
  ts.rays = n;
  for (uint64_t* f : {&ts.box_tests, &ts.tri_tests, &ts.sphere_tests, &ts.plane_tests, &ts.box_issue_cycles,
                      &ts.tri_issue_cycles, &ts.node_fetches, &ts.prim_fetches, &ts.cache_hits, &ts.cache_misses,
                      &ts.dram_bytes, &ts.dram_busy_cycles, &ts.stream_bytes, &ts.stack_spills, &ts.stack_refills,
                      &ts.queue_stall_cycles, &ts.slot_busy_cycles})
    *f = scaled(*f);
  ++m_sample_stats.packets_sampled;
  m_sample_stats.rays_simulated += simulated;
  m_sample_stats.rays_warmed += warmed;
  m_sample_stats.units_measured += order.size();
  m_sample_stats.warmup_rays += warmup_total;
  if (strata.size() > 1) ++m_sample_stats.packets_stratified;
  m_sample_stats.variance += var;
  return cycles;
}

Geometry::Counts TimedEngine::counts() const {
  if (!m_image) return {};
  const ImageHeader& h = m_image->header();
  return {h.num_triangles, h.num_spheres, h.plane_count};
}

bool TimedEngine::uses_bvh() const {
  return m_image && !(m_image->header().flags & kImageNoBvh);
}

std::unique_ptr<TraceEngine> make_timed_engine(const EngineOptions& o, const TimingConfig& c,
                                               std::unique_ptr<BoxUnit> unit) {
  return std::make_unique<TimedEngine>(o, c, std::move(unit));
}

}  // namespace rtu::hw
