// The prefetchers a configuration may name (the prefetcher key): one line each in the table below; and the keys
// and counters they own, which the central tables gather. Header-only, so that anything that validates a
// TimingConfig (the RTL parameter derivation too) sees the same list.
#pragma once

#include <array>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "hwmodel/timing/prefetch/fetch_observer.h"
#include "hwmodel/timing/prefetch/next_line.h"
#include "hwmodel/timing/prefetch/stack.h"
#include "hwmodel/timing/prefetch/treelet.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

namespace detail {

template <class P>
inline std::unique_ptr<FetchObserver> make_prefetcher(const TimingConfig& c, const FetchContext& ctx) {
  return std::make_unique<P>(c, ctx);
}

}  // namespace detail

inline const std::vector<PrefetcherInfo>& prefetchers() {
  static const std::vector<PrefetcherInfo> table = {
      {"none", "no prefetching: only demand fetches fill the node cache", nullptr},
      {"next_line", "on a miss, the prefetch_degree lines after the fetch's last line",
       detail::make_prefetcher<NextLinePrefetcher>},
      {"treelet", "on a fetch of a treelet's root, the treelet's other lines (needs treelet_bytes > 0)",
       detail::make_prefetcher<TreeletPrefetcher>},
      {"stack", "the lines of the prefetch_degree nodes a ray pushes that it pops first, at the push",
       detail::make_prefetcher<StackPrefetcher>, true},
      {"stack_pop",
       "on the second of two consecutive pops, the lines of the prefetch_degree entries then on the stack (TTP's "
       "trigger)",
       detail::make_prefetcher<StackPopPrefetcher>, true},
  };
  return table;
}

// The entry a prefetcher key names; null for none (TimingConfig::validate() refuses such a name).
inline const PrefetcherInfo* find_prefetcher(const std::string& name) {
  for (const PrefetcherInfo& p : prefetchers())
    if (name == p.name) return &p;
  return nullptr;
}

// The prefetchers' names, comma separated (for the refusal of an unknown one).
inline std::string prefetcher_names() {
  std::string names;
  for (const PrefetcherInfo& p : prefetchers()) names += (names.empty() ? "" : ", ") + std::string(p.name);
  return names;
}

// The prefetchers' counters (TimingStats members, filled by NodeCache::prefetch), gathered into the statistics
// table (timing_stats.cpp) after cache_misses.
inline constexpr std::array<TimingCounter, 6> kPrefetchCounters = {{
    {"prefetch_fills", &TimingStats::prefetch_fills, "lines", "lines a prefetcher brought into the node cache",
     SampleScale::kPerRay},
    {"prefetch_redundant", &TimingStats::prefetch_redundant, "lines",
     "lines a prefetcher asked for that the node cache held or had on their way", SampleScale::kPerRay},
    {"prefetch_useful", &TimingStats::prefetch_useful, "lines",
     "prefetched lines a demand access hit before they were evicted (each counted once)", SampleScale::kPerRay},
    {"prefetch_dropped", &TimingStats::prefetch_dropped, "lines",
     "fills dropped from a full prefetch queue, oldest first (prefetch_queue > 0)", SampleScale::kPerRay},
    {"prefetch_late", &TimingStats::prefetch_late, "lines",
     "useful prefetched lines still on their way at the first demand hit (they saved part of the latency)",
     SampleScale::kPerRay},
    {"prefetch_unused", &TimingStats::prefetch_unused, "lines",
     "prefetched lines evicted before a demand access hit them", SampleScale::kPerRay},
}};

// The prefetchers' keys, gathered into the timing key table (timing_config.cpp) after dram_bytes_per_cycle.
inline const std::vector<TimingKeyInfo>& prefetch_keys() {
  using C = TimingConfig;
  static const std::vector<TimingKeyInfo> keys = {
      {"prefetcher", &C::prefetcher, 0, 0,
       "what fills the node cache besides demand fetches: none, next_line, treelet, stack or stack_pop "
       "(prefetch/prefetchers.h)",
       [](const C& c) {
         return find_prefetcher(c.prefetcher) ? std::string()
                                              : "prefetcher = '" + c.prefetcher +
                                                    "' is not a prefetcher (known: " + prefetcher_names() + ")";
       }},
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
  };
  return keys;
}

// Whether the configured prefetcher needs the nodes rays push (the tracer records them only then).
inline bool prefetcher_wants_stack_refs(const TimingConfig& c) {
  const PrefetcherInfo* p = find_prefetcher(c.prefetcher);
  return p && p->stack_refs;
}

inline std::unique_ptr<FetchObserver> make_fetch_observer(const TimingConfig& c, const FetchContext& ctx) {
  const PrefetcherInfo* p = find_prefetcher(c.prefetcher);
  if (!p) throw std::invalid_argument("prefetcher = '" + c.prefetcher + "' is not a prefetcher");
  return p->make ? p->make(c, ctx) : nullptr;
}

}  // namespace rtu::hw
