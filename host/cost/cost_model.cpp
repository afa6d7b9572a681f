#include "host/cost/cost_model.h"

#include <algorithm>
#include <map>
#include <sstream>
#include <stdexcept>

#include "rtl_sim/params/rtl_params.h"
#include "rtl_sim/params/tri_params.h"
#include "rtl_sim/trav/trav_params.h"

namespace rtu::host {

namespace {

// "-GN=4 -GLANES=4 ..." as a map; empty when a token is not -GNAME=VALUE.
std::map<std::string, double> params_of(const std::string& key) {
  std::map<std::string, double> m;
  std::istringstream in(key);
  std::string tok;
  while (in >> tok) {
    const size_t eq = tok.find('=');
    if (tok.rfind("-G", 0) != 0 || eq == std::string::npos) return {};
    try {
      m[tok.substr(2, eq - 2)] = std::stod(tok.substr(eq + 1));
    } catch (const std::exception&) {
      return {};
    }
  }
  return m;
}

enum class Kind { kBox, kTri, kOther };
Kind kind_of(const std::map<std::string, double>& p) {
  if (p.count("N") && p.count("LANES") && p.count("A") && p.count("M")) return Kind::kBox;
  if (p.count("B") && p.count("A") && p.count("D") && !p.count("N")) return Kind::kTri;
  return Kind::kOther;
}

// The size of a unit's multipliers, the regressor of the fit.
double box_feature(double lanes, double a, double m) {
  return lanes * (a + 1) * (m + 2);
}
double tri_feature(double a, double d) {
  return (a + 1) * (a + d + 2);
}
double feature(Kind k, const std::map<std::string, double>& p) {
  return k == Kind::kBox ? box_feature(p.at("LANES"), p.at("A"), p.at("M")) : tri_feature(p.at("A"), p.at("D"));
}

struct Fit {
  double a = 0, b = 0;  // nand2_eq = a + b x
  int points = 0;
  double activity = 0;  // mean transitions per test per signal bit
  int measured = 0;
};

Fit fit_kind(Kind kind, const AreaTable& area, const ActivityTable& activity) {
  Fit f;
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const auto& [key, e] : area.by_params) {
    const auto p = params_of(key);
    if (kind_of(p) != kind || e.transistors <= 0) continue;
    const double x = feature(kind, p), y = double(e.transistors) / 4.0;
    sx += x, sy += y, sxx += x * x, sxy += x * y, ++f.points;
  }
  if (f.points >= 2 && f.points * sxx - sx * sx > 0) {
    f.b = (f.points * sxy - sx * sy) / (f.points * sxx - sx * sx);
    f.a = (sy - f.b * sx) / f.points;
  } else if (f.points == 1) {
    f.b = sy / sx;  // proportional through the one point
  }
  for (const auto& [key, e] : activity.by_params) {
    const auto p = params_of(key);
    if (kind_of(p) != kind) continue;
    f.activity += e.toggles_per_test / e.signal_bits;
    ++f.measured;
  }
  if (f.measured > 0) f.activity /= f.measured;
  return f;
}

hw::UnitCost unit_cost(Kind kind, const std::string& key, double x, const AreaTable& area,
                       const ActivityTable& activity) {
  hw::UnitCost u;
  const auto a = area.by_params.find(key);
  const auto act = activity.by_params.find(key);
  const Fit fit = fit_kind(kind, area, activity);
  std::string size_source, act_source;
  if (a != area.by_params.end() && a->second.transistors > 0) {
    u.nand2_eq = double(a->second.transistors) / 4.0;
    size_source = "synthesized";
  } else if (fit.points > 0) {
    u.nand2_eq = std::max(0.0, fit.a + fit.b * x);
    size_source = "fit of " + std::to_string(fit.points) + " synthesized units";
  } else {
    size_source = "none";
  }
  double per_ge = 0;
  if (act != activity.by_params.end()) {
    per_ge = act->second.toggles_per_test / act->second.signal_bits;
    act_source = "measured";
  } else if (fit.measured > 0) {
    per_ge = fit.activity;
    act_source = "mean of " + std::to_string(fit.measured) + " measured units";
  } else {
    act_source = "none";
  }
  u.toggles_per_test = per_ge * u.nand2_eq;
  u.source = "size " + size_source + ", activity " + act_source;
  return u;
}

}  // namespace

hw::CostInputs cost_inputs(const hw::FixedFormat& f, const hw::TimingConfig& c, const AreaTable& area,
                           const ActivityTable& activity) {
  hw::CostInputs in;
  const double a = f.translated_bits();
  const int lanes = std::min(c.box_rate, c.bvh_width);
  std::string box_key, tri_key;
  try {
    box_key = rtl::verilator_args(rtl::box_unit_params(f, c.bvh_width, c.box_rate, c.box_latency));
  } catch (const std::invalid_argument&) {
    // A wide format: no RTL unit has its datapath; the fit estimates it.
  }
  try {
    tri_key = rtl::verilator_args(rtl::tri_unit_params(f, c.tri_latency));
  } catch (const std::invalid_argument&) {
  }
  try {
    // The RTL traversal unit's slot registers at this format's widths (a slot's storage, as SRAM bits).
    const rtl::TravSlotBits sb = rtl::trav_slot_bits(
        rtl::box_unit_params(f, c.bvh_width, c.box_rate, c.box_latency), rtl::tri_unit_params(f, c.tri_latency));
    in.slot_state_bits = double(sb.state + sb.buffer + sb.spill * sb.entry);
    in.stack_entry_bits = double(sb.entry);
    in.slot_source = "RTL traversal unit's registers (rtl_sim/trav)";
  } catch (const std::invalid_argument&) {
  }
  in.box = unit_cost(Kind::kBox, box_key, box_feature(lanes, a, f.rcp_bits + 1), area, activity);
  in.tri = unit_cost(Kind::kTri, tri_key, tri_feature(a, f.dir_bits), area, activity);
  if (f.node_kind_id() == hw::NodeKindId::kOrientedAabb) {
    // The rotation stage: 24 multiplies and 12 adds of the reference operators (synthesized and measured when
    // the tables have them, Horowitz's 45 nm figures else). A 32-bit operator bounds the stage's narrower ones
    // (origin x entry: B+G+F by rot_bits + 1 bits).
    const std::vector<ReferenceOp> ops = reference_ops(area, activity);
    const hw::Technology& t = hw::nangate45();
    double ge = 0.0, pj = 0.0;
    for (const ReferenceOp& op : ops) {
      const double n = op.key == "ref:mul32" ? 24.0 : 12.0;
      ge += n * (op.measured ? op.nand2_eq : op.horowitz_um2 / t.nand2_um2);
      pj += n * (op.measured ? op.pj : op.horowitz_pj);
    }
    in.rotate.toggles_per_test = pj / t.pj_per_transition();
    in.rotate.source = ops[0].measured && ops[1].measured ? "reference operators, synthesized"
                                                          : "reference operators, Horowitz ISSCC 2014";
    // The size: the synthesized rotation stage (rtl_sim/rtl/rotate_stage.sv: the 18 products and their sums;
    // bench/rtl_rotate_area.sh) where the table has the format's widths, plus the reciprocals' 6 multiplies.
    const std::string key = "-GOB=" + std::to_string(f.coord_bits + f.guard_bits + f.frac_bits + 1) +
                            " -GDB=" + std::to_string(f.dir_bits + 2) + " -GMB=" + std::to_string(f.rot_bits + 2);
    const auto row = area.by_params.find(key);
    if (row != area.by_params.end() && row->second.transistors > 0) {
      const ReferenceOp& mul = ops[1];
      ge = double(row->second.transistors) / 4.0 +
           6.0 * (mul.measured ? mul.nand2_eq : mul.horowitz_um2 / t.nand2_um2);
      in.rotate.source =
          "size synthesized (products) and reference multipliers (reciprocals), energy reference "
          "operators";
    }
    in.rotate.nand2_eq = ge;
  }
  {
    // The curve test, fitted from the reference operators (no RTL unit): swept_sphere_test's products at their
    // operand widths, a product of m by n bits costing m n / 32^2 reference 32-bit multiplies: 82 of a position
    // (C + 4 bits, C = curve_bits) by a direction (Dc + 3, Dc = max(D, 54 - C)), the cone's 58 and the two end
    // spheres' 24; the discriminant's 2 squares of C + Dc + 8 bits; the 3 parameter checks' of 2C + 9 by
    // C + Dc + 2; 5 quotients and 3 square roots as 4 position-by-direction products each. 60 sums of 2C + 8 bits
    // cost (2C + 8) / 32 reference adds each.
    const std::vector<ReferenceOp> ops = reference_ops(area, activity);
    const hw::Technology& t = hw::nangate45();
    const double C = f.curve_bits, Dc = std::max(f.dir_bits, 54 - f.curve_bits);
    const double pd = (C + 4.0) * (Dc + 3.0) / 1024.0;
    const double muls = (82.0 + 4.0 * 8.0) * pd + 2.0 * (C + Dc + 8.0) * (C + Dc + 8.0) / 1024.0 +
                        3.0 * (2.0 * C + 9.0) * (C + Dc + 2.0) / 1024.0,
                 adds = 60.0 * (2.0 * C + 8.0) / 32.0;
    double ge = 0.0, pj = 0.0;
    for (const ReferenceOp& op : ops) {
      const double n = op.key == "ref:mul32" ? muls : adds;
      ge += n * (op.measured ? op.nand2_eq : op.horowitz_um2 / t.nand2_um2);
      pj += n * (op.measured ? op.pj : op.horowitz_pj);
    }
    in.curve.nand2_eq = ge;
    in.curve.toggles_per_test = pj / t.pj_per_transition();
    in.curve.source = std::string("fit: operation counts of swept_sphere_test x reference operators (") +
                      (ops[0].measured && ops[1].measured ? "synthesized" : "Horowitz ISSCC 2014") + ")";
  }
  return in;
}

namespace {

// A block of `muls` reference multiplies (32 x 32 bits) and `adds` reference adds (32 bits), its products and sums
// scaled to their widths: area and toggles per operation from the synthesized reference operators (Horowitz's
// figures where the tables lack them).
hw::UnitCost fit_reference_ops(double muls, double adds, const std::string& what) {
  static const AreaTable area = AreaTable::shipped();
  static const ActivityTable activity = ActivityTable::shipped();
  const std::vector<ReferenceOp> ops = reference_ops(area, activity);
  const hw::Technology& t = hw::nangate45();
  hw::UnitCost u;
  double pj = 0.0;
  for (const ReferenceOp& op : ops) {
    const double n = op.key == "ref:mul32" ? muls : adds;
    u.nand2_eq += n * (op.measured ? op.nand2_eq : op.horowitz_um2 / t.nand2_um2);
    pj += n * (op.measured ? op.pj : op.horowitz_pj);
  }
  u.toggles_per_test = pj / t.pj_per_transition();
  u.source = "fit: " + what + " x reference operators (" +
             (ops[0].measured && ops[1].measured ? "synthesized" : "Horowitz ISSCC 2014") + ")";
  return u;
}

}  // namespace

MotionInterpolators motion_interpolators(const hw::FixedFormat& f, int time_bits, int box_time_bits) {
  const double b = f.coord_bits + 1.0;
  const auto fit = [&](double lanes, int bits) {
    return fit_reference_ops(lanes * b * bits / 1024.0, lanes * b / 32.0, "interpolation products");
  };
  return MotionInterpolators{fit(6.0, box_time_bits), fit(9.0, time_bits), fit(8.0, time_bits)};
}

hw::UnitCost omm_lookup_cost(int level) {
  const double L = std::max(0, level);
  return fit_reference_ops((L + 1.0) * (L + 2.0) / 1024.0, (4.0 * 24.0 + 2.0 * (2.0 * L + 1.0)) / 32.0,
                           "lookup operators");
}

hw::CostInputs cost_inputs(const hw::FixedFormat& f, const hw::TimingConfig& c) {
  static const AreaTable area = AreaTable::shipped();
  static const ActivityTable activity = ActivityTable::shipped();
  return cost_inputs(f, c, area, activity);
}

hw::CostInputs cost_inputs(const hw::TimingConfig& c) {
  hw::FixedFormat f = hw::format_from_spec(c.format);
  f.width = c.bvh_width;
  return cost_inputs(f, c);
}

Json energy_json(const hw::EnergyReport& e, const hw::TimingConfig& c, const hw::CostInputs& in) {
  Json j;
  j["technology"] = hw::nangate45().name;
  j["memory_type"] = hw::name_of(c.memory_type);
  j["area"] = {{"total_mm2", e.area.total_mm2},
               {"box_units_mm2", e.area.box_mm2},
               {"tri_units_mm2", e.area.tri_mm2},
               {"cache_mm2", e.area.cache_mm2},
               {"slots_mm2", e.area.slots_mm2},
               {"slot",
                {{"state_bits", in.slot_state_bits},
                 {"stack_entry_bits", in.stack_entry_bits},
                 {"source", in.slot_source}}},
               {"l2_mm2", e.area.l2_mm2},
               {"logic_nand2_eq", e.area.logic_nand2_eq},
               {"sram_bits", e.area.sram_bits},
               {"box_unit", {{"nand2_eq", in.box.nand2_eq}, {"source", in.box.source}}},
               {"tri_unit", {{"nand2_eq", in.tri.nand2_eq}, {"source", in.tri.source}}},
               {"rotate_stage", {{"nand2_eq", in.rotate.nand2_eq}, {"source", in.rotate.source}}},
               {"curve_units_mm2", e.area.curve_mm2},
               {"curve_unit", {{"nand2_eq", in.curve.nand2_eq}, {"source", in.curve.source}}}};
  Json events = Json::object();
  for (const hw::EnergyEvent& ev : e.events)
    events[ev.key] = {{"count", ev.count}, {"unit", ev.unit}, {"pj_each", ev.pj_each}, {"pj", ev.pj()}};
  j["events"] = events;
  j["total_pj"] = e.total_pj;
  j["pj_per_ray"] = e.pj_per_ray;
  j["unit_pj_per_ray"] = e.unit_pj_per_ray;
  j["rays_per_joule"] = e.rays_per_joule;
  j["watts"] = e.watts;
  return j;
}

std::vector<ReferenceOp> reference_ops(const AreaTable& area, const ActivityTable& activity) {
  const hw::Technology& t = hw::nangate45();
  std::vector<ReferenceOp> ops = {{"ref:add32", "32-bit integer add", false, 0, 0, 0, 0.1, 137.0},
                                  {"ref:mul32", "32-bit integer multiply", false, 0, 0, 0, 3.1, 3495.0}};
  for (ReferenceOp& op : ops) {
    const auto a = area.by_params.find(op.key);
    const auto act = activity.by_params.find(op.key);
    if (a == area.by_params.end() || act == activity.by_params.end() || a->second.transistors <= 0) continue;
    op.measured = true;
    op.nand2_eq = double(a->second.transistors) / 4.0;
    op.area_um2 = op.nand2_eq * t.nand2_um2;  // cell area, as Horowitz's figures (no placement utilization)
    op.pj = act->second.toggles_per_test / act->second.signal_bits * op.nand2_eq * t.pj_per_transition();
  }
  return ops;
}

std::vector<EnergyKey> energy_json_keys() {
  std::vector<EnergyKey> k = {
      {"energy.technology", "-", "technology of the estimate (docs/energy-model.md)"},
      {"energy.memory_type", "-", "DRAM type whose energy per bit is used (memory_type key)"},
      {"energy.area", "-", "area estimate of the unit"},
      {"energy.area.total_mm2", "mm^2", "units, cache and slot SRAM"},
      {"energy.area.box_units_mm2", "mm^2", "box units (NAND2 equivalents x NAND2 area / utilization)"},
      {"energy.area.tri_units_mm2", "mm^2", "triangle units"},
      {"energy.area.cache_mm2", "mm^2", "cache data and tag SRAM"},
      {"energy.area.slots_mm2", "mm^2", "ray slot state, short stacks and trails, ray and prefetch queue SRAM"},
      {"energy.area.slot", "-",
       "one ray slot's storage: state_bits (registers and buffers beside the stack), stack_entry_bits, and "
       "where they come from"},
      {"energy.area.l2_mm2", "mm^2", "the L2's data and tag SRAM (a chip's shared L2)"},
      {"energy.area.logic_nand2_eq", "NAND2", "NAND2 equivalents of all units"},
      {"energy.area.sram_bits", "bits", "SRAM bits of cache and slots"},
      {"energy.area.box_unit", "-", "one box unit: nand2_eq and where its size and activity come from"},
      {"energy.area.tri_unit", "-", "one triangle unit: nand2_eq and where its size and activity come from"},
      {"energy.area.rotate_stage", "-",
       "oriented nodes: one box unit's rotation stage (nand2_eq, 0 for axis-aligned nodes; in box_units_mm2)"},
      {"energy.area.curve_units_mm2", "mm^2", "curve units (curve_units; 0 without)"},
      {"energy.area.curve_unit", "-",
       "one curve test's logic: nand2_eq fitted from operation counts (its area counts only with curve_units)"},
      {"energy.events", "-", "each event: count, unit, pj_each, pj (count x pj_each)"},
      {"energy.total_pj", "pJ", "sum of the events' pj"},
      {"energy.pj_per_ray", "pJ/ray", "total_pj / rays"},
      {"energy.unit_pj_per_ray", "pJ/ray",
       "the same without the DRAM's events (dram, stream): the energy spent on the chip"},
      {"energy.rays_per_joule", "rays/J", "rays / total energy"},
      {"energy.watts", "W", "total energy / run time at clock_ghz"},
  };
  const hw::EnergyReport e = hw::energy_report(hw::TimingStats{}, hw::timing_preset("rdna2"), hw::CostInputs{});
  for (const hw::EnergyEvent& ev : e.events)
    k.push_back({std::string("energy.events.") + ev.key, ev.unit, ev.description});
  return k;
}

}  // namespace rtu::host
