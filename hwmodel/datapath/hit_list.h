// All-hit traversal's output (FloatTracer::trace_all, FixedTracer::trace_all): every intersection of a ray in
// [tmin, tmax], in the order the traversal finds them, at most `max` kept; `count` counts them all, so a list
// whose count exceeds max has overflowed (the hits beyond it were found and counted, not kept). A count-only query
// is a list of max 0.
#pragma once

#include <cstdint>

#include "hwmodel/interface/ray.h"

namespace rtu::hw {

struct HitList {
  Hit* out = nullptr;  // room for max hits (may be null when max is 0)
  uint32_t max = 0;
  uint64_t count = 0;

  void add(const Hit& h) {
    if (count < max) out[count] = h;
    ++count;
  }
  bool overflow() const { return count > max; }
  uint32_t kept() const { return count < max ? uint32_t(count) : max; }
};

}  // namespace rtu::hw
