// TTP as its authors published it (Tozlu, Naithani, Zhou, "A Hardware-Efficient Design for Precise Prefetching in
// Ray Tracing", arXiv 2605.16253, 2026; the mechanism as their Vulkan-Sim code, yavuz650/vulkan-sim branch
// traversal_trend_prefetcher, implements it): a trend counter per ray is cleared by a push and counts pops up to
// 3; after a pop that leaves it at 1, 2 or 3 the prefetcher takes 1, 2 or 16 entries from the top of the ray's
// stack downward, leaves included, and fills their lines into the L1 (the node cache here), skipping an entry
// among the 16 the ray prefetched last (a per-warp list in the paper's simulator, per slot here).
//
// How the trace maps onto it. Vulkan-Sim's traversal pushes every hit child and pops the top, so each visit is a
// pop, and a visit after a push is its first; this unit keeps the nearest child off the stack and visits it
// directly. So a visit not taken from the stack (the root, a descent) counts as the first pop (counter 1), and a
// visit taken from it (the slot fetches a node, or a leaf's first record, that is an entry) counts one more. A
// leaf's later records are not visits. TTP sends a prefetch only in a cycle without a demand request; with
// prefetch_queue > 0 the fills here wait for an idle memory the same way (prefetch_queue.h), without it they go
// at once. prefetch_degree is not read: the degrees are TTP's.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "hwmodel/timing/prefetch/fetch_observer.h"
#include "hwmodel/timing/prefetch/stack.h"

namespace rtu::hw {

class TtpPrefetcher final : public FetchObserver {
 public:
  static constexpr std::array<uint32_t, 3> kDegree = {1, 2, 16};  // after the first, second, later pops
  static constexpr size_t kRecent = 16;                           // unique prefetch addresses remembered

  TtpPrefetcher(const TimingConfig& c, const FetchContext&) : m_off(c.ttp_off), m_slots(size_t(c.ray_slots)) {}
  void on_ray(uint32_t slot) override { m_slots[slot] = Slot{}; }
  void on_push(const StackPush& p, LinePort&) override {
    if (p.leaf && m_off == TtpOff::kLeaves) return;
    m_slots[p.slot].stack.push(Entry{p.index, p.leaf, p.first_line, p.last_line});
  }
  void on_fetch(const LineFetch& f, LinePort& port) override {
    Slot& s = m_slots[f.slot];
    const bool leaf = f.kind == TraceEvent::kPrim;
    if (f.kind != TraceEvent::kNode && (!leaf || m_off == TtpOff::kLeaves)) return;
    const size_t i = s.stack.find([&](const Entry& e) { return e.index == f.index && e.leaf == leaf; });
    if (i == 0 && leaf) {
      // A leaf visited directly (the nearest child) counts as a visit only at its first record: the records
      // after it follow their predecessor in the same leaf.
      if (s.in_leaf && f.index == s.next_record) {
        ++s.next_record;
        return;
      }
    }
    s.stack.fetched();
    s.in_leaf = leaf;
    s.next_record = f.index + 1;
    if (i == 0) {
      s.trend = m_off == TtpOff::kDescents ? 0 : 1;  // a descent: Vulkan-Sim's push and pop of the nearest child
      if (s.trend == 0) return;
    } else {
      s.stack.entries.resize(i - 1);  // the entry and what was above it leave the stack
      s.trend = std::min<uint32_t>(s.trend + 1, 3);
    }
    uint32_t n = s.trend == 3 && m_off == TtpOff::kFill16 ? 2 : kDegree[s.trend - 1];
    for (size_t j = s.stack.entries.size(); j > 0 && n > 0; --j, --n) {
      const Entry& e = s.stack.entries[j - 1];
      const uint64_t key = (uint64_t(e.index) << 1) | uint64_t(e.leaf);
      bool seen = false;
      if (m_off != TtpOff::kFilter)
        for (uint64_t r : s.recent) seen = seen || r == key;
      if (seen) continue;
      if (s.recent.size() == kRecent) s.recent.erase(s.recent.begin());
      s.recent.push_back(key);
      for (uint64_t line = e.first_line; line <= e.last_line; ++line) port.fill(line);
    }
  }

 private:
  struct Entry {
    uint32_t index;  // node, or a leaf's first record
    bool leaf;
    uint64_t first_line, last_line;
  };
  struct Slot {
    PushedStack<Entry> stack;
    std::vector<uint64_t> recent;  // the last kRecent entries prefetched (index << 1 | leaf), oldest first
    uint32_t trend = 0;            // TTP's counter: consecutive pops, up to 3
    bool in_leaf = false;          // the last visit was a leaf's first record
    uint32_t next_record = 0;      // then, the record after the last one fetched
  };
  TtpOff m_off;
  std::vector<Slot> m_slots;
};

}  // namespace rtu::hw
