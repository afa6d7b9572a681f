// The seam below a unit's node cache: a memory backend serves line reads (cache fills), 8-byte stack words
// (spills and refills) and line write-backs (a cache level's dirty lines). memory_system.cpp composes the backends
// a configuration names, from the DRAM up (DramLevel over dram_channel.h or banked_dram.h, then the L2 of
// l2_cache.h in front of it); MemorySystem is the composition a unit, or a chip's units, fill from.
//
// The contract every backend keeps, which the timing model's early service and a chip's run-ahead rely on
// (timing_model.h): requests come in the order of their cycles and each is served at its own cycle, so the
// result depends only on that order; min_line_cycles() is a lower bound of every line read's latency; free_at()
// is only reported (the watchdog's dump), never a condition.
// A queued backend (dram_scheduler.h) keeps a weaker one: a request is never asked at a cycle earlier than the
// cycle of the caller's action that makes it; a read may answer a pending cycle (pending.h); the backend decides
// at next_decision() and the caller calls decide() once every action at a cycle <= next_decision() is done.
//
// To add a memory model: a class with transfer(addr, bytes, t, s), min_line_cycles() and free_at() is a DRAM
// (wrap it in DramLevel); one that implements MemoryBackend over a next level is a cache or buffer in front of
// it. Either way its header opens with what it models, its keys go into timing_config.h, and one line of
// compose_memory() (memory_system.cpp) places it.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "hwmodel/timing/memory/pending.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

inline constexpr uint64_t kNoDecision = ~uint64_t(0);  // a queued backend with nothing waiting

class MemoryBackend {
 public:
  virtual ~MemoryBackend() = default;
  // A line read at cycle t (line = byte address / line_bytes): the cycle its data is there.
  virtual uint64_t read_line(uint64_t line, uint64_t t, TimingStats& s) = 0;
  // An 8-byte stack entry at byte address `addr`: a refill returns its data's cycle; a spill leaves the slot at
  // once (bandwidth only, and its wait is not a ray's: mem_wait_cycles counts reads).
  virtual uint64_t read_word(uint64_t addr, uint64_t t, TimingStats& s) = 0;
  virtual void write_word(uint64_t addr, uint64_t t, TimingStats& s) = 0;
  // A dirty line written back at cycle t by the level in front (bandwidth only; nobody waits for it).
  virtual void write_line(uint64_t line, uint64_t t, TimingStats& s) = 0;
  // The fewest cycles a line read takes, from its request to its data.
  virtual uint64_t min_line_cycles() const = 0;
  // The fewest cycles any read (a line or a stack word) takes from its request to its data, whatever came before:
  // the lookahead of a chip whose units run on several host threads (timing_model.h). 0: no bound is known (the
  // units then run on one).
  virtual uint64_t min_answer_cycles() const { return 0; }
  // The latest cycle the backend's transfers keep it busy until.
  virtual uint64_t free_at() const = 0;
  // Functional warming (sampled timing): a cache level takes the line as a read would, with its replacement
  // order updated, but no time passes and nothing is counted. A DRAM has nothing to warm.
  virtual void warm_line(uint64_t line) { (void)line; }
  // A queued backend: the table its pending cycles live in, the cycle of its next decision (kNoDecision: none
  // waiting) and that decision. A synchronous backend has none; a cache level forwards its next level's.
  virtual PendingTable* pending() { return nullptr; }
  virtual uint64_t next_decision() const { return kNoDecision; }
  virtual void decide() {}
};

// Cycles a port of `bytes_per_cycle` is busy moving `bytes` (0 bytes per cycle: unlimited, no cycles).
inline uint64_t transfer_cycles(uint64_t bytes, double bytes_per_cycle) {
  return bytes_per_cycle > 0 ? uint64_t(std::ceil(double(bytes) / bytes_per_cycle)) : 0;
}

// Bytes moved over time: DRAM bytes by the cycle their transfer ends, L2 accesses (a line each for fills, hits and
// misses; 8 bytes for a stack word) by the cycle they are asked for, in bins of bin_cycles from cycle 0 (the
// device's cycles since bind). The bins start kTimelineBin wide and double (pairs merged) whenever a cycle falls
// beyond kTimelineBins bins, so the series stays at most that long however long the run.
struct MemoryTimeline {
  static constexpr uint64_t kTimelineBin = 256;
  static constexpr size_t kTimelineBins = 4096;
  uint64_t bin_cycles = kTimelineBin;
  std::vector<uint64_t> dram_bytes, l2_bytes;
  void add(std::vector<uint64_t>& series, uint64_t cycle, uint64_t bytes);
};

}  // namespace rtu::hw
