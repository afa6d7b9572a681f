#include "hwmodel/cost/energy_model.h"

#include <array>
#include <cmath>
#include <stdexcept>
#include <string_view>

namespace rtu::hw {

const Technology& nangate45() {
  static const Technology t;
  return t;
}

namespace {

// Per bit moved at the device (core and I/O). GDDR6 and HBM2E: the vendors' average device power in pJ/bit as
// tabulated for GDDR6 / GDDR6X / HBM2E systems (7.5 / 7.25 / 6.0); HBM2: O'Connor et al., "Fine-Grained DRAM",
// MICRO 2017 (3.9 pJ/bit). LPDDR5: no primary figure was found; 4.0 is our assumption between HBM2 and GDDR6 (its
// 0.5 V I/O), stated as such in docs/energy-model.md.
constexpr std::array<MemoryType, 3> kMemoryTypes = {{
    {"gddr6", 7.5, "GDDR6 average device power, vendor table (GDDR6 7.5, GDDR6X 7.25, HBM2E 6.0 pJ/bit)"},
    {"hbm2", 3.9, "O'Connor et al., Fine-Grained DRAM, MICRO 2017: HBM2 3.9 pJ/bit"},
    {"lpddr5", 4.0, "assumption (no primary source found): between HBM2 3.9 and GDDR6 7.5 pJ/bit"},
}};

constexpr bool same_order() {  // kMemoryTypes prices the memory_type key's choices in their order
  if (std::size(kMemoryTypes) != std::size(kDramTypes)) return false;
  for (size_t i = 0; i < std::size(kMemoryTypes); ++i)
    if (std::string_view(kMemoryTypes[i].name) != kDramTypes[i].name) return false;
  return true;
}
static_assert(same_order(),
              "kMemoryTypes and kDramTypes (timing/parts/memory.h) must list the same types in order");

}  // namespace

std::span<const MemoryType> memory_types() {
  return kMemoryTypes;
}

const MemoryType& memory_type(DramType type) {
  return kMemoryTypes[size_t(type)];
}

const MemoryType& memory_type(const std::string& name) {
  for (const MemoryType& m : kMemoryTypes)
    if (name == m.name) return m;
  throw std::invalid_argument("unknown memory type '" + name + "' (known: gddr6, hbm2, lpddr5)");
}

double sram_read64_pj(double bytes, const Technology& t) {
  // log E = log E_i + slope * (log bytes - log bytes_i) on the segment of Horowitz's points nearest to `bytes`.
  const double k8 = 8.0 * 1024, k32 = 32.0 * 1024, m1 = 1024.0 * 1024;
  const double b = bytes > 1.0 ? bytes : 1.0;
  if (b <= k32) {
    const double slope = std::log(t.sram_pj_32k / t.sram_pj_8k) / std::log(k32 / k8);
    return t.sram_pj_8k * std::pow(b / k8, slope);
  }
  const double slope = std::log(t.sram_pj_1m / t.sram_pj_32k) / std::log(m1 / k32);
  return t.sram_pj_32k * std::pow(b / k32, slope);
}

double sram_access_pj(double bytes, int access_bytes, const Technology& t) {
  return sram_read64_pj(bytes, t) * std::ceil(double(access_bytes) / 8.0);
}

double sram_area_mm2(double bits, const Technology& t) {
  return bits * t.sram_bit_um2 / t.sram_efficiency * 1e-6;
}

double logic_area_mm2(double nand2_eq, const Technology& t) {
  return nand2_eq * t.nand2_um2 / t.utilization * 1e-6;
}

double cache_sram_bits(const TimingConfig& c) {
  if (c.cache_kib <= 0) return 0.0;
  // The prefetch buffer's lines are cache lines with full tags beside it.
  const double lines = double(c.cache_kib) * 1024.0 / double(c.line_bytes) + double(c.prefetch_buffer);
  return lines * (double(c.line_bytes) * 8.0 + 33.0);
}

// The ray queue, or with gathering the gather buffer that takes its place (rays and their bin keys).
static double ray_queue_bytes(const TimingConfig& c) {
  return c.gather != GatherKey::kNone ? double(c.gather_buffer) * (kQueueRayBytes + kGatherKeyBytes)
                                      : double(c.queue_depth) * kQueueRayBytes;
}

double slot_sram_bits(const TimingConfig& c, const CostInputs& in) {
  const double trail = c.stack_mode == StackMode::kRestart ? 8.0 * kTrailBytes : 0.0;
  return double(c.ray_slots) * (in.slot_state_bits + in.stack_entry_bits * c.stack_entries + trail) +
         8.0 * (ray_queue_bytes(c) + double(c.prefetch_queue) * kPrefetchEntryBytes);
}

double l2_sram_bits(const TimingConfig& c) {
  if (c.l2_kib <= 0) return 0.0;
  const double lines = double(c.l2_kib) * 1024.0 / double(c.line_bytes);
  return lines * (double(c.line_bytes) * 8.0 + 33.0);
}

AreaReport area_report(const TimingConfig& c, const CostInputs& in, const Technology& t) {
  AreaReport a;
  const double units = double(c.units);  // a chip: every unit has its own units, cache and slots
  const double box_ge = in.box.nand2_eq + in.rotate.nand2_eq;  // a box unit and its rotation stage
  a.logic_nand2_eq = units * (c.box_units * box_ge + c.tri_units * in.tri.nand2_eq +
                              c.curve_units * c.curve_rate * in.curve.nand2_eq);
  a.box_mm2 = logic_area_mm2(units * c.box_units * box_ge, t);
  a.tri_mm2 = logic_area_mm2(units * c.tri_units * in.tri.nand2_eq, t);
  a.curve_mm2 = logic_area_mm2(units * c.curve_units * c.curve_rate * in.curve.nand2_eq, t);
  const double cache_bits = units * cache_sram_bits(c), slot_bits = units * slot_sram_bits(c, in);
  const double l2_bits = l2_sram_bits(c);
  a.sram_bits = cache_bits + slot_bits + l2_bits;
  a.cache_mm2 = sram_area_mm2(cache_bits, t);
  a.slots_mm2 = sram_area_mm2(slot_bits, t);
  a.l2_mm2 = sram_area_mm2(l2_bits, t);
  a.total_mm2 = a.box_mm2 + a.tri_mm2 + a.curve_mm2 + a.cache_mm2 + a.slots_mm2 + a.l2_mm2;
  return a;
}

EnergyReport energy_report(const TimingStats& s, const TimingConfig& c, const CostInputs& in,
                           const Technology& t) {
  EnergyReport r;
  r.area = area_report(c, in, t);
  const double e_gate = t.pj_per_transition();
  const double line = c.cache_kib > 0 ? sram_access_pj(double(c.cache_kib) * 1024.0, c.line_bytes, t) : 0.0;
  const double stack_bytes = double(c.ray_slots) * c.stack_entries * in.stack_entry_bits / 8.0;
  const int entry_bytes = int(std::ceil(in.stack_entry_bits / 8.0));
  // An L2 line is read from its slice: an SRAM of l2_kib / l2_slices.
  const double l2_line =
      c.l2_kib > 0 ? sram_access_pj(double(c.l2_kib) * 1024.0 / c.l2_slices, c.line_bytes, t) : 0.0;
  const double dram_pj_per_byte = 8.0 * memory_type(c.memory_type).pj_per_bit;
  // Leakage power (W) = area (um^2) x density (nW/um^2) x 1e-9; per cycle (pJ) = W / (clock_ghz x 1e9) x 1e12.
  const double leak_w = r.area.total_mm2 * 1e6 * t.leakage_nw_per_um2 * 1e-9;
  const double leak_pj_per_cycle = leak_w * 1e3 / c.clock_ghz;
  r.events = {
      {"box_test", "tests", "box tests x the box unit's switching energy per test", s.box_tests,
       in.box.toggles_per_test * e_gate},
      {"tri_test", "tests", "triangle unit tests (triangles, spheres, planes) x its switching energy per test",
       s.tri_issue_cycles - (c.curve_units == 0 ? s.curve_tests * uint64_t(c.curve_issue) : 0),
       in.tri.toggles_per_test * e_gate},
      {"curve_test", "tests", "curve segment tests x a curve test's switching energy (in either unit)",
       s.curve_tests, in.curve.toggles_per_test * e_gate},
      {"cache_read", "lines", "cache line reads (hits and misses)", s.cache_hits + s.cache_misses, line},
      {"cache_fill", "lines", "cache line writes on a miss or a prefetcher's fill",
       s.cache_misses + s.prefetch_fills, line},
      {"l2_read", "lines", "L2 line reads (node cache fills, hits and misses)", s.l2_hits + s.l2_misses, l2_line},
      {"l2_fill", "lines", "L2 line writes on a miss", s.l2_misses, l2_line},
      {"l2_stack", "words", "stack spills and refills through the L2: an 8-byte access of a slice's SRAM",
       s.l2_stack_hits + s.l2_stack_misses,
       c.l2_kib > 0 ? sram_access_pj(double(c.l2_kib) * 1024.0 / c.l2_slices, 8, t) : 0.0},
      {"stack", "accesses", "slot stack SRAM accesses (one entry per node fetch)", s.node_fetches,
       sram_access_pj(stack_bytes, entry_bytes, t)},
      {"gather", "rays", "gather buffer: each ray written and read once (ray and bin key)",
       c.gather != GatherKey::kNone ? s.rays : 0,
       2.0 * sram_access_pj(ray_queue_bytes(c), kQueueRayBytes + kGatherKeyBytes, t)},
      {"dram", "bytes", "DRAM bytes (line fills, stack spills, refills)", s.dram_bytes, dram_pj_per_byte},
      {"stream", "bytes", "ray and hit buffer bytes (in DRAM)", s.stream_bytes, dram_pj_per_byte},
      {"rotate", "nodes", "oriented node tests x the rotation stage's switching energy per rotation",
       s.obb_rotations, in.rotate.toggles_per_test * e_gate},
      {"transform", "rays", "instance transforms (two-level scenes): 18 float32 multiplies and 15 adds each",
       s.instance_transforms, 18.0 * t.fp32_mul_pj + 15.0 * t.fp32_add_pj},
      {"leakage", "cycles", "leakage of the unit's area over the run's cycles", s.cycles, leak_pj_per_cycle},
  };
  double memory_pj = 0.0;
  for (const EnergyEvent& e : r.events) {
    r.total_pj += e.pj();
    if (std::string_view(e.key) == "dram" || std::string_view(e.key) == "stream") memory_pj += e.pj();
  }
  if (s.rays > 0) {
    r.pj_per_ray = r.total_pj / double(s.rays);
    r.unit_pj_per_ray = (r.total_pj - memory_pj) / double(s.rays);
  }
  if (r.total_pj > 0) r.rays_per_joule = double(s.rays) / (r.total_pj * 1e-12);
  if (s.cycles > 0) r.watts = r.total_pj * 1e-12 / (double(s.cycles) / (c.clock_ghz * 1e9));
  return r;
}

}  // namespace rtu::hw
