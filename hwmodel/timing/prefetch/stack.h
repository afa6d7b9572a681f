// Traversal-stack prefetching (after TTP: Tozlu, Naithani, Zhou, arXiv 2605.16253, 2026): the nodes a ray pushes
// on its stack are nodes it will fetch unless a closer hit culls them, so their lines are filled when they are
// pushed. Of each push, the prefetch_degree entries popped first (the nearest) are filled.
// Modelled: the trigger at the push (after the node test that found the children), the fill of the nodes' lines
// (filtered by the cache's tags: prefetch_redundant), the rank in pop order. Left out: TTP's filtering of entries
// whose distance exceeds the closest hit at prefetch time, and its own prefetch buffer (fills go into the node
// cache; with prefetch_queue > 0 they wait for an idle memory).
#pragma once

#include "hwmodel/timing/prefetch/fetch_observer.h"

namespace rtu::hw {

class StackPrefetcher final : public FetchObserver {
 public:
  StackPrefetcher(const TimingConfig& c, const FetchContext&) : m_degree(uint32_t(c.prefetch_degree)) {}
  void on_fetch(const LineFetch&, LinePort&) override {}
  void on_push(const StackPush& p, LinePort& port) override {
    if (p.rank >= m_degree) return;
    for (uint64_t line = p.first_line; line <= p.last_line; ++line) port.fill(line);
  }

 private:
  uint32_t m_degree;
};

}  // namespace rtu::hw
