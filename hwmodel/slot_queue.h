// The timing model's event queue: ray slots waiting for a cycle, served in order of (cycle, slot).
//
// A calendar queue (Brown, "Calendar queues", CACM 31(10), 1988) specialised to the model: every wait is short
// against the run and most are a few cycles, so cycles within kWheel of the last one served sit in a ring of
// buckets, one bit per slot; a bucket's lowest bit is its lowest slot, and a bitmap of non-empty buckets finds
// the next cycle with a few bit scans. Later cycles (a DRAM miss behind a long queue) wait in a min-heap until
// they come within range. It serves exactly the order of one min-heap of (cycle, slot) keys, without the heap's
// data-dependent branches (tests/hwmodel/test_slot_queue.cpp compares the two).
//
// Contract: each slot is queued at most once at a time, and a pushed cycle is never earlier than the last
// cycle popped (the model never schedules into the past). Cycles must stay below 2^52 (std::overflow_error).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <utility>
#include <vector>

namespace rtu::hw {

class SlotQueue {
 public:
  static constexpr int kSlotBits = 12;      // slots < 4096: far keys are cycle << 12 | slot
  static constexpr uint64_t kWheel = 1024;  // cycles held in the ring of buckets (a power of two)

  // Empty, for slots 0 .. slots - 1 (at most 2^kSlotBits), with no cycle served yet.
  void reset(uint32_t slots) {
    if (slots == 0 || slots > (1u << kSlotBits)) throw std::invalid_argument("slot queue: 1 to 4096 slots");
    m_words = (slots + 63) / 64;
    m_bits.assign(size_t(kWheel) * m_words, 0);
    m_busy.fill(0);
    m_far.clear();
    m_now = 0;
    m_near = 0;
    m_top_valid = false;
  }
  bool empty() const { return m_near == 0 && m_far.empty(); }

  // Queues slot at cycle (>= the last cycle popped; the slot not queued already).
  void push(uint64_t cycle, uint32_t slot) {
    if (cycle >> (64 - kSlotBits))  // 2^52 cycles: 26 days of a 2 GHz unit, beyond any run
      throw std::overflow_error("timing model: cycle count beyond 2^52");
    if (cycle < m_now) throw std::logic_error("slot queue: a cycle before the last one served");
    if (cycle - m_now < kWheel) [[likely]]
      set_near(cycle, slot);
    else
      push_far(cycle, slot);
    if (m_top_valid && (cycle < m_top_cycle || (cycle == m_top_cycle && slot < m_top_slot))) m_top_valid = false;
  }

  // The earliest queued (cycle, slot), lowest slot first among equal cycles. Requires !empty().
  uint64_t top_cycle() {
    find_top();
    return m_top_cycle;
  }
  uint32_t top_slot() {
    find_top();
    return m_top_slot;
  }

  // Removes the top entry; its cycle becomes the last cycle served.
  void pop() {
    find_top();
    if (m_top_far) {
      std::pop_heap(m_far.begin(), m_far.end(), std::greater<>());
      m_far.pop_back();
      m_top_valid = false;
    } else {
      const size_t b = size_t(m_top_cycle & (kWheel - 1));
      uint64_t* w = &m_bits[b * m_words];
      const uint32_t i = m_top_slot >> 6;
      const uint64_t left = w[i] & ~(uint64_t(1) << (m_top_slot & 63));
      w[i] = left;
      --m_near;
      bool any = left != 0;
      for (uint32_t j = i + 1; j < m_words && !any; ++j) any = w[j] != 0;
      if (!any) m_busy[b >> 6] &= ~(uint64_t(1) << (b & 63));
      // The next slot of the same cycle is the new top when this word holds one (lower words are empty): far
      // entries that come into range below are later than it.
      m_top_valid = left != 0;
      if (m_top_valid) m_top_slot = i * 64 + uint32_t(__builtin_ctzll(left));
    }
    m_now = m_top_cycle;
    // Far entries that came within range move to the ring (all far entries stay >= m_now + kWheel).
    if (!m_far.empty() && (m_far.front() >> kSlotBits) - m_now < kWheel) [[unlikely]]
      pull_far();
  }

 private:
  static constexpr size_t kBusyWords = size_t(kWheel / 64);

  [[gnu::noinline]] void push_far(uint64_t cycle, uint32_t slot) {
    m_far.push_back(cycle << kSlotBits | slot);
    std::push_heap(m_far.begin(), m_far.end(), std::greater<>());
  }
  [[gnu::noinline]] void pull_far() {
    while (!m_far.empty() && (m_far.front() >> kSlotBits) - m_now < kWheel) {
      const uint64_t key = m_far.front();
      std::pop_heap(m_far.begin(), m_far.end(), std::greater<>());
      m_far.pop_back();
      set_near(key >> kSlotBits, uint32_t(key & ((uint64_t(1) << kSlotBits) - 1)));
    }
  }
  void set_near(uint64_t cycle, uint32_t slot) {
    const size_t b = size_t(cycle & (kWheel - 1));
    m_bits[b * m_words + (slot >> 6)] |= uint64_t(1) << (slot & 63);
    m_busy[b >> 6] |= uint64_t(1) << (b & 63);
    ++m_near;
  }

  void find_top() {
    if (m_top_valid) return;
    m_top_valid = true;
    if (m_near == 0) {  // only far entries: the heap's top
      m_top_far = true;
      m_top_cycle = m_far.front() >> kSlotBits;
      m_top_slot = uint32_t(m_far.front() & ((uint64_t(1) << kSlotBits) - 1));
      return;
    }
    // Ring entries lie in [m_now, m_now + kWheel) and every far entry beyond: the first non-empty bucket from
    // m_now's, going round once, holds the earliest cycle.
    m_top_far = false;
    const size_t b0 = size_t(m_now & (kWheel - 1));
    size_t w = b0 >> 6;
    uint64_t bits = m_busy[w] & (~uint64_t(0) << (b0 & 63));
    for (size_t step = 0; bits == 0; ++step) {  // at most kBusyWords steps: m_near > 0
      w = (w + 1) % kBusyWords;
      bits = m_busy[w];
      if (step == kBusyWords) break;  // unreachable while the counts are consistent
    }
    const size_t b = w * 64 + size_t(__builtin_ctzll(bits));
    m_top_cycle = m_now + ((b - b0) & (kWheel - 1));
    const uint64_t* words = &m_bits[b * m_words];
    uint32_t i = 0;
    while (words[i] == 0) ++i;
    m_top_slot = i * 64 + uint32_t(__builtin_ctzll(words[i]));
  }

  uint32_t m_words = 1;          // 64-bit words per bucket
  std::vector<uint64_t> m_bits;  // kWheel buckets of m_words words: bit s of a bucket = slot s waits there
  std::array<uint64_t, kBusyWords> m_busy{};  // bit b: bucket b is not empty
  std::vector<uint64_t> m_far;                // cycle << kSlotBits | slot, min-heap, cycles >= m_now + kWheel
  uint64_t m_now = 0;                         // the last cycle popped
  size_t m_near = 0;                          // entries in the ring
  bool m_top_valid = false, m_top_far = false;
  uint64_t m_top_cycle = 0;
  uint32_t m_top_slot = 0;
};

}  // namespace rtu::hw
