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
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "hwmodel/timing/parts/chip.h"
#include "hwmodel/timing/parts/command.h"
#include "hwmodel/timing/parts/dram_scheduler.h"
#include "hwmodel/timing/parts/fetch_port.h"
#include "hwmodel/timing/parts/gather.h"
#include "hwmodel/timing/parts/memory.h"
#include "hwmodel/timing/parts/prefetch.h"
#include "hwmodel/timing/parts/raster.h"
#include "hwmodel/timing/parts/slots.h"
#include "hwmodel/timing/parts/sort.h"
#include "hwmodel/timing/parts/stack.h"
#include "hwmodel/timing/parts/test_units.h"
#include "hwmodel/timing/parts/watchdog.h"
#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

// The configuration: the datapath's own keys below, and each part's keys in the part's struct (parts/*.h).
struct TimingConfig : CommandConfig,
                      SlotConfig,
                      StackConfig,
                      SchedulerConfig,
                      UnitConfig,
                      FetchConfig,
                      DramChannelConfig,
                      PrefetchConfig,
                      GatherConfig,
                      ChipConfig,
                      L2Config,
                      DramBankConfig,
                      DramSchedulerConfig,
                      RasterConfig,
                      SortConfig,
                      WatchdogConfig {
  std::string name = "rdna2";      // preset it came from
  std::string format = "default";  // fixed-point format spec of the datapath (format_from_spec), e.g. compact
  int bvh_width = 4;               // children per node: 2, 4, 6 or 8 (overrides the format's width)
  double clock_ghz = 2.0;          // for reporting time and bandwidth in seconds and GB/s only

  // Checks every field; throws std::invalid_argument naming the first bad key and its allowed range.
  void validate() const;
};

// The field of a choice key (timing_key.h): `Member` an enum member of a part's struct whose values number the
// entries of choices(E).
template <auto Member>
ChoiceField choice_field() {
  using E = std::remove_cvref_t<decltype(std::declval<TimingConfig&>().*Member)>;
  return {[](const TimingConfig& c) { return int(c.*Member); }, [](TimingConfig& c, int v) { c.*Member = E(v); },
          [] { return choices(E{}); }};
}

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
