#include "hwmodel/timing/memory/banked_dram.h"

#include <algorithm>

#include "hwmodel/timing/memory/memory_backend.h"

namespace rtu::hw {

BankedDram::BankedDram(const TimingConfig& c)
    : m_latency(uint64_t(c.dram_latency)),
      m_activate(uint64_t(c.dram_activate_cycles)),
      m_precharge(uint64_t(c.dram_precharge_cycles)),
      m_bytes_per_cycle(c.dram_bytes_per_cycle / std::max(1, c.dram_channels)),
      m_line_bytes(uint64_t(c.line_bytes)),
      m_line_cycles(transfer_cycles(m_line_bytes, m_bytes_per_cycle)),
      m_lines_per_row(std::max<uint64_t>(1, uint64_t(c.dram_row_bytes) / uint64_t(c.line_bytes))),
      m_channels(uint32_t(std::max(1, c.dram_channels))),
      m_banks(uint32_t(std::max(1, c.dram_banks))),
      m_rows(c.dram_banks > 0),
      m_bank(size_t(m_channels) * m_banks),
      m_bus_free(m_channels, 0) {}

BankedDram::Place BankedDram::place(uint64_t addr) const {
  const uint64_t line = addr / m_line_bytes;
  // The channel: the line number folded with two higher fields of its bits (XOR), as memory controllers hash
  // addresses, so that strided streams (slots' stacks 4 KiB apart, rows of nodes) spread over the channels.
  const uint64_t channel = (line ^ (line >> 6) ^ (line >> 12)) % m_channels;
  const uint64_t local = line / m_channels;  // the line's index within its channel
  const uint64_t row_index = local / m_lines_per_row;
  return Place{uint32_t(channel), uint32_t(row_index % m_banks), row_index / m_banks};
}

uint64_t BankedDram::transfer(uint64_t addr, uint64_t bytes, uint64_t t, TimingStats& s) {
  const Place p = place(addr);
  Bank& b = m_bank[size_t(p.channel) * m_banks + p.bank];
  uint64_t cmd = t;  // no rows: the bank is never the wait
  if (m_rows) {
    cmd = std::max(t, b.ready);
    s.mem_wait_cycles += cmd - t;  // the bank busy with an earlier command
    if (b.open_row == p.row) {
      ++s.dram_row_hits;
    } else {
      ++s.dram_row_misses;
      cmd += (b.open_row == ~uint64_t(0) ? 0 : m_precharge) + m_activate;
      b.open_row = p.row;
    }
  }
  const uint64_t xfer = bytes == m_line_bytes ? m_line_cycles : transfer_cycles(bytes, m_bytes_per_cycle);
  uint64_t& bus = m_bus_free[p.channel];
  const uint64_t start = std::max(cmd, bus);
  bus = start + xfer;
  s.mem_wait_cycles += start - cmd;  // the channel busy with an earlier transfer
  b.ready = start;
  s.dram_bytes += bytes;
  s.dram_busy_cycles += xfer;
  return start + xfer + m_latency;
}

uint64_t BankedDram::free_at() const {
  return *std::max_element(m_bus_free.begin(), m_bus_free.end());
}

}  // namespace rtu::hw
