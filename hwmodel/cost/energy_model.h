// Area and energy of a unit: an estimate in a named technology from the unit's own RTL (its synthesized size and
// the switching activity measured in Verilator, both supplied by the caller as UnitCost) and documented tables for
// what the RTL does not cover (SRAM, DRAM, leakage). docs/energy-model.md gives every constant's source.
//
// Energy is a sum of events, each a counter of the timed run (TimingStats) times an energy per event, leakage
// included as one event per cycle, so the report adds up by construction and a test checks that it does:
//   box_test       box tests x (gate transitions per test x energy per gate transition)
//   tri_test       triangle unit issue slots (triangles, spheres, planes) x the same for the triangle unit
//   cache_read     cache line accesses x one line read of an SRAM of the cache's size
//   cache_fill     cache misses x one line write (as a read)
//   l2_read        L2 line reads x one line read of an L2 slice's SRAM; l2_fill: L2 misses x one line write
//   l2_stack       stack spills and refills through the L2 x one 8-byte access of a slice's SRAM
//   stack          node fetches x one 8-byte access of the slots' stack SRAM (a push or a pop per node visit)
//   dram           DRAM bytes (line fills, stack spills and refills) x 8 x the memory type's energy per bit
//   stream         ray and hit buffer bytes x 8 x the same (they live in DRAM)
//   rotate         oriented node tests x the rotation stage's energy (CostInputs::rotate)
//   transform      instance transforms (two-level scenes) x 18 float32 multiplies and 15 adds (the origin's three
//                  rows of 3 products and 3 sums, the direction's of 3 products and 2 sums)
//   leakage        cycles x the unit's leakage power over the clock
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

// The technology of the estimates: the NanGate FreePDK45 Open Cell Library (45 nm) for logic area and leakage,
// 45 nm SRAM, and switching energy at Horowitz's 0.9 V so that his per-operation figures compare directly.
struct Technology {
  const char* name = "nangate45";
  double nand2_um2 = 0.798;  // NAND2_X1 area (NanGate 45 nm Open Cell Library)
  double vdd = 0.9;          // volts of the switching energy (Horowitz, ISSCC 2014: 45 nm at 0.9 V)
  // Switched capacitance per NAND2 equivalent transition, calibrated on one of Horowitz's figures: with it the
  // model's 32-bit adder (ref:add32: its synthesis and measured activity) costs his 0.1 pJ. The multiplier is the
  // check: 3.03 pJ against his 3.1 (tests/host/test_energy.cpp). Below a NAND2_X1 input's 1.6 fF because a
  // NAND2 equivalent is a unit of area, not a node: an XOR is 3 of them with one output.
  double cap_per_ge_ff = 1.23;
  double utilization = 0.7;          // standard-cell placement density: logic area = cells / utilization
  double leakage_nw_per_um2 = 27.0;  // INV_X1 14.35 nW over its 0.532 um^2 (NanGate typical corner)
  double sram_bit_um2 = 0.346;       // 45 nm 6T SRAM cell (Intel, Mistry et al., IEDM 2007)
  double sram_efficiency = 0.5;      // bit cells / array area (decoders, sense amplifiers, I/O)
  // Energy of one 64-bit SRAM read by capacity (Horowitz, ISSCC 2014, 45 nm): 8 KB 10 pJ, 32 KB 20 pJ, 1 MB 100
  // pJ.
  double sram_pj_8k = 10.0, sram_pj_32k = 20.0, sram_pj_1m = 100.0;
  // float32 add and multiply (Horowitz, ISSCC 2014, 45 nm): the instance transform's operators.
  double fp32_add_pj = 0.9, fp32_mul_pj = 3.7;

  double pj_per_transition() const { return 0.5 * cap_per_ge_ff * 1e-3 * vdd * vdd; }  // 1/2 C V^2
};
const Technology& nangate45();

// DRAM energy per bit moved, by memory type (TimingConfig::memory_type).
struct MemoryType {
  const char* name;
  double pj_per_bit;
  const char* source;
};
std::span<const MemoryType> memory_types();
// Throws std::invalid_argument for an unknown name.
const MemoryType& memory_type(const std::string& name);
const MemoryType& memory_type(DramType type);

// One 64-bit read of an SRAM of `bytes` bytes (pJ): Horowitz's three points, interpolated log-log and extrapolated
// with the nearest segment's slope.
double sram_read64_pj(double bytes, const Technology& t = nangate45());
// An access of `access_bytes` (a cache line): as many 64-bit reads (an upper estimate: a wide row shares decode).
double sram_access_pj(double bytes, int access_bytes, const Technology& t = nangate45());
double sram_area_mm2(double bits, const Technology& t = nangate45());
double logic_area_mm2(double nand2_eq, const Technology& t = nangate45());

// The unit's SRAM: cache data and tags, ray slot state (CostInputs::slot_state_bits per slot), short stacks
// (stack_entry_bits an entry) and trails, ray queue, prefetch queue.
inline constexpr int kSlotStateBytes = 64;  // estimate of a slot's ray, hit and traversal registers
inline constexpr int kStackEntryBytes = 8;  // estimate of a stack entry: a reference and a float32 distance
inline constexpr int kQueueRayBytes = 32;   // a queued ray (origin, direction, t range as floats)
// stack_mode restart: a slot's trail, a 4-bit counter (children taken, up to 8) for each of 64 levels.
inline constexpr int kTrailBytes = 32;
// prefetch_queue: a queued prefetch is a line address.
inline constexpr int kPrefetchEntryBytes = 8;
// gather (ray_gather.h): a buffered ray's bin key beside the ray.
inline constexpr int kGatherKeyBytes = 4;
// What the area and energy need beyond the configuration: each unit's size and switching activity.
struct UnitCost {
  double nand2_eq = 0.0;          // NAND2 equivalents (yosys CMOS transistors / 4)
  double toggles_per_test = 0.0;  // gate transitions per test (activity per test x nand2_eq)
  std::string source = "none";    // where the figures come from ("synthesized", "fit", "none")
};
struct CostInputs {
  UnitCost box, tri;  // one box unit, one triangle unit
  // A ray slot's storage: its registers beside the stack, and one short-stack entry. The defaults are the
  // estimates used where the RTL traversal unit has no widths for the format; host/cost/cost_model.cpp takes
  // the RTL's (rtl_sim/trav/trav_params.h trav_slot_bits) where it has.
  double slot_state_bits = 8.0 * kSlotStateBytes;
  double stack_entry_bits = 8.0 * kStackEntryBytes;
  std::string slot_source = "estimate";
  // Oriented nodes: the rotation stage in front of each box unit (24 multiplies: the origin's and direction's
  // 3x3 products and a Newton step per reciprocal; 12 adds), its size and its energy per rotation as gate
  // transitions; zero for axis-aligned nodes.
  UnitCost rotate;
  // Curve segments: one curve test (swept_sphere_test: its products, sums, quotients and roots), sized from the
  // reference operators (host/cost/cost_model.cpp says how); a curve unit's area when curve_units > 0, and the
  // energy of every curve test, on a curve unit or in triangle unit slots.
  UnitCost curve;
};

struct AreaReport {
  double box_mm2 = 0, tri_mm2 = 0;      // all units of the kind
  double curve_mm2 = 0;                 // curve units (curve_units, 0 without)
  double cache_mm2 = 0, slots_mm2 = 0;  // all units'
  double l2_mm2 = 0;                    // the chip's L2
  double total_mm2 = 0;
  double logic_nand2_eq = 0, sram_bits = 0;
};
AreaReport area_report(const TimingConfig& c, const CostInputs& in, const Technology& t = nangate45());
double cache_sram_bits(const TimingConfig& c);  // data + tags (a 32-bit tag and a valid bit per line)
double slot_sram_bits(const TimingConfig& c, const CostInputs& in);  // slot state, stacks, trails, queues
double l2_sram_bits(const TimingConfig& c);                          // the L2's data + tags (0 without one)

struct EnergyEvent {
  const char* key;
  const char* unit;  // of count
  const char* description;
  uint64_t count = 0;
  double pj_each = 0.0;
  double pj() const { return double(count) * pj_each; }
};
struct EnergyReport {
  std::vector<EnergyEvent> events;  // in the order of the list at the top of this file
  double total_pj = 0.0;            // the events' sum
  double pj_per_ray = 0.0;
  double unit_pj_per_ray = 0.0;  // the same without the DRAM's events (dram, stream): the chip's own energy
  double rays_per_joule = 0.0;
  double watts = 0.0;  // total over the run's time at clock_ghz
  AreaReport area;
};
EnergyReport energy_report(const TimingStats& s, const TimingConfig& c, const CostInputs& in,
                           const Technology& t = nangate45());

}  // namespace rtu::hw
