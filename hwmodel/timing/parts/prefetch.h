// Prefetching (prefetch/prefetchers.h): which prefetcher watches the fetch port, how much it fills, where its
// fills wait and land, and the treelet layout. Its keys and counters.
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

// A prefetcher (the prefetcher key): an index of prefetchers() (prefetch/prefetchers.h); 0 is none.
enum class PrefetcherId : uint8_t { kNone = 0 };
std::span<const TimingChoice> choices(PrefetcherId);  // prefetchers()' names and descriptions

// prefetcher ttp (prefetch/ttp.h): one part of the published mechanism switched off, to measure what it brings.
enum class TtpOff : uint8_t {
  kNone,      // as published
  kLeaves,    // the stack view holds inner nodes only; leaves are neither filled nor seen popped
  kDescents,  // a visit not taken from the stack is no pop: it fills nothing and ends a run of pops
  kFilter,    // no filter of the slot's recent prefetches
  kFill16,    // a third or later consecutive pop fills 2 entries, not 16
};
inline std::span<const TimingChoice> choices(TtpOff) {
  static constexpr TimingChoice list[] = {
      {"none", "TTP as published"},
      {"leaves", "inner nodes only: leaves are neither filled nor seen popped"},
      {"descents", "a visit not taken from the stack is no pop: it fills nothing and ends a run of pops"},
      {"filter", "no filter of the slot's 16 recent prefetches"},
      {"fill16", "a third or later consecutive pop fills 2 entries, not 16"},
  };
  return list;
}

struct PrefetchConfig {
  // A prefetcher watching the unit's fetches (prefetch/fetch_observer.h): none (the default) or one of
  // prefetchers() such as next_line; prefetch_degree lines per trigger.
  PrefetcherId prefetcher = PrefetcherId::kNone;
  int prefetch_degree = 1;
  // Lines a prefetcher's fills may wait for an idle memory (0: none wait, each goes at once).
  int prefetch_queue = 0;
  // Lines of a fully associative prefetch buffer beside the node cache (LRU): fills go there instead of into the
  // cache, and a demand hit moves the line into the cache (0: fills go into the cache).
  int prefetch_buffer = 0;
  // Bytes of a treelet in the timing layout (prefetch/treelets.h): 0 places nodes in the image's order.
  int treelet_bytes = 0;
  // prefetcher ttp: a part of its mechanism switched off (none: as published).
  TtpOff ttp_off = TtpOff::kNone;
};

// Prefetcher fills (prefetch/fetch_observer.h): lines brought in, asked for but already there, and brought in and
// then hit by a demand access before being evicted.
struct PrefetchCounters {
  uint64_t prefetch_fills = 0, prefetch_redundant = 0, prefetch_useful = 0;
  uint64_t prefetch_dropped = 0;  // fills a full prefetch queue dropped (prefetch_queue > 0)
  uint64_t prefetch_late = 0;     // useful fills whose data was still on its way at the first demand hit
  uint64_t prefetch_unused = 0;   // prefetched lines evicted before any demand access hit them
};

const TimingKeyTable& prefetch_keys();
std::span<const TimingCounter> prefetch_counters();

}  // namespace rtu::hw
