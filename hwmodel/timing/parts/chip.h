// A chip (hwmodel/device/timed_engine_chip.cpp): `units` ray-tracing units, each with everything of one unit,
// sharing the memory behind their node caches, and how a packet's rays are dispatched to them.
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

// How a packet's rays go to a chip's units (ray_scheduler.h: ray_unit()).
enum class RayPolicy : uint8_t { kWaves, kRoundRobin, kBlocks, kDynamic };
inline std::span<const TimingChoice> choices(RayPolicy) {
  static constexpr TimingChoice list[] = {
      {"waves", "ray_slots consecutive rays (a wave) to each unit in turn"},
      {"round_robin", "ray i to unit i mod units"},
      {"blocks", "the packet cut into units consecutive blocks"},
      {"dynamic", "a wave to whichever unit asks first; the policy sampled timing runs on a chip with"},
  };
  return list;
}

// A packet's rays go to the units by ray_policy: "waves" (ray_slots consecutive rays, a wave, to each unit in
// turn, as a GPU dispatches waves to its compute units), "round_robin" (ray i to unit i mod units), "blocks" (the
// packet cut into `units` consecutive blocks, as screen bands for camera rays) or "dynamic" (a wave to whichever
// unit asks first). units = 1 is the single unit.
struct ChipConfig {
  int units = 1;
  RayPolicy ray_policy = RayPolicy::kWaves;
};

const TimingKeyTable& chip_keys();

}  // namespace rtu::hw
