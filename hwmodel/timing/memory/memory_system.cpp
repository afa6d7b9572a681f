#include "hwmodel/timing/memory/memory_system.h"

#include <algorithm>
#include <cmath>

namespace rtu::hw {

namespace {

uint64_t cycles_for(uint64_t bytes, double bytes_per_cycle) {
  return bytes_per_cycle > 0 ? uint64_t(std::ceil(double(bytes) / bytes_per_cycle)) : 0;
}

}  // namespace

BankedDram::BankedDram(const TimingConfig& c)
    : m_latency(uint64_t(c.dram_latency)),
      m_activate(uint64_t(c.dram_activate_cycles)),
      m_precharge(uint64_t(c.dram_precharge_cycles)),
      m_bytes_per_cycle(c.dram_bytes_per_cycle / std::max(1, c.dram_channels)),
      m_line_bytes(uint64_t(c.line_bytes)),
      m_line_cycles(cycles_for(m_line_bytes, m_bytes_per_cycle)),
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
  const uint64_t xfer = bytes == m_line_bytes ? m_line_cycles : cycles_for(bytes, m_bytes_per_cycle);
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

L2Cache::L2Cache(const TimingConfig& c)
    : m_latency(uint64_t(c.l2_latency)),
      m_xfer(cycles_for(uint64_t(c.line_bytes), c.l2_bytes_per_cycle)),
      m_slices(uint32_t(std::max(1, c.l2_slices))),
      m_sets(0),
      m_ways(uint32_t(std::max(1, c.l2_ways))) {
  if (c.l2_kib <= 0) return;
  const uint64_t lines = uint64_t(c.l2_kib) * 1024 / uint64_t(c.line_bytes);
  m_sets = uint32_t(lines / (uint64_t(m_slices) * m_ways));  // validate(): a whole number of sets per slice
  m_lines.assign(size_t(m_slices) * m_sets * m_ways, Line{});
  m_port_free.assign(m_slices, 0);
}

void MemoryTimeline::add(std::vector<uint64_t>& series, uint64_t cycle, uint64_t bytes) {
  uint64_t bin = cycle / bin_cycles;
  while (bin >= kTimelineBins) {
    // Coarsen both series together, so that their bins stay the same.
    for (std::vector<uint64_t>* v : {&dram_bytes, &l2_bytes}) {
      for (size_t i = 0; i < v->size(); ++i) (*v)[i / 2] = (i % 2 ? (*v)[i / 2] : 0) + (*v)[i];
      v->resize((v->size() + 1) / 2);
    }
    bin_cycles *= 2;
    bin = cycle / bin_cycles;
  }
  if (series.size() <= bin) series.resize(size_t(bin) + 1, 0);
  series[size_t(bin)] += bytes;
}

MemorySystem::MemorySystem(const TimingConfig& c)
    : m_line_bytes(uint64_t(c.line_bytes)),
      m_banked(c.dram_banks > 0 || c.dram_channels > 1),
      m_channel(c),
      m_dram(c),
      m_l2(c),
      m_latency(uint64_t(c.dram_latency)) {}

uint64_t MemorySystem::dram(uint64_t addr, uint64_t bytes, uint64_t t, TimingStats& s) {
  const uint64_t ready = m_banked ? m_dram.transfer(addr, bytes, t, s) : m_channel.transfer(bytes, t, s);
  m_timeline.add(m_timeline.dram_bytes, ready - m_latency, bytes);
  return ready;
}

uint64_t MemorySystem::dram_line(uint64_t line, uint64_t t, TimingStats& s) {
  return dram(line * m_line_bytes, m_line_bytes, t, s);
}

uint64_t MemorySystem::read_line(uint64_t line, uint64_t t, TimingStats& s) {
  if (!m_l2.enabled()) return dram_line(line, t, s);
  m_timeline.add(m_timeline.l2_bytes, t, m_line_bytes);
  return m_l2.access(
      line, t, [&](uint64_t l, uint64_t at) { return dram_line(l, at, s); }, s);
}

void MemorySystem::write_word(uint64_t addr, uint64_t t, TimingStats& s) {
  // A write leaves the slot at once: its wait for the channel is not the ray's (mem_wait_cycles counts reads).
  const uint64_t waited = s.mem_wait_cycles;
  dram(addr, 8, t, s);
  s.mem_wait_cycles = waited;
}

uint64_t MemorySystem::read_word(uint64_t addr, uint64_t t, TimingStats& s) {
  return dram(addr, 8, t, s);
}

uint64_t MemorySystem::min_line_cycles() const {
  const uint64_t dram = m_banked ? m_dram.min_line_cycles() : m_channel.line_cycles() + m_channel.latency();
  return m_l2.enabled() ? m_l2.min_cycles(dram) : dram;
}

uint64_t MemorySystem::free_at() const {
  return m_banked ? m_dram.free_at() : m_channel.free_at();
}

}  // namespace rtu::hw
