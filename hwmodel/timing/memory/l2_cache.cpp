#include "hwmodel/timing/memory/l2_cache.h"

#include <algorithm>

#include "hwmodel/timing/memory/memory_backend.h"

namespace rtu::hw {

L2Cache::L2Cache(const TimingConfig& c)
    : m_latency(uint64_t(c.l2_latency)),
      m_xfer(transfer_cycles(uint64_t(c.line_bytes), c.l2_bytes_per_cycle)),
      m_word_xfer(transfer_cycles(8, c.l2_bytes_per_cycle)),
      m_slices(uint32_t(std::max(1, c.l2_slices))),
      m_sets(0),
      m_ways(uint32_t(std::max(1, c.l2_ways))) {
  if (c.l2_kib <= 0) return;
  const uint64_t lines = uint64_t(c.l2_kib) * 1024 / uint64_t(c.line_bytes);
  m_sets = uint32_t(lines / (uint64_t(m_slices) * m_ways));  // validate(): a whole number of sets per slice
  m_lines.assign(size_t(m_slices) * m_sets * m_ways, Line{});
  m_port_free.assign(m_slices, 0);
}

uint64_t L2Cache::state_bytes(const TimingConfig& c) {
  if (c.l2_kib <= 0) return 0;
  return uint64_t(c.l2_kib) * 1024 / uint64_t(c.line_bytes) * sizeof(Line) +
         uint64_t(std::max(1, c.l2_slices)) * sizeof(uint64_t);
}

}  // namespace rtu::hw
