// The command processor: packet decode, the ray buffer's stream into ray setup, hit write-back, fences and their
// interrupts (timing_model.h). Its keys and counters; the timing model acts them out.
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

struct CommandConfig {
  int packet_latency = 20;     // cycles from doorbell (or the previous packet) to a decoded packet
  int ray_fetch_latency = 10;  // cycles to bring a ray from the ray buffer into ray setup (streamed, 1 per clock)
  int setup_latency = 8;       // ray setup pipeline depth (float -> fixed, reciprocal); 1 ray per clock
  int writeback_latency = 4;   // hit write-back pipeline depth; 1 hit per clock
  int fence_latency = 10;      // cycles from the last earlier hit written to the fence value in memory
  int irq_latency = 100;       // cycles from a FENCE's value write to its interrupt reaching the host (kIrqFence)
};

struct CommandCounters {
  uint64_t packets = 0;       // TRACE packets simulated
  uint64_t cycles = 0;        // cycles of those packets
  uint64_t rays = 0;          // rays through the slots (including rays rejected at setup)
  uint64_t stream_bytes = 0;  // ray and hit buffers
};

const TimingKeyTable& command_keys();
std::span<const TimingCounter> command_counters();

}  // namespace rtu::hw
