#include "hwmodel/timing/parts/command.h"

#include <array>

#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

const TimingKeyTable& command_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"packet_latency", &C::packet_latency, 0, kMaxLatency,
       "cycles from doorbell (or the previous packet) to a decoded packet"},
      {"ray_fetch_latency", &C::ray_fetch_latency, 0, kMaxLatency,
       "cycles to bring a ray from the ray buffer into setup (1 per clock)"},
      {"setup_latency", &C::setup_latency, 0, kMaxLatency, "ray setup pipeline depth (float -> fixed, 1/d)"},
      {"writeback_latency", &C::writeback_latency, 0, kMaxLatency, "hit write-back pipeline depth (1 per clock)"},
      {"fence_latency", &C::fence_latency, 0, kMaxLatency, "cycles from the last earlier hit to the fence value"},
      {"irq_latency", &C::irq_latency, 0, kMaxLatency,
       "cycles from a FENCE's value write to its interrupt reaching the host"},
  };
  return keys;
}

std::span<const TimingCounter> command_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 4> counters = {{
      {"packets", &S::packets, "packets", "TRACE packets simulated", kPacket},
      {"cycles", &S::cycles, "cycles", "cycles of those packets, from decode to the last hit written", kPacket},
      {"rays", &S::rays, "rays", "rays through the ray slots (rays rejected at setup included)", kPacket},
      {"stream_bytes", &S::stream_bytes, "bytes", "ray buffer reads and hit buffer writes (their own port)",
       kPerRay},
  }};
  return counter_table<CommandCounters>(counters);
}

}  // namespace rtu::hw
