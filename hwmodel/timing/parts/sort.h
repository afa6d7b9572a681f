// Ray sorting in the firmware (sort_timing.h): the key the renderer sorts each bounce's rays of a type by before
// their TRACE, and the controller's cost of the sort.
#pragma once

#include <string>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

struct SortConfig {
  std::string ray_sort = "none";     // "none": no sorting; a name of kRaySortKeys
  double sort_key_cycles = 1.0;      // cycles per key computed
  double sort_keys_per_clock = 1.0;  // keys a radix pass counts and scatters per clock
  int sort_radix_bits = 8;           // digit bits of the LSD radix sort
};

const TimingKeyTable& sort_keys();

}  // namespace rtu::hw
