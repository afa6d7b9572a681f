#include "hwmodel/timing/parts/watchdog.h"

#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

const TimingKeyTable& watchdog_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"watchdog_cycles", &C::watchdog_cycles, 0, 2147483647,
       "most cycles a ray may stay in its slot before a watchdog error (0: off)"},
  };
  return keys;
}

}  // namespace rtu::hw
