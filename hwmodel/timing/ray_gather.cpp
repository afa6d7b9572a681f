#include "hwmodel/timing/ray_gather.h"

#include <algorithm>
#include <stdexcept>

namespace rtu::hw {

RayGather::RayGather(const TimingConfig& c)
    : m_buffer(uint64_t(c.gather_buffer)),
      m_bin_rays(uint64_t(c.gather_rays)),
      m_timeout(uint64_t(c.gather_timeout)),
      m_fetch_latency(uint64_t(c.ray_fetch_latency)),
      m_events(m_buffer),
      m_ray(m_buffer, 0),
      m_arrival(m_buffer, 0),
      m_departed(m_buffer, 0) {}

void RayGather::begin(size_t n, uint64_t t0) {
  m_n = n;
  m_arrived = m_left = 0;
  m_t0 = t0;
  m_free.clear();
  for (uint64_t e = m_buffer; e-- > 0;) m_free.push_back(uint32_t(e));  // entry 0 is taken first
  m_bins.clear();
  m_timeouts.clear();
  m_ready.clear();
}

uint64_t RayGather::next_arrival() const {
  const size_t i = m_arrived;
  if (i >= m_n) return kNever;
  uint64_t fetch = m_t0 + i;
  if (i >= m_buffer) {
    // Ray i takes the entry ray number i - m_buffer (in the order rays left) freed.
    if (m_left <= i - m_buffer) return kNever;
    fetch = std::max(fetch, m_departed[(i - m_buffer) % m_buffer]);
  }
  // Both terms grow with i (departures come in cycle order), so rays arrive in order.
  return fetch + m_fetch_latency;
}

void RayGather::arrive(std::vector<TraceEvent>& events, TimingStats& s) {
  const uint64_t t = next_arrival();
  if (t == kNever || m_free.empty()) throw std::logic_error("gather: a ray arrived with no room for it");
  const uint32_t entry = m_free.back();
  m_free.pop_back();
  const uint32_t key = !events.empty() && events[0].kind == TraceEvent::kRayKey ? events[0].index : 0;
  m_events[entry].swap(events);
  m_ray[entry] = m_arrived++;
  m_arrival[entry] = t;
  Bin& b = m_bins[key];
  if (b.entries.empty()) {
    b.first = t;
    m_timeouts.insert({t + m_timeout, key});
  }
  b.entries.push_back(entry);
  if (b.entries.size() >= m_bin_rays) {
    ++s.gather_bins_full;
    issue(key, t, s);
  }
  if (m_arrived == m_n) {  // the packet's last ray: every bin goes, oldest first
    while (!m_timeouts.empty()) issue(m_timeouts.begin()->second, t, s);
  } else if (m_free.empty() && m_ready.empty()) {
    // The buffer is full and nothing can leave it: the fullest bin goes (a tie: the oldest, then the lower key).
    uint32_t best = 0;
    const Bin* pick = nullptr;
    for (const auto& [k, bin] : m_bins) {
      if (bin.entries.empty()) continue;
      if (!pick || bin.entries.size() > pick->entries.size() ||
          (bin.entries.size() == pick->entries.size() &&
           (bin.first < pick->first || (bin.first == pick->first && k < best)))) {
        pick = &bin;
        best = k;
      }
    }
    if (pick) issue(best, t, s);
  }
}

void RayGather::expire(uint64_t t, TimingStats& s) {
  while (!m_timeouts.empty() && m_timeouts.begin()->first <= t) {
    const auto [at, key] = *m_timeouts.begin();
    ++s.gather_bins_timeout;
    issue(key, at, s);
  }
}

void RayGather::issue(uint32_t key, uint64_t t, TimingStats& s) {
  auto it = m_bins.find(key);
  if (it == m_bins.end() || it->second.entries.empty()) return;
  Bin& b = it->second;
  m_timeouts.erase({b.first + m_timeout, key});
  ++s.gather_bins;
  for (uint32_t e : b.entries) {
    s.gather_wait_cycles += t - m_arrival[e];
    m_ready.push_back({e, t});
  }
  m_bins.erase(it);
}

size_t RayGather::take(std::vector<TraceEvent>& events, uint64_t& issued) {
  if (m_ready.empty()) throw std::logic_error("gather: a slot took a ray with none issued");
  const auto [entry, t] = m_ready.front();
  m_ready.pop_front();
  events.swap(m_events[entry]);
  issued = t;
  m_free.push_back(entry);
  return m_ray[entry];
}

void RayGather::leave(uint64_t cycle) {
  m_departed[m_left % m_buffer] = cycle;
  ++m_left;
}

}  // namespace rtu::hw
