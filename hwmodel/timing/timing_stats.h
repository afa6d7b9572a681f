// The timed device's statistics: counters the timing model adds up while it simulates (TimingStats), and the
// figures a report derives from them and the configuration (rates, utilisation, the lower bound).
//
// Each counter is declared once, by its part (parts/*.h, parts/*.cpp): its member, unit, description and how
// sampled timing extrapolates it; the report (the stats JSON, in its order, timing_stats.cpp) names each entry's
// key, unit and description. Merging runs (add), scaling a sample to its packet (scale_sampled), the JSON
// (host/io/stats_json.cpp), `rtusim config --stats` and the tests' field-by-field comparisons all read the tables,
// so a new counter is one line in its part's struct and one in its part's table (and a report row to show it).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

// The counters: each part's in the part's struct (parts/*.h).
struct TimingStats : CommandCounters,
                     UnitCounters,
                     FetchCounters,
                     PrefetchCounters,
                     L2Counters,
                     DramCounters,
                     StackCounters,
                     SlotCounters,
                     SchedulerCounters,
                     GatherCounters,
                     DramSchedulerCounters {
  void add(const TimingStats& o);  // every counter summed (runs, packets, ray types merge this way)
};

// Every counter of TimingStats, part by part in the order of the struct's parts.
std::span<const TimingCounter> timing_counters();

// Multiplies every kPerRay counter by `factor`, rounded to nearest; kPacket counters are left to the caller.
void scale_sampled(TimingStats& s, double factor);

// The unit cannot be faster than its busiest resource: box tests count in whole issue clocks per node (a node of c
// children issues for ceil(c / box_rate) clocks) over the box units; triangle, sphere and plane tests one per
// issue slot of the triangle units; DRAM bytes over its bandwidth; the L2's port clocks (lines and stack words)
// over its slices. Nor faster than its ray slots let it be (Little's law: rays in flight = throughput x lifetime,
// and at most ray_slots x units are in flight): the latency bound is rays x their mean lifetime / (ray_slots x
// units), the lifetime without the waits the throughput bounds already account for (unit_wait_cycles,
// mem_wait_cycles), so it binds when rays wait on latency, not on a queue.
// Each term assumes its resource busy without a gap; a queue at a slice, bank or unit that is busy while others
// idle is in none of them. What rays spent queued is measured: unit_queue and mem_queue are the slots' waits
// for busy units and for busy memory (L2 ports, DRAM banks and channels) on the scale of the latency term, so that
// with every slot full latency + unit_queue + mem_queue is about the cycles (slot_occupancy).
struct LowerBound {
  // fetch: rays / 1 per clock (the ray buffer streams and ray setup issues one ray per clock)
  double fetch = 0.0, box = 0.0, triangle = 0.0, curve = 0.0, dram = 0.0, l2 = 0.0, latency = 0.0;
  double cycles = 0.0;             // the largest of them
  const char* limited_by = "box";  // "fetch", "box", "triangle", "curve", "dram", "l2" or "latency"
  double cycles_over_bound = 0.0;  // simulated cycles / cycles (0 without a bound)
  // Slot time: waits for busy units and busy memory, and every slot's busy time, / (ray_slots x units).
  double unit_queue = 0.0, mem_queue = 0.0, slot_occupancy = 0.0;
};
LowerBound lower_bound(const TimingStats& s, const TimingConfig& c);

// One entry of a timing report: what the stats JSON holds for a TimingStats, in its order.
struct TimingStatValue {
  const char* key;  // JSON key; "a.b" is key b of object a
  const char* unit;
  const char* description;
  std::variant<uint64_t, double, std::string> value;
};
std::vector<TimingStatValue> timing_report(const TimingStats& s, const TimingConfig& c);
// The report's entries without values (for `rtusim config --stats`).
std::vector<TimingStatValue> timing_report_keys();

}  // namespace rtu::hw
