// Next-line prefetching (Smith, "Sequential program prefetching in memory hierarchies", IEEE Computer 1978; gem5's
// TaggedPrefetcher is the tagged variant): on a fetch that missed, the prefetch_degree lines after the last line
// it touched are filled. A BVH laid out depth-first puts a node's first child right after it, and a leaf's
// records are consecutive, so a miss is often followed by a fetch of the next lines.
// Left out: prefetch on hits to prefetched lines (tagged), a prefetch queue or its own MSHRs, throttling.
#pragma once

#include <memory>

#include "hwmodel/timing/prefetch/fetch_observer.h"

namespace rtu::hw {

class NextLinePrefetcher final : public FetchObserver {
 public:
  NextLinePrefetcher(const TimingConfig& c, const FetchContext&) : m_degree(uint64_t(c.prefetch_degree)) {}
  void on_fetch(const LineFetch& f, LinePort& port) override {
    if (!f.missed) return;
    for (uint64_t d = 1; d <= m_degree; ++d) port.fill(f.last_line + d);
  }

 private:
  uint64_t m_degree;
};

}  // namespace rtu::hw
