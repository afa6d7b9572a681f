// Traversal-stack prefetching, in the spirit of TTP (Tozlu, Naithani, Zhou, arXiv 2605.16253, 2026: prefetch BVH
// nodes from the addresses already on the ray's traversal stack): the nodes a ray pushes are nodes it will fetch
// unless a closer hit culls them, so their lines are filled. Of each push, the prefetch_degree entries popped
// first (the nearest) are filled, at the push.
// Modelled: the trigger at the push (after the node test that found the children), the fill of the nodes' lines
// (filtered by the cache's tags: prefetch_redundant), the rank in pop order. Differs from TTP: TTP triggers when
// nodes are popped consecutively (upward traversal) and prefetches the entries then on the stack; fills here go
// into the node cache (with prefetch_queue > 0 they wait for an idle memory).
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
