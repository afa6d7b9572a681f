#include "hwmodel/timing/memory/dram_scheduler.h"

#include <algorithm>

namespace rtu::hw {

FrFcfsDram::FrFcfsDram(const TimingConfig& c, MemoryTimeline& timeline)
    : m_geometry(c),
      m_timeline(timeline),
      m_latency(uint64_t(c.dram_latency)),
      m_activate(uint64_t(c.dram_activate_cycles)),
      m_precharge(uint64_t(c.dram_precharge_cycles)),
      m_line_bytes(uint64_t(c.line_bytes)),
      m_bytes_per_cycle(c.dram_bytes_per_cycle / std::max(1, c.dram_channels)),
      m_banks(uint32_t(std::max(1, c.dram_banks))),
      m_cap(uint32_t(c.dram_frfcfs_cap)),
      m_bank(size_t(std::max(1, c.dram_channels)) * m_banks),
      m_bus_free(size_t(std::max(1, c.dram_channels)), 0) {
  m_line_cycles = transfer_cycles(m_line_bytes, m_bytes_per_cycle);
}

uint64_t FrFcfsDram::enqueue(uint64_t addr, uint64_t bytes, uint64_t t, bool read, TimingStats& s) {
  const BankedDram::Place p = m_geometry.place(addr);
  Bank& b = m_bank[size_t(p.channel) * m_banks + p.bank];
  const uint64_t ready = read ? m_pending.make() : 0;
  b.queue.push_back(Request{t, m_seq++, p.row, bytes, ready, &s, p.channel});
  update_decision(b);
  m_next = std::min(m_next, b.decision);
  return ready;
}

void FrFcfsDram::update_decision(Bank& b) {
  if (b.queue.empty()) {
    b.decision = kNoDecision;
    return;
  }
  uint64_t oldest = b.queue.front().arrival;
  for (const Request& r : b.queue) oldest = std::min(oldest, r.arrival);
  b.decision = std::max(b.ready, oldest);
}

// The request bank b serves at cycle `now`, among those arrived by then: one passed over `m_cap` times (the
// oldest), else the oldest row hit, else the oldest. `capped_by` is set when the cap chose and a row hit would
// have gone instead.
size_t FrFcfsDram::choose(const Bank& b, uint64_t now, TimingStats*& capped_by) const {
  auto older = [](const Request& x, const Request& y) {
    return x.arrival != y.arrival ? x.arrival < y.arrival : x.seq < y.seq;
  };
  size_t oldest = SIZE_MAX, hit = SIZE_MAX, capped = SIZE_MAX;
  for (size_t i = 0; i < b.queue.size(); ++i) {
    const Request& r = b.queue[i];
    if (r.arrival > now) continue;
    if (oldest == SIZE_MAX || older(r, b.queue[oldest])) oldest = i;
    if (r.row == b.open_row && (hit == SIZE_MAX || older(r, b.queue[hit]))) hit = i;
    if (r.bypassed >= m_cap && (capped == SIZE_MAX || older(r, b.queue[capped]))) capped = i;
  }
  const size_t fr = hit != SIZE_MAX ? hit : oldest;
  capped_by = nullptr;
  if (capped == SIZE_MAX) return fr;
  if (capped != fr) capped_by = b.queue[capped].s;
  return capped;
}

void FrFcfsDram::decide() {
  // The bank with the earliest decision (ties: the lowest bank); m_next is its cycle.
  size_t bi = 0;
  while (m_bank[bi].decision != m_next) ++bi;
  Bank& b = m_bank[bi];
  const uint64_t now = b.decision;
  TimingStats* capped_by = nullptr;
  const size_t pick = choose(b, now, capped_by);
  const Request r = b.queue[pick];
  TimingStats& s = *r.s;
  if (capped_by) ++s.dram_capped;
  bool passed = false;  // an older request that had arrived is passed over
  for (size_t i = 0; i < b.queue.size(); ++i) {
    Request& o = b.queue[i];
    if (i == pick || o.arrival > now) continue;
    if (o.arrival < r.arrival || (o.arrival == r.arrival && o.seq < r.seq)) {
      ++o.bypassed;
      passed = true;
    }
  }
  s.dram_reordered += passed;
  b.queue.erase(b.queue.begin() + std::ptrdiff_t(pick));

  uint64_t cmd = now;
  if (b.open_row == r.row) {
    ++s.dram_row_hits;
  } else {
    ++s.dram_row_misses;
    cmd += (b.open_row == ~uint64_t(0) ? 0 : m_precharge) + m_activate;
    b.open_row = r.row;
  }
  const uint64_t xfer = r.bytes == m_line_bytes ? m_line_cycles : transfer_cycles(r.bytes, m_bytes_per_cycle);
  uint64_t& bus = m_bus_free[r.channel];
  const uint64_t start = std::max(cmd, bus);
  bus = start + xfer;
  b.ready = start;
  s.dram_bytes += r.bytes;
  s.dram_busy_cycles += xfer;
  // A read's queueing: waiting for its decision (the bank busy, or others served first) and for the bus; not
  // its row opening (as banked_dram.h counts it). A write's wait is nobody's.
  if (r.ready) s.mem_wait_cycles += (now - r.arrival) + (start - cmd);
  m_timeline.add(m_timeline.dram_bytes, start + xfer, r.bytes);

  update_decision(b);
  m_next = kNoDecision;
  for (const Bank& k : m_bank) m_next = std::min(m_next, k.decision);
  // Last: the waiters it wakes may queue slots, never requests.
  if (r.ready) m_pending.resolve(r.ready, start + xfer + m_latency);
}

uint64_t FrFcfsDram::free_at() const {
  return *std::max_element(m_bus_free.begin(), m_bus_free.end());
}

}  // namespace rtu::hw
