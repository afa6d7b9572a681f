// The DRAM scheduler (memory/dram_scheduler.h): the order the banked DRAM serves requests in. Its keys and
// counters; their tables are beside the scheduler (memory/dram_scheduler.cpp).
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

enum class DramScheduler : uint8_t {
  kFcfs,    // each request served at its own cycle, in the order requests come (banked_dram.h)
  kFrFcfs,  // queued per bank: row hits first, then the oldest, with a cap on passing one over
};
inline std::span<const TimingChoice> choices(DramScheduler) {
  static constexpr TimingChoice list[] = {
      {"fcfs", "each request served at its own cycle, in the order requests come"},
      {"frfcfs", "queued per bank: row hits first, then the oldest (memory/dram_scheduler.h)"},
  };
  return list;
}

// The scheduler, and the number of younger requests that may pass one over before it is served next.
struct DramSchedulerConfig {
  DramScheduler dram_scheduler = DramScheduler::kFcfs;
  int dram_frfcfs_cap = 16;
};

// Requests served before an older arrived one of their bank, and requests the cap served where a row hit would
// have gone.
struct DramSchedulerCounters {
  uint64_t dram_reordered = 0, dram_capped = 0;
};

const TimingKeyTable& dram_scheduler_keys();
std::span<const TimingCounter> dram_scheduler_counters();

}  // namespace rtu::hw
