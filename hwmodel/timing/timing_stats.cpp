#include "hwmodel/timing/timing_stats.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "hwmodel/timing/memory/dram_scheduler.h"
#include "hwmodel/timing/prefetch/prefetchers.h"
#include "hwmodel/timing/ray_gather.h"

namespace rtu::hw {

namespace {

using S = TimingStats;
constexpr SampleScale kPacket = SampleScale::kPacket, kPerRay = SampleScale::kPerRay;

// The unit's own counters, in the order of the struct, with a component's gathered from its header where its
// members sit.
constexpr std::array<TimingCounter, 14> kBeforePrefetch = {{
    {"packets", &S::packets, "packets", "TRACE packets simulated", kPacket},
    {"cycles", &S::cycles, "cycles", "cycles of those packets, from decode to the last hit written", kPacket},
    {"rays", &S::rays, "rays", "rays through the ray slots (rays rejected at setup included)", kPacket},
    {"box_tests", &S::box_tests, "tests", "ray-box tests (one per child of a node visited)", kPerRay},
    {"tri_tests", &S::tri_tests, "tests", "ray-triangle tests", kPerRay},
    {"sphere_tests", &S::sphere_tests, "tests", "ray-sphere tests (in the triangle units' issue slots)", kPerRay},
    {"plane_tests", &S::plane_tests, "tests", "ray-plane tests (in the triangle units' issue slots)", kPerRay},
    {"curve_tests", &S::curve_tests, "tests",
     "ray-curve segment tests (curve units, or curve_issue triangle unit clocks each without them)", kPerRay},
    {"box_issue_cycles", &S::box_issue_cycles, "unit clocks",
     "box unit issue clocks used, summed over the units (ceil(children / box_rate) per node)", kPerRay},
    {"tri_issue_cycles", &S::tri_issue_cycles, "unit clocks",
     "triangle unit issue slots used (one per triangle, sphere or plane test)", kPerRay},
    {"node_fetches", &S::node_fetches, "fetches", "node fetches (each one or more cache lines)", kPerRay},
    {"prim_fetches", &S::prim_fetches, "fetches", "primitive record and plane fetches", kPerRay},
    {"cache_hits", &S::cache_hits, "lines", "cache line accesses that hit (a line in flight counts as a hit)",
     kPerRay},
    {"cache_misses", &S::cache_misses, "lines", "cache line accesses that missed and went to DRAM", kPerRay},
}};
constexpr std::array<TimingCounter, 26> kAfterPrefetch = {{
    {"l2_hits", &S::l2_hits, "lines", "node cache fills found in the L2 (with l2_kib > 0)", kPerRay},
    {"l2_misses", &S::l2_misses, "lines", "node cache fills the L2 missed (read from DRAM)", kPerRay},
    {"l2_stack_hits", &S::l2_stack_hits, "words", "stack spills and refills whose line was in the L2", kPerRay},
    {"l2_stack_misses", &S::l2_stack_misses, "words",
     "stack spills that allocated their line in the L2, and refills that read it from DRAM", kPerRay},
    {"l2_writebacks", &S::l2_writebacks, "lines", "dirty L2 lines (spilled stack words) written back to DRAM",
     kPerRay},
    {"l2_port_cycles", &S::l2_port_cycles, "port clocks",
     "clocks the L2 slices' ports were held, summed over the slices (line and stack word accesses)", kPerRay},
    {"dram_bytes", &S::dram_bytes, "bytes",
     "bytes moved over the DRAM channel (line fills, stack spills and refills past any L2, L2 write-backs)",
     kPerRay},
    {"dram_busy_cycles", &S::dram_busy_cycles, "cycles", "cycles the DRAM channel spent transferring", kPerRay},
    {"dram_row_hits", &S::dram_row_hits, "accesses", "DRAM accesses to the bank's open row (with dram_banks > 0)",
     kPerRay},
    {"dram_row_misses", &S::dram_row_misses, "accesses",
     "DRAM accesses that opened a row (empty bank or another row open; with dram_banks > 0)", kPerRay},
    {"stream_bytes", &S::stream_bytes, "bytes", "ray buffer reads and hit buffer writes (their own port)",
     kPerRay},
    {"stack_spills", &S::stack_spills, "entries", "stack entries beyond the short stack written to memory",
     kPerRay},
    {"stack_refills", &S::stack_refills, "entries", "spilled stack entries read back", kPerRay},
    {"restarts", &S::restarts, "restarts",
     "stack_mode restart: pops of a dropped entry, each a restart from the root along the trail", kPerRay},
    {"restart_nodes", &S::restart_nodes, "nodes",
     "stack_mode restart: nodes fetched and tested again by restarts (in node_fetches and box_tests too)",
     kPerRay},
    {"queue_stall_cycles", &S::queue_stall_cycles, "cycles",
     "cycles unit requests waited beyond queue_depth for a free unit", kPerRay},
    {"slot_busy_cycles", &S::slot_busy_cycles, "cycles",
     "sum over rays of the cycles from entering a ray slot to leaving it", kPerRay},
    {"any_hit_requests", &S::any_hit_requests, "requests",
     "candidate hits on non-opaque triangles sent to the any-hit stage (each waits any_hit_latency)", kPerRay},
    {"tri_pairs", &S::tri_pairs, "requests",
     "triangle pairs (format tri_pairs) fetched and tested as one request; their two tests are in tri_tests",
     kPerRay},
    {"obb_rotations", &S::obb_rotations, "nodes",
     "oriented nodes: rays turned into a node's frame, one per oriented node test (each adds obb_latency)",
     kPerRay},
    {"cluster_box_tests", &S::cluster_box_tests, "tests",
     "triangle clusters: box tests of clusters' internal nodes by the cluster engine (not in box_tests)", kPerRay},
    {"cluster_tri_tests", &S::cluster_tri_tests, "tests",
     "triangle clusters: triangle tests by the cluster engine (not in tri_tests)", kPerRay},
    {"cluster_requests", &S::cluster_requests, "requests",
     "triangle clusters: requests to the cluster engine (an internal node, or a leaf's triangles)", kPerRay},
    {"instance_transforms", &S::instance_transforms, "rays",
     "two-level scenes: rays transformed into an instance's bottom level (each waits xform_latency)", kPerRay},
    {"unit_wait_cycles", &S::unit_wait_cycles, "cycles",
     "cycles box, triangle, sphere and plane requests waited for a free unit", kPerRay},
    {"mem_wait_cycles", &S::mem_wait_cycles, "cycles",
     "cycles line and stack reads waited for a busy L2 slice port, DRAM bank or channel (not rows opening, not "
     "the latency itself)",
     kPerRay},
}};

template <size_t... N>
constexpr std::array<TimingCounter, (N + ...)> join(const std::array<TimingCounter, N>&... parts) {
  std::array<TimingCounter, (N + ...)> out{};
  size_t i = 0;
  ((std::copy(parts.begin(), parts.end(), out.begin() + i), i += parts.size()), ...);
  return out;
}
constexpr auto kCounters =
    join(kBeforePrefetch, kPrefetchCounters, kAfterPrefetch, kGatherCounters, kDramSchedulerCounters);
static_assert(sizeof(TimingStats) == kCounters.size() * sizeof(uint64_t), "a counter is missing from the table");

const TimingCounter& counter(uint64_t S::*member) {
  for (const TimingCounter& c : kCounters)
    if (c.member == member) return c;
  return kCounters[0];  // unreachable: every member is in the table (the static_assert above)
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

ReportEntry count(const char* key, uint64_t S::*member) {
  const TimingCounter& c = counter(member);
  return {key, member, c.unit, c.description, nullptr};
}
ReportEntry figure(const char* key, const char* unit, const char* description,
                   Value (*f)(const S&, const TimingConfig&, const LowerBound&)) {
  return {key, nullptr, unit, description, f};
}

const std::vector<ReportEntry>& report_table() {
  using C = TimingConfig;
  static const std::vector<ReportEntry> table = {
      count("cycles", &S::cycles),
      count("packets", &S::packets),
      count("rays", &S::rays),
      figure("cycles_per_ray", "cycles/ray", "cycles / rays",
             [](const S& s, const C&, const LowerBound&) -> Value {
               return ratio(double(s.cycles), double(s.rays));
             }),
      figure("rays_per_clock", "rays/cycle", "rays / cycles",
             [](const S& s, const C&, const LowerBound&) -> Value {
               return ratio(double(s.rays), double(s.cycles));
             }),
      figure("seconds_at_clock", "s", "cycles at clock_ghz",
             [](const S& s, const C& c, const LowerBound&) -> Value {
               return double(s.cycles) / (c.clock_ghz * 1e9);
             }),
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
      figure("cache.line_accesses", "lines", "cache line accesses (hits + misses)",
             [](const S& s, const C&, const LowerBound&) -> Value { return s.cache_hits + s.cache_misses; }),
      count("cache.hits", &S::cache_hits),
      count("cache.misses", &S::cache_misses),
      figure("cache.hit_rate", "1", "hits / line accesses",
             [](const S& s, const C&, const LowerBound&) -> Value {
               return ratio(double(s.cache_hits), double(s.cache_hits + s.cache_misses));
             }),
      count("prefetch.fills", &S::prefetch_fills),
      count("prefetch.redundant", &S::prefetch_redundant),
      count("prefetch.useful", &S::prefetch_useful),
      count("prefetch.dropped", &S::prefetch_dropped),
      count("prefetch.late", &S::prefetch_late),
      count("prefetch.unused", &S::prefetch_unused),
      figure("prefetch.accuracy", "1", "useful / fills; 0 without fills",
             [](const S& s, const C&, const LowerBound&) -> Value {
               return ratio(double(s.prefetch_useful), double(s.prefetch_fills));
             }),
      figure("prefetch.coverage", "1",
             "useful / (useful + cache misses): the share of would-be misses the prefetches removed",
             [](const S& s, const C&, const LowerBound&) -> Value {
               return ratio(double(s.prefetch_useful), double(s.prefetch_useful + s.cache_misses));
             }),
      count("l2.hits", &S::l2_hits),
      count("l2.misses", &S::l2_misses),
      figure("l2.hit_rate", "1", "L2 hits / (hits + misses); 0 without an L2",
             [](const S& s, const C&, const LowerBound&) -> Value {
               return ratio(double(s.l2_hits), double(s.l2_hits + s.l2_misses));
             }),
      count("l2.stack_hits", &S::l2_stack_hits),
      count("l2.stack_misses", &S::l2_stack_misses),
      count("l2.writebacks", &S::l2_writebacks),
      count("l2.port_cycles", &S::l2_port_cycles),
      count("node_fetches", &S::node_fetches),
      count("prim_fetches", &S::prim_fetches),
      count("dram_bytes", &S::dram_bytes),
      figure("dram_bytes_per_cycle", "bytes/cycle", "DRAM bytes / cycles",
             [](const S& s, const C&, const LowerBound&) -> Value {
               return ratio(double(s.dram_bytes), double(s.cycles));
             }),
      figure("dram_gb_per_s", "GB/s", "DRAM bytes / cycles at clock_ghz",
             [](const S& s, const C& c, const LowerBound&) -> Value {
               return s.cycles > 0 ? double(s.dram_bytes) / double(s.cycles) * c.clock_ghz : 0.0;
             }),
      count("dram_rows.hits", &S::dram_row_hits),
      count("dram_rows.misses", &S::dram_row_misses),
      figure("dram_rows.hit_rate", "1", "DRAM row hits / accesses; 0 without banks",
             [](const S& s, const C&, const LowerBound&) -> Value {
               return ratio(double(s.dram_row_hits), double(s.dram_row_hits + s.dram_row_misses));
             }),
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
             [](const S& s, const C&, const LowerBound&) -> Value {
               return ratio(double(s.rays), double(s.gather_bins));
             }),
      figure("gather.wait_per_ray", "cycles", "cycles a ray waited in its bin, mean; 0 without gathering",
             [](const S& s, const C&, const LowerBound&) -> Value {
               return s.gather_bins > 0 ? ratio(double(s.gather_wait_cycles), double(s.rays)) : 0.0;
             }),
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
  return table;
}

}  // namespace

std::span<const TimingCounter> timing_counters() {
  return kCounters;
}

void TimingStats::add(const TimingStats& o) {
  for (const TimingCounter& c : kCounters) this->*c.member += o.*c.member;
}

void scale_sampled(TimingStats& s, double factor) {
  for (const TimingCounter& c : kCounters)
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
