// The timing model (timing_model.h): construction, the prefetch observer's port, the walks that warm the cache
// for sampled timing, and the event loop. simulate() admits rays into free slots and lets the earliest slot act,
// event by event, until it waits: the events the units do not test (stack traffic, any-hit requests, ...), line
// fetches through the node cache, unit requests served in the order of (cycle, slot); then the hit's write-back.
// The units' pricing of a request is timing_model_units.cpp's, the watchdog's report timing_model_watchdog.cpp's,
// the layout of an image in device memory timing_model_layout.cpp's.
#include "hwmodel/timing/timing_model.h"

#include <algorithm>
#include <functional>
#include <stdexcept>
#include <string>
#include <tuple>

#include "hwmodel/timing/memory/dram_scheduler.h"

namespace rtu::hw {

TimingModel::TimingModel(const TimingConfig& c, const Layout& layout, MemorySystem* shared, uint32_t unit)
    : m_c((c.validate(), c)),
      m_layout(layout),
      m_cache(c),
      m_omm_cache(omm_cache_config(c)),
      m_port(c.fetch_port_rate),
      m_own(shared ? nullptr : std::make_unique<MemorySystem>(c)),
      m_mem(shared ? shared : m_own.get()),
      m_unit(unit) {
  // A stride of 0 is the item's size (packed): resolved once here, not per fetch.
  auto resolve = [](Layout& l) {
    if (l.node_stride == 0) l.node_stride = l.node_bytes;
    if (l.record_stride == 0) l.record_stride = kRecordBytes;
    if (l.plane_stride == 0) l.plane_stride = sizeof(PlaneRecord);
  };
  resolve(m_layout);
  for (Layout& b : m_layout.bottoms) resolve(b);
  FetchContext ctx;
  ctx.node_offset = m_layout.node_offset;
  ctx.node_stride = m_layout.node_stride;
  ctx.node_bytes = m_layout.node_bytes;
  ctx.line_bytes = uint64_t(c.line_bytes);
  ctx.treelets = m_layout.treelets.get();
  set_fetch_observer(make_fetch_observer(c, ctx));
  m_box_free.assign(size_t(c.box_units), 0);
  m_tri_free.assign(size_t(c.tri_units) * size_t(c.tri_rate), 0);  // a unit of rate r: r issue slots per clock
  m_curve_free.assign(size_t(c.curve_units) * size_t(c.curve_rate), 0);
  if (c.cluster_tri_rate > 0) {
    m_cluster_box_free.assign(1, 0);
    m_cluster_tri_free.assign(1, 0);
  }
  m_slots.resize(size_t(c.ray_slots));
  m_admission = make_ray_admission(c);
  while ((uint64_t(1) << m_line_shift) < uint64_t(c.line_bytes)) ++m_line_shift;
  m_min_fetch = m_cache.enabled() ? m_cache.latency() : m_mem->min_line_cycles();
  m_stack_base = stack_base(layout.total_bytes, unit, c.ray_slots);
  m_waiting.reserve(size_t(c.ray_slots));
  if (memory_is_queued(c)) {
    m_queued = true;
    m_early = false;
    m_park.resize(size_t(c.ray_slots));
  }
  // One format builds both levels of a two-level scene, so the top level's node kind prices every node.
  m_box_cost = box_cost(c, layout.node_cost);
  m_oriented = layout.node_cost == NodeCostClass::kOriented;
}

TimingConfig omm_cache_config(const TimingConfig& c) {
  TimingConfig o = c;
  o.cache_kib = c.omm_cache_kib;
  o.prefetch_buffer = 0;
  return o;
}

uint64_t TimingModel::state_bytes(const TimingConfig& c, bool walk) {
  // Per slot: the slot, its place in the queue, the free list, the age list and the waiting requests (a few
  // words each); the admission record per queued ray; a gathered ray's entry and bin (a few words).
  const uint64_t slots = uint64_t(c.ray_slots);
  return NodeCache::state_bytes(c, walk) + NodeCache::state_bytes(omm_cache_config(c), false) +
         slots * (sizeof(Slot) + 8 * sizeof(uint64_t)) + uint64_t(c.queue_depth) * sizeof(uint64_t) +
         uint64_t(c.gather_buffer) * 8 * sizeof(uint64_t);
}

// The observer's port: fills at the fetch's cycle, into this unit's cache, from its memory.
class TimingModel::Port final : public LinePort {
 public:
  Port(TimingModel& m, uint64_t t) : m_m(m), m_t(t) {}
  void fill(uint64_t line) override {
    if (m_m.m_c.prefetch_queue == 0) {
      m_m.m_cache.prefetch(line, m_t, *m_m.m_mem, *m_m.m_s);
      return;
    }
    if (m_m.m_pf_queue.size() == size_t(m_m.m_c.prefetch_queue)) {
      m_m.m_pf_queue.pop_front();
      ++m_m.m_s->prefetch_dropped;
    }
    m_m.m_pf_queue.push_back(line);
  }
  bool holds(uint64_t line) const override { return m_m.m_cache.holds(line); }

 private:
  TimingModel& m_m;
  uint64_t m_t;
};

void TimingModel::set_fetch_observer(std::unique_ptr<FetchObserver> observer) {
  m_observer = std::move(observer);
  if (m_observer) m_cache.track_prefetches();
}

std::pair<uint64_t, uint64_t> TimingModel::line_range(const Layout& l, const TraceEvent& e) const {
  uint64_t first = ~uint64_t(0), last = 0;
  for_each_line<false>(l, e, [&](uint64_t line) {
    first = std::min(first, line);
    last = std::max(last, line);
  });
  return {first, last};
}

void TimingModel::observe(const Slot& sl, uint32_t k, const TraceEvent& e, uint64_t t, bool missed) {
  const auto [first, last] = line_range(*sl.layout, e);
  if (first > last) return;                      // a block's later record: nothing fetched
  const uint64_t waited = m_s->mem_wait_cycles;  // a prefetcher's fills wait for nobody's ray
  Port port(*this, t);
  m_observer->on_fetch(LineFetch{t, k, uint8_t(e.kind), e.index, first, last, missed}, port);
  drain_prefetches(t);
  m_s->mem_wait_cycles = waited;
}

void TimingModel::observe_push(const Slot& sl, uint32_t k, const TraceEvent& e, uint64_t t) {
  // A node's lines, or a leaf's records' (unit_issue of them from index, FixedTraceOptions::record_leaf_refs).
  uint64_t first = ~uint64_t(0), last = 0;
  if (e.unit_issue == 0) {
    std::tie(first, last) = line_range(*sl.layout, TraceEvent{TraceEvent::kNode, 0, 0, 0, e.index});
  } else {
    for (uint32_t i = e.index; i < e.index + e.unit_issue; ++i) {
      const auto [f, l] = line_range(*sl.layout, TraceEvent{TraceEvent::kPrim, 0, 0, 0, i});
      first = std::min(first, f);
      last = std::max(last, l);
    }
  }
  if (e.unit_issue > 0 && first > last) return;  // a leaf whose records lie in an earlier record's block fetch
  const uint64_t waited = m_s->mem_wait_cycles;
  Port port(*this, t);
  m_observer->on_push(StackPush{t, k, e.count, first, last, e.index, e.unit_issue > 0}, port);
  drain_prefetches(t);
  m_s->mem_wait_cycles = waited;
}

void TimingModel::drain_prefetches(uint64_t t) {
  // Queued fills go while the memory is idle at this cycle: after the demand requests made so far, before any
  // demand a later cycle brings (a fill keeps the memory busy, so usually one goes per fetch).
  while (!m_pf_queue.empty() && m_mem->free_at() <= t) {
    m_cache.prefetch(m_pf_queue.front(), t, *m_mem, *m_s);
    m_pf_queue.pop_front();
  }
}

const TimingModel::Layout& TimingModel::bottom(uint32_t mesh) const {
  if (mesh >= m_layout.bottoms.size())
    throw std::logic_error("timing model: a bottom level (mesh " + std::to_string(mesh) + ") the layout lacks");
  return m_layout.bottoms[mesh];
}

template <bool Reverse, class F>
void TimingModel::for_each_fetch(const std::vector<TraceEvent>& ev, F&& f) const {
  const Layout* cur = &m_layout;
  for (size_t j = 0; j < ev.size(); ++j) {
    const TraceEvent& e = ev[Reverse ? ev.size() - 1 - j : j];
    if (e.kind == (Reverse ? TraceEvent::kLeave : TraceEvent::kEnter))
      cur = &bottom(e.index);
    else if (e.kind == (Reverse ? TraceEvent::kEnter : TraceEvent::kLeave))
      cur = &m_layout;
    else
      f(*cur, e);
  }
}

template <bool Reverse, class F>
void TimingModel::for_each_line(const Layout& l, const TraceEvent& e, F&& f) const {
  uint64_t addr, bytes;
  if (cluster_node(l, e)) {
    const DeviceImage::Span& s = l.cluster_node_spans[e.index - l.cluster_node_begin];
    if (s.bytes == 0) return;  // in the cluster its root fetched
    bytes = s.bytes;
    addr = s.offset;
  } else if (e.kind == TraceEvent::kNode) {
    bytes = l.node_bytes;
    addr = l.node_offset + uint64_t(l.treelets ? l.treelets->position[e.index] : e.index) * l.node_stride;
  } else if (e.kind == TraceEvent::kPrim && e.count == uint8_t(RecordKind::kInstance)) {
    bytes = l.instance_bytes;
    addr = l.record_offset + uint64_t(e.index) * l.record_stride;
  } else if (e.kind == TraceEvent::kPrim && !l.record_spans.empty()) {
    const DeviceImage::Span& s = l.record_spans[e.index];
    if (s.bytes == 0) return;  // in the block its leaf's first record fetched
    bytes = s.bytes;
    addr = s.offset;
  } else if (e.kind == TraceEvent::kPrim) {
    // A triangle pair's two records in one fetch.
    bytes = e.count == uint8_t(RecordKind::kTrianglePair) ? l.record_stride + kRecordBytes : kRecordBytes;
    addr = l.record_offset + uint64_t(e.index) * l.record_stride;
  } else if (e.kind == TraceEvent::kPlane) {
    bytes = sizeof(PlaneRecord);
    addr = l.plane_offset + uint64_t(e.index) * l.plane_stride;
  } else if (e.kind == TraceEvent::kOmm) {
    bytes = 1;
    addr = l.micromap_offset + e.index;
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
  if (!m_cache.enabled() && !m_omm_cache.enabled()) return;
  for (size_t i = 0; i < m; ++i)
    for_each_fetch<false>(events[i], [&](const Layout& l, const TraceEvent& e) {
      NodeCache& c = e.kind == TraceEvent::kOmm && m_omm_cache.enabled() ? m_omm_cache : m_cache;
      if (c.enabled()) for_each_line<false>(l, e, [&](uint64_t line) { c.warm(line); });
    });
}

uint64_t TimingModel::omm_access(uint64_t line, uint64_t t) {
  return m_omm_cache.access<OmmCacheCounters>(line, t, *m_mem, *m_s);
}

void TimingModel::warm_memory(const std::vector<TraceEvent>* events, size_t m) {
  for (size_t i = 0; i < m; ++i)
    for_each_fetch<false>(events[i], [&](const Layout& l, const TraceEvent& e) {
      for_each_line<false>(l, e, [&](uint64_t line) { m_mem->warm_line(line); });
    });
}

void TimingModel::walk_begin(const std::vector<TraceEvent>* events, size_t m) {
  m_cache.walk_reset();
  if (!m_cache.enabled()) return;  // nothing to warm
  for (size_t i = 0; i < m; ++i)
    for_each_fetch<false>(events[i], [&](const Layout& l, const TraceEvent& e) {
      for_each_line<false>(l, e, [&](uint64_t line) { m_cache.walk_need(line); });
    });
  m_cache.walk_start();
}

size_t TimingModel::walk_add(const std::vector<TraceEvent>* events, size_t m, size_t enough) {
  if (!m_cache.enabled()) return m;
  // Backwards, ray by ray and fetch by fetch from the last, each fetch's lines last first: the order opposite to
  // the one in which warming forward would touch them.
  for (size_t i = m; i-- > 0;) {
    for_each_fetch<true>(events[i], [&](const Layout& l, const TraceEvent& e) {
      for_each_line<true>(l, e, [&](uint64_t line) { m_cache.walk_see(line); });
    });
    if (m_cache.walk_open() <= enough) return m - i;
  }
  return m;
}

void TimingModel::begin(size_t n, TimingStats& s) {
  m_s = &s;
  m_n = n;
  m_next = 0;
  m_feed = RayFeed{};  // no ray given yet (feed or add_rays)
  m_queue.reset(uint32_t(m_c.ray_slots));
  m_waiting.clear();
  m_t0 = m_base + uint64_t(m_c.packet_latency);
  m_setup_free = m_wb_free = 0;
  m_end = m_t0;
  m_admission->begin(n, m_t0);
  ++s.packets;
  // Every slot is free when the packet is decoded; they take rays as the rays are fed.
  m_free_slots.clear();
  for (uint32_t k = 0; k < uint32_t(m_c.ray_slots); ++k) m_free_slots.push_back({m_t0, k});
  for (Slot& sl : m_slots) sl.busy = false;
  m_age.clear();
  m_watch_deadline = kNoDeadline;
}

void TimingModel::admit(uint32_t k, uint64_t free_at) {
  Slot& sl = m_slots[k];
  uint64_t enter;
  const size_t i = m_admission->take(sl.ev, m_feed, free_at, m_setup_free, enter);
  ++m_next;
  m_setup_free = enter + 1;
  m_s->stream_bytes += kRayBytesStream;
  ++m_s->rays;
  sl.pos = 0;
  sl.layout = &m_layout;
  sl.depth = 0;
  sl.spilled = 0;
  sl.unit_phase = false;
  sl.entered = enter;
  sl.ray = i;
  sl.busy = true;
  if (m_observer) m_observer->on_ray(k);
  if (m_c.watchdog_cycles > 0) {
    if (m_watch_deadline == kNoDeadline) m_watch_deadline = enter + uint64_t(m_c.watchdog_cycles);
    m_age.push_back({enter, k});
  }
  if (m_trace) m_trace->add(m_unit, k, "setup", enter, enter + uint64_t(m_c.setup_latency));
  m_queue.push(enter + uint64_t(m_c.setup_latency), k);
  __builtin_prefetch(sl.ev.data());
}

void TimingModel::spill(Slot& sl, uint32_t k, uint64_t t) {
  m_mem->write_word(stack_addr(k, sl.spilled), m_port.request(t, m_s->port_request_waits),
                    *m_s);  // bandwidth only: the write leaves the slot
  ++sl.spilled;
  ++m_s->stack_spills;
}

uint64_t TimingModel::refill(Slot& sl, uint32_t k, uint64_t t) {
  --sl.spilled;
  ++m_s->stack_refills;
  uint64_t ready = m_mem->read_word(stack_addr(k, sl.spilled), m_port.request(t, m_s->port_request_waits), *m_s);
  if (is_pending(ready)) [[unlikely]] {
    park(k, ready, t);
    return ready;
  }
  // Through a one-a-clock port the entry is compared with the closest hit the clock after its data.
  if (m_port.on()) ready = m_port.response(ready, m_s->port_response_waits) + 1;
  if (m_trace) m_trace->add(m_unit, k, "stack refill", t, ready);
  return ready;
}

void TimingModel::park(uint32_t k, uint64_t ready, uint64_t floor) {
  Park& p = m_park[k];
  if (p.count++ == 0) p.ready = p.unqueued = floor;
  m_mem->pending()->notify(ready, this, k);
}

void TimingModel::woken(uint32_t k, uint64_t cycle, uint64_t wait) {
  Park& p = m_park[k];
  p.ready = std::max(p.ready, cycle);
  p.unqueued = std::max(p.unqueued, cycle - wait);
  if (--p.count > 0) return;
  // Its fetch's lines are all there: its unit request waits for its cycle as any other (simulate()).
  if (m_slots[k].unit_phase) {
    // Deferred, the ray's wait is counted now, as simulate() counts it acting on the memory itself.
    if (m_defer) m_s->mem_wait_cycles += p.ready - p.unqueued;
    m_waiting.push_back(p.ready << SlotQueue::kSlotBits | k);
    std::push_heap(m_waiting.begin(), m_waiting.end(), std::greater<>());
  }
  m_queue.push(p.ready, k);
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

bool TimingModel::touches_memory(const Slot& sl) const {
  if (sl.pos == sl.ev.size()) return false;  // the write-back
  const TraceEvent& e = sl.ev[sl.pos];
  const int SE = m_c.stack_entries;
  switch (e.kind) {
    case TraceEvent::kPush:
      return sl.depth + int(e.count) > SE;
    case TraceEvent::kPop:
      return sl.depth > SE;
    case TraceEvent::kSpill:
      return e.count > 0;
    case TraceEvent::kRefill:
      return true;
    case TraceEvent::kAnyHit:
    case TraceEvent::kEnter:
    case TraceEvent::kLeave:
      return false;
    case TraceEvent::kStackRef:
      return m_observer != nullptr;  // the observer may fill the pushed node's lines
    case TraceEvent::kRestart:
    case TraceEvent::kRayKey:
      return false;
    default:
      break;
  }
  if (sl.unit_phase) return false;  // the unit test: the data is there
  if (m_observer) return true;      // the observer may fill lines at any fetch
  bool miss = false;
  for_each_line<false>(*sl.layout, e, [&](uint64_t line) { miss |= !m_cache.holds(line); });
  return miss;
}

void TimingModel::simulate(uint64_t limit, bool ahead) {
  for (;;) {
    // A queued memory decides at a cycle once every action up to it is done: its own here, a chip's by
    // run_units_in_step (the unit stops). A decision may wake slots at later cycles.
    if (m_queued && m_mem->next_decision() < next_cycle()) [[unlikely]] {
      if (!m_own) return;
      m_mem->decide();
      continue;
    }
    if (!admit_rays(limit, ahead)) return;
    if (m_queue.empty()) {
      if (m_queued && m_mem->next_decision() != kNoDecision) continue;  // slots wait for its decisions
      return;
    }
    // The earliest slot acts, until it knows its next cycle (replace_top: it waits again) or leaves (pop).
    const uint64_t t = m_queue.top_cycle();
    if (t > limit && !ahead) return;
    if (m_queued && m_mem->next_decision() < t) continue;
    const uint32_t k = m_queue.top_slot();
    m_now = t;
    if (t > m_watch_deadline) watchdog(t);
    Slot& sl = m_slots[k];
    uint64_t next_t = 0;
    bool waiting = false;
    while (!waiting) {
      // Ahead of the limit, the slot stops (still first in the queue, at t) before an event that reaches memory.
      if (t > limit && touches_memory(sl)) return;
      if (sl.pos == sl.ev.size()) {  // hit write-back; the slot is free the clock after
        write_back(sl, k, t);
        break;
      }
      const TraceEvent& e = sl.ev[sl.pos];
      if (control_event(sl, k, e, t, next_t, waiting)) continue;
      if (!m_cluster_tri_free.empty() && sl.pos > 0 && leaf_follower(*sl.layout, sl.ev[sl.pos - 1], e)) {
        ++sl.pos;  // tested in its leaf's request to the cluster engine
        continue;
      }
      if (!sl.unit_phase) {  // fetch the data the unit needs: ready when its last line is
        if (e.kind != TraceEvent::kOmm) ++(e.kind == TraceEvent::kNode ? m_s->node_fetches : m_s->prim_fetches);
        next_t = t;
        const uint64_t misses = m_s->cache_misses;
        // The lines are asked for together, so the ray waits for the last to arrive: its queueing is how much
        // later that is than the last would be without its lines' waits (mem_wait_cycles counts the ray's wait,
        // not the sum over lines in parallel).
        const uint64_t waited = m_s->mem_wait_cycles;
        uint64_t unqueued = t;
        uint64_t pending_wait = 0;  // waits on the way to a queued memory's lines (its own count at decisions)
        const uint64_t tr = m_port.request(t, m_s->port_request_waits);
        const bool omm = e.kind == TraceEvent::kOmm && m_omm_cache.enabled();
        for_each_line<false>(*sl.layout, e, [&](uint64_t line) {
          const uint64_t before = m_s->mem_wait_cycles;
          const uint64_t ready = omm ? omm_access(line, tr) : m_cache.access(line, tr, *m_mem, *m_s);
          if (is_pending(ready)) [[unlikely]] {
            park(k, ready, t);
            pending_wait += m_s->mem_wait_cycles - before;
            return;
          }
          next_t = std::max(next_t, ready);
          unqueued = std::max(unqueued, ready - (m_s->mem_wait_cycles - before));
        });
        const bool parked = (m_queued || m_defer) && m_park[k].count > 0;
        if (parked && m_defer) {  // the wait is counted when the last line is known (woken())
          m_s->mem_wait_cycles = waited;
          m_park[k].unqueued = std::max(m_park[k].unqueued, unqueued);
        } else {
          m_s->mem_wait_cycles = waited + (next_t - unqueued) + pending_wait;
        }
        next_t = m_port.response(next_t, m_s->port_response_waits);
        if (parked) [[unlikely]] {
          // Some lines wait for the memory's decisions: the slot leaves the queue until woken() (no trace span).
          m_park[k].ready = std::max(m_park[k].ready, next_t);
          sl.unit_phase = true;
          next_t = kPending;
          waiting = true;
          continue;
        }
        if (m_observer) [[unlikely]]
          observe(sl, k, e, t, m_s->cache_misses != misses);
        if (m_trace)
          m_trace->add(m_unit, k, e.kind == TraceEvent::kNode ? "node fetch" : "record fetch", t, next_t);
        // The unit request at next_t. Requests reach the units in the order of (cycle, slot), and only they
        // touch the units' state, so a request may be served before its cycle if no request can come before it.
        // A fetch from now on is at t or later and takes at least m_min_fetch, so where this one took that long,
        // every later fetch's request comes after this one's (at t itself, slots served later are higher), and
        // so does every request still waiting once those before it (m_waiting, earliest first) are served: all
        // are served now and the slot skips a wake-up, with every cycle as if each had waited for its own.
        const uint64_t key = next_t << SlotQueue::kSlotBits | k;
        // Deferred, a parked slot's request comes after `limit` (its answer does): early only up to it.
        if (!m_early || next_t != t + m_min_fetch || (m_defer && next_t > limit)) {
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
      if (is_pending(next_t)) [[unlikely]] {
        m_queue.pop();  // woken() queues it again
        continue;
      }
      m_queue.replace_top(next_t);
      // The slot's next event is read when it comes up again, after other slots' events: start the load now.
      __builtin_prefetch(sl.ev.data() + sl.pos);
    }
  }
}

// Free slots take the next rays, earliest free first (ties: lowest slot). Taking a ray stays inside the unit (its
// ray fetch has its own port). False when simulate() stops here: the earliest free slot comes after `limit`
// (and not `ahead`), or its ray is not fed yet.
bool TimingModel::admit_rays(uint64_t limit, bool ahead) {
  while (!m_free_slots.empty() && m_next < m_n) {
    const auto [free_at, k] = m_free_slots.front();
    if (!m_queue.empty() && m_queue.top_cycle() < free_at) break;  // a busy slot acts first
    if (free_at > limit && !ahead) return false;
    if (m_queued && m_mem->next_decision() < free_at) break;       // the memory decides first (simulate())
    if (!m_admission->reach(free_at, m_feed, *m_s)) return false;  // its ray is not fed yet
    std::pop_heap(m_free_slots.begin(), m_free_slots.end(), std::greater<>());
    m_free_slots.pop_back();
    if (!m_admission->ready()) {  // no ray for a slot yet: it asks again when the admission says
      m_free_slots.push_back({m_admission->retry_at(), k});
      std::push_heap(m_free_slots.begin(), m_free_slots.end(), std::greater<>());
      continue;
    }
    admit(k, free_at);
  }
  return true;
}

// Slot k writes its ray's hit back from cycle t (or when the write-back pipe is free); the slot is free the clock
// after and leaves the queue. The watchdog fires if the ray was in its slot too long.
void TimingModel::write_back(Slot& sl, uint32_t k, uint64_t t) {
  const uint64_t st = std::max(t, m_wb_free);
  if (m_c.watchdog_cycles > 0 && st + 1 - sl.entered > uint64_t(m_c.watchdog_cycles))
    fire(k, sl.entered + uint64_t(m_c.watchdog_cycles) + 1);
  m_wb_free = st + 1;
  sl.busy = false;
  // Rays that left are dropped from the age queue's front (the watchdog skips them; this keeps it short).
  while (!m_age.empty() &&
         (!m_slots[m_age.front().second].busy || m_slots[m_age.front().second].entered != m_age.front().first))
    m_age.pop_front();
  m_end = std::max(m_end, st + uint64_t(m_c.writeback_latency));
  if (m_done) {
    m_done->push_back(st + uint64_t(m_c.writeback_latency));
    if (m_entered) m_entered->push_back(sl.entered);
  }
  if (m_trace) m_trace->add(m_unit, k, "write-back", st, st + 1);  // the slot hands its hit to the write-back pipe
  m_s->stream_bytes += kHitBytesStream;
  m_s->slot_busy_cycles += st + 1 - sl.entered;
  m_free_slots.push_back({st + 1, k});
  std::push_heap(m_free_slots.begin(), m_free_slots.end(), std::greater<>());
  m_queue.pop();
}

// Event e of slot k at cycle t when the units do not test it (stack traffic, an any-hit request, entering or
// leaving a bottom level, a restart, a ray key, a stack reference): true, the slot past it and, when it waits
// for it, `waiting` set and next_t the cycle it waits for. False for any other event.
bool TimingModel::control_event(Slot& sl, uint32_t k, const TraceEvent& e, uint64_t t, uint64_t& next_t,
                                bool& waiting) {
  const uint64_t SE = uint64_t(m_c.stack_entries);
  switch (e.kind) {
    case TraceEvent::kPush:
      for (int j = 0; j < e.count; ++j)
        if (uint64_t(++sl.depth) > SE) spill(sl, k, t);
      ++sl.pos;
      return true;
    case TraceEvent::kPop:
      ++sl.pos;
      if (uint64_t(sl.depth--) > SE) {
        next_t = refill(sl, k, t);
        waiting = true;
      }
      return true;
    case TraceEvent::kSpill:  // the recorder left out the stack traffic within the short stack
      for (int j = 0; j < e.count; ++j) spill(sl, k, t);
      ++sl.pos;
      return true;
    case TraceEvent::kRefill:
      ++sl.pos;
      next_t = refill(sl, k, t);
      waiting = true;
      return true;
    case TraceEvent::kAnyHit:  // the ray waits for the firmware's answer; the units serve other slots
      ++sl.pos;
      ++m_s->any_hit_requests;
      next_t = t + uint64_t(m_c.any_hit_latency);
      if (m_trace) m_trace->add(m_unit, k, "any-hit", t, next_t);
      waiting = true;
      return true;
    case TraceEvent::kEnter:  // the following events address the mesh's bottom level
      sl.layout = &bottom(e.index);
      ++sl.pos;
      return true;
    case TraceEvent::kLeave:
      sl.layout = &m_layout;
      ++sl.pos;
      return true;
    case TraceEvent::kRestart:  // no time of its own: the node events that follow are the restart's cost
      ++m_s->restarts;
      m_s->restart_nodes += e.index;
      ++sl.pos;
      return true;
    case TraceEvent::kRayKey:  // read by the gathering unit when the ray arrived
      ++sl.pos;
      return true;
    case TraceEvent::kHitOut:  // all-hit: a kept hit is a posted write through the write-back pipe
      ++sl.pos;
      if (e.count) {
        const uint64_t st = std::max(t, m_wb_free);
        m_wb_free = st + 1;
        m_s->stream_bytes += kHitBytesStream;
        if (m_trace) m_trace->add(m_unit, k, "hit-out", st, st + 1);
      }
      return true;
    case TraceEvent::kStackRef:  // no time: the push it follows is done
      if (m_observer) observe_push(sl, k, e, t);
      ++sl.pos;
      return true;
    default:
      break;
  }
  return false;
}

void TimingModel::feed(std::vector<TraceEvent>* events, size_t m) {
  m_feed = RayFeed{events, m_admission->fed_up_to(), m};
  simulate();
  m_feed.rays = nullptr;
}

namespace {

// run_units_in_step with a queued memory (memory/dram_scheduler.h): the memory is an actor too, deciding at its
// next decision's cycle after every unit's actions at that cycle. A decision may wake any unit's slot, so the
// earliest actor is looked for anew each time (a scan of the units), and a unit acts strictly in step: until the
// next other unit's action or the memory's decision, whichever is first.
uint64_t run_units_queued(const std::vector<TimingModel*>& units, uint64_t start,
                          const std::function<void(size_t)>& give) {
  MemorySystem& mem = units[0]->memory();
  for (;;) {
    size_t u = units.size();
    uint64_t t = TimingModel::kNever;
    for (size_t i = 0; i < units.size(); ++i) {
      const uint64_t c = units[i]->next_cycle();
      if (c < t) {
        t = c;
        u = i;
      }
    }
    const uint64_t d = mem.next_decision();
    if (u == units.size() && d == kNoDecision) break;
    if (d < t) {
      mem.decide();
      continue;
    }
    TimingModel& unit = *units[u];
    if (unit.starved()) {
      give(u);  // its next action takes a ray: give it more, then let it act
      continue;
    }
    uint64_t limit = d;  // the unit may act at d: requests arriving then are in before the decision
    for (size_t i = 0; i < units.size(); ++i) {
      const uint64_t c = units[i]->next_cycle();
      if (i != u && c != TimingModel::kNever) limit = std::min(limit, i < u ? c - 1 : c);
    }
    unit.run_until(limit);
  }
  mem.drain();  // writes nobody waits for
  uint64_t end = start;
  for (const TimingModel* unit : units) end = std::max(end, unit->end_cycle());
  for (TimingModel* unit : units) unit->end_packet(end);
  return end;
}

}  // namespace

// run_units_in_step on several host threads (timing_model_threads.cpp).
uint64_t run_units_threaded(const std::vector<TimingModel*>& units, uint64_t start,
                            const std::function<void(size_t)>& give, int threads);

bool TimingModel::can_defer() const {
  return m_own == nullptr && !m_queued && !m_observer && !m_trace && !m_port.on() && lookahead() > 0;
}

void TimingModel::defer(bool on) {
  if (on == (m_defer != nullptr)) return;
  if (on) {
    if (!can_defer()) throw std::logic_error("timing model: this unit cannot defer its memory requests");
    auto held = std::make_unique<DeferredMemory>(*m_mem, m_now);
    m_defer = held.get();
    m_held_memory = std::make_unique<MemorySystem>(std::move(held));
    m_shared = m_mem;
    m_mem = m_held_memory.get();
    m_park.resize(size_t(m_c.ray_slots));
  } else {
    m_mem = m_shared;
    m_defer = nullptr;
    m_held_memory.reset();
  }
}

uint64_t run_units_in_step(const std::vector<TimingModel*>& units, uint64_t start,
                           const std::function<void(size_t)>& give, int threads) {
  if (!units.empty() && units[0]->queued()) return run_units_queued(units, start, give);
  if (threads > 1 && units.size() > 1 &&
      std::all_of(units.begin(), units.end(), [](const TimingModel* u) { return u->can_defer(); }))
    return run_units_threaded(units, start, give, threads);
  using Next = std::pair<uint64_t, uint32_t>;  // (next action's cycle, unit): a min-heap
  std::vector<Next> heap;
  for (size_t u = 0; u < units.size(); ++u) heap.push_back({units[u]->next_cycle(), uint32_t(u)});
  std::make_heap(heap.begin(), heap.end(), std::greater<>());
  while (!heap.empty() && heap.front().first != TimingModel::kNever) {
    std::pop_heap(heap.begin(), heap.end(), std::greater<>());
    const auto [t, u] = heap.back();
    TimingModel& unit = *units[u];
    if (unit.starved()) {
      give(u);  // its next action takes a ray: give it more, then let it act
    } else {
      // The unit acts until the next other unit's action: every cycle before it, and that cycle too when the
      // other unit comes after it (ties go to the lower unit). The popped (t, u) is below the heap's front, so
      // the limit is at least t.
      uint64_t limit = TimingModel::kNever - 1;
      if (heap.size() > 1) limit = heap.front().second < u ? heap.front().first - 1 : heap.front().first;
      unit.run_until(limit);
    }
    heap.back() = {unit.next_cycle(), u};
    std::push_heap(heap.begin(), heap.end(), std::greater<>());
  }
  uint64_t end = start;
  for (const TimingModel* unit : units) end = std::max(end, unit->end_cycle());
  for (TimingModel* unit : units) unit->end_packet(end);
  return end;
}

void TimingModel::add_rays(std::vector<TraceEvent>* events, size_t m) {
  m_feed = RayFeed{events, m_admission->fed_up_to(), m};
}

uint64_t TimingModel::next_cycle() const {
  uint64_t t = m_queue.empty() ? kNever : m_queue.top_cycle();
  if (!m_free_slots.empty() && m_next < m_n) t = std::min(t, m_free_slots.front().first);
  return t;
}

bool TimingModel::starved() const {
  if (m_free_slots.empty() || m_next >= m_n) return false;
  const uint64_t free_at = m_free_slots.front().first;
  if (!(m_queue.empty() || m_queue.top_cycle() >= free_at)) return false;  // a busy slot acts first
  return m_admission->starved(m_feed, free_at);
}

void TimingModel::end_packet(uint64_t end) {
  m_feed.rays = nullptr;
  m_base = std::max(m_base, end);
}

uint64_t TimingModel::finish() {
  m_feed = RayFeed{nullptr, m_admission->fed_up_to(), 0};
  simulate();
  const uint64_t cycles = m_end - m_base;
  m_base = m_end;
  m_s->cycles += cycles;
  return cycles;
}

}  // namespace rtu::hw
