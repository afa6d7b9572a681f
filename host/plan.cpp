#include "host/plan.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include "host/cost_model.h"
#include "host/error.h"
#include "hwmodel/energy_model.h"
#include "hwmodel/timing_config.h"

namespace rtu::host {

namespace {

// A candidate: the configuration's format with b coordinate and k child-offset bits.
std::string spec(const std::string& base, int b, int k) {
  return base + ":coord_bits=" + std::to_string(b) + ":child_bits=" + std::to_string(k);
}

// log P(X = i) for X ~ Binomial(n, p), 0 < p < 1.
double log_binomial_pmf(uint64_t i, uint64_t n, double p) {
  const double di = double(i), dn = double(n);
  return std::lgamma(dn + 1.0) - std::lgamma(di + 1.0) - std::lgamma(dn - di + 1.0) + di * std::log(p) +
         (dn - di) * std::log1p(-p);
}

// P(X <= k) for X ~ Binomial(n, p), for p >= k / n: the terms fall from i = k downward (the mode is at or above
// k), so the sum stops once a term is below 2^-60 of it.
double binomial_cdf_upper_tail_side(uint64_t k, uint64_t n, double p) {
  double term = std::exp(log_binomial_pmf(k, n, p));
  double sum = term;
  const double q_over_p = (1.0 - p) / p;
  for (uint64_t i = k; i > 0 && term > sum * 0x1p-60; --i) {
    term *= double(i) / double(n - i + 1) * q_over_p;
    sum += term;
  }
  return sum;
}

// The standard normal's quantile by bisection of erfc (the bound needs a few digits, not speed).
double normal_quantile(double c) {
  double lo = -40.0, hi = 40.0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < c ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

double plan_error(const SweepRow& r, const std::string& metric) {
  return metric == "t" ? r.t_rel_error_mean : std::max(r.hit_disagreement(), 0.0);
}

double proportion_upper_bound(uint64_t k, uint64_t n, double confidence) {
  if (n == 0 || k >= n) return 1.0;
  const double alpha = 1.0 - confidence;
  if (k == 0) return -std::expm1(std::log(alpha) / double(n));  // (1 - p)^n = alpha, exactly
  // P(X <= k) falls as p rises: bisect on [k / n, 1].
  double lo = double(k) / double(n), hi = 1.0;
  for (int it = 0; it < 100 && hi - lo > 1e-15 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (binomial_cdf_upper_tail_side(k, n, mid) > alpha ? lo : hi) = mid;
  }
  return hi;
}

double mean_upper_bound(double mean, double sd, uint64_t n, double confidence) {
  if (n < 2) return std::numeric_limits<double>::infinity();
  return mean + normal_quantile(confidence) * sd / std::sqrt(double(n));
}

double plan_error_bound(const SweepRow& r, const PlanOptions& o) {
  if (o.metric == "t")
    return mean_upper_bound(r.t_rel_error_mean, r.t_rel_error_sd, r.t_compared_rays, o.confidence);
  return proportion_upper_bound(r.false_misses + r.false_hits, r.compared_rays, o.confidence);
}

bool plan_cheaper(const SweepRow& a, const SweepRow& b, const PlanOptions& o) {
  if (o.minimise == "energy")
    return a.pj_per_ray < b.pj_per_ray || (a.pj_per_ray == b.pj_per_ray && a.cycles < b.cycles);
  if (o.minimise == "bytes")
    return a.bvh_bytes < b.bvh_bytes || (a.bvh_bytes == b.bvh_bytes && a.cycles < b.cycles);
  return a.cycles < b.cycles || (a.cycles == b.cycles && a.bvh_bytes < b.bvh_bytes);
}

bool plan_meets(const SweepRow& r, const PlanOptions& o) {
  return plan_error_bound(r, o) <= o.max_error && r.box_false_negatives == 0 &&
         (o.min_psnr <= 0.0 || r.psnr_db >= o.min_psnr) && (o.area_budget <= 0.0 || r.area_mm2 <= o.area_budget);
}

PlanResult plan_format(const PlanOptions& a, const std::function<void(const PlanStep&)>& progress) {
  if (a.metric != "hit" && a.metric != "t") throw Error("--metric: hit or t, got '" + a.metric + "'");
  if (!(a.max_error >= 0.0) || !std::isfinite(a.max_error)) throw Error("--max-error: a finite number >= 0");
  if (!(a.confidence > 0.0 && a.confidence < 1.0)) throw Error("--confidence: a number in (0, 1)");
  if (a.min_psnr > 0.0 && a.sweep.image_width <= 0)
    throw Error("--min-psnr needs a render to measure: --image-width must be above 0");
  if (a.minimise != "cycles" && a.minimise != "bytes" && a.minimise != "energy")
    throw Error("--minimise: cycles, bytes or energy, got '" + a.minimise + "'");
  if (!(a.area_budget >= 0.0) || !std::isfinite(a.area_budget))
    throw Error("--area-budget: a finite number of mm^2 >= 0 (0: none)");
  std::string base;
  try {
    base = hw::timing_preset(a.config).format;
  } catch (const std::invalid_argument& e) {
    throw Error(std::string("--config: ") + e.what());
  }
  if (!a.format.empty()) base = a.format;
  int base_child_bits = 0;
  try {
    base_child_bits = hw::format_from_spec(base).child_bits;
  } catch (const std::invalid_argument& e) {
    throw Error(std::string("--format: ") + e.what());
  }
  // Zero disagreements on every ray is the best a candidate can show; below that bound no format can meet the
  // budget, however good.
  const uint64_t sample = 2 * a.sweep.rays;
  if (a.metric == "hit" && proportion_upper_bound(0, sample, a.confidence) > a.max_error) {
    uint64_t need = sample;
    while (proportion_upper_bound(0, need, a.confidence) > a.max_error) need *= 2;
    throw Error("--max-error " + std::to_string(a.max_error) + " cannot be shown on " + std::to_string(sample) +
                " rays: with no disagreement at all the " + std::to_string(a.confidence) + " upper bound is " +
                std::to_string(proportion_upper_bound(0, sample, a.confidence)) + "; use --rays " +
                std::to_string(need / 2) + " or more");
  }
  const Scene scene = load_scene(a.scene);
  const AreaTable area = a.area.empty() ? AreaTable::shipped() : AreaTable::load(a.area);
  const ActivityTable activity = ActivityTable::shipped();
  auto cache = make_sweep_cache();
  auto report = [&](PlanStage stage, int width, int coord_bits = 0, const SweepRow* row = nullptr,
                    bool meets = false) {
    if (progress) progress(PlanStep{stage, width, coord_bits, row, meets});
  };
  auto meets = [&](const SweepRow& r) { return plan_meets(r, a); };
  // The area of a format at a width with a configuration spec, without running it.
  auto area_of = [&](const std::string& format, int width, const std::string& config) {
    hw::FixedFormat f = hw::format_from_spec(format);
    f.width = width;
    hw::TimingConfig c = sweep_config(config);
    hw::set_timing_key(c, "bvh_width", std::to_string(width));
    return hw::area_report(c, cost_inputs(f, c, area, activity)).total_mm2;
  };
  // Iso-area: one more box or triangle unit at a time, the cheaper of the two that fit, while it is cheaper.
  auto afford = [&](SweepRow cur) {
    const hw::TimingConfig preset = hw::timing_preset(a.config);
    int box = preset.box_units, tri = preset.tri_units;
    while (cur.area_mm2 <= a.area_budget) {
      std::unique_ptr<SweepRow> next;
      for (const auto& [nb, nt] : {std::pair{box + 1, tri}, std::pair{box, tri + 1}}) {
        if (nb > 64 || nt > 64) continue;
        const std::string config =
            a.config + ":box_units=" + std::to_string(nb) + ":tri_units=" + std::to_string(nt);
        if (area_of(cur.p.format, cur.p.bvh_width, config) > a.area_budget) continue;
        SweepRow r = retime_sweep_point(scene, cur, config, a.sweep, area, *cache);
        if (!next || plan_cheaper(r, *next, a)) next = std::make_unique<SweepRow>(r);
      }
      if (!next || !plan_cheaper(*next, cur, a)) break;
      cur = *next;
      const hw::TimingConfig c = sweep_config(cur.p.config);
      box = c.box_units, tri = c.tri_units;
    }
    return cur;
  };
  auto point = [&](const std::string& format, int width) {
    SweepRow r = run_sweep_point(scene, SweepPoint{a.scene, format, width, a.config}, a.sweep, area, *cache);
    if (a.area_budget > 0.0) r = afford(r);
    report(PlanStage::kCandidate, width, 0, &r, meets(r));
    return r;
  };

  PlanResult res;
  res.scene = scene.name;
  Json& j = res.json;
  j["scene"] = scene.name;
  j["metric"] = a.metric == "t" ? "t_rel_error_mean" : "hit_disagreement";
  j["max_error"] = a.max_error;
  j["confidence"] = a.confidence;
  j["seed"] = a.sweep.seed;
  j["rays"] = sample;
  j["min_psnr"] = a.min_psnr;
  j["config"] = a.config;
  j["base_format"] = base;
  j["minimise"] = a.minimise;
  j["cost"] = a.minimise == "bytes"    ? "image bytes (bvh_bytes), then cycles on " + a.config
              : a.minimise == "energy" ? "energy per ray on " + a.config + ", then cycles"
                                       : "cycles on " + a.config + ", then image bytes (bvh_bytes)";
  if (a.area_budget > 0.0) j["area_budget_mm2"] = a.area_budget;
  Json per_width = Json::array();
  std::unique_ptr<SweepRow> best;
  for (int w : a.widths) {
    report(PlanStage::kCoordBits, w);
    // The fewest coordinate bits that meet the budget (error falls with bits; the first that meets is taken).
    std::unique_ptr<SweepRow> first_ok, last_bad;
    for (int b : a.coord_bits) {
      SweepRow r = point(spec(base, b, base_child_bits), w);
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
    // Fewer coordinate bits are fewer bytes, but not always fewer cycles or less energy: they cost node visits
    // (looser boxes) where they save bytes, so on a compute-bound unit more bits can be faster. Minimising cycles
    // or energy, the bits above go on while they are cheaper and meet the budget (cost against bits falls, then
    // rises).
    SweepRow at_b = *first_ok;
    if (a.minimise != "bytes") {
      const int b0 = hw::format_from_spec(first_ok->p.format).coord_bits;
      for (int more : a.coord_bits) {
        if (more <= b0) continue;
        SweepRow r = point(spec(base, more, base_child_bits), w);
        if (!meets(r) || !plan_cheaper(r, at_b, a)) break;
        at_b = r;
      }
    }
    const int b = hw::format_from_spec(at_b.p.format).coord_bits;
    // Child-offset bits: the cheapest among those that still meet the budget.
    report(PlanStage::kChildBits, w, b);
    SweepRow chosen = at_b;
    Json ks = Json::array();
    for (int k : a.child_bits) {
      SweepRow r = k == base_child_bits ? at_b : point(spec(base, b, k), w);
      ks.push_back({{"child_bits", k},
                    {"error", plan_error(r, a.metric)},
                    {"error_bound", plan_error_bound(r, a)},
                    {"cycles", r.cycles},
                    {"bytes", r.bvh_bytes},
                    {"bytes_per_prim", r.bytes_per_prim},
                    {"dram_bytes_per_ray", r.dram_bytes_per_ray},
                    {"config", r.p.config},
                    {"area_mm2", r.area_mm2},
                    {"pj_per_ray", r.pj_per_ray},
                    {"meets", meets(r)}});
      if (meets(r) && plan_cheaper(r, chosen, a)) chosen = r;
    }
    jw["feasible"] = true;
    jw["coord_bits"] = hw::format_from_spec(first_ok->p.format).coord_bits;
    jw["chosen_coord_bits"] = b;
    jw["error_at_coord_bits"] = plan_error(*first_ok, a.metric);
    jw["error_bound_at_coord_bits"] = plan_error_bound(*first_ok, a);
    if (last_bad) {
      jw["fewer_coord_bits"] = hw::format_from_spec(last_bad->p.format).coord_bits;
      jw["error_at_fewer_coord_bits"] = plan_error(*last_bad, a.metric);
      jw["error_bound_at_fewer_coord_bits"] = plan_error_bound(*last_bad, a);
    }
    jw["child_bits"] = ks;
    jw["chosen"] = {{"format", chosen.p.format},
                    {"cycles", chosen.cycles},
                    {"bytes", chosen.bvh_bytes},
                    {"bytes_per_prim", chosen.bytes_per_prim},
                    {"dram_bytes_per_ray", chosen.dram_bytes_per_ray},
                    {"error", plan_error(chosen, a.metric)},
                    {"error_bound", plan_error_bound(chosen, a)},
                    {"psnr_db", chosen.psnr_db},
                    {"rtl_cells", chosen.rtl_cells},
                    {"config", chosen.p.config},
                    {"area_mm2", chosen.area_mm2},
                    {"pj_per_ray", chosen.pj_per_ray}};
    per_width.push_back(jw);
    if (!best || plan_cheaper(chosen, *best, a)) best = std::make_unique<SweepRow>(chosen);
  }
  j["widths"] = per_width;
  // The base format at the chosen width, for comparison.
  if (!best) {
    j["plan"] = nullptr;
    return res;
  }
  report(PlanStage::kDefault, best->p.bvh_width);
  const SweepRow def = point(base, best->p.bvh_width);
  const hw::FixedFormat f = hw::format_from_spec(best->p.format);
  j["plan"] = {{"format", best->p.format},
               {"bvh_width", best->p.bvh_width},
               {"coord_bits", f.coord_bits},
               {"child_bits", f.child_bits},
               {"cycles", best->cycles},
               {"bytes", best->bvh_bytes},
               {"bytes_per_prim", best->bytes_per_prim},
               {"dram_bytes_per_ray", best->dram_bytes_per_ray},
               {"error", plan_error(*best, a.metric)},
               {"error_bound", plan_error_bound(*best, a)},
               {"psnr_db", best->psnr_db},
               {"rtl_cells", best->rtl_cells},
               {"config", best->p.config},
               {"box_units", sweep_config(best->p.config).box_units},
               {"tri_units", sweep_config(best->p.config).tri_units},
               {"area_mm2", best->area_mm2},
               {"pj_per_ray", best->pj_per_ray}};
  j["default"] = {{"format", base},
                  {"cycles", def.cycles},
                  {"bytes", def.bvh_bytes},
                  {"bytes_per_prim", def.bytes_per_prim},
                  {"dram_bytes_per_ray", def.dram_bytes_per_ray},
                  {"error", plan_error(def, a.metric)},
                  {"error_bound", plan_error_bound(def, a)},
                  {"rtl_cells", def.rtl_cells},
                  {"config", def.p.config},
                  {"area_mm2", def.area_mm2},
                  {"pj_per_ray", def.pj_per_ray}};
  res.found = true;
  res.best = *best;
  res.format = f;
  res.reference = def;
  return res;
}

}  // namespace rtu::host
