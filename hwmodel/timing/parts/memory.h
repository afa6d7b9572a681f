// The memory behind the node cache (memory/memory_system.h): the DRAM channel (memory/dram_channel.h), or an L2
// (memory/l2_cache.h) and banked DRAM (memory/banked_dram.h) shared by a chip's units; and the DRAM type its
// energy is priced at. Their keys and counters.
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

// What the memory behind the cache is, for its energy per bit (the memory_type key; energy_model.h prices each, in
// this order). Timing does not depend on it.
enum class DramType : uint8_t { kGddr6, kHbm2, kLpddr5 };
inline constexpr TimingChoice kDramTypes[] = {
    {"gddr6", "GDDR6"},
    {"hbm2", "HBM2"},
    {"lpddr5", "LPDDR5"},
};
inline std::span<const TimingChoice> choices(DramType) {
  return kDramTypes;
}

struct DramChannelConfig {
  int dram_latency = 200;              // cycles from request to the first byte
  double dram_bytes_per_cycle = 64.0;  // bandwidth
};

// Without an L2 and without banks (the defaults) the memory is the one DRAM channel above. An L2: l2_kib KiB in
// l2_slices slices (a line's slice: its line number modulo the slices), l2_ways-way LRU, l2_latency cycles,
// l2_bytes_per_cycle per slice port (0: unlimited).
struct L2Config {
  int l2_kib = 0;  // 0: no L2
  int l2_slices = 4;
  int l2_ways = 16;
  int l2_latency = 100;
  double l2_bytes_per_cycle = 64.0;
};

// DRAM banks: dram_channels channels sharing dram_bytes_per_cycle, dram_banks open-page banks each with
// dram_row_bytes rows, dram_activate_cycles to open a row and dram_precharge_cycles to close one.
struct DramBankConfig {
  int dram_channels = 1;
  int dram_banks = 0;  // 0: no bank model (no rows: every access as a row hit)
  int dram_row_bytes = 2048;
  int dram_activate_cycles = 0;
  int dram_precharge_cycles = 0;
  DramType memory_type = DramType::kGddr6;
};

struct L2Counters {
  uint64_t l2_hits = 0, l2_misses = 0;  // node cache fills through the L2 (memory_system.h)
  // Stack spills and refills through the L2 (l2_cache.h): words that found their line there, and the others;
  // dirty lines the L2 wrote back to DRAM; clocks its slices' ports were held (lines and words).
  uint64_t l2_stack_hits = 0, l2_stack_misses = 0, l2_writebacks = 0, l2_port_cycles = 0;
};

struct DramCounters {
  uint64_t dram_bytes = 0, dram_busy_cycles = 0;
  uint64_t dram_row_hits = 0, dram_row_misses = 0;  // with DRAM banks: accesses to the open row, and the others
  // Line and stack reads queued for a busy L2 slice port, DRAM bank or channel: throughput, not latency (the
  // latency bound takes them out of a ray's life).
  uint64_t mem_wait_cycles = 0;
};

const TimingKeyTable& dram_channel_keys();
const TimingKeyTable& l2_keys();
const TimingKeyTable& dram_bank_keys();
std::span<const TimingCounter> l2_counters();
std::span<const TimingCounter> dram_counters();

}  // namespace rtu::hw
