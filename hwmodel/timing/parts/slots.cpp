#include "hwmodel/timing/parts/slots.h"

#include <array>

#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

const TimingKeyTable& slot_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"ray_slots", &C::ray_slots, 1, 4096, "rays in flight, each with its own traversal state"},
  };
  return keys;
}

const TimingKeyTable& scheduler_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"traversal_latency", &C::traversal_latency, 0, kMaxLatency,
       "scheduler: cycles from a unit result to the slot's next request"},
      {"any_hit_latency", &C::any_hit_latency, 0, kMaxLatency,
       "cycles a ray waits for the any-hit stage's answer on a non-opaque triangle's candidate hit"},
      {"omm_latency", &C::omm_latency, 0, kMaxLatency,
       "cycles a ray waits for the opacity micromap lookup of a non-opaque triangle's candidate hit (scenes "
       "traced with micromaps)"},
      {"xform_latency", &C::xform_latency, 0, kMaxLatency,
       "two-level scenes: cycles of the instance transform (an instance record to the object-space ray)"},
      {"instance_bytes", &C::instance_bytes, 0, 4096,
       "two-level scenes: bytes an instance visit fetches, at that stride (0: the record and its stored "
       "transform, "
       "96 at 24 bits; 64: a one-line instance leaf)"},
  };
  return keys;
}

std::span<const TimingCounter> slot_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 1> counters = {{
      {"slot_busy_cycles", &S::slot_busy_cycles, "cycles",
       "sum over rays of the cycles from entering a ray slot to leaving it", kPerRay},
  }};
  return counter_table<SlotCounters>(counters);
}

std::span<const TimingCounter> scheduler_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 3> counters = {{
      {"any_hit_requests", &S::any_hit_requests, "requests",
       "candidate hits on non-opaque triangles sent to the any-hit stage (each waits any_hit_latency)", kPerRay},
      {"omm_lookups", &S::omm_lookups, "lookups",
       "candidate hits on non-opaque triangles looked up in their opacity micromap (each waits omm_latency)",
       kPerRay},
      {"instance_transforms", &S::instance_transforms, "rays",
       "two-level scenes: rays transformed into an instance's bottom level (each waits xform_latency)", kPerRay},
  }};
  return counter_table<SchedulerCounters>(counters);
}

}  // namespace rtu::hw
