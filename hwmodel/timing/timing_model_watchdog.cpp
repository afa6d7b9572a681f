// The timing model's watchdog (timing_model.h): when the oldest ray in a slot has been there more than
// watchdog_cycles, the TRACE stops with WatchdogError and a report of the unit's state at that cycle (rays, slots
// and their next events, the units' queued work, the DRAM channel, the write-back, this TRACE's counters), so
// that a hang in the model or a pathological scene is diagnosed from the message alone.
#include "hwmodel/timing/timing_model.h"

#include <algorithm>
#include <string>

#include "hwmodel/datapath/watchdog.h"

namespace rtu::hw {

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
    const std::string what = e.kind == TraceEvent::kNode     ? "node "
                             : e.kind == TraceEvent::kPrim   ? "record "
                             : e.kind == TraceEvent::kPlane  ? "plane "
                             : e.kind == TraceEvent::kAnyHit ? "any-hit answer for record "
                             : e.kind == TraceEvent::kOmm    ? "micromap state for record "
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
       u(m_mem->free_at() > cycle ? m_mem->free_at() - cycle : 0) + " more cycles; write-back free at " +
       u(m_wb_free) + "\n";
  d += "  this TRACE so far: cache hits " + u(m_s->cache_hits) + ", misses " + u(m_s->cache_misses) +
       ", DRAM bytes " + u(m_s->dram_bytes) + ", stack spills " + u(m_s->stack_spills) + ", queue stall cycles " +
       u(m_s->queue_stall_cycles);
  throw WatchdogError(d, cycle - m_base);
}

}  // namespace rtu::hw
