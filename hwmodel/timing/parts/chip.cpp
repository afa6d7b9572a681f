#include "hwmodel/timing/parts/chip.h"

#include "hwmodel/timing/ray_scheduler.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

const TimingKeyTable& chip_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"units", &C::units, 1, 256, "ray-tracing units on the chip, sharing the L2 and DRAM (1: one unit)"},
      {"ray_policy", &C::ray_policy, 0, 0,
       "how a packet's rays go to the units: waves (ray_slots consecutive rays to each unit in turn), round_robin "
       "(ray i to unit i mod units), blocks (the packet in units consecutive blocks) or dynamic (a wave to "
       "whichever "
       "unit asks first; the policy sampled timing runs on a chip with)",
       [](const C& c) {
         RayPolicy policy;
         return parse_ray_policy(c.ray_policy, policy)
                    ? std::string()
                    : "ray_policy = '" + c.ray_policy + "' must be waves, round_robin, blocks or dynamic";
       }},
  };
  return keys;
}

}  // namespace rtu::hw
