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

// A ray's stack as its pushes show it, bottom first (stack_pop, ttp.h): a push's entries arrive nearest first and
// each later one goes below the ones before it; a fetch between pushes (fetched()) starts a new push.
template <class E>
struct PushedStack {
  std::vector<E> entries;
  size_t group = 0;      // where the current push's entries go
  bool new_push = true;  // the next pushed entry starts a push

  void push(const E& e) {
    if (new_push) group = entries.size();
    new_push = false;
    entries.insert(entries.begin() + ptrdiff_t(group), e);
  }
  void fetched() { new_push = true; }
  // One past the topmost entry `match` accepts (0: none); a pop to it is resize(find(...) - 1).
  template <class F>
  size_t find(F match) const {
    size_t i = entries.size();
    while (i > 0 && !match(entries[i - 1])) --i;
    return i;
  }
};

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
  void on_ray(uint32_t slot) override { m_slots[slot] = Slot{}; }
  void on_push(const StackPush& p, LinePort&) override {
    // A push's entries come together, after the fetch of the node whose test pushed them (leaves are not shown,
    // so the first may have any rank).
    m_slots[p.slot].stack.push(Entry{p.index, p.first_line, p.last_line});
  }
  void on_fetch(const LineFetch& f, LinePort& port) override {
    Slot& s = m_slots[f.slot];
    s.stack.fetched();
    if (f.kind != TraceEvent::kNode) return;
    const size_t i = s.stack.find([&](const Entry& e) { return e.index == f.index; });
    if (i == 0) {  // a descent
      s.popped = false;
      return;
    }
    std::vector<Entry>& st = s.stack.entries;
    st.resize(i - 1);  // the node and what was above it leave the stack
    if (s.popped) {
      for (size_t j = 0; j < m_degree && j < st.size(); ++j) {
        const Entry& e = st[st.size() - 1 - j];
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
    PushedStack<Entry> stack;
    bool popped = false;  // the slot's last node fetch was a pop
  };
  uint32_t m_degree;
  std::vector<Slot> m_slots;
};

}  // namespace rtu::hw
