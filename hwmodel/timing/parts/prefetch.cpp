#include "hwmodel/timing/parts/prefetch.h"

#include <array>
#include <string>
#include <vector>

#include "hwmodel/timing/prefetch/prefetchers.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

std::span<const TimingChoice> choices(PrefetcherId) {
  static const std::vector<TimingChoice> choices = [] {
    std::vector<TimingChoice> out;
    for (const PrefetcherInfo& p : prefetchers()) out.push_back({p.name, p.description});
    return out;
  }();
  return choices;
}

const TimingKeyTable& prefetch_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"prefetcher", choice_field<&C::prefetcher>(), 0, 0,
       "what fills the node cache besides demand fetches (prefetch/prefetchers.h)"},
      {"prefetch_degree", &C::prefetch_degree, 1, 64, "lines a prefetcher fills per trigger"},
      {"prefetch_queue", &C::prefetch_queue, 0, 4096,
       "0: a prefetcher's fills go to memory at once; > 0: they wait in a queue of this many lines and go only "
       "when the memory is idle at a fetch (demand first; a full queue drops its oldest)"},
      {"prefetch_buffer", &C::prefetch_buffer, 0, 4096,
       "0: a prefetcher's fills go into the node cache; > 0: into a fully associative buffer of this many lines "
       "beside it, from which a demand hit moves the line into the cache (no pollution of the cache)"},
      {"treelet_bytes", &C::treelet_bytes, 0, 65536,
       "timing layout: 0 nodes in the image's order; > 0 nodes in treelets of at most this many bytes, each "
       "contiguous (prefetch/treelets.h; prefetcher = treelet needs it > 0)"},
      {"ttp_off", choice_field<&C::ttp_off>(), 0, 0,
       "prefetcher ttp: one part of the published mechanism switched off, to measure what it brings",
       [](const C& c) -> std::string {
         if (c.ttp_off != TtpOff::kNone && std::string(prefetcher_info(c.prefetcher).name) != "ttp")
           return "ttp_off applies to prefetcher ttp only (prefetcher = " +
                  std::string(prefetcher_info(c.prefetcher).name) + ")";
         return {};
       }},
  };
  return keys;
}

// Filled by NodeCache::prefetch.
std::span<const TimingCounter> prefetch_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 6> counters = {{
      {"prefetch_fills", &S::prefetch_fills, "lines", "lines a prefetcher brought into the node cache", kPerRay},
      {"prefetch_redundant", &S::prefetch_redundant, "lines",
       "lines a prefetcher asked for that the node cache held or had on their way", kPerRay},
      {"prefetch_useful", &S::prefetch_useful, "lines",
       "prefetched lines a demand access hit before they were evicted (each counted once)", kPerRay},
      {"prefetch_dropped", &S::prefetch_dropped, "lines",
       "fills dropped from a full prefetch queue, oldest first (prefetch_queue > 0)", kPerRay},
      {"prefetch_late", &S::prefetch_late, "lines",
       "useful prefetched lines still on their way at the first demand hit (they saved part of the latency)",
       kPerRay},
      {"prefetch_unused", &S::prefetch_unused, "lines", "prefetched lines evicted before a demand access hit them",
       kPerRay},
  }};
  return counter_table<PrefetchCounters>(counters);
}

}  // namespace rtu::hw
