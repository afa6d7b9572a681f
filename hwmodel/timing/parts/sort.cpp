#include "hwmodel/timing/parts/sort.h"

#include "hwmodel/timing/sort_timing.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

const TimingKeyTable& sort_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"ray_sort", &C::ray_sort, 0, 0,
       "ray sorting in the firmware before each TRACE: none, origin, direction, origin_direction or termination "
       "(sort_timing.h)",
       [](const C& c) {
         if (find_ray_sort_key(c.ray_sort)) return std::string();
         std::string names;
         for (const RaySortKeyInfo& k : kRaySortKeys) names += (names.empty() ? "" : ", ") + std::string(k.name);
         return "ray_sort = '" + c.ray_sort + "' is not a sort key (known: " + names + ")";
       }},
      {"sort_key_cycles", &C::sort_key_cycles, 0, 100000, "ray sorting: controller cycles per key computed"},
      {"sort_keys_per_clock", &C::sort_keys_per_clock, 0.001, 4096,
       "ray sorting: keys a radix pass counts and scatters per clock (rays gathered, hits returned likewise)"},
      {"sort_radix_bits", &C::sort_radix_bits, 1, 16,
       "ray sorting: digit bits of the LSD radix sort (passes = ceil(key bits / this))"},
  };
  return keys;
}

}  // namespace rtu::hw
