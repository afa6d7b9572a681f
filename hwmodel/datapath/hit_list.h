// All-hit traversal's output (FloatTracer::trace_all, FixedTracer::trace_all): every intersection of a ray in
// [tmin, tmax], in the order the traversal finds them, at most `max` kept; `count` counts them all, so a list
// whose count exceeds max has overflowed (the hits beyond it were found and counted, not kept). A count-only query
// is a list of max 0.
#pragma once

#include <cstddef>
#include <cstdint>

#include "hwmodel/datapath/batch.h"
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

// Where a batch's hit lists go (TraceEngine::trace_all_cycles, host::DirectDevice::trace_all_batch): for ray i, up
// to k hits at lists[i * k ...] in the order the traversal found them, and counts[i] the intersections found (more
// than k: the list overflowed).
struct AllHitsOut {
  uint32_t k = 0;
  Hit* lists = nullptr;        // n * k hits (may be null when k is 0)
  uint64_t* counts = nullptr;  // n counts
  HitList list(size_t i) const { return HitList{lists ? lists + i * size_t(k) : nullptr, k}; }
};

// An all-hit batch of n rays on `threads` threads (run_batch): ray i's list from trace(i, list, stats).
template <class Fn>
void all_hits_batch(size_t n, int threads, const AllHitsOut& out, TraversalStats& s, Fn&& trace) {
  run_batch(n, threads, s, [&](size_t i, TraversalStats& st) {
    HitList list = out.list(i);
    out.counts[i] = trace(i, list, st);
  });
}

}  // namespace rtu::hw
