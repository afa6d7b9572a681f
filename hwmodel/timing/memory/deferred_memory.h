// A chip's unit acting on a host thread of its own (run_units_in_step with threads > 1, timing_model.h): what the
// unit asks of the chip's shared memory (line fills, stack spills and refills) is held here, each request with
// the cycle of the unit's action that made it, and every read answers a pending cycle (pending.h) at once.
//
// The units act in windows of simulated time no longer than the shared memory's fewest answer cycles
// (MemoryBackend::min_answer_cycles). After a window every unit's held requests are served by the shared memory
// in the order of (action cycle, unit, request), which is the order the units acting in step on one thread make
// them; each read's pending cycle then resolves with the shared memory's answer. An answer comes at least the
// lookahead after its request, so after the window its request was made in: no unit would have acted on it
// inside the window, and every unit's actions and every answer are those of the units acting in step.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <vector>

#include "hwmodel/timing/memory/memory_backend.h"
#include "hwmodel/timing/memory/memory_system.h"

namespace rtu::hw {

class DeferredMemory final : public MemoryBackend {
 public:
  enum Kind : uint8_t { kLine, kWordRead, kWordWrite };
  struct Request {
    uint64_t action;  // the cycle of the unit's action that made it (the order it is served in)
    uint64_t addr;    // a line number (kLine) or a byte address (stack words)
    uint64_t t;       // the cycle it is asked at
    uint64_t ready;   // a read's pending cycle
    Kind kind;
    uint64_t answer = 0, wait = 0;  // served: the read's data cycle and its queueing in the shared memory
  };
  // `now`: the cycle of the unit's current action, read at each request.
  DeferredMemory(MemorySystem& shared, const uint64_t& now)
      : m_shared(shared), m_now(now), m_min_line(shared.min_line_cycles()) {}

  uint64_t read_line(uint64_t line, uint64_t t, TimingStats& /*s*/) override { return hold(kLine, line, t); }
  uint64_t read_word(uint64_t addr, uint64_t t, TimingStats& /*s*/) override { return hold(kWordRead, addr, t); }
  void write_word(uint64_t addr, uint64_t t, TimingStats& /*s*/) override {
    m_held.push_back(Request{m_now, addr, t, 0, kWordWrite});
  }
  void write_line(uint64_t /*line*/, uint64_t /*t*/, TimingStats& /*s*/) override {
    throw std::logic_error("deferred memory: a unit's node cache writes no lines back");
  }
  uint64_t min_line_cycles() const override { return m_min_line; }
  uint64_t min_answer_cycles() const override { return m_shared.min_answer_cycles(); }
  // The shared memory's, as it was when the window began (the watchdog's dump reads it on the unit's thread).
  uint64_t free_at() const override { return m_free_at; }
  PendingTable* pending() override { return &m_pending; }

  const std::vector<Request>& held() const { return m_held; }
  // Held request i served by the shared memory, its statistics into s (the unit's); returns a read's data cycle
  // (a write's: ~0). A line read's queueing is kept for its waiter rather than counted: the unit counts a fetch's
  // wait once its last line is known, as it does acting on the shared memory itself (timing_model.cpp).
  uint64_t serve(size_t i, TimingStats& s) {
    Request& r = m_held[i];
    switch (r.kind) {
      case kLine: {
        const uint64_t before = s.mem_wait_cycles;
        r.answer = m_shared.read_line(r.addr, r.t, s);
        r.wait = s.mem_wait_cycles - before;
        s.mem_wait_cycles = before;
        return r.answer;
      }
      case kWordRead:
        return r.answer = m_shared.read_word(r.addr, r.t, s);
      case kWordWrite:
        m_shared.write_word(r.addr, r.t, s);
        break;
    }
    return ~uint64_t(0);
  }
  // Every held request served: their pending cycles resolve (the unit's waiting slots wake, in the order of the
  // requests) and the next window begins with nothing held. On the unit's thread: nothing else is shared.
  void settle() {
    for (const Request& r : m_held)
      if (r.kind != kWordWrite) m_pending.resolve(r.ready, r.answer, r.wait);
    m_held.clear();
    m_free_at = m_shared.free_at();
  }

 private:
  uint64_t hold(Kind kind, uint64_t addr, uint64_t t) {
    const uint64_t ready = m_pending.make();
    m_held.push_back(Request{m_now, addr, t, ready, kind});
    return ready;
  }
  MemorySystem& m_shared;
  const uint64_t& m_now;
  uint64_t m_min_line;
  uint64_t m_free_at = 0;
  PendingTable m_pending;
  std::vector<Request> m_held;
};

}  // namespace rtu::hw
