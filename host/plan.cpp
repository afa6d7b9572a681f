#include "host/plan.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>

#include "host/error.h"
#include "hwmodel/timing_config.h"

namespace rtu::host {

namespace {

std::string spec(int b, int k) {
  return "default:coord_bits=" + std::to_string(b) + ":child_bits=" + std::to_string(k);
}

}  // namespace

double plan_error(const SweepRow& r, const std::string& metric) {
  return metric == "t" ? r.t_rel_error_mean : std::max(r.hit_disagreement(), 0.0);
}

bool plan_meets(const SweepRow& r, const PlanOptions& o) {
  return plan_error(r, o.metric) <= o.max_error && r.box_false_negatives == 0 &&
         (o.min_psnr <= 0.0 || r.psnr_db >= o.min_psnr);
}

PlanResult plan_format(const PlanOptions& a, const std::function<void(const PlanStep&)>& progress) {
  if (a.metric != "hit" && a.metric != "t") throw Error("--metric: hit or t, got '" + a.metric + "'");
  if (!(a.max_error >= 0.0) || !std::isfinite(a.max_error)) throw Error("--max-error: a finite number >= 0");
  try {
    hw::timing_preset(a.config);
  } catch (const std::invalid_argument& e) {
    throw Error(std::string("--config: ") + e.what());
  }
  const Scene scene = load_scene(a.scene);
  const AreaTable area = a.area.empty() ? AreaTable{} : AreaTable::load(a.area);
  auto cache = make_sweep_cache();
  auto report = [&](PlanStage stage, int width, int coord_bits = 0, const SweepRow* row = nullptr,
                    bool meets = false) {
    if (progress) progress(PlanStep{stage, width, coord_bits, row, meets});
  };
  auto meets = [&](const SweepRow& r) { return plan_meets(r, a); };
  auto point = [&](const std::string& format, int width) {
    const SweepRow r = run_sweep_point(scene, SweepPoint{a.scene, format, width, a.config}, a.sweep, area, *cache);
    report(PlanStage::kCandidate, width, 0, &r, meets(r));
    return r;
  };

  PlanResult res;
  res.scene = scene.name;
  Json& j = res.json;
  j["scene"] = scene.name;
  j["metric"] = a.metric == "t" ? "t_rel_error_mean" : "hit_disagreement";
  j["max_error"] = a.max_error;
  j["min_psnr"] = a.min_psnr;
  j["config"] = a.config;
  Json per_width = Json::array();
  std::unique_ptr<SweepRow> best;
  for (int w : a.widths) {
    report(PlanStage::kCoordBits, w);
    // The fewest coordinate bits that meet the budget (error falls with bits; the first that meets is taken).
    std::unique_ptr<SweepRow> first_ok, last_bad;
    for (int b : a.coord_bits) {
      SweepRow r = point(spec(b, 8), w);
      if (meets(r)) {
        first_ok = std::make_unique<SweepRow>(r);
        break;
      }
      last_bad = std::make_unique<SweepRow>(r);
    }
    Json jw;
    jw["bvh_width"] = w;
    if (!first_ok) {
      jw["feasible"] = false;
      per_width.push_back(jw);
      report(PlanStage::kInfeasible, w);
      continue;
    }
    const int b = hw::format_from_spec(first_ok->p.format).coord_bits;
    // Child-offset bits: the fewest cycles among those that still meet the budget.
    report(PlanStage::kChildBits, w, b);
    SweepRow chosen = *first_ok;
    Json ks = Json::array();
    for (int k : a.child_bits) {
      SweepRow r = k == 8 ? *first_ok : point(spec(b, k), w);
      ks.push_back({{"child_bits", k},
                    {"error", plan_error(r, a.metric)},
                    {"cycles", r.cycles},
                    {"bytes", r.bvh_bytes},
                    {"meets", meets(r)}});
      if (meets(r) && (r.cycles < chosen.cycles || (r.cycles == chosen.cycles && r.bvh_bytes < chosen.bvh_bytes)))
        chosen = r;
    }
    jw["feasible"] = true;
    jw["coord_bits"] = b;
    jw["error_at_coord_bits"] = plan_error(*first_ok, a.metric);
    if (last_bad) {
      jw["fewer_coord_bits"] = hw::format_from_spec(last_bad->p.format).coord_bits;
      jw["error_at_fewer_coord_bits"] = plan_error(*last_bad, a.metric);
    }
    jw["child_bits"] = ks;
    jw["chosen"] = {{"format", chosen.p.format}, {"cycles", chosen.cycles},
                    {"bytes", chosen.bvh_bytes}, {"error", plan_error(chosen, a.metric)},
                    {"psnr_db", chosen.psnr_db}, {"rtl_cells", chosen.rtl_cells}};
    per_width.push_back(jw);
    if (!best || chosen.cycles < best->cycles ||
        (chosen.cycles == best->cycles && chosen.bvh_bytes < best->bvh_bytes))
      best = std::make_unique<SweepRow>(chosen);
  }
  j["widths"] = per_width;
  // The default format at the chosen width, for comparison.
  if (!best) {
    j["plan"] = nullptr;
    return res;
  }
  report(PlanStage::kDefault, best->p.bvh_width);
  const SweepRow def = point("default", best->p.bvh_width);
  const hw::FixedFormat f = hw::format_from_spec(best->p.format);
  j["plan"] = {{"format", best->p.format},
               {"bvh_width", best->p.bvh_width},
               {"coord_bits", f.coord_bits},
               {"child_bits", f.child_bits},
               {"cycles", best->cycles},
               {"bytes", best->bvh_bytes},
               {"error", plan_error(*best, a.metric)},
               {"psnr_db", best->psnr_db},
               {"rtl_cells", best->rtl_cells}};
  j["default"] = {{"cycles", def.cycles},
                  {"bytes", def.bvh_bytes},
                  {"error", plan_error(def, a.metric)},
                  {"rtl_cells", def.rtl_cells}};
  res.found = true;
  res.best = *best;
  res.format = f;
  res.reference = def;
  return res;
}

}  // namespace rtu::host
