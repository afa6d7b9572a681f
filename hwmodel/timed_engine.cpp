#include "hwmodel/timed_engine.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>

#include "hwmodel/batch.h"
#include "hwmodel/regs.h"

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
    m_cache.assign(lines, Line{});
  }
  m_box_free.assign(size_t(c.box_units), 0);
  m_tri_free.assign(size_t(c.tri_units) * size_t(c.tri_rate), 0);  // a unit of rate r: r issue slots per clock
  m_slots.resize(size_t(c.ray_slots));
  m_recent.assign(size_t(c.queue_depth), 0);
  while ((uint64_t(1) << m_line_shift) < uint64_t(c.line_bytes)) ++m_line_shift;
  m_line_xfer = xfer_cycles(uint64_t(c.line_bytes));
  m_word_xfer = xfer_cycles(8);
  for (uint64_t k = 0; k < m_box_issue.size(); ++k) m_box_issue[k] = (k + uint64_t(c.box_rate) - 1) / uint64_t(c.box_rate);
}

uint64_t TimingModel::xfer_cycles(uint64_t bytes) const {
  return uint64_t(std::ceil(double(bytes) / m_c.dram_bytes_per_cycle));
}

uint64_t TimingModel::dram(uint64_t bytes, uint64_t t) {
  const uint64_t xfer = bytes == uint64_t(m_c.line_bytes) ? m_line_xfer : (bytes == 8 ? m_word_xfer : xfer_cycles(bytes));
  const uint64_t start = std::max(t, m_dram_free);
  m_dram_free = start + xfer;
  m_s->dram_bytes += bytes;
  m_s->dram_busy_cycles += xfer;
  return start + xfer + uint64_t(m_c.dram_latency);
}

uint64_t TimingModel::line_access(uint64_t line, uint64_t t) {
  if (m_cache.empty()) {
    ++m_s->cache_misses;
    return dram(uint64_t(m_c.line_bytes), t);
  }
  const uint64_t set = line % m_sets;
  Line* ways = &m_cache[set * uint64_t(m_c.cache_ways)];
  Line* victim = ways;
  for (int w = 0; w < m_c.cache_ways; ++w) {
    if (ways[w].tag == line) {
      ++m_s->cache_hits;
      ways[w].stamp = ++m_stamp;
      return std::max(t, ways[w].ready) + uint64_t(m_c.cache_latency);
    }
    if (ways[w].stamp < victim->stamp) victim = &ways[w];  // never-used lines have stamp 0
  }
  ++m_s->cache_misses;
  victim->tag = line;
  victim->stamp = ++m_stamp;
  victim->ready = dram(uint64_t(m_c.line_bytes), t + uint64_t(m_c.cache_latency));
  return victim->ready;
}

uint64_t TimingModel::access(uint64_t addr, uint64_t bytes, uint64_t t) {
  const uint64_t lb = uint64_t(m_c.line_bytes);
  uint64_t ready = t;
  for (uint64_t line = addr / lb; line <= (addr + bytes - 1) / lb; ++line)
    ready = std::max(ready, line_access(line, t));
  return ready;
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
  m_heap.clear();
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
  const std::vector<TraceEvent>& ev = m_feed[i - m_feed_first];
  sl.ev.assign(ev.begin(), ev.end());
  sl.pos = 0;
  sl.depth = 0;
  sl.unit_phase = false;
  sl.entered = enter;
  sl.ray = i;
  sl.busy = true;
  if (m_c.watchdog_cycles > 0) m_age.push_back({enter, k});
  if (m_trace) m_trace->add(k, "setup", enter, enter + uint64_t(m_c.setup_latency));
  m_heap.push_back({enter + uint64_t(m_c.setup_latency), k});
  std::push_heap(m_heap.begin(), m_heap.end(), std::greater<>());
}

void TimingModel::simulate() {
  const uint64_t SE = uint64_t(m_c.stack_entries);
  for (;;) {
    // Free slots take the next rays, earliest free first (ties: lowest slot).
    while (!m_free_slots.empty() && m_next < m_n) {
      std::pop_heap(m_free_slots.begin(), m_free_slots.end(), std::greater<>());
      const auto [free_at, k] = m_free_slots.back();
      if (!m_heap.empty() && m_heap.front().first < free_at) {  // a busy slot acts first
        std::push_heap(m_free_slots.begin(), m_free_slots.end(), std::greater<>());
        break;
      }
      if (m_next >= m_feed_first + m_feed_count) {  // its ray is not fed yet
        std::push_heap(m_free_slots.begin(), m_free_slots.end(), std::greater<>());
        return;
      }
      m_free_slots.pop_back();
      admit(k, free_at);
    }
    if (m_heap.empty()) return;
    std::pop_heap(m_heap.begin(), m_heap.end(), std::greater<>());
    const auto [t, k] = m_heap.back();
    m_heap.pop_back();
    if (m_c.watchdog_cycles > 0) watchdog(t);
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
        m_end = std::max(m_end, st + uint64_t(m_c.writeback_latency));
        if (m_trace) m_trace->add(k, "write-back", st, st + 1);  // the slot hands its hit to the write-back pipe
        m_s->stream_bytes += kHitBytesStream;
        m_s->slot_busy_cycles += st + 1 - sl.entered;
        m_free_slots.push_back({st + 1, k});
        std::push_heap(m_free_slots.begin(), m_free_slots.end(), std::greater<>());
        break;
      }
      const TraceEvent& e = sl.ev[sl.pos];
      switch (e.kind) {
        case TraceEvent::kPush:
          for (int j = 0; j < e.count; ++j) {
            if (uint64_t(++sl.depth) > SE) {
              ++m_s->stack_spills;
              dram(8, t);  // bandwidth only: the write leaves the slot
            }
          }
          ++sl.pos;
          continue;
        case TraceEvent::kPop:
          ++sl.pos;
          if (uint64_t(sl.depth--) > SE) {
            ++m_s->stack_refills;
            next_t = dram(8, t);
            if (m_trace) m_trace->add(k, "stack refill", t, next_t);
            waiting = true;
          }
          continue;
        default:
          break;
      }
      if (!sl.unit_phase) {  // fetch the data the unit needs
        uint64_t addr, bytes;
        if (e.kind == TraceEvent::kNode) {
          addr = m_layout.node_offset + uint64_t(e.index) * m_layout.node_bytes;
          bytes = m_layout.node_bytes;
          ++m_s->node_fetches;
        } else if (e.kind == TraceEvent::kPrim) {
          addr = m_layout.record_offset + uint64_t(e.index) * kRecordBytes;
          bytes = kRecordBytes;
          ++m_s->prim_fetches;
        } else {
          addr = m_layout.plane_offset + uint64_t(e.index) * sizeof(PlaneRecord);
          bytes = sizeof(PlaneRecord);
          ++m_s->prim_fetches;
        }
        next_t = access(addr, bytes, t);
        if (m_trace) m_trace->add(k, e.kind == TraceEvent::kNode ? "node fetch" : "record fetch", t, next_t);
        sl.unit_phase = true;
        waiting = true;
        continue;
      }
      // The data is there: the unit request.
      uint64_t done;
      if (e.kind == TraceEvent::kNode) {
        const uint64_t issue = m_box_issue[e.count];
        done = unit(m_box_free, issue, uint64_t(m_c.box_latency), t);
        if (m_trace) m_trace->add(k, "box", t, done);
        m_s->box_tests += e.count;
        m_s->box_issue_cycles += issue;
      } else {
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
              k,
              e.kind == TraceEvent::kPlane ? "plane" : (lat == uint64_t(m_c.tri_latency) ? "triangle" : "sphere"),
              t, done);
        ++m_s->tri_issue_cycles;
      }
      ++sl.pos;
      sl.unit_phase = false;
      next_t = done + uint64_t(m_c.traversal_latency);
      waiting = true;
    }
    if (waiting) {
      m_heap.push_back({next_t, k});
      std::push_heap(m_heap.begin(), m_heap.end(), std::greater<>());
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
    if (t > entered + uint64_t(m_c.watchdog_cycles)) fire(k, entered + uint64_t(m_c.watchdog_cycles) + 1);
    return;
  }
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
         " of " + u(sl.ev.size()) + " (" + event_name(sl) + "), stack depth " + std::to_string(sl.depth) + "\n";
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

void TimingModel::feed(const std::vector<TraceEvent>* events, size_t m) {
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

TimedEngine::TimedEngine(const EngineOptions& o, const TimingConfig& c) : m_opt(o), m_c(c) {
  m_c.validate();
}

uint32_t TimedEngine::caps() const {
  return reg::kCapTriangles | reg::kCapSpheres | reg::kCapPlanes | reg::kCapAnyHit | reg::kCapFixed |
         reg::kCapTimed;
}

void TimedEngine::bind(const uint8_t* data, size_t bytes) {
  unbind();
  DeviceImage img = DeviceImage::from_bytes(data, bytes);
  m_image = std::make_unique<DeviceImage>(std::move(img));
  m_tracer = std::make_unique<FixedTracer>(*m_image, FixedTraceOptions{false, m_opt.max_steps});
  const ImageHeader& h = m_image->header();
  TimingModel::Layout l;
  l.node_offset = h.node_offset;
  l.node_bytes = m_image->node_bytes();
  l.record_offset = h.record_offset;
  l.plane_offset = h.plane_offset;
  m_model = std::make_unique<TimingModel>(m_c, l);
  m_model->set_trace(m_trace);
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

uint64_t TimedEngine::trace_cycles(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                   uint8_t ray_type, uint8_t bounce) {
  // Chunks of rays: traced (and recorded) on the worker threads, then replayed through the model in order.
  constexpr size_t kChunk = 4096;
  std::vector<std::vector<TraceEvent>> events(std::min(n, kChunk));
  TimingStats ts;
  m_model->begin(n, ts);
  uint64_t cycles = 0;
  try {
    for (size_t first = 0; first < n; first += kChunk) {
      const size_t m = std::min(kChunk, n - first);
      TraversalStats local;
      run_batch(m, m_opt.threads, local, [&](size_t i, TraversalStats& st) {
        events[i].clear();
        hits[first + i] = m_tracer->trace_recorded(rays[first + i], any_hit, st, events[i]);
      });
      if (local.watchdog_rays > 0)
        throw WatchdogError(m_tracer->watchdog_report(rays, n, any_hit, local.watchdog_rays), 0);
      if (local.first_invalid != UINT64_MAX) local.first_invalid += first;
      s.add(local);
      m_model->feed(events.data(), m);
    }
    cycles = m_model->finish();
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

Geometry::Counts TimedEngine::counts() const {
  if (!m_image) return {};
  const ImageHeader& h = m_image->header();
  return {h.num_triangles, h.num_spheres, h.plane_count};
}

bool TimedEngine::uses_bvh() const {
  return m_image && !(m_image->header().flags & kImageNoBvh);
}

std::unique_ptr<TraceEngine> make_timed_engine(const EngineOptions& o, const TimingConfig& c) {
  return std::make_unique<TimedEngine>(o, c);
}

}  // namespace rtu::hw
