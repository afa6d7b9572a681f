// The timing model's configuration: every latency, rate and size of the timed device (timing_model.h), as named
// keys with presets. `rtusim config --config P` prints a resolved configuration; `--set key=value`
// overrides one key; unknown keys and out-of-range values are errors naming the key.
//
// Ranges (checked by validate()): latencies 0..100000 cycles (box, triangle, sphere and plane latencies >= 1);
// units and rates 1..64; ray_slots and queue_depth 1..4096; stack_entries 1..64; cache_kib 0..65536 (a whole
// number of sets: cache_kib * 1024 divisible by cache_ways * line_bytes); cache_ways 1..64; line_bytes a power
// of two in 16..4096; clock_ghz 0.001..1000; dram_bytes_per_cycle 0.001..65536 (finite); raster_setup_cycles
// 0..100000; raster_samples_per_clock and raster_fragments_per_clock 0.001..4096; raster_latency 0..100000;
// raster_prim_bytes 0..4096, raster_depth_bytes 1..64, raster_gbuffer_bytes 0..4096; bvh_width 2, 4, 6 or 8;
// format a fixed-point format spec (a preset, optionally with :key=value changes); box_unit and tri_unit cpp or
// rtl; memory_type gddr6, hbm2 or lpddr5; prefetcher a name of prefetchers(), prefetch_degree 1..64; ray_sort a
// name of kRaySortKeys, sort_key_cycles 0..100000, sort_keys_per_clock 0.001..4096, sort_radix_bits 1..16;
// watchdog_cycles 0..2^31-1 (0: off). The default-constructed configuration is the "rdna2" preset: its figures are
// the defaults below, and every other preset is a base preset plus the keys it changes (timing_config.cpp), so a
// new key with a neutral default needs no preset edited.
#pragma once

#include <cstdint>
#include <string>
#include <variant>
#include <vector>

namespace rtu::hw {

struct TimingConfig {
  std::string name = "rdna2";      // preset it came from
  std::string format = "default";  // fixed-point format spec of the datapath (format_from_spec), e.g. compact
  int bvh_width = 4;               // children per node: 2, 4, 6 or 8 (overrides the format's width)
  double clock_ghz = 2.0;          // for reporting time and bandwidth in seconds and GB/s only

  // Command processor: packet fetch, ray fetch, hit write-back, fences.
  int packet_latency = 20;     // cycles from doorbell (or the previous packet) to a decoded packet
  int ray_fetch_latency = 10;  // cycles to bring a ray from the ray buffer into ray setup (streamed, 1 per clock)
  int setup_latency = 8;       // ray setup pipeline depth (float -> fixed, reciprocal); 1 ray per clock
  int writeback_latency = 4;   // hit write-back pipeline depth; 1 hit per clock
  int fence_latency = 10;      // cycles from the last earlier hit written to the fence value in memory
  int irq_latency = 100;       // cycles from a FENCE's value write to its interrupt reaching the host (kIrqFence)

  // Ray slots and traversal.
  int ray_slots = 32;     // rays in flight, each with its own traversal state
  int stack_entries = 8;  // short stack per slot; deeper entries spill to memory (8 bytes each)
  // What happens to entries beyond the short stack: "spill" (to memory, read back when popped) or "restart" (the
  // oldest is dropped; popping a dropped entry restarts from the root along a trail, restart_trail.h).
  std::string stack_mode = "spill";
  int traversal_latency = 2;  // scheduler: cycles from a unit result to the slot's next request
  // Cycles a ray waits in its slot for the any-hit stage's answer on a candidate hit of a non-opaque triangle
  // (any_hit.h): the request to the firmware, its mask lookup (a texture read from memory) and the answer.
  int any_hit_latency = 400;
  // Two-level scenes (instanced_fixed.h): cycles from an instance record's arrival to the ray's object-space
  // origin and direction (the transform unit, pipelined: one ray per clock).
  int xform_latency = 12;
  // Two-level scenes: the bytes an instance visit fetches, at a stride of as many bytes. 0: the image's instance
  // record and its stored transform and bottom-level address (40 + 56 = 96 bytes at 24 transform bits); 64 models
  // a one-line instance leaf such as the 64-byte half of Intel's 128-byte InstanceLeaf that traversal reads.
  int instance_bytes = 0;

  // Units: count, tests per clock per unit, pipeline depth (cycles from issue to result).
  int box_units = 1;
  int box_rate = 4;  // box tests per clock per unit (a node of width <= rate issues in one clock)
  int box_latency = 6;
  // Oriented nodes (node_kind 1): clocks the ray's rotation into the node's frame adds to the box test's latency
  // (a 3x3 integer product of origin and direction and the reciprocals of the rotated direction; an estimate,
  // timing-model.md). No effect on axis-aligned images.
  int obb_latency = 4;
  // Which box unit answers the box tests: "cpp" (the C++ datapath, box_rate and box_latency) or "rtl" (the
  // Verilated RTL of rtl_sim/, co-simulation: its clocks per node replace box_rate and box_latency; hits stay
  // the C++ unit's, bit for bit). The host attaches the RTL unit (hwmodel never sees it).
  std::string box_unit = "cpp";
  int tri_units = 1;
  int tri_rate = 1;  // triangle tests per clock per unit
  int tri_latency = 12;
  // Which triangle unit answers the triangle tests: "cpp" (the C++ datapath, one issue clock and tri_latency) or
  // "rtl" (the Verilated RTL of rtl_sim/, co-simulation: its clocks per triangle replace them; hits stay the C++
  // unit's, bit for bit). Spheres and planes stay C++. The host attaches the RTL unit (hwmodel never sees it).
  std::string tri_unit = "cpp";
  int sphere_latency = 16;  // spheres and planes share the triangle units' issue slots (one test per clock)
  int plane_latency = 8;
  // Curve segments (linear swept spheres): a unit of their own, as NVIDIA Blackwell's RT core has, or none, and
  // then each curve test takes one triangle unit issue slot for curve_issue clocks. Latency and fallback slots
  // are estimates (timing-model.md); curve_units 0 is every preset but the -lss what-ifs.
  int curve_units = 0;     // curve units per unit; 0: curve tests go to the triangle units
  int curve_rate = 1;      // curve tests per clock per curve unit
  int curve_latency = 20;  // curve test pipeline depth, issue to result
  int curve_issue = 2;     // without curve units: clocks a curve test holds a triangle unit issue slot
  // Triangle clusters (format prim_layout 2, format/cluster_layout.h): the cluster engine, one per unit, tests a
  // cluster's internal nodes (box_rate boxes per clock, box_latency deep, beside the box units) and each leaf of
  // the cluster as one request of cluster_tri_rate triangles per clock (tri_latency deep). 0: off, a cluster's
  // nodes and triangles go to the box and triangle units as any others do. An estimate: no published figure.
  int cluster_tri_rate = 0;
  // Rays the ray prefetch queue holds ahead of the slots, and clocks a unit request may wait for a free unit
  // before the wait counts as a queue stall (waiting requests stay in their slots; there is no request buffer).
  int queue_depth = 16;

  // Memory: node and primitive fetches through one cache into DRAM.
  int cache_kib = 64;  // 0: no cache
  int cache_ways = 4;
  int line_bytes = 64;
  // Where fetches fall in memory: 0 packs nodes, primitive records and plane records back to back as the device
  // image lays them out (a 56-byte node straddles two 64-byte lines about 7 times in 8); a power of two in
  // [8, 4096] pads each to a multiple of it and aligns each section's start, as a padded layout would (64 with
  // 64-byte lines: one line per node and record, at 64/56 the node bytes and 64/40 the record bytes). The
  // functional image is unchanged; only the timing model's addresses and the padded footprint differ.
  int layout_align = 0;
  int cache_latency = 4;               // hit latency
  int dram_latency = 200;              // cycles from request to the first byte
  double dram_bytes_per_cycle = 64.0;  // bandwidth
  // A prefetcher watching the unit's fetches (prefetch/fetch_observer.h): "none" (the default) or a name of
  // prefetchers() such as "next_line"; prefetch_degree lines per trigger.
  std::string prefetcher = "none";
  int prefetch_degree = 1;
  // Lines a prefetcher's fills may wait for an idle memory (0: none wait, each goes at once).
  int prefetch_queue = 0;
  // Lines of a fully associative prefetch buffer beside the node cache (LRU): fills go there instead of into the
  // cache, and a demand hit moves the line into the cache (0: fills go into the cache).
  int prefetch_buffer = 0;
  // Bytes of a treelet in the timing layout (prefetch/treelets.h): 0 places nodes in the image's order.
  int treelet_bytes = 0;
  // Ray coherence gathering (ray_gather.h): "none" (the default) or the bin key; the origin grid's bits per axis,
  // the gather buffer's rays, a bin's rays when it is issued full, and the cycles after which it is issued anyway.
  std::string gather = "none";
  int gather_grid_bits = 3;
  int gather_buffer = 64;
  int gather_rays = 16;
  int gather_timeout = 200;
  // A chip: `units` ray-tracing units, each with everything above (ray slots, box and triangle units, node cache),
  // sharing the memory below (L2 and DRAM). A packet's rays go to the units by ray_policy: "waves" (ray_slots
  // consecutive rays, a wave, to each unit in turn, as a GPU dispatches waves to its compute units), "round_robin"
  // (ray i to unit i mod units) or "blocks" (the packet cut into `units` consecutive blocks, as screen bands for
  // camera rays). units = 1 is the single unit.
  int units = 1;
  std::string ray_policy = "waves";
  // The memory behind the node cache (memory_system.h). Without an L2 and without banks (the defaults) it is the
  // one DRAM channel above. An L2: l2_kib KiB in l2_slices slices (a line's slice: its line number modulo the
  // slices), l2_ways-way LRU, l2_latency cycles, l2_bytes_per_cycle per slice port (0: unlimited). DRAM banks:
  // dram_channels channels sharing dram_bytes_per_cycle, dram_banks open-page banks each with dram_row_bytes
  // rows, dram_activate_cycles to open a row and dram_precharge_cycles to close one.
  int l2_kib = 0;  // 0: no L2
  int l2_slices = 4;
  int l2_ways = 16;
  int l2_latency = 100;
  double l2_bytes_per_cycle = 64.0;
  int dram_channels = 1;
  int dram_banks = 0;  // 0: no bank model (no rows: every access as a row hit)
  int dram_row_bytes = 2048;
  int dram_activate_cycles = 0;
  int dram_precharge_cycles = 0;
  // What the memory behind the cache is, for its energy per bit (energy_model.h memory_types()): gddr6, hbm2 or
  // lpddr5. Timing does not depend on it.
  std::string memory_type = "gddr6";
  // The DRAM scheduler (memory/dram_scheduler.h, its keys declared there): "fcfs" (each request served at its own
  // cycle, in order) or "frfcfs" (queued per bank, row hits first, then the oldest; needs dram_banks > 0), and the
  // number of younger requests that may pass one over before it is served next.
  std::string dram_scheduler = "fcfs";
  int dram_frfcfs_cap = 16;

  // Rasterizer of hybrid mode (raster_timing.h): a raster pipeline beside the unit, sharing its DRAM channel.
  double raster_setup_cycles = 20.0;        // cycles per primitive set up
  double raster_samples_per_clock = 6.4;    // coverage tests per clock (scan of each primitive's rectangle)
  double raster_fragments_per_clock = 1.6;  // covered samples through interpolation and the depth test per clock
  int raster_latency = 100;                 // pipeline depth, paid once per raster pass
  int raster_prim_bytes = 36;               // bytes fetched per primitive per pass (three float3 vertices)
  int raster_depth_bytes = 4;               // depth bytes read per fragment, written per pass and per clear
  int raster_gbuffer_bytes = 12;            // G-buffer bytes written per pass besides depth (prim, u, v)
  // Ray sorting in the firmware (sort_timing.h): the key the renderer sorts each bounce's rays of a type by before
  // their TRACE ("none": no sorting; a name of kRaySortKeys), and the controller's cost of the sort.
  std::string ray_sort = "none";
  double sort_key_cycles = 1.0;      // cycles per key computed
  double sort_keys_per_clock = 1.0;  // keys a radix pass counts and scatters per clock
  int sort_radix_bits = 8;           // digit bits of the LSD radix sort
  // Watchdog: the most cycles a ray may stay in its ray slot; a ray still there after that stops the TRACE with
  // a watchdog error and a dump of the unit's state (timing_model.h). 0: off.
  // 50 ms at 2 GHz: far beyond any ray's traversal (the slowest in bench/cycles_table.sh take thousands).
  int watchdog_cycles = 100000000;

  // Checks every field; throws std::invalid_argument naming the first bad key and its allowed range.
  void validate() const;
};

// The presets: "rdna2" (resembling AMD RDNA2's ray accelerator: BVH4, 4 box tests or 1 triangle test per clock),
// "intel" (resembling Intel's RTU: 6-wide nodes, 12 box tests (two units of 6) and 1 triangle test per
// clock), "embedded" (a small unit: BVH4, 16-bit coordinates (format compact), one box unit, a small cache),
// and the memory-bound
// "rdna2-mem" and "intel-mem" (rdna2's and intel's datapath with one unit's share of a real GPU's memory: its
// small first-level cache, VRAM latency and bandwidth / units), and the chips "rdna2-chip" (80 rdna2-mem units,
// a 4 MB L2, 16 GDDR6 channels), "intel-chip" (32 intel-mem units, a 16 MB L2, 16 GDDR6 channels) and
// "embedded-chip" (4 embedded units, a 1 MiB L2, LPDDR5); the units of 2025, "rdna4" (an RDNA4 Ray Accelerator:
// BVH8 of 128-byte nodes with 12-bit child boxes, 8 box tests or 2 triangle tests per clock) and "xe2" (an Xe2
// RTU: BVH6, three traversal pipelines as three box units of 6, 2 triangle tests per clock, more ray slots), with
// "rdna4-mem", "xe2-mem" (RX 9070 XT and Arc B580 shares) and "rdna4-chip" (64 units, an 8 MB L2, no Infinity
// Cache), "xe2-chip" (20 units, an 18 MB L2). timing_config.cpp says where each figure comes from.
const std::vector<std::string>& timing_preset_names();
// Throws std::invalid_argument for an unknown name (listing the known ones).
TimingConfig timing_preset(const std::string& name);
// One line saying what a preset resembles (for `rtusim config --list`); throws like timing_preset().
std::string timing_preset_description(const std::string& name);

// A key's declaration: the field it names, its allowed range (ints and doubles), a one-line description, and a
// rule beyond the range (null, or the problem as text, empty when the value is allowed). The central table in
// timing_config.cpp holds the unit's own keys; a component declares its keys beside itself (as the prefetchers'
// prefetch_keys() in prefetch/prefetchers.h) and the table gathers them at their place in the struct's order.
struct TimingKeyInfo {
  const char* key;
  std::variant<int TimingConfig::*, double TimingConfig::*, std::string TimingConfig::*> field;
  double lo, hi;  // inclusive range of ints and doubles; unused for strings
  const char* description;
  std::string (*rule)(const TimingConfig&) = nullptr;
};

// One key of the configuration: name, value as text, one-line description.
struct TimingKey {
  std::string key, value, description;
};
// Every key in a fixed order (the order of the struct), `name` excepted (it is the preset, not a key). Values are
// text that set_timing_key() parses back to the same value (doubles in their shortest round-trip form).
std::vector<TimingKey> timing_keys(const TimingConfig& c);
// Sets one key from text ("key=value" split by the caller); throws std::invalid_argument for an unknown key
// (listing the known ones), a value that does not parse, or one out of range (validate()). Integers must be
// whole decimal integers ("12x", "", "1e3" are refused); doubles must parse whole and be finite. `c` is left
// unchanged when it throws. `name` is not changed.
void set_timing_key(TimingConfig& c, const std::string& key, const std::string& value);

}  // namespace rtu::hw
