// Traversal-stack prefetching, in the spirit of TTP (Tozlu, Naithani, Zhou, arXiv 2605.16253, 2026: prefetch BVH
// nodes from the addresses already on the ray's traversal stack): the nodes a ray pushes are nodes it will fetch
// unless a closer hit culls them, so their lines are filled. Of each push, the prefetch_degree entries popped
// first (the nearest) are filled, at the push.
// Modelled: the trigger at the push (after the node test that found the children), the fill of the nodes' lines
// (filtered by the cache's tags: prefetch_redundant), the rank in pop order. Differs from TTP: TTP triggers when
// nodes are popped consecutively (upward traversal) and prefetches the entries then on the stack; fills here go
// into the node cache (with prefetch_queue > 0 they wait for an idle memory).
//
// StackPopPrefetcher (stack_pop) is the trigger TTP describes: it keeps each slot's stack as the pushes showed it
// (inner nodes only; leaves are not recorded), sees a pop when a slot fetches a node on that stack (the entries
// above it were culled or were leaves), and on the second of two consecutive pops fills the lines of the
// prefetch_degree entries then on top. A fetch of a node not on the stack (a descent to the nearest child) ends a
// run of pops. Differs from TTP: fills go into the node cache, not a prefetch buffer.
#pragma once

#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
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

class StackPopPrefetcher final : public FetchObserver {
 public:
  StackPopPrefetcher(const TimingConfig& c, const FetchContext&)
      : m_degree(uint32_t(c.prefetch_degree)), m_slots(size_t(c.ray_slots)) {}
  void on_ray(uint32_t slot) override {
    Slot& s = m_slots[slot];
    s.stack.clear();
    s.popped = false;
    s.new_push = true;
  }
  void on_push(const StackPush& p, LinePort&) override {
    Slot& s = m_slots[p.slot];
    // A push's entries come together, after the fetch of the node whose test pushed them (leaves are not shown,
    // so the first may have any rank).
    if (s.new_push) s.group = s.stack.size();
    s.new_push = false;
    // The nearest entry of a push is on top: each later rank goes below the ones before it.
    s.stack.insert(s.stack.begin() + ptrdiff_t(s.group), Entry{p.index, p.first_line, p.last_line});
  }
  void on_fetch(const LineFetch& f, LinePort& port) override {
    Slot& s = m_slots[f.slot];
    s.new_push = true;
    if (f.kind != TraceEvent::kNode) return;
    size_t i = s.stack.size();
    while (i > 0 && s.stack[i - 1].index != f.index) --i;
    if (i == 0) {  // a descent
      s.popped = false;
      return;
    }
    s.stack.resize(i - 1);  // the node and what was above it leave the stack
    if (s.popped) {
      for (size_t j = 0; j < m_degree && j < s.stack.size(); ++j) {
        const Entry& e = s.stack[s.stack.size() - 1 - j];
        for (uint64_t line = e.first_line; line <= e.last_line; ++line) port.fill(line);
      }
    }
    s.popped = true;
  }

 private:
  struct Entry {
    uint32_t index;
    uint64_t first_line, last_line;
  };
  struct Slot {
    std::vector<Entry> stack;  // bottom first
    size_t group = 0;          // where the current push's entries go
    bool popped = false;       // the slot's last node fetch was a pop
    bool new_push = true;      // the next pushed entry starts a push (a fetch came since the last)
  };
  uint32_t m_degree;
  std::vector<Slot> m_slots;
};

}  // namespace rtu::hw
