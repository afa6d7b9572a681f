// The timed device's statistics: counters the timing model adds up while it simulates (TimingStats), and the
// figures a report derives from them and the configuration (rates, utilisation, the lower bound).
//
// Each statistic is declared once, in the tables of timing_stats.cpp: the counters with their unit, description
// and how sampled timing extrapolates them; the report (the stats JSON, in its order) with each entry's key,
// unit and description. Merging runs (add), scaling a sample to its packet (scale_sampled), the JSON
// (host/io/stats_json.cpp), `rtusim config --stats` and the tests' field-by-field comparisons all read the tables,
// so a new counter is one line in TimingStats and one in the counter table.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

struct TimingStats {
  uint64_t packets = 0;  // TRACE packets simulated
  uint64_t cycles = 0;   // cycles of those packets
  uint64_t rays = 0;     // rays through the slots (including rays rejected at setup)
  uint64_t box_tests = 0, tri_tests = 0, sphere_tests = 0, plane_tests = 0;
  uint64_t curve_tests = 0;  // curve segment tests, in curve units or triangle unit slots (curve_units)
  uint64_t box_issue_cycles = 0, tri_issue_cycles = 0;  // unit issue slots used, summed over the units
  uint64_t node_fetches = 0, prim_fetches = 0;
  uint64_t cache_hits = 0, cache_misses = 0;  // line accesses
  // Prefetcher fills (prefetch/fetch_observer.h): lines brought in, asked for but already there, and brought in
  // and then hit by a demand access before being evicted.
  uint64_t prefetch_fills = 0, prefetch_redundant = 0, prefetch_useful = 0;
  uint64_t prefetch_dropped = 0;        // fills a full prefetch queue dropped (prefetch_queue > 0)
  uint64_t prefetch_late = 0;           // useful fills whose data was still on its way at the first demand hit
  uint64_t prefetch_unused = 0;         // prefetched lines evicted before any demand access hit them
  uint64_t l2_hits = 0, l2_misses = 0;  // node cache fills through the L2 (memory_system.h)
  // Stack spills and refills through the L2 (l2_cache.h): words that found their line there, and the others;
  // dirty lines the L2 wrote back to DRAM; clocks its slices' ports were held (lines and words).
  uint64_t l2_stack_hits = 0, l2_stack_misses = 0, l2_writebacks = 0, l2_port_cycles = 0;
  uint64_t dram_bytes = 0, dram_busy_cycles = 0;
  uint64_t dram_row_hits = 0, dram_row_misses = 0;  // with DRAM banks: accesses to the open row, and the others
  uint64_t stream_bytes = 0;                        // ray and hit buffers
  uint64_t stack_spills = 0, stack_refills = 0;
  uint64_t restarts = 0, restart_nodes = 0;  // stack_mode restart: restarts from the root, nodes re-visited
  uint64_t queue_stall_cycles = 0;
  uint64_t slot_busy_cycles = 0;  // sum over rays of the cycles from entering a slot to leaving it
  uint64_t any_hit_requests = 0;  // candidate hits on non-opaque triangles sent to the firmware's any-hit stage
  uint64_t tri_pairs = 0;         // triangle pairs tested as one request (in tri_tests twice)
  uint64_t obb_rotations = 0;     // oriented nodes: rays turned into a node's frame (one per oriented node test)
  // Triangle clusters with the cluster engine on (cluster_tri_rate > 0): box tests of clusters' internal nodes and
  // triangle tests it did (not in box_tests, tri_tests), and its requests (a node, or a leaf's triangles).
  uint64_t cluster_box_tests = 0, cluster_tri_tests = 0, cluster_requests = 0;
  uint64_t instance_transforms = 0;  // two-level scenes: rays transformed into an instance's bottom level
  // Waits that are throughput, not latency: requests queued for a busy box or triangle unit, and line and stack
  // reads queued for a busy L2 slice port, DRAM bank or channel (the latency bound takes them out of a ray's
  // life).
  uint64_t unit_wait_cycles = 0, mem_wait_cycles = 0;
  // Ray coherence gathering (ray_gather.h): bins issued (full, by timeout), rays' waits in their bins.
  uint64_t gather_bins = 0, gather_bins_full = 0, gather_bins_timeout = 0, gather_wait_cycles = 0;
  // The FR-FCFS DRAM scheduler (memory/dram_scheduler.h): requests served before an older arrived one of their
  // bank, and requests the cap served where a row hit would have gone.
  uint64_t dram_reordered = 0, dram_capped = 0;

  void add(const TimingStats& o);  // every counter summed (runs, packets, ray types merge this way)
};

// How sampled timing (sampler.h) turns the counters of the rays it simulated into a packet's.
enum class SampleScale : uint8_t {
  kPacket,  // set for the packet as a whole: packets (1), cycles (the estimate), rays (the packet's count)
  kPerRay,  // simulated value x packet rays / simulated rays, rounded to nearest
};

struct TimingCounter {
  const char* name;  // the member's name
  uint64_t TimingStats::*member;
  const char* unit;
  const char* description;
  SampleScale scale;
};
// Every counter of TimingStats, in the order of the struct.
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
