// The watchdog (timing_model_watchdog.cpp): the most cycles a ray may stay in its ray slot; a ray still there
// after that stops the TRACE with a watchdog error and a dump of the unit's state.
#pragma once

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

struct WatchdogConfig {
  // 0: off. 50 ms at 2 GHz: far beyond any ray's traversal (the slowest in bench/cycles_table.sh take thousands).
  int watchdog_cycles = 100000000;
};

const TimingKeyTable& watchdog_keys();

}  // namespace rtu::hw
