// Ray sorting in the firmware (sort_timing.h): the key the renderer sorts each bounce's rays of a type by before
// their TRACE, and the controller's cost of the sort.
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

// The key rays are sorted by (the ray_sort key): an index of kRaySortKeys (sort_timing.h), whose order is the
// firmware's fw::RaySortKey; 0 is none (no sorting).
enum class RaySort : uint8_t { kNone = 0 };
std::span<const TimingChoice> choices(RaySort);  // kRaySortKeys' names and descriptions

// Where the sorted order goes (the sort_gather key).
enum class SortGather : uint8_t {
  kCopy,   // the rays are copied into sorted order, the hits back into the rays' (permute and return phases)
  kIndex,  // the unit reads each ray through the sorted index and writes its hit in place (Meister et al.'s code)
};
inline std::span<const TimingChoice> choices(SortGather) {
  static constexpr TimingChoice list[] = {
      {"copy", "the firmware copies the rays into sorted order and the hits back into the rays' order"},
      {"index",
       "no copies: the unit reads each ray through the sorted index and writes its hit in the ray's place, as "
       "Meister et al.'s tracer does; the sort costs its keys and radix passes only"},
  };
  return list;
}

struct SortConfig {
  RaySort ray_sort = RaySort::kNone;
  double sort_key_cycles = 1.0;      // cycles per key computed
  double sort_keys_per_clock = 1.0;  // keys a radix pass counts and scatters per clock
  int sort_radix_bits = 8;           // digit bits of the LSD radix sort
  SortGather sort_gather = SortGather::kCopy;
};

const TimingKeyTable& sort_keys();

}  // namespace rtu::hw
