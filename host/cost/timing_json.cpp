#include "host/cost/timing_json.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdio>
#include <map>
#include <set>
#include <variant>

#include "host/cost/cost_model.h"
#include "host/io/error.h"
#include "rtl_sim/trav/trav_params.h"

namespace rtu::host {

Json timing_json(const hw::TimingConfig& c) {
  Json j;
  j["preset"] = c.name;
  for (const hw::TimingKey& k : hw::timing_keys(c)) {
    // The value text is an integer, a double in its round-trip form, or text (the format's name).
    const char* first = k.value.data();
    const char* last = first + k.value.size();
    long long i = 0;
    double d = 0;
    if (auto r = std::from_chars(first, last, i); !k.value.empty() && r.ec == std::errc() && r.ptr == last)
      j[k.key] = i;
    else if (auto r2 = std::from_chars(first, last, d); !k.value.empty() && r2.ec == std::errc() && r2.ptr == last)
      j[k.key] = d;
    else
      j[k.key] = k.value;
  }
  return j;
}

Json timing_stats_json(const hw::TimingStats& s, const hw::TimingConfig& c, const hw::FixedFormat& f) {
  // The report table of timing_stats.h, in its order; "a.b" is key b of object a.
  Json j;
  for (const hw::TimingStatValue& v : hw::timing_report(s, c)) {
    const std::string key = v.key;
    const size_t dot = key.find('.');
    Json& slot = dot == std::string::npos ? j[key] : j[key.substr(0, dot)][key.substr(dot + 1)];
    std::visit([&](const auto& x) { slot = x; }, v.value);
  }
  const hw::CostInputs in = cost_inputs(f, c);
  j["energy"] = energy_json(hw::energy_report(s, c, in), c, in);
  return j;
}

// The statistics in total, then by ray type (the types that ran rays) and by bounce.
Json timing_breakdown_json(const hw::TimingStats& total,
                           const std::array<hw::TimingStats, hw::cmd::kRayTypeCount>& by_type,
                           const std::map<int, hw::TimingStats>& by_bounce, const hw::TimingConfig& c,
                           const hw::FixedFormat& f) {
  Json j = timing_stats_json(total, c, f);
  Json types = Json::object();
  for (int t = 0; t < hw::cmd::kRayTypeCount; ++t)
    if (by_type[size_t(t)].rays > 0)
      types[hw::cmd::ray_type_name(hw::cmd::RayType(t))] = timing_stats_json(by_type[size_t(t)], c, f);
  j["by_ray_type"] = types;
  Json bounces = Json::object();
  for (const auto& [b, s] : by_bounce) bounces[std::to_string(b)] = timing_stats_json(s, c, f);
  j["by_bounce"] = bounces;
  return j;
}

// Per unit of a chip: what each unit did over the chip's cycles (its utilizations are of its own resources).
Json units_json(const std::vector<hw::TimingStats>& by_unit, const hw::TimingConfig& c) {
  static const std::set<std::string> keep = {"rays",
                                             "box_tests",
                                             "triangle_tests",
                                             "utilization.box_units",
                                             "utilization.triangle_units",
                                             "utilization.ray_slots",
                                             "cache.hit_rate",
                                             "l2.hit_rate",
                                             "dram_bytes",
                                             "stack_spills"};
  hw::TimingConfig one = c;
  one.units = 1;
  Json units = Json::array();
  for (const hw::TimingStats& s : by_unit) {
    Json u;
    for (const hw::TimingStatValue& v : hw::timing_report(s, one)) {
      const std::string key = v.key;
      if (keep.count(key) == 0) continue;
      const size_t dot = key.find('.');
      Json& slot = dot == std::string::npos ? u[key] : u[key.substr(0, dot)][key.substr(dot + 1)];
      std::visit([&](const auto& x) { slot = x; }, v.value);
    }
    units.push_back(u);
  }
  return units;
}

// The memory's bytes over time (memory_system.h); left out when a packet was sampled (the series would hold the
// simulated rays' traffic at their simulated cycles, not the run's).
void add_timeline(Json& j, const hw::MemoryTimeline* tl, const hw::SampleStats& sampling) {
  if (!tl || sampling.packets_sampled > 0) return;
  j["timeline"] = {{"bin_cycles", tl->bin_cycles}, {"dram_bytes", tl->dram_bytes}, {"l2_bytes", tl->l2_bytes}};
}

// Cycles over the lower bound above which the bound's terms do not name the limit: no resource it counts is
// busy more than two thirds of the time.
constexpr double kFarAboveBound = 1.5;
// A packet whose slots' fill and drain (about one mean ray lifetime per packet) is more than this share of its
// cycles is short: its rays per clock are below the unit's steady state.
constexpr double kShortPacketShare = 0.1;
// Rays a slot below which a chip's packet is short: rays per clock on rdna2-chip still rose from 3.6 to 4.5 when
// builtin:atrium's camera rays went from 102 to 205 a slot (bench/results/chip-scaling.md, "Packet size").
constexpr double kChipSteadyRaysPerSlot = 256;

namespace {

// What checks a configuration's cycles beyond the timing model's own tests: the RTL traversal unit, where it
// models every part of the configuration (rtl_sim/trav/trav_params.h, trav_refusal).
std::string checked_by(const hw::TimingConfig& c) {
  const std::string why_not = rtl::trav_refusal(c);
  if (why_not.empty())
    return "checked by: the RTL traversal unit models every part of this configuration; trace --rtl-unit runs "
           "these rays on it (one-level triangle scenes, its unit verilated: docs/guide/rtl.md) beside the model, "
           "held to it in bench/results/rtl-correlation.md";
  return "checked by: the timing model's own tests; no RTL checks these cycles, as " + why_not;
}

}  // namespace

std::vector<std::string> timing_notes(const hw::TimingStats& s, const hw::TimingConfig& c,
                                      const hw::SampleStats* sampling) {
  std::vector<std::string> notes;
  if (s.rays == 0 || s.cycles == 0) return notes;
  const hw::LowerBound b = hw::lower_bound(s, c);
  char text[600];
  const auto pct = [](double a, double whole) { return whole > 0 ? 100.0 * a / whole : 0.0; };
  const double occ = b.slot_occupancy, full = double(s.cycles) > 0 ? occ / double(s.cycles) : 0.0;
  if (occ > 0 && b.mem_queue + b.unit_queue > 0.1 * occ) {
    // Name only the memory this configuration has: an L2's ports where it has one, banks where it has them.
    const bool l2 = c.l2_kib > 0;
    const char* where =
        l2 ? (c.dram_banks > 0 ? "L2 ports, DRAM banks and channels" : "L2 ports and the DRAM channel")
           : (c.dram_banks > 0 ? "DRAM banks and channels" : "the DRAM channel");
    std::snprintf(text, sizeof text,
                  "slot time: latency %.0f%%, queued for memory %.0f%% (%s), queued for units %.0f%%; the slots "
                  "are full %.0f%% of the cycles",
                  pct(b.latency, occ), pct(b.mem_queue, occ), where, pct(b.unit_queue, occ),
                  100.0 * std::min(1.0, full));
    std::string line = text;
    if (b.mem_queue > 0.25 * occ && b.mem_queue >= b.unit_queue)
      line += l2 ? ": memory queueing holds the slots, so more L2 or DRAM bandwidth (l2_bytes_per_cycle, "
                   "l2_slices, dram_bytes_per_cycle) moves the cycles more than more ray slots do"
                 : ": memory queueing holds the slots, so more DRAM bandwidth (dram_bytes_per_cycle) "
                   "moves the cycles more than more ray slots do";
    else if (b.unit_queue > 0.25 * occ)
      line += ": rays queue for the units, so more or faster units move the cycles more than more ray slots do";
    notes.push_back(line);
  }
  if (b.cycles_over_bound > kFarAboveBound) {
    std::snprintf(text, sizeof text,
                  "warning: the cycles are %.2f times the lower bound: no resource the bound counts is busy most "
                  "of the time, so '%s' is its largest term, not the limit; %s",
                  b.cycles_over_bound, b.limited_by,
                  full < 0.7
                      ? "the ray slots are full only part of the time (fill and drain of the packet, the ray "
                        "fetch, gathering or a few long rays)"
                      : "the slots are full and their rays wait in queues the bound does not count (slot "
                        "time above)");
    notes.push_back(text);
  }
  if (s.stack_spills > 0) {
    std::snprintf(text, sizeof text, "stack: %.3f entries spilled and %.3f refilled per ray (%s)",
                  double(s.stack_spills) / double(s.rays), double(s.stack_refills) / double(s.rays),
                  c.l2_kib > 0 ? "through the L2" : "to DRAM");
    notes.push_back(text);
  }
  const double slots = double(c.ray_slots) * double(c.units);
  const double per_packet = double(s.rays) / double(std::max<uint64_t>(1, s.packets));
  const double lifetime = double(s.slot_busy_cycles) / double(s.rays);
  const double fill_drain = lifetime * double(std::max<uint64_t>(1, s.packets)) / double(s.cycles);
  if (c.units > 1 && per_packet < kChipSteadyRaysPerSlot * slots) {
    std::snprintf(
        text, sizeof text,
        "note: %.0f rays a packet for %.0f ray slots (%.1f a slot): on a chip the start of a packet (cold "
        "caches, every unit missing on the same nodes at once) and its end (the last units' tail) weigh "
        "on packets this short, so rays per clock still rise with the packet's size (rdna2-chip, "
        "builtin:atrium camera rays: 2.0 rays per clock at 26 rays a slot, 4.5 at 205); compare designs "
        "on packets of your workload's size (trace --packet-rays)",
        per_packet, slots, per_packet / slots);
    notes.push_back(text);
  } else if (fill_drain > kShortPacketShare) {
    // The rays a packet needs for fill and drain to be under 5% of its cycles at this throughput.
    const double enough = 20.0 * lifetime * double(s.rays) / double(s.cycles);
    std::snprintf(text, sizeof text,
                  "note: %.0f rays a packet for %.0f ray slots (%.1f a slot): filling and draining the slots (a "
                  "ray's mean lifetime, %.0f cycles) is about %.0f%% of the cycles, so rays per clock are below "
                  "the steady state; compare designs on packets of at least %.0f rays (trace --packet-rays)",
                  per_packet, slots, per_packet / slots, lifetime, 100.0 * std::min(1.0, fill_drain), enough);
    notes.push_back(text);
  }
  if (sampling != nullptr && sampling->packets_unthinned > 0) {
    std::snprintf(text, sizeof text,
                  "sampled: %llu of %llu packets could not be thinned and were simulated in full (their cycles "
                  "exact, not estimated); the first: ",
                  (unsigned long long)sampling->packets_unthinned, (unsigned long long)sampling->packets);
    notes.push_back(text + sampling->unthinned_why);
  }
  if (sampling != nullptr && sampling->packets_sampled > 0) {
    std::snprintf(text, sizeof text,
                  "sampled: %llu of %llu packets estimated from %.1f%% of their rays; cycles +- %.0f (95%%)",
                  (unsigned long long)sampling->packets_sampled, (unsigned long long)sampling->packets,
                  pct(double(sampling->rays_simulated), double(sampling->rays)), sampling->ci95());
    std::string line = text;
    if (c.units > 1)
      line += "; the estimate is of ray_policy " + std::string(hw::name_of(c.ray_policy)) +
              " (sampled chips need it): a full run under another policy (the chip presets' is waves) differs "
              "by its policy too";
    notes.push_back(line);
    if (sampling->rays_simulated >= sampling->rays) {
      std::snprintf(text, sizeof text,
                    "warning: sampled timing simulated %llu rays for packets of %llu (its warm-up): a full run "
                    "would cost no more and be exact; shorten --sample-warmup or drop --sample",
                    (unsigned long long)sampling->rays_simulated, (unsigned long long)sampling->rays);
      notes.push_back(text);
    }
    // The bound is estimated from the same sample, so only an estimate below it by more than the interval says
    // the sample does not stand for the packet.
    if (double(s.cycles) + sampling->ci95() < b.cycles) {
      std::snprintf(text, sizeof text,
                    "warning: the sampled estimate (%llu +- %.0f cycles) is below its own lower bound (%.0f "
                    "cycles): the sample does not stand for the packet (too few measured rays, or a warm-up that "
                    "outweighs them); use a larger --sample or a shorter --sample-warmup",
                    (unsigned long long)s.cycles, sampling->ci95(), b.cycles);
      notes.push_back(text);
    }
  }
  notes.push_back(checked_by(c));
  return notes;
}

Json timed_json(const hw::TimedEngine& e) {
  Json j = timing_breakdown_json(e.timing(), e.timing_by_type(), e.timing_by_bounce(), e.config(), e.format());
  j["notes"] = timing_notes(e.timing(), e.config(), &e.sampling());
  if (!e.timing_by_unit().empty()) j["units"] = units_json(e.timing_by_unit(), e.config());
  add_timeline(j, e.timeline(), e.sampling());
  j["config"] = timing_json(e.config());
  j["sample"] = sample_json(e.sampling());
  return j;
}

Json sample_json(const hw::SampleStats& s) {
  Json j;
  j["packets"] = s.packets;
  j["packets_sampled"] = s.packets_sampled;
  j["rays"] = s.rays;
  j["rays_simulated"] = s.rays_simulated;
  j["rays_warmed"] = s.rays_warmed;
  j["simulated_fraction"] = s.rays > 0 ? double(s.rays_simulated) / double(s.rays) : 0.0;
  j["units_measured"] = s.units_measured;
  j["warmup_rays_mean"] = s.units_measured > 0 ? double(s.warmup_rays) / double(s.units_measured) : 0.0;
  j["packets_stratified"] = s.packets_stratified;
  j["packets_unthinned"] = s.packets_unthinned;
  j["unthinned_why"] = s.unthinned_why;
  j["cycles_ci95"] = s.ci95();
  return j;
}

}  // namespace rtu::host
