#include "hwmodel/timing/parts/memory.h"

#include <array>

#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

const TimingKeyTable& dram_channel_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"dram_latency", &C::dram_latency, 0, kMaxLatency, "cycles from a miss to the first byte"},
      {"dram_bytes_per_cycle", &C::dram_bytes_per_cycle, 0.001, 65536, "DRAM bandwidth in bytes per cycle"},
  };
  return keys;
}

const TimingKeyTable& l2_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"l2_kib", &C::l2_kib, 0, 1048576, "L2 behind the node cache in KiB (0: none; memory_system.h)",
       [](const C& c) -> std::string {
         const long long set_bytes = static_cast<long long>(c.l2_slices) * c.l2_ways * c.line_bytes;
         if (c.l2_kib > 0 && set_bytes > 0 && (static_cast<long long>(c.l2_kib) * 1024) % set_bytes != 0)
           return "l2_kib = " + std::to_string(c.l2_kib) + ": not a whole number of sets in each of " +
                  std::to_string(c.l2_slices) + " slices of l2_ways * line_bytes = " +
                  std::to_string(static_cast<long long>(c.l2_ways) * c.line_bytes) + " bytes";
         return {};
       }},
      {"l2_slices", &C::l2_slices, 1, 256, "L2 slices (a line's slice: line number mod slices)"},
      {"l2_ways", &C::l2_ways, 1, 64, "L2 associativity"},
      {"l2_latency", &C::l2_latency, 0, kMaxLatency, "L2 latency in cycles (tag check to data)"},
      {"l2_bytes_per_cycle", &C::l2_bytes_per_cycle, 0, 65536,
       "bytes per clock of each L2 slice's port (0: unlimited)"},
  };
  return keys;
}

const TimingKeyTable& dram_bank_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"dram_channels", &C::dram_channels, 1, 64,
       "DRAM channels sharing dram_bytes_per_cycle (lines interleaved)"},
      {"dram_banks", &C::dram_banks, 0, 64, "open-page banks per DRAM channel (0: no row model)"},
      {"dram_row_bytes", &C::dram_row_bytes, 16, 65536, "DRAM row (page) bytes: a power of two >= line_bytes",
       [](const C& c) -> std::string {
         if ((c.dram_row_bytes & (c.dram_row_bytes - 1)) != 0 || c.dram_row_bytes < c.line_bytes)
           return "dram_row_bytes = " + std::to_string(c.dram_row_bytes) +
                  " must be a power of two >= line_bytes (" + std::to_string(c.line_bytes) + ")";
         return {};
       }},
      {"dram_activate_cycles", &C::dram_activate_cycles, 0, kMaxLatency, "cycles to open a DRAM row (tRCD)"},
      {"dram_precharge_cycles", &C::dram_precharge_cycles, 0, kMaxLatency, "cycles to close a DRAM row (tRP)"},
      {"memory_type", choice_field<&C::memory_type>(), 0, 0, "DRAM type, for its energy per bit"},
  };
  return keys;
}

std::span<const TimingCounter> l2_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 6> counters = {{
      {"l2_hits", &S::l2_hits, "lines", "node cache fills found in the L2 (with l2_kib > 0)", kPerRay},
      {"l2_misses", &S::l2_misses, "lines", "node cache fills the L2 missed (read from DRAM)", kPerRay},
      {"l2_stack_hits", &S::l2_stack_hits, "words", "stack spills and refills whose line was in the L2", kPerRay},
      {"l2_stack_misses", &S::l2_stack_misses, "words",
       "stack spills that allocated their line in the L2, and refills that read it from DRAM", kPerRay},
      {"l2_writebacks", &S::l2_writebacks, "lines", "dirty L2 lines (spilled stack words) written back to DRAM",
       kPerRay},
      {"l2_port_cycles", &S::l2_port_cycles, "port clocks",
       "clocks the L2 slices' ports were held, summed over the slices (line and stack word accesses)", kPerRay},
  }};
  return counter_table<L2Counters>(counters);
}

std::span<const TimingCounter> dram_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 5> counters = {{
      {"dram_bytes", &S::dram_bytes, "bytes",
       "bytes moved over the DRAM channel (line fills, stack spills and refills past any L2, L2 write-backs)",
       kPerRay},
      {"dram_busy_cycles", &S::dram_busy_cycles, "cycles", "cycles the DRAM channel spent transferring", kPerRay},
      {"dram_row_hits", &S::dram_row_hits, "accesses",
       "DRAM accesses to the bank's open row (with dram_banks > 0)", kPerRay},
      {"dram_row_misses", &S::dram_row_misses, "accesses",
       "DRAM accesses that opened a row (empty bank or another row open; with dram_banks > 0)", kPerRay},
      {"mem_wait_cycles", &S::mem_wait_cycles, "cycles",
       "cycles line and stack reads waited for a busy L2 slice port, DRAM bank or channel (not rows opening, not "
       "the latency itself)",
       kPerRay},
  }};
  return counter_table<DramCounters>(counters);
}

}  // namespace rtu::hw
