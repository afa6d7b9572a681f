// DRAM with channels and open-page banks (dram_channels > 1 or dram_banks > 0), the last level of the memory
// behind a unit's node cache when the configuration asks for banks or channels (memory_system.cpp composes it).
//
// DRAM with channels or banks (dram_channels > 1 or dram_banks > 0): dram_channels channels, each with
// dram_banks banks and an open-page row buffer of dram_row_bytes (dram_banks = 0: no rows, no activates). Lines
// are interleaved over the channels (channel = line XOR line >> 6 XOR line >> 12, mod channels: consecutive
// lines alternate, strided streams spread); within a channel consecutive lines fill a row, and rows rotate over
// the banks. The channels share dram_bytes_per_cycle equally. An access to a bank whose open row is the line's
// is a row hit; to a bank with no open row it first activates the row (dram_activate_cycles); to a bank with
// another row open it precharges and activates (dram_precharge_cycles + dram_activate_cycles). The transfer then
// takes the channel's data bus for ceil(bytes / channel bandwidth) clocks from max(the bank's command, bus
// free), and the data is there dram_latency after the transfer ends, as on the single channel. A bank takes its
// next command when the previous one's transfer has started.
// Requests are served at their own cycle in the order they come (the unit's come in cycle order).
// Left out: refresh, read/write turnaround, request reordering (FR-FCFS), bank groups.
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

// DRAM with channels and open-page banks (dram_channels > 1 or dram_banks > 0; no rows without banks).
class BankedDram {
 public:
  explicit BankedDram(const TimingConfig& c);
  // A transfer of `bytes` at byte address `addr` requested at cycle t: returns the cycle its data is there.
  // Counts bytes, busy cycles and row hits and misses.
  uint64_t transfer(uint64_t addr, uint64_t bytes, uint64_t t, TimingStats& s);
  // The fewest cycles a line read can take (a row hit on an idle channel).
  uint64_t min_line_cycles() const { return m_line_cycles + m_latency; }
  uint64_t free_at() const;  // the latest cycle a channel's data bus is busy until
  // Where an address falls (for tests and the watchdog's dump).
  struct Place {
    uint32_t channel, bank;
    uint64_t row;
  };
  Place place(uint64_t addr) const;

 private:
  struct Bank {
    uint64_t open_row = ~uint64_t(0);  // none
    uint64_t ready = 0;                // next command no earlier than this
  };
  uint64_t m_latency, m_activate, m_precharge;
  double m_bytes_per_cycle;  // per channel
  uint64_t m_line_bytes, m_line_cycles, m_lines_per_row;
  uint32_t m_channels, m_banks;
  bool m_rows;                       // dram_banks > 0: open-page rows
  std::vector<Bank> m_bank;          // channel * banks + bank
  std::vector<uint64_t> m_bus_free;  // per channel
};

}  // namespace rtu::hw
