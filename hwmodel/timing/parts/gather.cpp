#include "hwmodel/timing/parts/gather.h"

#include <array>

#include "hwmodel/timing/ray_gather.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

const TimingKeyTable& gather_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"gather", choice_field<&C::gather>(), 0, 0,
       "ray coherence gathering (ray_gather.h): none, or the key rays are binned by"},
      {"gather_grid_bits", &C::gather_grid_bits, 1, 8,
       "gathering: origin grid cells per axis = 2^bits over the scene's frame (origin and two_point keys)"},
      {"gather_buffer", &C::gather_buffer, 1, 4096,
       "gathering: rays the gather buffer holds (replaces queue_depth)"},
      {"gather_rays", &C::gather_rays, 1, 4096, "gathering: a bin is issued when it holds this many rays"},
      {"gather_timeout", &C::gather_timeout, 1, 1000000,
       "gathering: a bin is issued this many cycles after its first ray arrived, full or not"},
  };
  return keys;
}

std::span<const TimingCounter> gather_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 4> counters = {{
      {"gather_bins", &S::gather_bins, "bins", "bins the gathering unit issued to the ray slots", kPerRay},
      {"gather_bins_full", &S::gather_bins_full, "bins", "bins issued because they held gather_rays rays",
       kPerRay},
      {"gather_bins_timeout", &S::gather_bins_timeout, "bins",
       "bins issued after gather_timeout cycles (the rest: the buffer full, or the packet's last ray arrived)",
       kPerRay},
      {"gather_wait_cycles", &S::gather_wait_cycles, "cycles",
       "sum over rays of the cycles from arriving in the gather buffer to their bin's issue", kPerRay},
  }};
  return counter_table<GatherCounters>(counters);
}

}  // namespace rtu::hw
