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
#include "hwmodel/timing/prefetch/ttp.h"
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
      {"ttp",
       "TTP as published: at each visit, 1, 2 or 16 entries from the top of the stack, leaves included, as the "
       "visit is the first, second or a later of consecutive pops; none among the slot's 16 last",
       detail::make_prefetcher<TtpPrefetcher>, true, true},
  };
  return table;
}

// The entry the prefetcher key names.
inline const PrefetcherInfo& prefetcher_info(PrefetcherId p) {
  return prefetchers()[size_t(p)];
}

// Whether the configured prefetcher needs the nodes rays push (the tracer records them only then).
inline bool prefetcher_wants_stack_refs(const TimingConfig& c) {
  return prefetcher_info(c.prefetcher).stack_refs;
}
// Whether it needs the leaves they push as well.
inline bool prefetcher_wants_leaf_refs(const TimingConfig& c) {
  return prefetcher_info(c.prefetcher).leaf_refs;
}

inline std::unique_ptr<FetchObserver> make_fetch_observer(const TimingConfig& c, const FetchContext& ctx) {
  const PrefetcherInfo& p = prefetcher_info(c.prefetcher);
  return p.make ? p.make(c, ctx) : nullptr;
}

}  // namespace rtu::hw
