// Which unit of a chip takes which of a packet's rays (ray_policy), as one enum read from the key once per packet.
//
// - waves: ray_slots consecutive rays (a wave) to each unit in turn, as a GPU dispatches waves to its compute
//   units;
// - round_robin: ray i to unit i mod units;
// - blocks: the packet cut into `units` consecutive blocks, as screen bands for camera rays;
// - dynamic: ray_slots consecutive rays (a wave) to whichever unit asks first for a ray it has not been given (the
//   units in the order of the cycle they ask, ties to the lower unit), as a GPU's dispatcher hands waves to the
//   compute units with room. The only policy under which sampled timing runs on a chip (sampler.h).
// Within a unit, a free slot takes the unit's next ray in order (TimingModel::admit): rays arrive from the ray
// buffer in order through a queue of queue_depth, so that is the order the ray fetch model (timing_model.h)
// prices; or, with gathering (ray_gather.h), the first ray of the bins issued so far. To add a policy: a value of
// RayPolicy and its row in choices(RayPolicy) (parts/chip.h), and a case in ray_unit(); the key's check and
// description follow from the list.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "hwmodel/timing/parts/chip.h"

namespace rtu::hw {

// The unit of `units` that takes ray i of a packet of n rays, with `slots` ray slots per unit (dynamic: decided
// while the packet runs, TimedEngine::run_chip_dynamic; the waves' unit here).
inline size_t ray_unit(RayPolicy policy, size_t i, size_t n, size_t units, size_t slots) {
  switch (policy) {
    case RayPolicy::kBlocks:
      return i * units / n;
    case RayPolicy::kWaves:
    case RayPolicy::kDynamic:
      return (i / slots) % units;
    case RayPolicy::kRoundRobin:
      break;
  }
  return i % units;
}

}  // namespace rtu::hw
