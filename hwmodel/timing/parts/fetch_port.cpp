#include "hwmodel/timing/parts/fetch_port.h"

#include <array>

#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

const TimingKeyTable& fetch_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"cache_kib", &C::cache_kib, 0, 65536, "node and primitive cache in KiB (0: no cache)"},
      {"cache_ways", &C::cache_ways, 1, 64, "cache associativity"},
      {"line_bytes", &C::line_bytes, 16, 4096, "cache line bytes, the unit of every fetch (a power of two)",
       [](const C& c) -> std::string {
         if ((c.line_bytes & (c.line_bytes - 1)) != 0)
           return "line_bytes = " + std::to_string(c.line_bytes) + " must be a power of two in [16, 4096]";
         const long long set_bytes = static_cast<long long>(c.cache_ways) * c.line_bytes;
         if (c.cache_kib > 0 && (static_cast<long long>(c.cache_kib) * 1024) % set_bytes != 0)
           return "cache_kib = " + std::to_string(c.cache_kib) + ": " + std::to_string(c.cache_kib) +
                  " KiB is not a whole number of sets of cache_ways * line_bytes = " + std::to_string(set_bytes) +
                  " bytes";
         return {};
       }},
      {"layout_align", &C::layout_align, 0, 4096,
       "fetch addresses: 0 packed as the image; a power of two >= 8 pads and aligns each node and record to it",
       [](const C& c) -> std::string {
         if (c.layout_align != 0 && (c.layout_align < 8 || (c.layout_align & (c.layout_align - 1)) != 0))
           return "layout_align = " + std::to_string(c.layout_align) + " must be 0 or a power of two in [8, 4096]";
         return {};
       }},
      {"cache_latency", &C::cache_latency, 0, kMaxLatency, "cache hit latency in cycles"},
      {"omm_cache_kib", &C::omm_cache_kib, 0, 65536,
       "opacity micromap states through a cache of their own (KiB, cache_ways, line_bytes, cache_latency); 0: "
       "through the node cache",
       [](const C& c) -> std::string {
         const long long set_bytes = static_cast<long long>(c.cache_ways) * c.line_bytes;
         if (c.omm_cache_kib > 0 && (static_cast<long long>(c.omm_cache_kib) * 1024) % set_bytes != 0)
           return "omm_cache_kib = " + std::to_string(c.omm_cache_kib) +
                  " KiB is not a whole number of sets of cache_ways * line_bytes = " + std::to_string(set_bytes) +
                  " bytes";
         return {};
       }},
      {"fetch_port_rate", &C::fetch_port_rate, 0, 1,
       "requests and read answers the memory port takes a clock: 0 no limit; 1 one of each, as the RTL traversal "
       "unit (rtl_sim/trav), whose refilled stack entries are decided the clock after their data",
       [](const C& c) -> std::string {
         if (c.fetch_port_rate > 0 && c.dram_scheduler != DramScheduler::kFcfs)
           return "fetch_port_rate = 1 needs dram_scheduler = fcfs (the queued memory answers later)";
         return {};
       }},
  };
  return keys;
}

std::span<const TimingCounter> fetch_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 8> counters = {{
      {"node_fetches", &S::node_fetches, "fetches", "node fetches (each one or more cache lines)", kPerRay},
      {"prim_fetches", &S::prim_fetches, "fetches", "primitive record and plane fetches", kPerRay},
      {"cache_hits", &S::cache_hits, "lines", "cache line accesses that hit (a line in flight counts as a hit)",
       kPerRay},
      {"cache_misses", &S::cache_misses, "lines", "cache line accesses that missed and went to DRAM", kPerRay},
      {"port_request_waits", &S::port_request_waits, "cycles",
       "fetch_port_rate 1: cycles requests waited for the memory port behind others", kPerRay},
      {"port_response_waits", &S::port_response_waits, "cycles",
       "fetch_port_rate 1: cycles read answers waited for the port behind others", kPerRay},
      {"omm_cache_hits", &S::omm_cache_hits, "lines",
       "omm_cache_kib > 0: micromap state line accesses that hit the micromap cache", kPerRay},
      {"omm_cache_misses", &S::omm_cache_misses, "lines",
       "omm_cache_kib > 0: micromap state line accesses that missed it and went to memory", kPerRay},
  }};
  return counter_table<FetchCounters>(counters);
}

}  // namespace rtu::hw
