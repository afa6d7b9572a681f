// Ray coherence gathering (ray_gather.h), the in-unit ray scheduler seam: rays wait in a gather buffer, binned by
// a key, and the slots take the rays of issued bins. Its keys and counters.
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

// The bin key of the gathering unit (ray_gather.h: gather_key()), or none.
enum class GatherKey : uint8_t { kNone, kOctant, kOrigin, kOriginOctant, kTwoPoint };
inline std::span<const TimingChoice> choices(GatherKey) {
  static constexpr TimingChoice list[] = {
      {"none", "no gathering: the slots take rays in order"},
      {"octant", "the direction's three sign bits"},
      {"origin", "the origin's cell in a grid over the scene's frame"},
      {"origin_octant", "the origin's cell and the direction's octant"},
      {"two_point", "the origin's cell and the cell of the point a quarter of the frame along the ray"},
  };
  return list;
}

// none (the default) or the bin key; the origin grid's bits per axis, the gather buffer's rays, a bin's rays when
// it is issued full, and the cycles after which it is issued anyway.
struct GatherConfig {
  GatherKey gather = GatherKey::kNone;
  int gather_grid_bits = 3;
  int gather_buffer = 64;
  int gather_rays = 16;
  int gather_timeout = 200;
};

// Bins issued (full, by timeout), rays' waits in their bins.
struct GatherCounters {
  uint64_t gather_bins = 0, gather_bins_full = 0, gather_bins_timeout = 0, gather_wait_cycles = 0;
};

const TimingKeyTable& gather_keys();
std::span<const TimingCounter> gather_counters();

}  // namespace rtu::hw
