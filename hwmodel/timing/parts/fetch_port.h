// The unit's fetch port (timing_model.h): node, record and plane fetches through the node cache
// (memory/node_cache.h) at addresses the timing layout gives them (timing_model_layout.cpp).
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

struct FetchConfig {
  int cache_kib = 64;  // 0: no cache
  int cache_ways = 4;
  int line_bytes = 64;
  // Where fetches fall in memory: 0 packs nodes, primitive records and plane records back to back as the device
  // image lays them out (a 56-byte node straddles two 64-byte lines about 7 times in 8); a power of two in
  // [8, 4096] pads each to a multiple of it and aligns each section's start, as a padded layout would (64 with
  // 64-byte lines: one line per node and record, at 64/56 the node bytes and 64/40 the record bytes). The
  // functional image is unchanged; only the timing model's addresses and the padded footprint differ.
  int layout_align = 0;
  int cache_latency = 4;  // hit latency
  // Requests and read answers the unit's memory port takes a clock (memory/port_limit.h): 0 no limit, 1 one of
  // each, as the RTL traversal unit's port (a refilled stack entry is then decided the clock after its data).
  int fetch_port_rate = 0;
  // Opacity micromaps' states (kOmm fetches) through a cache of their own of this many KiB, cache_ways-way with
  // line_bytes lines and cache_latency, beside the node cache; 0: through the node cache, as nodes and records.
  int omm_cache_kib = 0;
};

struct FetchCounters {
  uint64_t node_fetches = 0, prim_fetches = 0;
  uint64_t cache_hits = 0, cache_misses = 0;                 // line accesses
  uint64_t port_request_waits = 0, port_response_waits = 0;  // fetch_port_rate 1: cycles behind other requests
  uint64_t omm_cache_hits = 0, omm_cache_misses = 0;         // omm_cache_kib > 0: micromap state lines
};

const TimingKeyTable& fetch_keys();
std::span<const TimingCounter> fetch_counters();

}  // namespace rtu::hw
