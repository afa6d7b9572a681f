// What lies behind a unit's node cache: the memory its line fills and stack spills and refills go to, composed
// from the configuration's keys (memory_system.cpp, compose_memory):
// - the DRAM: without banks and with one channel (dram_banks = 0, dram_channels = 1: the defaults) the one
//   channel of dram_channel.h, and the unit's cycles are what they always were; otherwise channels with
//   open-page banks (banked_dram.h);
// - in front of it, with l2_kib > 0, the L2 (l2_cache.h), shared by a chip's units: line fills and stack spills
//   and refills go through it, its dirty lines back to the DRAM.
// A new level or DRAM model is a backend (memory_backend.h) and one line of compose_memory().
// Every request is served at its own cycle in the order the unit makes them (the unit's requests come in
// cycle order), so the result is deterministic. With dram_scheduler = frfcfs the DRAM is queued instead
// (dram_scheduler.h): reads may answer pending cycles, decided when the caller lets simulated time pass.
#pragma once

#include <cstdint>
#include <memory>

#include "hwmodel/timing/memory/banked_dram.h"
#include "hwmodel/timing/memory/dram_channel.h"
#include "hwmodel/timing/memory/l2_cache.h"
#include "hwmodel/timing/memory/memory_backend.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

// The memory behind one unit's node cache (or a chip's units' caches).
class MemorySystem {
 public:
  explicit MemorySystem(const TimingConfig& c);
  // One backend alone (a chip unit's deferred requests, deferred_memory.h).
  explicit MemorySystem(std::unique_ptr<MemoryBackend> top);
  // Bytes a memory system of configuration c holds: the L2's lines, the DRAM's banks and the timeline.
  static uint64_t state_bytes(const TimingConfig& c);
  // Its levels refer to its timeline: it stays where it was made.
  MemorySystem(const MemorySystem&) = delete;
  MemorySystem& operator=(const MemorySystem&) = delete;
  // A line read at cycle t (a node cache fill): the cycle its data is there.
  uint64_t read_line(uint64_t line, uint64_t t, TimingStats& s) { return m_top->read_line(line, t, s); }
  // An 8-byte stack entry at byte address `addr`: a spill (bandwidth only) and a refill (its data's cycle).
  void write_word(uint64_t addr, uint64_t t, TimingStats& s) { m_top->write_word(addr, t, s); }
  uint64_t read_word(uint64_t addr, uint64_t t, TimingStats& s) { return m_top->read_word(addr, t, s); }
  // The fewest cycles a line read takes (a lower bound the timing model's early requests rely on).
  uint64_t min_line_cycles() const { return m_top->min_line_cycles(); }
  uint64_t min_answer_cycles() const { return m_top->min_answer_cycles(); }  // memory_backend.h
  uint64_t free_at() const { return m_top->free_at(); }      // when the DRAM is free (the watchdog's dump)
  void warm_line(uint64_t line) { m_top->warm_line(line); }  // functional warming (memory_backend.h)
  // A queued memory (dram_scheduler = frfcfs, memory_backend.h): reads may answer pending cycles of this table
  // (null: every answer is a cycle); the cycle of its next decision, and that decision.
  PendingTable* pending() { return m_pending; }
  uint64_t next_decision() const { return m_top->next_decision(); }
  void decide() { m_top->decide(); }
  // Every decision still waiting (a packet's end: only writes are left, which nobody waits for).
  void drain() {
    while (m_top->next_decision() != kNoDecision) m_top->decide();
  }
  const MemoryTimeline& timeline() const { return m_timeline; }

 private:
  MemoryTimeline m_timeline;
  std::unique_ptr<MemoryBackend> m_top;  // the first level a fill reaches
  PendingTable* m_pending;               // the queued DRAM's, or null
};

}  // namespace rtu::hw
