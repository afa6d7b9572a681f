#include "hwmodel/timing/parts/sort.h"

#include <vector>

#include "hwmodel/timing/sort_timing.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

std::span<const TimingChoice> choices(RaySort) {
  static const std::vector<TimingChoice> choices = [] {
    std::vector<TimingChoice> out;
    for (const RaySortKeyInfo& k : kRaySortKeys) out.push_back({k.name, k.description});
    return out;
  }();
  return choices;
}

const TimingKeyTable& sort_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"ray_sort", choice_field<&C::ray_sort>(), 0, 0,
       "ray sorting in the firmware before each TRACE (sort_timing.h): none, or the key rays are sorted by"},
      {"sort_key_cycles", &C::sort_key_cycles, 0, 100000, "ray sorting: controller cycles per key computed"},
      {"sort_keys_per_clock", &C::sort_keys_per_clock, 0.001, 4096,
       "ray sorting: keys a radix pass counts and scatters per clock (rays gathered, hits returned likewise)"},
      {"sort_radix_bits", &C::sort_radix_bits, 1, 16,
       "ray sorting: digit bits of the LSD radix sort (passes = ceil(key bits / this))"},
      {"sort_gather", choice_field<&C::sort_gather>(), 0, 0,
       "ray sorting: copy (rays permuted into sorted order, hits returned: four phases) or index (the unit reads "
       "rays through the sorted index and writes hits in place, as Meister et al.'s tracer: keys and radix "
       "passes only)"},
  };
  return keys;
}

}  // namespace rtu::hw
