// A timed run's figures as JSON, as rtusim writes them (--stats, --json, report.json): the timing configuration,
// what the run measured with its lower bound and notes, and its area and energy priced for the run's format
// (cost_model.h). Here rather than in host/io/stats_json.h because the price needs the cost tables: io stays below
// cost (docs/architecture.md).
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

#include "host/io/stats_json.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

// {"preset": name, key: value, ...} in timing_keys() order: numbers as JSON numbers, text as strings.
Json timing_json(const hw::TimingConfig& c);
// What a timed run measured: cycles, cycles per ray, rays per clock, unit utilization, cache and DRAM figures,
// stack spills, queue stalls, and the lower bound max(box tests / box rate, triangle tests / triangle rate,
// DRAM bytes / bandwidth) with the cycles divided by it.
// The energy and area are priced for the run's format `f` (cost_model.h).
Json timing_stats_json(const hw::TimingStats& s, const hw::TimingConfig& c, const hw::FixedFormat& f);
// The timed engine's statistics in total, by ray type and by bounce, with its configuration, and the notes of
// timing_notes ("notes", a list of text).
Json timed_json(const hw::TimedEngine& e);
// What a reader of a timed run's figures should know, one sentence each (the summary prints them, the stats JSON
// lists them under "notes"): where the ray slots' time went when rays queued; a warning when the cycles are far
// above the lower bound (its terms then do not name the limit); stack spills; a short packet (the slots' fill and
// drain a large part of the cycles); for sampled timing its interval, on a chip the ray policy the estimate is
// of, and a warning for an estimate below its own lower bound. `sampling` may be null (no sampled timing).
std::vector<std::string> timing_notes(const hw::TimingStats& s, const hw::TimingConfig& c,
                                      const hw::SampleStats* sampling);
// What sampled timing simulated (hw::SampleStats), with the 95% interval of the cycles.
Json sample_json(const hw::SampleStats& s);
// The statistics in total (timing_stats_json), then by ray type (the types that ran rays) and by bounce.
Json timing_breakdown_json(const hw::TimingStats& total,
                           const std::array<hw::TimingStats, hw::cmd::kRayTypeCount>& by_type,
                           const std::map<int, hw::TimingStats>& by_bounce, const hw::TimingConfig& c,
                           const hw::FixedFormat& f);
// Per unit of a chip: what each unit did over the chip's cycles (its utilizations are of its own resources).
Json units_json(const std::vector<hw::TimingStats>& by_unit, const hw::TimingConfig& c);
// Adds the memory's bytes over time (memory_system.h) to j as "timeline"; nothing when tl is null or a packet was
// sampled (the series would hold the simulated rays' traffic at their simulated cycles, not the run's).
void add_timeline(Json& j, const hw::MemoryTimeline* tl, const hw::SampleStats& sampling);

}  // namespace rtu::host
