// The unit's front end: the register file (regs.h) and the command processor that consumes the ring of command
// packets (commands.h) from device memory and runs them on a TraceEngine (engine.h).
//
// A doorbell (a write of kRingTail) consumes every packet up to the new tail before the write returns, in ring
// order; the device clock advances by the engine's cycles per packet (functional engines: one per packet; the
// timed engine: simulated cycles, one packet after another). A malformed packet or register access sets the error
// code, the error info (the packet's ring slot or the register offset), kStatusError and kIrqError, and stops
// consumption (head stays on the faulting packet) until kCtrlReset. A TRACE the engine's watchdog stops
// (WatchdogError) is the error kWatchdog: its hits are not written, the clock advances by the cycles it ran. Every
// address is checked before use: no packet can make the model read or write outside device memory, crash, or loop.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "hwmodel/datapath/stats.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/interface/device_memory.h"
#include "hwmodel/interface/regs.h"

namespace rtu::hw {

// What the command processor did since it was made (reset does not clear it).
struct DeviceCounters {
  uint64_t packets = 0;                                            // packets consumed (the functional clock)
  std::array<uint64_t, cmd::kOpcodeCount> by_opcode{};             // packets consumed, by opcode
  std::array<uint64_t, cmd::kRayTypeCount> rays_by_type{};         // rays traced, by the TRACE's ray type
  std::array<TraversalStats, cmd::kRayTypeCount> stats_by_type{};  // traversal statistics, by ray type
  uint64_t any_hit_rays = 0;                                       // rays traced with kTraceAnyHit
  uint64_t all_hit_rays = 0;                                       // rays traced with kTraceAllHits
  uint64_t all_hits_found = 0;                                     // intersections they found
  uint64_t all_hit_overflows = 0;                                  // of them, rays whose list overflowed
  uint64_t max_bounce = 0;                                         // deepest bounce seen in a TRACE
  uint64_t errors = 0;                                             // errors raised
  uint64_t irqs = 0;                                               // interrupts raised (fence and error)
  uint64_t fence_irqs = 0;                                         // of them, by a FENCE with kFenceIrq
  // Device clock at which the latest fence interrupt reached the host: the FENCE's end plus the engine's
  // irq_latency (0 on the functional engines). The model raises the line at once (the doorbell write returns
  // after the packets ran); this is when hardware would.
  uint64_t last_irq_cycle = 0;
  TraversalStats total() const {
    TraversalStats t;
    for (const TraversalStats& s : stats_by_type) t.add(s);
    return t;
  }
};

class CommandProcessor {
 public:
  // Keeps references to both: they must outlive the processor.
  CommandProcessor(DeviceMemory& memory, TraceEngine& engine);

  // MMIO access at a byte offset of the register window. Reads of unknown or unaligned offsets return
  // 0xFFFFFFFF (like a bus with nothing behind it); writes to them are kBadRegister errors.
  uint32_t read(uint32_t offset);
  void write(uint32_t offset, uint32_t value);

  // The interrupt line: some enabled interrupt status bit is set.
  bool irq_line() const { return (m_irq_status & m_irq_enable) != 0; }
  reg::ErrorCode error() const { return m_error; }
  // Words beside the error code for the host (empty for most errors): for kWatchdog, the unit's state dump
  // (WatchdogError::what()); for kBadScene, why the image was refused. Cleared by reset.
  const std::string& error_detail() const { return m_error_detail; }
  const DeviceCounters& counters() const { return m_counters; }
  const TraceEngine& engine() const { return m_engine; }
  DeviceMemory& memory() { return m_mem; }

 private:
  void raise(reg::ErrorCode e, uint32_t info);
  void reset();
  void consume();
  // Runs one packet; returns false (after raise) when it is malformed.
  bool execute(const cmd::Packet& p);
  bool execute_trace(const cmd::Packet& p);
  // An all-hit TRACE's lists (commands.h HitListHeader): ray i's header and kept hits at `at` + i list bytes.
  void write_hit_lists(uint64_t at, uint32_t k, const std::vector<Hit>& hits, const std::vector<uint64_t>& counts);
  bool check_buffer(uint64_t addr, uint64_t bytes, uint64_t align);

  DeviceMemory& m_mem;
  TraceEngine& m_engine;
  DeviceCounters m_counters;
  uint32_t m_control = 0;
  uint32_t m_irq_status = 0, m_irq_enable = 0;
  reg::ErrorCode m_error = reg::ErrorCode::kNone;
  uint32_t m_error_info = 0;
  std::string m_error_detail;
  uint64_t m_ring_base = 0;
  uint32_t m_ring_size = 0, m_head = 0, m_tail = 0;
  uint64_t m_fence = 0;
  uint64_t m_clock = 0;
  uint64_t m_trace_cycles = 0;  // cycles of the TRACE being executed (the engine's answer)
  uint32_t m_clock_hi_latch = 0;
};

}  // namespace rtu::hw
