// The inputs of the area and energy estimate (hwmodel/cost/energy_model.h) for a format and a timing
// configuration: the box and triangle units' size from the RTL synthesis table (AreaTable) and their switching
// activity from the Verilator activity table (ActivityTable), looked up by the units' Verilator parameters.
//
// A unit the tables do not hold (a format no synthesis ran for) is estimated and says so (source "fit"): its size
// from a least-squares line through the synthesized units of its kind against the size of its multipliers (box
// unit: lanes x (A+1) x (M+2); triangle unit: (A+1) x (A+D+2), the edge functions' products), its activity the
// mean of its kind's measured units.
#pragma once

#include <string>
#include <vector>

#include "host/cost/area_tables.h"
#include "host/io/stats_json.h"
#include "hwmodel/cost/energy_model.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::host {

// `f` is the datapath's format (the configuration's `format` preset, or a sweep point's spec), at c.bvh_width.
hw::CostInputs cost_inputs(const hw::FixedFormat& f, const hw::TimingConfig& c, const AreaTable& area,
                           const ActivityTable& activity);
// With the shipped tables: the run's format `f` (what its image was encoded with: every field, the node kind and
// the BVH width), so that a design point has one price in trace, render, sweep and plan.
hw::CostInputs cost_inputs(const hw::FixedFormat& f, const hw::TimingConfig& c);
// The configuration's own format (its `format` preset at its bvh_width): what `rtusim config` prices.
hw::CostInputs cost_inputs(const hw::TimingConfig& c);

// The time-aware motion unit's interpolators (hwmodel/timing/motion_timing.h), fitted from the reference operators
// as the curve test is (a product of m by n bits costs m n / 32^2 reference 32-bit multiplies, a sum of m bits
// m / 32 reference adds): `box` is one child box's interpolation (6 planes: a (B+1) x box_time_bits product and a
// B+1-bit sum each), box_rate of them in each box unit; `tri` is one triangle's (9 coordinates: (B+1) x time_bits
// and a B+1-bit sum each), one in each triangle unit; `round` a curve segment's (its end points' 6 coordinates and
// 2 radii), one in each curve unit (with curve_units > 0; a triangle unit's serves the spheres it tests, 4
// coordinates, and the curves without curve units). toggles_per_test: per box, triangle and curve segment.
struct MotionInterpolators {
  hw::UnitCost box, tri, round;
};
MotionInterpolators motion_interpolators(const hw::FixedFormat& f, int time_bits, int box_time_bits);

// The opacity micromap lookup of one triangle unit (hwmodel/format/micromap.h, micro_index), priced from the
// reference operators as the interpolators are: the two barycentrics' truncations to `level` bits (a 24-bit
// aligning shift each, priced as a 24-bit add), their fractions' sum and its compare with 1 (two 24-bit adds), the
// row's base j (2N - j) (an (L + 1) x (L + 2)-bit product) and the index's sums (two (2L + 1)-bit adds).
// toggles_per_test: per lookup. The state's fetch is the memory system's (timing-model.md).
hw::UnitCost omm_lookup_cost(int level);

// {technology, memory_type, area: {...mm^2, units: {box, tri}}, events: [{key, count, pj_each, pj}], total_pj,
// pj_per_ray, rays_per_joule, watts}
Json energy_json(const hw::EnergyReport& e, const hw::TimingConfig& c, const hw::CostInputs& in);

// The reference operators of the calibration (rtl_sim/rtl/ref_ops.sv, keys "ref:add32" and "ref:mul32"): their
// energy per operation and area by this model from their synthesis and measured activity, beside Horowitz's
// 45 nm figures (ISSCC 2014: 32-bit add 0.1 pJ and 137 um^2, 32-bit multiply 3.1 pJ and 3495 um^2). `measured`
// is false when the tables lack the operator (then only Horowitz's figures are set).
struct ReferenceOp {
  std::string key, name;
  bool measured = false;
  double nand2_eq = 0.0, area_um2 = 0.0, pj = 0.0;
  double horowitz_pj = 0.0, horowitz_um2 = 0.0;
};
std::vector<ReferenceOp> reference_ops(const AreaTable& area, const ActivityTable& activity);

// The keys of energy_json ("energy.x" and "energy.x.y"), with unit and meaning, for `rtusim config --stats`.
struct EnergyKey {
  std::string key, unit, description;
};
std::vector<EnergyKey> energy_json_keys();

}  // namespace rtu::host
