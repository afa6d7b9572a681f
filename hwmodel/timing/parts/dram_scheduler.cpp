#include "hwmodel/timing/parts/dram_scheduler.h"

#include <array>
#include <string>

#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

const TimingKeyTable& dram_scheduler_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"dram_scheduler", choice_field<&C::dram_scheduler>(), 0, 0,
       "DRAM request order: each served at its cycle in the order they come, or queued per bank with row hits "
       "first, then the oldest (memory/dram_scheduler.h)",
       [](const C& c) -> std::string {
         if (c.dram_scheduler == DramScheduler::kFrFcfs && c.dram_banks == 0)
           return "dram_scheduler = frfcfs needs DRAM banks (dram_banks > 0): without rows there is no row hit "
                  "to serve first";
         if (c.dram_scheduler == DramScheduler::kFrFcfs && c.prefetcher != PrefetcherId::kNone)
           return "dram_scheduler = frfcfs with prefetcher = " + std::string(name_of(c.prefetcher)) +
                  " is not built (a prefetch queue drains against the memory's free cycle, which a queued memory "
                  "does not know yet); use prefetcher = none or dram_scheduler = fcfs";
         return {};
       }},
      {"dram_frfcfs_cap", &C::dram_frfcfs_cap, 0, 65536,
       "frfcfs: a request passed over by this many younger ones is served next (0: oldest first, FCFS)"},
  };
  return keys;
}

std::span<const TimingCounter> dram_scheduler_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 2> counters = {{
      {"dram_reordered", &S::dram_reordered, "requests",
       "dram_scheduler frfcfs: requests served before an older one of their bank that had arrived (row hits "
       "first)",
       kPerRay},
      {"dram_capped", &S::dram_capped, "requests",
       "dram_scheduler frfcfs: requests served first because dram_frfcfs_cap younger ones had passed them over, "
       "where a row hit would have gone instead",
       kPerRay},
  }};
  return counter_table<DramSchedulerCounters>(counters);
}

}  // namespace rtu::hw
