#include "host/jobs/plan.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>

#include "host/cost/cost_model.h"
#include "host/io/error.h"
#include "hwmodel/cost/energy_model.h"
#include "hwmodel/timing/timing_config.h"

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

// A number as the messages print it (%g: 1e-20, not 0.000000).
std::string g(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

// A fraction as a signed percentage ("+12%", "-0.3%").
std::string signed_pct(double fraction) {
  return (fraction >= 0.0 ? "+" : "") + g(100.0 * fraction) + "%";
}

// A's gain over b in the cost o.minimise names first, in words: "0.2% fewer cycles", "3% more rays per clock per
// mm^2".
std::string gain_text(const SweepRow& a, const SweepRow& b, const PlanOptions& o) {
  const std::string pct = g(100.0 * plan_gain(a, b, o)) + "% ";
  if (o.minimise == "energy") return pct + "less energy per ray";
  if (o.minimise == "bytes") return pct + "fewer bytes";
  if (o.minimise == "area") return pct + "less area";
  if (o.minimise == "perf-per-area") return pct + "more rays per clock per mm^2";
  return pct + "fewer cycles";
}

// Coordinate and child-offset bits of a row's format (0 when it names none).
int format_bits(const SweepRow& r) {
  try {
    const hw::FixedFormat f = hw::format_from_spec(r.p.format);
    return f.coord_bits + f.child_bits;
  } catch (const std::invalid_argument&) {
    return 0;
  }
}

// True when a is the costlier in size: more area, or as much and more bits.
bool costlier(const SweepRow& a, const SweepRow& b) {
  return a.area_mm2 != b.area_mm2 ? a.area_mm2 > b.area_mm2 : format_bits(a) > format_bits(b);
}

// What `a` costs over `b` in size, for a costlier a: "+12% area", or with as much area "+2 bits".
std::string size_cost(const SweepRow& a, const SweepRow& b) {
  if (a.area_mm2 != b.area_mm2 && b.area_mm2 > 0.0) return signed_pct(a.area_mm2 / b.area_mm2 - 1.0) + " area";
  return "+" + std::to_string(format_bits(a) - format_bits(b)) + " bits";
}

// Of candidates that all meet the budget, the one a walk from the least costly up (in size: area, then bits, then
// BVH width) keeps: each replaces the one kept when it pays (plan_pays). A candidate cheaper than the one finally
// kept then comes after it in the walk and was weighed against it: every candidate kept is cheaper than those
// passed over before it (it saved more than the threshold over the one kept then; they did not). Returns the
// index of the candidate kept.
size_t keep_by_size(const std::vector<const SweepRow*>& rows, const PlanOptions& o) {
  std::vector<size_t> order(rows.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t x, size_t y) {
    const SweepRow &a = *rows[x], &b = *rows[y];
    if (a.area_mm2 != b.area_mm2) return a.area_mm2 < b.area_mm2;
    if (format_bits(a) != format_bits(b)) return format_bits(a) < format_bits(b);
    return a.p.bvh_width < b.p.bvh_width;
  });
  size_t kept = order.front();
  for (size_t i : order)
    if (i != kept && plan_pays(*rows[i], *rows[kept], o)) kept = i;
  return kept;
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

double plan_rays_per_clock(const SweepRow& r) {
  return r.cycles > 0 ? double(r.rays) / double(r.cycles) : 0.0;
}

double plan_perf_per_area(const SweepRow& r) {
  return r.area_mm2 > 0.0 ? plan_rays_per_clock(r) / r.area_mm2 : 0.0;
}

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
  if (o.minimise == "area") return a.area_mm2 < b.area_mm2 || (a.area_mm2 == b.area_mm2 && a.cycles < b.cycles);
  if (o.minimise == "perf-per-area") {
    const double pa = plan_perf_per_area(a), pb = plan_perf_per_area(b);
    return pa > pb || (pa == pb && a.cycles < b.cycles);
  }
  return a.cycles < b.cycles || (a.cycles == b.cycles && a.bvh_bytes < b.bvh_bytes);
}

double plan_gain(const SweepRow& a, const SweepRow& b, const PlanOptions& o) {
  const auto saving = [](double x, double y) { return y > 0.0 ? 1.0 - x / y : 0.0; };
  if (o.minimise == "energy") return saving(a.pj_per_ray, b.pj_per_ray);
  if (o.minimise == "bytes") return saving(double(a.bvh_bytes), double(b.bvh_bytes));
  if (o.minimise == "area") return saving(a.area_mm2, b.area_mm2);
  if (o.minimise == "perf-per-area") {
    const double pb = plan_perf_per_area(b);
    return pb > 0.0 ? plan_perf_per_area(a) / pb - 1.0 : 0.0;
  }
  return saving(double(a.cycles), double(b.cycles));
}

bool plan_min_gain_applies(const PlanOptions& o) {
  return o.minimise == "cycles" || o.minimise == "energy";
}

bool plan_pays(const SweepRow& candidate, const SweepRow& kept, const PlanOptions& o) {
  if (!plan_cheaper(candidate, kept, o)) return false;
  if (!plan_min_gain_applies(o) || o.min_gain_pct <= 0.0 || !costlier(candidate, kept)) return true;
  return 100.0 * plan_gain(candidate, kept, o) > o.min_gain_pct;
}

std::string plan_passed_over(const SweepRow& costlier, const SweepRow& kept, const PlanOptions& o) {
  if (!plan_cheaper(costlier, kept, o) || plan_pays(costlier, kept, o)) return {};
  return gain_text(costlier, kept, o) + " for " + size_cost(costlier, kept) + ", below --min-gain " +
         g(o.min_gain_pct) + "%";
}

bool plan_more_bits_pay(const SweepRow& more, const SweepRow& fewer, const PlanOptions& o) {
  if (!plan_pays(more, fewer, o)) return false;
  if (o.minimise == "bytes" || o.minimise == "area") return true;  // exact: no placement noise
  // Both overheads are over the same float reference (one scene, one width): a smaller one is fewer visits.
  const bool less_work =
      more.node_visit_overhead < fewer.node_visit_overhead || more.prim_test_overhead < fewer.prim_test_overhead;
  return less_work || plan_gain(more, fewer, o) > kPlacementNoise;
}

std::string plan_more_bits_cause(const SweepRow& more, const SweepRow& fewer, const PlanOptions& o) {
  const std::string saving = gain_text(more, fewer, o) + " for " + size_cost(more, fewer);
  std::vector<std::string> causes;
  // Node visits and primitive tests as overheads over the float reference's (one reference for both rows).
  auto pct = [](double overhead) { return (overhead >= 0.0 ? "+" : "") + g(100.0 * overhead) + "%"; };
  auto work = [&](double m, double f, const char* what) {
    if (m < f)
      causes.push_back(std::string("fewer ") + what + " (" + pct(m) + " over the float reference's, against " +
                       pct(f) + ")");
  };
  work(more.node_visit_overhead, fewer.node_visit_overhead, "node visits");
  work(more.prim_test_overhead, fewer.prim_test_overhead, "primitive tests");
  const bool less_work = !causes.empty();
  if (more.dram_bytes_per_ray < fewer.dram_bytes_per_ray)
    causes.push_back("fewer DRAM bytes per ray (" + g(more.dram_bytes_per_ray) + " against " +
                     g(fewer.dram_bytes_per_ray) + ")" +
                     (less_work ? std::string()
                                : ", with no less traversal work: where the nodes fall on cache lines, which is "
                                  "not monotonic in the bits"));
  std::string why;
  for (size_t i = 0; i < causes.size(); ++i) why += (i ? "; " : "") + causes[i];
  if (why.empty()) why = "no measured cause in node visits, primitive tests or DRAM bytes";
  if (!plan_cheaper(more, fewer, o)) return saving + " (" + why + "): not cheaper, the fewer bits kept";
  if (!plan_pays(more, fewer, o))
    return saving + ", below --min-gain " + g(o.min_gain_pct) + "% (" + why + "): the fewer bits kept";
  if (!plan_more_bits_pay(more, fewer, o))
    return saving + ", within the " + g(100.0 * kPlacementNoise) + "% placement noise (" + why +
           "): a tie, the fewer bits kept";
  return saving + ": " + why;
}

bool plan_meets(const SweepRow& r, const PlanOptions& o) {
  return plan_error_bound(r, o) <= o.max_error && r.box_false_negatives == 0 &&
         (o.min_psnr <= 0.0 || (r.psnr_measured() && r.psnr_db >= o.min_psnr)) &&
         (o.area_budget <= 0.0 || r.area_mm2 <= o.area_budget);
}

double plan_smallest_hit_budget(uint64_t rays_per_kind, double confidence) {
  return proportion_upper_bound(0, 2 * rays_per_kind, confidence);
}

namespace {

// Refuses options no plan can run with.
void check_plan_options(const PlanOptions& a) {
  if (a.metric != "hit" && a.metric != "t") throw Error("--metric: hit or t, got '" + a.metric + "'");
  if (!(a.max_error >= 0.0) || !std::isfinite(a.max_error))
    throw Error("--max-error: a finite number >= 0, got " + g(a.max_error));
  if (!(a.confidence > 0.0 && a.confidence < 1.0))
    throw Error("--confidence: a number in (0, 1), got " + g(a.confidence));
  if (!(a.min_psnr >= 0.0) || !std::isfinite(a.min_psnr))
    throw Error("--min-psnr: a finite number of dB >= 0 (0: none), got " + g(a.min_psnr));
  if (a.min_psnr > 0.0 && a.sweep.image_width <= 0)
    throw Error("--min-psnr needs a render to measure: --image-width must be above 0");
  if (a.minimise != "cycles" && a.minimise != "bytes" && a.minimise != "energy" && a.minimise != "area" &&
      a.minimise != "perf-per-area")
    throw Error("--minimise: cycles, bytes, energy, area or perf-per-area, got '" + a.minimise + "'");
  if (!(a.min_gain_pct >= 0.0 && a.min_gain_pct <= 100.0))
    throw Error("--min-gain: a finite percentage in 0..100, got " + g(a.min_gain_pct));
  if (!(a.area_budget >= 0.0) || !std::isfinite(a.area_budget))
    throw Error("--area-budget: a finite number of mm^2 >= 0 (0: none), got " + g(a.area_budget));
  if (a.sweep.rays < 1 || a.sweep.rays > kMaxPlanRays)
    throw Error("--rays: " + std::to_string(a.sweep.rays) + " is not in 1.." + std::to_string(kMaxPlanRays));
}

// The format whose bits the plan varies: --format, else the configuration's.
struct BaseFormat {
  std::string spec;
  int child_bits = 0;
};

BaseFormat plan_base_format(const PlanOptions& a) {
  BaseFormat b;
  try {
    b.spec = hw::timing_preset(a.config).format;
  } catch (const std::invalid_argument& e) {
    throw Error(std::string("--config: ") + e.what());
  }
  if (!a.format.empty()) b.spec = a.format;
  try {
    b.child_bits = hw::format_from_spec(b.spec).child_bits;
  } catch (const std::invalid_argument& e) {
    throw Error(std::string("--format: ") + e.what());
  }
  return b;
}

// Zero disagreements on every ray is the best a candidate can show; below that bound no format can meet the
// budget, however good. Below the bound on the most rays --rays allows no run can: refused as such (a budget of 0
// would need infinitely many rays). Else the rays that can show it, (1 - p)^n = 1 - confidence solved for n.
void check_hit_budget_can_be_shown(const PlanOptions& a) {
  if (a.metric != "hit") return;
  const uint64_t sample = 2 * a.sweep.rays;
  const double smallest = plan_smallest_hit_budget(kMaxPlanRays, a.confidence);
  if (a.max_error < smallest)
    throw Error("--max-error " + g(a.max_error) + " is below the smallest hit disagreement a plan can show, " +
                g(smallest) + " (the " + g(100.0 * a.confidence) +
                "% upper bound with no disagreement at all on " + std::to_string(2 * kMaxPlanRays) +
                " rays, the most --rays " + std::to_string(kMaxPlanRays) + " gives): give --max-error " +
                g(smallest) + " or more, or --metric t");
  const double here = plan_smallest_hit_budget(a.sweep.rays, a.confidence);
  if (here > a.max_error) {
    const double n = std::log(1.0 - a.confidence) / std::log1p(-a.max_error);  // sample size, both kinds
    uint64_t need = std::min<uint64_t>(kMaxPlanRays, uint64_t(std::ceil(n / 2.0)));
    while (need < kMaxPlanRays && plan_smallest_hit_budget(need, a.confidence) > a.max_error) ++need;
    throw Error("--max-error " + g(a.max_error) + " cannot be shown on " + std::to_string(sample) +
                " rays: with no disagreement at all the " + g(100.0 * a.confidence) + "% upper bound is " +
                g(here) + "; use --rays " + std::to_string(need) + " or more");
  }
}

// Runs the plan's candidates on its scene and tells the progress callback of each.
class Planner {
 public:
  Planner(const PlanOptions& a, const std::function<void(const PlanStep&)>& progress)
      : m_a(a),
        m_progress(progress),
        m_scene(load_scene(a.scene)),
        m_area(a.area.empty() ? AreaTable::shipped() : AreaTable::load(a.area)),
        m_activity(ActivityTable::shipped()),
        m_cache(make_sweep_cache()) {}

  const Scene& scene() const { return m_scene; }

  void report(PlanStage stage, int width, int coord_bits = 0, const SweepRow* row = nullptr,
              bool meets = false) const {
    if (m_progress) m_progress(PlanStep{stage, width, coord_bits, row, meets});
  }

  bool meets(const SweepRow& r) const { return plan_meets(r, m_a); }

  // The format at a width, on the configuration (with the units the area budget affords).
  SweepRow point(const std::string& format, int width) {
    if (m_a.sweep.poll) m_a.sweep.poll();
    SweepRow r =
        run_sweep_point(m_scene, SweepPoint{m_a.scene, format, width, m_a.config}, m_a.sweep, m_area, *m_cache);
    if (m_a.area_budget > 0.0) r = afford(r);
    report(PlanStage::kCandidate, width, 0, &r, meets(r));
    m_measured.push_back(r);
    return r;
  }

  // Every candidate measured, in order.
  const std::vector<SweepRow>& measured() const { return m_measured; }

 private:
  // The area of a format at a width with a configuration spec, without running it.
  double area_of(const std::string& format, int width, const std::string& config) const {
    hw::FixedFormat f = hw::format_from_spec(format);
    f.width = width;
    hw::TimingConfig c = sweep_config(config);
    hw::set_timing_key(c, "bvh_width", std::to_string(width));
    return hw::area_report(c, cost_inputs(f, c, m_area, m_activity)).total_mm2;
  }

  // Iso-area: one more box or triangle unit at a time, the cheaper of the two that fit, while it is cheaper.
  SweepRow afford(SweepRow cur) {
    const hw::TimingConfig preset = hw::timing_preset(m_a.config);
    int box = preset.box_units, tri = preset.tri_units;
    while (cur.area_mm2 <= m_a.area_budget) {
      std::unique_ptr<SweepRow> next;
      for (const auto& [nb, nt] : {std::pair{box + 1, tri}, std::pair{box, tri + 1}}) {
        if (nb > 64 || nt > 64) continue;
        const std::string config =
            m_a.config + ":box_units=" + std::to_string(nb) + ":tri_units=" + std::to_string(nt);
        if (area_of(cur.p.format, cur.p.bvh_width, config) > m_a.area_budget) continue;
        SweepRow r = retime_sweep_point(m_scene, cur, config, m_a.sweep, m_area, *m_cache);
        if (!next || plan_cheaper(r, *next, m_a)) next = std::make_unique<SweepRow>(r);
      }
      if (!next || !plan_cheaper(*next, cur, m_a)) break;
      cur = *next;
      const hw::TimingConfig c = sweep_config(cur.p.config);
      box = c.box_units, tri = c.tri_units;
    }
    return cur;
  }

  const PlanOptions& m_a;
  const std::function<void(const PlanStep&)>& m_progress;
  const Scene m_scene;
  const AreaTable m_area;
  const ActivityTable m_activity;
  std::unique_ptr<SweepCache, SweepCacheDeleter> m_cache;
  std::vector<SweepRow> m_measured;
};

// What the plan was asked: the JSON's keys before the widths.
Json plan_request_json(const PlanOptions& a, const std::string& scene, const std::string& base) {
  Json j;
  j["scene"] = scene;
  j["metric"] = a.metric == "t" ? "t_rel_error_mean" : "hit_disagreement";
  j["max_error"] = a.max_error;
  j["confidence"] = a.confidence;
  j["seed"] = a.sweep.seed;
  j["rays"] = 2 * a.sweep.rays;
  j["min_psnr"] = a.min_psnr;
  j["flatten"] = a.sweep.flatten;
  j["config"] = a.config;
  j["base_format"] = base;
  j["minimise"] = a.minimise;
  j["cost"] = a.minimise == "bytes"           ? "image bytes (bvh_bytes), then cycles on " + a.config
              : a.minimise == "energy"        ? "energy per ray on " + a.config + ", then cycles"
              : a.minimise == "area"          ? "area (area_mm2), then cycles on " + a.config
              : a.minimise == "perf-per-area" ? "rays per clock per mm^2 on " + a.config + ", then cycles"
                                              : "cycles on " + a.config + ", then image bytes (bvh_bytes)";
  j["min_gain_pct"] = a.min_gain_pct;
  j["min_gain_applies"] = plan_min_gain_applies(a);
  if (a.area_budget > 0.0) j["area_budget_mm2"] = a.area_budget;
  return j;
}

// The fewest coordinate bits that meet the budget at a width (error falls with bits; the first that meets is
// taken), and the candidate just below it.
struct FewestBits {
  std::unique_ptr<SweepRow> first_ok, last_bad;
};

FewestBits fewest_coord_bits(Planner& pl, const PlanOptions& a, const BaseFormat& base, int w) {
  FewestBits f;
  for (int b : a.coord_bits) {
    SweepRow r = pl.point(spec(base.spec, b, base.child_bits), w);
    if (pl.meets(r)) {
      f.first_ok = std::make_unique<SweepRow>(r);
      break;
    }
    f.last_bad = std::make_unique<SweepRow>(r);
  }
  return f;
}

// Fewer coordinate bits are fewer bytes and less area, but not always fewer cycles or less energy: they cost node
// visits (looser boxes) where they save bytes, so on a compute-bound unit more bits can be faster. Minimising
// cycles, energy or rays per clock per mm^2, the bits above go on while they meet the budget and each is cheaper
// than the one before (cost against bits falls, then rises). Each is weighed against the bits kept so far and
// taken when it pays: beyond --min-gain and the placement noise (plan_more_bits_pay); so a run of small steps
// that together save more than --min-gain is taken at the step that crosses it. Each step weighed, with its
// measured cause, goes to `steps`. Returns the candidate kept.
SweepRow walk_more_coord_bits(Planner& pl, const PlanOptions& a, const BaseFormat& base, int w,
                              const SweepRow& first_ok, Json& steps) {
  SweepRow kept = first_ok;
  if (a.minimise == "bytes" || a.minimise == "area") return kept;  // more bits never take fewer
  SweepRow prev = first_ok;
  const int b0 = hw::format_from_spec(first_ok.p.format).coord_bits;
  for (int more : a.coord_bits) {
    if (more <= b0) continue;
    SweepRow r = pl.point(spec(base.spec, more, base.child_bits), w);
    if (!pl.meets(r) || !plan_cheaper(r, prev, a)) break;
    const bool pays = plan_more_bits_pay(r, kept, a);
    steps.push_back({{"from_coord_bits", hw::format_from_spec(kept.p.format).coord_bits},
                     {"to_coord_bits", more},
                     {"taken", pays},
                     {"cause", plan_more_bits_cause(r, kept, a)},
                     {"gain", plan_gain(r, kept, a)},
                     {"node_visit_overhead", {kept.node_visit_overhead, r.node_visit_overhead}},
                     {"prim_test_overhead", {kept.prim_test_overhead, r.prim_test_overhead}},
                     {"dram_bytes_per_ray", {kept.dram_bytes_per_ray, r.dram_bytes_per_ray}},
                     {"cycles", {kept.cycles, r.cycles}},
                     {"area_mm2", {kept.area_mm2, r.area_mm2}},
                     {"perf_per_mm2", {plan_perf_per_area(kept), plan_perf_per_area(r)}}});
    if (pays) kept = r;
    prev = r;
  }
  return kept;
}

// Child-offset bits at b coordinate bits: among those that still meet the budget (and at_b, which does), the one
// keep_by_size keeps; each candidate's figures into `ks`, with why when it was cheaper and not taken
// ("passed_over").
SweepRow cheapest_child_bits(Planner& pl, const PlanOptions& a, const BaseFormat& base, int w, int b,
                             const SweepRow& at_b, Json& ks) {
  std::vector<SweepRow> rows;
  for (int k : a.child_bits) rows.push_back(k == base.child_bits ? at_b : pl.point(spec(base.spec, b, k), w));
  std::vector<const SweepRow*> ok{&at_b};
  for (const SweepRow& r : rows)
    if (pl.meets(r)) ok.push_back(&r);
  const SweepRow chosen = *ok[keep_by_size(ok, a)];
  for (size_t i = 0; i < rows.size(); ++i) {
    const SweepRow& r = rows[i];
    Json k = {{"child_bits", a.child_bits[i]},
              {"error", plan_error(r, a.metric)},
              {"error_bound", plan_error_bound(r, a)},
              {"cycles", r.cycles},
              {"bytes", r.bvh_bytes},
              {"bytes_per_prim", r.bytes_per_prim},
              {"dram_bytes_per_ray", r.dram_bytes_per_ray},
              {"config", r.p.config},
              {"area_mm2", r.area_mm2},
              {"pj_per_ray", r.pj_per_ray},
              {"rays_per_clock", plan_rays_per_clock(r)},
              {"perf_per_mm2", plan_perf_per_area(r)},
              {"meets", pl.meets(r)}};
    if (pl.meets(r))
      if (const std::string why = plan_passed_over(r, chosen, a); !why.empty()) k["passed_over"] = why;
    ks.push_back(k);
  }
  return chosen;
}

// A measured row's figures as the plan's JSON gives them, in its order: cycles to the error bound, the measured
// PSNR (with `psnr`), the RTL cells and the configuration.
void add_measured(Json& j, const SweepRow& r, const PlanOptions& a, bool psnr) {
  j["cycles"] = r.cycles;
  j["bytes"] = r.bvh_bytes;
  j["bytes_per_prim"] = r.bytes_per_prim;
  j["dram_bytes_per_ray"] = r.dram_bytes_per_ray;
  j["error"] = plan_error(r, a.metric);
  j["error_bound"] = plan_error_bound(r, a);
  if (psnr) j["psnr_db"] = r.psnr_measured() ? Json(r.psnr_db) : Json(nullptr);
  j["rtl_cells"] = r.rtl_cells;
  j["config"] = r.p.config;
}

// A measured row's costs: area, energy per ray, rays per clock and per clock and mm^2.
void add_costs(Json& j, const SweepRow& r) {
  j["area_mm2"] = r.area_mm2;
  j["pj_per_ray"] = r.pj_per_ray;
  j["rays_per_clock"] = plan_rays_per_clock(r);
  j["perf_per_mm2"] = plan_perf_per_area(r);
}

// A measured candidate, as the JSON's width's "candidates".
Json candidate_json(const SweepRow& r, const PlanOptions& a, bool meets) {
  const hw::FixedFormat f = hw::format_from_spec(r.p.format);
  Json j = {{"format", r.p.format},
            {"coord_bits", f.coord_bits},
            {"child_bits", f.child_bits},
            {"config", r.p.config},
            {"cycles", r.cycles},
            {"bytes", r.bvh_bytes},
            {"error", plan_error(r, a.metric)},
            {"error_bound", plan_error_bound(r, a)}};
  add_costs(j, r);
  j["meets"] = meets;
  return j;
}

// The format chosen at a width, as the JSON's "chosen".
Json chosen_json(const SweepRow& c, const PlanOptions& a) {
  Json j = {{"format", c.p.format}};
  add_measured(j, c, a, true);
  add_costs(j, c);
  return j;
}

// One width of the plan: its candidates into the JSON jw, and the format chosen there (none when no coordinate
// width meets the budget).
std::unique_ptr<SweepRow> plan_width(Planner& pl, const PlanOptions& a, const BaseFormat& base, int w, Json& jw) {
  pl.report(PlanStage::kCoordBits, w);
  const size_t first_measured = pl.measured().size();
  const auto list_candidates = [&] {
    Json cs = Json::array();
    for (size_t i = first_measured; i < pl.measured().size(); ++i)
      cs.push_back(candidate_json(pl.measured()[i], a, pl.meets(pl.measured()[i])));
    jw["candidates"] = cs;
  };
  const FewestBits fewest = fewest_coord_bits(pl, a, base, w);
  jw["bvh_width"] = w;
  if (!fewest.first_ok) {
    jw["feasible"] = false;
    list_candidates();
    pl.report(PlanStage::kInfeasible, w);
    return nullptr;
  }
  const SweepRow& first_ok = *fewest.first_ok;
  Json steps = Json::array();
  const SweepRow at_b = walk_more_coord_bits(pl, a, base, w, first_ok, steps);
  const int b = hw::format_from_spec(at_b.p.format).coord_bits;
  pl.report(PlanStage::kChildBits, w, b);
  Json ks = Json::array();
  const SweepRow chosen = cheapest_child_bits(pl, a, base, w, b, at_b, ks);
  jw["feasible"] = true;
  jw["coord_bits"] = hw::format_from_spec(first_ok.p.format).coord_bits;
  jw["chosen_coord_bits"] = b;
  jw["more_coord_bits"] = steps;
  jw["error_at_coord_bits"] = plan_error(first_ok, a.metric);
  jw["error_bound_at_coord_bits"] = plan_error_bound(first_ok, a);
  if (const SweepRow* last_bad = fewest.last_bad.get()) {
    jw["fewer_coord_bits"] = hw::format_from_spec(last_bad->p.format).coord_bits;
    jw["error_at_fewer_coord_bits"] = plan_error(*last_bad, a.metric);
    jw["error_bound_at_fewer_coord_bits"] = plan_error_bound(*last_bad, a);
  }
  jw["child_bits"] = ks;
  jw["chosen"] = chosen_json(chosen, a);
  list_candidates();
  return std::make_unique<SweepRow>(chosen);
}

// The plan's format, as the JSON's "plan".
Json plan_json(const SweepRow& best, const hw::FixedFormat& f, const PlanOptions& a) {
  Json j = {{"format", best.p.format},
            {"bvh_width", best.p.bvh_width},
            {"coord_bits", f.coord_bits},
            {"child_bits", f.child_bits}};
  add_measured(j, best, a, true);
  j["box_units"] = sweep_config(best.p.config).box_units;
  j["tri_units"] = sweep_config(best.p.config).tri_units;
  add_costs(j, best);
  return j;
}

// The base format at the plan's width, as the JSON's "default".
Json default_json(const SweepRow& def, const std::string& base, const PlanOptions& a) {
  Json j = {{"format", base}};
  add_measured(j, def, a, false);
  add_costs(j, def);
  return j;
}

}  // namespace

PlanResult plan_format(const PlanOptions& a, const std::function<void(const PlanStep&)>& progress) {
  check_plan_options(a);
  const BaseFormat base = plan_base_format(a);
  check_hit_budget_can_be_shown(a);
  check_sweep_rays("plan", a.sweep.rays);
  Planner pl(a, progress);

  PlanResult res;
  res.scene = pl.scene().name;
  Json& j = res.json;
  j = plan_request_json(a, pl.scene().name, base.spec);
  Json per_width = Json::array();
  std::vector<std::unique_ptr<SweepRow>> chosen;  // per width; null where none meets the budget
  for (int w : a.widths) {
    Json jw;
    chosen.push_back(plan_width(pl, a, base, w, jw));
    per_width.push_back(jw);
  }
  std::vector<const SweepRow*> feasible;
  for (const auto& c : chosen)
    if (c) feasible.push_back(c.get());
  if (feasible.empty()) {
    j["widths"] = per_width;
    j["plan"] = nullptr;
    return res;
  }
  // The width: of each width's choice, the one keep_by_size keeps; a cheaper width not taken says why.
  const SweepRow best = *feasible[keep_by_size(feasible, a)];
  for (size_t i = 0; i < chosen.size(); ++i)
    if (chosen[i])
      if (const std::string why = plan_passed_over(*chosen[i], best, a); !why.empty())
        per_width[i]["passed_over"] = why;
  j["widths"] = per_width;
  // The base format at the chosen width, for comparison.
  pl.report(PlanStage::kDefault, best.p.bvh_width);
  const SweepRow def = pl.point(base.spec, best.p.bvh_width);
  const hw::FixedFormat f = hw::format_from_spec(best.p.format);
  j["plan"] = plan_json(best, f, a);
  j["default"] = default_json(def, base.spec, a);
  res.found = true;
  res.best = best;
  res.format = f;
  res.reference = def;
  return res;
}

}  // namespace rtu::host
