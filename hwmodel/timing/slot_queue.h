// The timing model's event queue: ray slots waiting for a cycle, served in order of (cycle, slot).
//
// A tournament tree (a complete binary tree of minima over one leaf per slot; Knuth, TAOCP vol. 3, 5.4.1): leaf s
// holds slot s's key cycle << 12 | slot (or empty), every inner node the smaller of its two children, so the root
// is the earliest (cycle, slot) and the keys' order is exactly that of one min-heap of (cycle, slot) pairs (the
// slot breaks ties, lowest first). Queuing or re-queuing a slot rewrites its leaf and the log2(slots) minima above
// it: a fixed number of loads, compares and stores with no data-dependent branch (the model re-queues the slot it
// has just served, replace_top, one walk up the tree). tests/hwmodel/test_slot_queue.cpp compares it with a
// std::set of (cycle, slot) pairs on random schedules.
//
// Contract: each slot is queued at most once at a time (std::logic_error otherwise), and a queued cycle is never
// earlier than the last cycle served (the model never schedules into the past: std::logic_error). Cycles must
// stay below 2^52 (std::overflow_error).
#pragma once

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace rtu::hw {

class SlotQueue {
 public:
  static constexpr int kSlotBits = 12;  // slots < 4096: keys are cycle << 12 | slot

  SlotQueue() { reset(1); }

  // Empty, for slots 0 .. slots - 1 (at most 2^kSlotBits), with no cycle served yet.
  void reset(uint32_t slots) {
    if (slots == 0 || slots > (1u << kSlotBits)) throw std::invalid_argument("slot queue: 1 to 4096 slots");
    m_leaves = 1;
    while (m_leaves < slots) m_leaves *= 2;
    m_tree.assign(2 * size_t(m_leaves), kEmpty);  // node 1 is the root, node i's children 2i and 2i + 1
    m_now = 0;
  }
  bool empty() const { return m_tree[1] == kEmpty; }

  // Queues slot at cycle (>= the last cycle served; the slot not queued already).
  void push(uint64_t cycle, uint32_t slot) {
    check(cycle);
    if (m_tree[m_leaves + slot] != kEmpty) throw std::logic_error("slot queue: a slot queued twice");
    set(slot, cycle << kSlotBits | slot);
  }

  // The earliest queued (cycle, slot), lowest slot first among equal cycles. Requires !empty().
  uint64_t top_cycle() const { return m_tree[1] >> kSlotBits; }
  uint32_t top_slot() const { return uint32_t(m_tree[1] & kSlotMask); }

  // Removes the top entry; its cycle becomes the last cycle served.
  void pop() {
    m_now = top_cycle();
    set(top_slot(), kEmpty);
  }

  // Moves a queued slot to cycle (>= the last cycle served).
  void requeue(uint32_t slot, uint64_t cycle) {
    check(cycle);
    if (m_tree[m_leaves + slot] == kEmpty) throw std::logic_error("slot queue: requeue of a slot not queued");
    set(slot, cycle << kSlotBits | slot);
  }

  // pop() and push(cycle, top_slot()) in one walk: the top slot is served and waits again until cycle.
  void replace_top(uint64_t cycle) {
    const uint32_t slot = top_slot();
    m_now = top_cycle();
    check(cycle);
    set(slot, cycle << kSlotBits | slot);
  }

 private:
  static constexpr uint64_t kEmpty = ~uint64_t(0);  // above every key: cycles < 2^52
  static constexpr uint64_t kSlotMask = (uint64_t(1) << kSlotBits) - 1;

  void check(uint64_t cycle) const {
    if (cycle >> (64 - kSlotBits)) [[unlikely]]  // 2^52 cycles: 26 days of a 2 GHz unit, beyond any run
      throw std::overflow_error("timing model: cycle count beyond 2^52");
    if (cycle < m_now) [[unlikely]]
      throw std::logic_error("slot queue: a cycle before the last one served");
  }
  void set(uint32_t slot, uint64_t key) {
    // The running minimum stays in a register: each level loads only the sibling (an address known up front), so
    // the walk is a chain of compares, not of stores read back.
    uint64_t* t = m_tree.data();
    size_t i = m_leaves + slot;
    uint64_t v = key;
    t[i] = v;
    while (i > 1) {
      v = std::min(v, t[i ^ 1]);
      i >>= 1;
      t[i] = v;
    }
  }

  uint32_t m_leaves = 1;         // a power of two >= the slots
  std::vector<uint64_t> m_tree;  // 2 * m_leaves keys; [0] unused
  uint64_t m_now = 0;            // the last cycle served
};

}  // namespace rtu::hw
