#include "hwmodel/timing/timing_stats.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

namespace rtu::hw {

namespace {

using S = TimingStats;
// Every counter: one row a part, in the order of TimingStats's parts.
std::vector<TimingCounter> make_counters() {
  const std::span<const TimingCounter> parts[] = {
      command_counters(),   unit_counters(),   fetch_counters(),          prefetch_counters(),
      l2_counters(),        dram_counters(),   stack_counters(),          slot_counters(),
      scheduler_counters(), gather_counters(), dram_scheduler_counters(),
  };
  std::vector<TimingCounter> all;
  for (std::span<const TimingCounter> part : parts) all.insert(all.end(), part.begin(), part.end());
  if (all.size() * sizeof(uint64_t) != sizeof(TimingStats))
    throw std::logic_error("a part of TimingStats is missing from the counter tables");
  return all;
}
const std::vector<TimingCounter>& counters() {
  static const std::vector<TimingCounter> all = make_counters();
  return all;
}

const TimingCounter& counter(uint64_t S::*member) {
  for (const TimingCounter& c : counters())
    if (c.member == member) return c;
  throw std::logic_error("a TimingStats counter missing from its part's table");
}

double ratio(double a, double b) {
  return b > 0 ? a / b : 0.0;
}

// The report: a counter shown under its own unit and description, or a figure derived from the counters and the
// configuration.
using Value = std::variant<uint64_t, double, std::string>;
struct ReportEntry {
  const char* key;
  uint64_t S::*member;  // a counter (the figure fields below unused)
  const char* unit;
  const char* description;
  Value (*figure)(const S&, const TimingConfig&, const LowerBound&);
};

// Figures of two counters: a / b, and hits / (hits + misses); 0 when the denominator is.
template <auto A, auto B>  // pointers to counters (of TimingStats's parts)
Value quotient(const S& s, const TimingConfig&, const LowerBound&) {
  return ratio(double(s.*A), double(s.*B));
}
template <auto Hits, auto Misses>
Value hit_rate(const S& s, const TimingConfig&, const LowerBound&) {
  return ratio(double(s.*Hits), double(s.*Hits + s.*Misses));
}

ReportEntry count(const char* key, uint64_t S::*member) {
  const TimingCounter& c = counter(member);
  return {key, member, c.unit, c.description, nullptr};
}
ReportEntry figure(const char* key, const char* unit, const char* description,
                   Value (*f)(const S&, const TimingConfig&, const LowerBound&)) {
  return {key, nullptr, unit, description, f};
}

// The packet: cycles, rays and their rates.
std::vector<ReportEntry> report_rays() {
  using C = TimingConfig;
  return {
      count("cycles", &S::cycles),
      count("packets", &S::packets),
      count("rays", &S::rays),
      figure("cycles_per_ray", "cycles/ray", "cycles / rays", quotient<&S::cycles, &S::rays>),
      figure("rays_per_clock", "rays/cycle", "rays / cycles", quotient<&S::rays, &S::cycles>),
      figure("seconds_at_clock", "s", "cycles at clock_ghz",
             [](const S& s, const C& c, const LowerBound&) -> Value {
               return double(s.cycles) / (c.clock_ghz * 1e9);
             }),
  };
}

// The test units: tests and how busy the units, DRAM and slots were.
std::vector<ReportEntry> report_units() {
  using C = TimingConfig;
  return {
      count("box_tests", &S::box_tests),
      count("triangle_tests", &S::tri_tests),
      count("sphere_tests", &S::sphere_tests),
      count("plane_tests", &S::plane_tests),
      count("curve_tests", &S::curve_tests),
      figure("utilization.box_units", "1", "box unit issue clocks used / (cycles x box_units x units)",
             [](const S& s, const C& c, const LowerBound&) -> Value {
               return s.cycles > 0 ? double(s.box_issue_cycles) / (double(s.cycles) * c.box_units * c.units) : 0.0;
             }),
      figure("utilization.triangle_units", "1",
             "triangle unit issue slots used / (cycles x tri_units x tri_rate x units)",
             [](const S& s, const C& c, const LowerBound&) -> Value {
               return s.cycles > 0
                          ? double(s.tri_issue_cycles) / (double(s.cycles) * c.tri_units * c.tri_rate * c.units)
                          : 0.0;
             }),
      figure("utilization.dram", "1", "DRAM channel busy cycles / (cycles x channels)",
             [](const S& s, const C& c, const LowerBound&) -> Value {
               return ratio(double(s.dram_busy_cycles), double(s.cycles) * c.dram_channels);
             }),
      figure("utilization.ray_slots", "1", "slot busy cycles / (cycles x ray_slots x units)",
             [](const S& s, const C& c, const LowerBound&) -> Value {
               return s.cycles > 0 ? double(s.slot_busy_cycles) / (double(s.cycles) * c.ray_slots * c.units) : 0.0;
             }),
  };
}

// The node cache, its prefetcher and the L2.
std::vector<ReportEntry> report_caches() {
  using C = TimingConfig;
  return {
      figure("cache.line_accesses", "lines", "cache line accesses (hits + misses)",
             [](const S& s, const C&, const LowerBound&) -> Value { return s.cache_hits + s.cache_misses; }),
      count("cache.hits", &S::cache_hits),
      count("cache.misses", &S::cache_misses),
      figure("cache.hit_rate", "1", "hits / line accesses", hit_rate<&S::cache_hits, &S::cache_misses>),
      count("omm_cache.hits", &S::omm_cache_hits),
      count("omm_cache.misses", &S::omm_cache_misses),
      figure("omm_cache.hit_rate", "1", "micromap cache hits / its line accesses; 0 without one",
             hit_rate<&S::omm_cache_hits, &S::omm_cache_misses>),
      count("prefetch.fills", &S::prefetch_fills),
      count("prefetch.redundant", &S::prefetch_redundant),
      count("prefetch.useful", &S::prefetch_useful),
      count("prefetch.dropped", &S::prefetch_dropped),
      count("prefetch.late", &S::prefetch_late),
      count("prefetch.unused", &S::prefetch_unused),
      figure("prefetch.accuracy", "1", "useful / fills; 0 without fills",
             quotient<&S::prefetch_useful, &S::prefetch_fills>),
      figure("prefetch.coverage", "1",
             "useful / (useful + cache misses): the share of would-be misses the prefetches removed",
             hit_rate<&S::prefetch_useful, &S::cache_misses>),
      count("l2.hits", &S::l2_hits),
      count("l2.misses", &S::l2_misses),
      figure("l2.hit_rate", "1", "L2 hits / (hits + misses); 0 without an L2",
             hit_rate<&S::l2_hits, &S::l2_misses>),
      count("l2.stack_hits", &S::l2_stack_hits),
      count("l2.stack_misses", &S::l2_stack_misses),
      count("l2.writebacks", &S::l2_writebacks),
      count("l2.port_cycles", &S::l2_port_cycles),
  };
}

// Fetches, DRAM, the stack and the waits of rays in their slots; gathering.
std::vector<ReportEntry> report_memory() {
  using C = TimingConfig;
  return {
      count("node_fetches", &S::node_fetches),
      count("prim_fetches", &S::prim_fetches),
      count("dram_bytes", &S::dram_bytes),
      figure("dram_bytes_per_cycle", "bytes/cycle", "DRAM bytes / cycles", quotient<&S::dram_bytes, &S::cycles>),
      figure("dram_gb_per_s", "GB/s", "DRAM bytes / cycles at clock_ghz",
             [](const S& s, const C& c, const LowerBound&) -> Value {
               return s.cycles > 0 ? double(s.dram_bytes) / double(s.cycles) * c.clock_ghz : 0.0;
             }),
      count("dram_rows.hits", &S::dram_row_hits),
      count("dram_rows.misses", &S::dram_row_misses),
      figure("dram_rows.hit_rate", "1", "DRAM row hits / accesses; 0 without banks",
             hit_rate<&S::dram_row_hits, &S::dram_row_misses>),
      count("stream_bytes", &S::stream_bytes),
      count("stack_spills", &S::stack_spills),
      count("stack_refills", &S::stack_refills),
      count("restarts", &S::restarts),
      count("restart_nodes", &S::restart_nodes),
      count("queue_stall_cycles", &S::queue_stall_cycles),
      count("any_hit_requests", &S::any_hit_requests),
      count("tri_pairs", &S::tri_pairs),
      count("obb_rotations", &S::obb_rotations),
      count("cluster.box_tests", &S::cluster_box_tests),
      count("cluster.tri_tests", &S::cluster_tri_tests),
      count("cluster.requests", &S::cluster_requests),
      count("instance_transforms", &S::instance_transforms),
      count("unit_wait_cycles", &S::unit_wait_cycles),
      count("mem_wait_cycles", &S::mem_wait_cycles),
      count("dram_sched.reordered", &S::dram_reordered),
      count("dram_sched.capped", &S::dram_capped),
      count("gather.bins", &S::gather_bins),
      count("gather.full", &S::gather_bins_full),
      count("gather.timeout", &S::gather_bins_timeout),
      figure("gather.rays_per_bin", "rays", "rays / bins issued; 0 without gathering",
             quotient<&S::rays, &S::gather_bins>),
      figure("gather.wait_per_ray", "cycles", "cycles a ray waited in its bin, mean; 0 without gathering",
             [](const S& s, const C&, const LowerBound&) -> Value {
               return s.gather_bins > 0 ? ratio(double(s.gather_wait_cycles), double(s.rays)) : 0.0;
             }),
  };
}

// The lower bound and where the slots' time went.
std::vector<ReportEntry> report_bounds() {
  using C = TimingConfig;
  return {
      figure("lower_bound.cycles", "cycles",
             "the largest of the ray fetch, box, triangle, curve, DRAM, L2 and latency bounds",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.cycles; }),
      figure("lower_bound.fetch", "cycles",
             "rays / (1 per clock x units) (each unit's ray fetch and setup issue one ray a clock)",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.fetch; }),
      figure("lower_bound.box", "cycles", "box unit issue clocks / (box_units x units)",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.box; }),
      figure("lower_bound.triangle", "cycles",
             "triangle, sphere and plane tests (and curve slots without curve units) / (tri_rate x tri_units x "
             "units)",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.triangle; }),
      figure("lower_bound.curve", "cycles",
             "curve tests / (curve_rate x curve_units x units); 0 without curve units",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.curve; }),
      figure("lower_bound.dram", "cycles", "DRAM bytes / dram_bytes_per_cycle",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.dram; }),
      figure("lower_bound.l2", "cycles",
             "L2 port clocks / l2_slices (line and stack word accesses); 0 without an L2",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.l2; }),
      figure("lower_bound.latency", "cycles",
             "(slot busy cycles - unit and memory waits) / (ray_slots x units): rays x mean lifetime / rays in "
             "flight (Little's law)",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.latency; }),
      figure("lower_bound.limited_by", "",
             "which bound is the largest: fetch, box, triangle, curve, dram, l2 or latency",
             [](const S&, const C&, const LowerBound& b) -> Value { return std::string(b.limited_by); }),
      figure("lower_bound.cycles_over_bound", "1", "simulated cycles / lower bound",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.cycles_over_bound; }),
      figure("queueing.slot_occupancy", "cycles",
             "slot busy cycles / (ray_slots x units): the cycles if every slot were always full",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.slot_occupancy; }),
      figure("queueing.units", "cycles", "unit_wait_cycles / (ray_slots x units): slot time queued for busy units",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.unit_queue; }),
      figure("queueing.memory", "cycles",
             "mem_wait_cycles / (ray_slots x units): slot time queued for busy L2 ports, DRAM banks and channels",
             [](const S&, const C&, const LowerBound& b) -> Value { return b.mem_queue; }),
  };
}

// The report: the sections in the stats JSON's order.
const std::vector<ReportEntry>& report_table() {
  static const std::vector<ReportEntry> table = [] {
    std::vector<ReportEntry> all;
    for (auto section : {report_rays, report_units, report_caches, report_memory, report_bounds}) {
      const std::vector<ReportEntry> part = section();
      all.insert(all.end(), part.begin(), part.end());
    }
    return all;
  }();
  return table;
}

}  // namespace

std::span<const TimingCounter> timing_counters() {
  return counters();
}

void TimingStats::add(const TimingStats& o) {
  for (const TimingCounter& c : counters()) this->*c.member += o.*c.member;
}

void scale_sampled(TimingStats& s, double factor) {
  for (const TimingCounter& c : counters())
    if (c.scale == SampleScale::kPerRay) s.*c.member = uint64_t(std::llround(double(s.*c.member) * factor));
}

LowerBound lower_bound(const TimingStats& s, const TimingConfig& c) {
  LowerBound b;
  // On a chip every unit has its own ray fetch, box and triangle units (units = 1: the single unit).
  const double units = double(c.units);
  b.fetch = double(s.rays) / units;
  b.box = double(s.box_issue_cycles) / (double(c.box_units) * units);
  const uint64_t curve_slots = c.curve_units == 0 ? s.curve_tests * uint64_t(c.curve_issue) : 0;
  b.triangle = double(s.tri_tests + s.sphere_tests + s.plane_tests + curve_slots) /
               (double(c.tri_rate * c.tri_units) * units);
  if (c.curve_units > 0) b.curve = double(s.curve_tests) / (double(c.curve_rate * c.curve_units) * units);
  b.dram = double(s.dram_bytes) / c.dram_bytes_per_cycle;
  if (c.l2_kib > 0) b.l2 = double(s.l2_port_cycles) / double(std::max(1, c.l2_slices));
  const uint64_t waits = s.unit_wait_cycles + s.mem_wait_cycles;
  const double slots = double(c.ray_slots) * units;
  b.latency = double(s.slot_busy_cycles > waits ? s.slot_busy_cycles - waits : 0) / slots;
  b.unit_queue = double(s.unit_wait_cycles) / slots;
  b.mem_queue = double(s.mem_wait_cycles) / slots;
  b.slot_occupancy = double(s.slot_busy_cycles) / slots;
  b.cycles = std::max({b.fetch, b.box, b.triangle, b.curve, b.dram, b.l2, b.latency});
  b.limited_by = b.cycles == b.box        ? "box"
                 : b.cycles == b.triangle ? "triangle"
                 : b.cycles == b.curve    ? "curve"
                 : b.cycles == b.dram     ? "dram"
                 : b.cycles == b.l2       ? "l2"
                 : b.cycles == b.fetch    ? "fetch"
                                          : "latency";
  b.cycles_over_bound = b.cycles > 0 ? double(s.cycles) / b.cycles : 0.0;
  return b;
}

std::vector<TimingStatValue> timing_report(const TimingStats& s, const TimingConfig& c) {
  std::vector<TimingStatValue> out;
  out.reserve(report_table().size());
  const LowerBound b = lower_bound(s, c);
  for (const ReportEntry& e : report_table())
    out.push_back({e.key, e.unit, e.description, e.member ? Value(s.*e.member) : e.figure(s, c, b)});
  return out;
}

std::vector<TimingStatValue> timing_report_keys() {
  std::vector<TimingStatValue> out;
  for (const ReportEntry& e : report_table()) out.push_back({e.key, e.unit, e.description, uint64_t(0)});
  return out;
}

}  // namespace rtu::hw
