// The timed device's DRAM channel: node cache fills and stack spills and refills go over it (the default last
// level of memory_system.h).
//
// Models: one transfer at a time, in the order requested; a transfer of b bytes occupies the channel for
// ceil(b / dram_bytes_per_cycle) cycles, and its data is there dram_latency cycles after the transfer ends.
// Writes (stack spills) occupy the channel the same way; their latency is not waited for.
// Left out: banks, rows and refresh, read/write turnaround, more than one channel, request reordering.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

class DramChannel {
 public:
  explicit DramChannel(const TimingConfig& c)
      : m_latency(uint64_t(c.dram_latency)),
        m_bytes_per_cycle(c.dram_bytes_per_cycle),
        m_line_bytes(uint64_t(c.line_bytes)),
        m_line_cycles(transfer_cycles(m_line_bytes)),
        m_word_cycles(transfer_cycles(8)) {}

  // Cycles the channel is busy with b bytes: ceil(b / bandwidth).
  uint64_t transfer_cycles(uint64_t bytes) const { return uint64_t(std::ceil(double(bytes) / m_bytes_per_cycle)); }

  // A transfer of `bytes` requested at cycle t: returns the cycle its data is there. Counts bytes and busy cycles.
  uint64_t transfer(uint64_t bytes, uint64_t t, TimingStats& s) {
    const uint64_t xfer =
        bytes == m_line_bytes ? m_line_cycles : (bytes == 8 ? m_word_cycles : transfer_cycles(bytes));
    const uint64_t start = std::max(t, m_free);
    m_free = start + xfer;
    s.mem_wait_cycles += start - t;
    s.dram_bytes += bytes;
    s.dram_busy_cycles += xfer;
    return start + xfer + m_latency;
  }
  // The same, as a DRAM model of memory_backend.h: one channel has no addresses.
  uint64_t transfer(uint64_t /*addr*/, uint64_t bytes, uint64_t t, TimingStats& s) {
    return transfer(bytes, t, s);
  }
  // The fewest cycles a line read takes (an idle channel).
  uint64_t min_line_cycles() const { return m_line_cycles + m_latency; }
  // The cycle the channel is free for the next transfer.
  uint64_t free_at() const { return m_free; }

 private:
  uint64_t m_latency;
  double m_bytes_per_cycle;
  uint64_t m_line_bytes;
  uint64_t m_line_cycles, m_word_cycles;  // a line's and an 8-byte stack entry's transfer
  uint64_t m_free = 0;
};

}  // namespace rtu::hw
