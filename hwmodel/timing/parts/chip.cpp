#include "hwmodel/timing/parts/chip.h"

#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

const TimingKeyTable& chip_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"units", &C::units, 1, 256, "ray-tracing units on the chip, sharing the L2 and DRAM (1: one unit)"},
      {"ray_policy", choice_field<&C::ray_policy>(), 0, 0,
       "how a packet's rays go to the units: a wave of ray_slots rays to each unit in turn, ray i to unit i mod "
       "units, the packet in units consecutive blocks, or a wave to whichever unit asks first"},
  };
  return keys;
}

}  // namespace rtu::hw
