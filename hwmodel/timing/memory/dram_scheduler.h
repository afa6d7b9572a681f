// The DRAM scheduler (dram_scheduler key): fcfs, the default, serves each request at its own cycle in the order
// requests come (banked_dram.h, synchronous: the caller learns its data's cycle at once); frfcfs queues requests
// per bank and decides a bank's next service only when simulated time reaches the cycle the bank is free, among
// the requests that have arrived by then, as a memory controller's scheduler does. Its reads answer a pending
// cycle (pending.h) that the decision resolves; the ray slot waiting for it is woken then.
//
// Example: `--set dram_scheduler=frfcfs --set dram_frfcfs_cap=16` on a preset with DRAM banks (rdna2-chip).
//
// FR-FCFS (Rixner et al., "Memory Access Scheduling", ISCA 2000; Ramulator 2's FRFCFS scheduler,
// src/dram_controller/impl/scheduler/generic_scheduler.cpp, compares two requests by whether their next command is
// ready, a row hit's column access, then by arrival): at the cycle D a bank is free (max(the bank's last transfer
// start, its oldest request's arrival)), among the bank's requests that arrived by D, the oldest row hit, or the
// oldest request if none hits the open row. The cap: a request passed over by dram_frfcfs_cap younger requests is
// served next (the oldest such first), so a row miss behind a stream of hits waits for at most that many.
// Ramulator (1)'s FRFCFS_Cap caps the hits a row serves since it opened (cap = 16 in its Scheduler.h); the cap
// here is the starvation bound of Mutlu and Moscibroda's FR-FCFS+Cap (STFM, MICRO 2007), the same 16 by default.
// dram_frfcfs_cap = 0 is FCFS in the queued model (the oldest arrival first, decided when the bank is free).
//
// Once chosen, a request is served as banked_dram.h serves one: activate (and precharge) on a row miss, the
// channel's bus for ceil(bytes / channel bandwidth) clocks from max(command, bus free), the data dram_latency
// after the transfer ends; the bank takes its next command when the transfer has started. Writes (stack spills
// without an L2, L2 write-backs) queue with reads and are scheduled alike; nobody waits for them.
//
// What it takes of the rest (refused at validation otherwise, naming the keys): dram_banks > 0 (rows to hit),
// prefetcher = none (fills happen at a fetch's cycle against an idle memory, which a queue does not report), no
// sampled timing. The timing model serves unit requests only at their own cycles and runs a chip's units strictly
// in step when the memory is queued (timing_model.h): the same cycles as with both shortcuts, slower.
// Left out: read and write queues of their own (write drain), queue capacity and back-pressure, refresh,
// bank groups, a command bus. A packet's requests still queued when its last ray leaves (writes) are served then.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hwmodel/timing/memory/banked_dram.h"
#include "hwmodel/timing/memory/memory_backend.h"
#include "hwmodel/timing/memory/pending.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

// Banked DRAM with a queue per bank and an FR-FCFS scheduler (dram_scheduler = frfcfs).
class FrFcfsDram final : public MemoryBackend {
 public:
  FrFcfsDram(const TimingConfig& c, MemoryTimeline& timeline);
  uint64_t read_line(uint64_t line, uint64_t t, TimingStats& s) override {
    return enqueue(line * m_line_bytes, m_line_bytes, t, true, s);
  }
  uint64_t read_word(uint64_t addr, uint64_t t, TimingStats& s) override { return enqueue(addr, 8, t, true, s); }
  void write_word(uint64_t addr, uint64_t t, TimingStats& s) override { enqueue(addr, 8, t, false, s); }
  void write_line(uint64_t line, uint64_t t, TimingStats& s) override {
    enqueue(line * m_line_bytes, m_line_bytes, t, false, s);
  }
  uint64_t min_line_cycles() const override { return m_geometry.min_line_cycles(); }
  uint64_t free_at() const override;
  PendingTable* pending() override { return &m_pending; }
  uint64_t next_decision() const override { return m_next; }
  void decide() override;

 private:
  struct Request {
    uint64_t arrival, seq;  // the cycle it reaches the DRAM; the order it came in (ties of arrival)
    uint64_t row, bytes;
    uint64_t ready;  // a read's pending cycle; 0 for a write
    TimingStats* s;  // whose counters it adds to
    uint32_t channel;
    uint32_t bypassed = 0;  // younger requests served before it since it arrived
  };
  struct Bank {
    uint64_t open_row = ~uint64_t(0);  // none
    uint64_t ready = 0;                // next command no earlier than this
    uint64_t decision = kNoDecision;   // max(ready, oldest arrival); kNoDecision when the queue is empty
    std::vector<Request> queue;        // in the order requests came
  };
  uint64_t enqueue(uint64_t addr, uint64_t bytes, uint64_t t, bool read, TimingStats& s);
  size_t choose(const Bank& b, uint64_t now, TimingStats*& capped_by) const;
  void update_decision(Bank& b);
  BankedDram m_geometry;  // where an address falls (BankedDram::place) and the fewest cycles of a line
  MemoryTimeline& m_timeline;
  PendingTable m_pending;
  uint64_t m_latency, m_activate, m_precharge, m_line_bytes, m_line_cycles;
  double m_bytes_per_cycle;  // per channel
  uint32_t m_banks, m_cap;
  std::vector<Bank> m_bank;          // channel * banks + bank
  std::vector<uint64_t> m_bus_free;  // per channel
  uint64_t m_seq = 0, m_next = kNoDecision;
};

// Whether the configuration's memory is queued (its reads may answer pending cycles): dram_scheduler = frfcfs.
inline bool memory_is_queued(const TimingConfig& c) {
  return c.dram_scheduler == DramScheduler::kFrFcfs;
}

}  // namespace rtu::hw
