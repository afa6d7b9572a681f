// rtusim plan: the cheapest format for a scene within an error budget (host/jobs/plan.h); prints each candidate as
// it is measured and the plan with why it was chosen.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/jobs/plan.h"
#include "hwmodel/cost/energy_model.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host::cli {

namespace {

// Refuses NaN and infinities, which CLI::Range lets through (NaN compares false with both ends), naming the
// option in CLI11's message.
const CLI::Validator kFinite(
    [](std::string& s) {
      double v = 0.0;
      return CLI::detail::lexical_cast(s, v) && std::isfinite(v) ? std::string()
                                                                 : "'" + s + "' is not a finite number";
    },
    "FINITE");

// A percentage as the plan prints it ("2%", "0.5%").
std::string format_pct(double pct) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g%%", pct);
  return buf;
}

struct PlanArgs {
  PlanOptions o;
  std::string json;
};

void print_step(const PlanStep& s, const PlanOptions& a) {
  switch (s.stage) {
    case PlanStage::kCoordBits:
      std::printf("width %d: coordinate bits, fewest first (the format's child bits)\n", s.width);
      break;
    case PlanStage::kCandidate: {
      const SweepRow& r = *s.row;
      char psnr[48] = "";  // no render, no PSNR
      if (r.psnr_measured()) std::snprintf(psnr, sizeof psnr, ", PSNR %.1f dB", r.psnr_db);
      char units[96] = "";  // with an area budget: the units the candidate affords
      if (a.area_budget > 0) {
        const hw::TimingConfig c = sweep_config(r.p.config);
        std::snprintf(units, sizeof units, ", %d box + %d tri units", c.box_units, c.tri_units);
      }
      std::printf(
          "  %-40s w%d: %s %.3g (%g%% bound %.3g)%s, %llu cycles, %llu bytes (%.1f per primitive), %.3f mm^2%s, "
          "%.0f pJ/ray, %.4g rays/clock/mm^2%s\n",
          r.p.format.c_str(), s.width, a.metric == "t" ? "t error" : "hit disagreement", plan_error(r, a.metric),
          100.0 * a.confidence, plan_error_bound(r, a), psnr, (unsigned long long)r.cycles,
          (unsigned long long)r.bvh_bytes, r.bytes_per_prim, r.area_mm2, units, r.pj_per_ray,
          plan_perf_per_area(r), s.meets ? "" : "  (over budget)");
      std::fflush(stdout);
      break;
    }
    case PlanStage::kInfeasible:
      std::printf("  no coordinate width meets the budget at width %d\n", s.width);
      break;
    case PlanStage::kChildBits:
      std::printf("width %d, %d coordinate bits: child-offset bits\n", s.width, s.coord_bits);
      break;
    case PlanStage::kDefault:
      std::printf("the base format at width %d, for comparison\n", s.width);
      break;
  }
}

void run_plan(const PlanArgs& args) {
  check_output_files({args.json});
  const PlanOptions& a = args.o;
  const PlanResult res = plan_format(a, [&](const PlanStep& s) { print_step(s, a); });
  const Json& j = res.json;
  if (!res.found) {
    if (!args.json.empty()) write_json(args.json, j);
    std::printf("plan: no format meets %s <= %g on %s\n", a.metric.c_str(), a.max_error, res.scene.c_str());
    throw ExitStatus(1);
  }
  const SweepRow* best = &res.best;
  const SweepRow& def = res.reference;
  const hw::FixedFormat& f = res.format;
  const hw::FixedFormat base = hw::format_from_spec(def.p.format);
  const char* metric = a.metric == "t" ? "t error" : "hit disagreement";
  std::printf(
      "plan for %s (%s <= %g at %g%% confidence%s; seed %llu, %llu rays%s): %s at BVH width %d: %d coordinate "
      "bits, "
      "%d child-offset bits; %llu cycles, %llu bytes (%.1f per primitive, %.1f DRAM bytes per ray), %s %.3g "
      "(bound %.3g)\n",
      res.scene.c_str(), metric, a.max_error, 100.0 * a.confidence,
      a.min_psnr > 0 ? (", PSNR >= " + std::to_string(a.min_psnr)).c_str() : "", (unsigned long long)a.sweep.seed,
      (unsigned long long)(2 * a.sweep.rays), a.sweep.flatten ? ", instanced scene flattened" : "",
      best->p.format.c_str(), best->p.bvh_width, f.coord_bits, f.child_bits, (unsigned long long)best->cycles,
      (unsigned long long)best->bvh_bytes, best->bytes_per_prim, best->dram_bytes_per_ray, metric,
      plan_error(*best, a.metric), plan_error_bound(*best, a));
  std::printf(
      "  cheapest: %s%s%s\n", j["cost"].get<std::string>().c_str(),
      a.area_budget > 0 ? (" within " + std::to_string(a.area_budget) + " mm^2").c_str() : "",
      plan_min_gain_applies(a) && a.min_gain_pct > 0
          ? ("; more bits or area only for a saving over " + format_pct(a.min_gain_pct) + " (--min-gain)").c_str()
          : "");
  std::printf(
      "  units: %d box, %d triangle (%s); %.3f mm^2, %.0f pJ per ray (%s); %.4g rays per clock, %.4g per mm^2\n",
      j["plan"]["box_units"].get<int>(), j["plan"]["tri_units"].get<int>(), best->p.config.c_str(), best->area_mm2,
      best->pj_per_ray, hw::nangate45().name, plan_rays_per_clock(*best), plan_perf_per_area(*best));
  for (const Json& jw : j["widths"]) {
    if (jw["bvh_width"] != best->p.bvh_width) continue;
    if (jw.contains("fewer_coord_bits"))
      std::printf("  why %d coordinate bits at least: %d give %s %.3g (bound %.3g) > %g\n",
                  jw["coord_bits"].get<int>(), jw["fewer_coord_bits"].get<int>(), metric,
                  jw["error_at_fewer_coord_bits"].get<double>(),
                  jw["error_bound_at_fewer_coord_bits"].get<double>(), a.max_error);
    // Each step up the coordinate bits the plan weighed, with its measured cause (plan_more_bits_cause).
    for (const Json& m : jw["more_coord_bits"])
      std::printf("  %s %d coordinate bits over %d on %s: %s\n", m["taken"].get<bool>() ? "took" : "kept",
                  m["taken"].get<bool>() ? m["to_coord_bits"].get<int>() : m["from_coord_bits"].get<int>(),
                  m["taken"].get<bool>() ? m["from_coord_bits"].get<int>() : m["to_coord_bits"].get<int>(),
                  a.config.c_str(), m["cause"].get<std::string>().c_str());
    // Child-offset bits that were cheaper but saved too little for their size (plan_passed_over).
    for (const Json& k : jw["child_bits"])
      if (k.contains("passed_over"))
        std::printf("  kept %d child-offset bits over %d on %s: %s\n", f.child_bits, k["child_bits"].get<int>(),
                    a.config.c_str(), k["passed_over"].get<std::string>().c_str());
  }
  for (const Json& jw : j["widths"])
    if (jw.contains("passed_over"))
      std::printf("  kept BVH width %d over %d on %s: %s\n", best->p.bvh_width, jw["bvh_width"].get<int>(),
                  a.config.c_str(), jw["passed_over"].get<std::string>().c_str());
  std::printf(
      "  against the base format (%s: %d coordinate bits, %d child bits%s): %+.1f%% cycles, %+.1f%% bytes, "
      "%+.1f%% energy per ray\n",
      def.p.format.c_str(), base.coord_bits, base.child_bits,
      a.area_budget > 0 ? (", " + def.p.config + " in the same area").c_str() : "",
      100.0 * (double(best->cycles) / double(std::max<uint64_t>(def.cycles, 1)) - 1.0),
      100.0 * (double(best->bvh_bytes) / double(std::max<uint64_t>(def.bvh_bytes, 1)) - 1.0),
      100.0 * (best->pj_per_ray / std::max(def.pj_per_ray, 1e-30) - 1.0));
  if (best->rtl_cells >= 0 && def.rtl_cells >= 0)
    std::printf("  RTL box unit: %lld cells against %lld for the base format (%+.1f%%)\n",
                (long long)best->rtl_cells, (long long)def.rtl_cells,
                100.0 * (double(best->rtl_cells) / double(def.rtl_cells) - 1.0));
  if (!args.json.empty()) write_json(args.json, j);
}

}  // namespace

void add_plan(CLI::App& app) {
  const auto [sub, a] = add_command<PlanArgs>(
      app, "plan",
      "The cheapest format (by --minimise: fewest cycles on --config, fewest image bytes, least energy, "
      "smallest area or most rays per clock per mm^2; coordinate bits, offset bits, BVH width; with "
      "--area-budget the units it affords) whose error's upper confidence bound meets a budget on a scene",
      [](PlanArgs& a, CLI::App&) { run_plan(a); });
  sub->add_option("--scene", a->o.scene, "scene file, mesh file or builtin:NAME")->required();
  sub->add_option("--max-error", a->o.max_error, "error budget of --metric")->required()->check(kFinite);
  sub->add_option("--metric", a->o.metric,
                  "hit: fraction of rays whose hit/miss differs from float; t: mean relative t error")
      ->check(CLI::IsMember({"hit", "t"}))
      ->capture_default_str();
  sub->add_option("--min-psnr", a->o.min_psnr, "also require the render's PSNR against float (dB; 0: no)")
      ->check(kFinite)
      ->capture_default_str();
  sub->add_option("--confidence", a->o.confidence,
                  "confidence of the error's upper bound that must meet the budget (hit: Clopper-Pearson; t: "
                  "normal approximation of the mean)")
      ->check(kFinite & CLI::Range(0.5, 0.999999))
      ->capture_default_str();
  sub->add_option("--seed", a->o.sweep.seed, "seed of the incoherent rays (another seed, another sample)")
      ->capture_default_str();
  sub->add_option("--config", a->o.config,
                  "timing preset whose cycles are the cost; its format is the one whose bits the plan varies "
                  "(unless --format)")
      ->check(CLI::IsMember(hw::timing_preset_names()))
      ->capture_default_str();
  sub->add_option("--format", a->o.format,
                  "base format spec whose coordinate and child bits the plan varies, every other field (storage "
                  "layouts too) kept, e.g. packed or cwbvh (default: the --config's format)");
  sub->add_option("--minimise,--minimize", a->o.minimise,
                  "the cost: cycles (fewest cycles on --config, then fewest image bytes), bytes (fewest image "
                  "bytes, bvh_bytes, then fewest cycles), energy (fewest pJ per ray, then fewest cycles), area "
                  "(smallest area_mm2, then fewest cycles) or perf-per-area (most rays per clock per mm^2, then "
                  "fewest cycles)")
      ->check(CLI::IsMember({"cycles", "bytes", "energy", "area", "perf-per-area"}))
      ->capture_default_str();
  sub->add_option("--min-gain", a->o.min_gain_pct,
                  "PCT: minimising cycles or energy, a candidate with more bits or area is taken over a smaller "
                  "one only when it saves more than PCT% (0: any saving). Default 2: the timing model is "
                  "deterministic, but its cycles are of a sample of rays and it is cycle-approximate; one "
                  "format's saving over another moves by about a point from one --seed to the next, so a "
                  "smaller saving is not shown, while the bits cost area for certain")
      ->check(kFinite & CLI::Range(0.0, 100.0))
      ->capture_default_str();
  sub->add_flag_callback(
      "--energy", [a = a] { a->o.minimise = "energy"; }, "the same as --minimise energy");
  sub->add_option("--area-budget", a->o.area_budget,
                  "iso-area design: the unit's area budget in mm^2 (45 nm estimate); each candidate gets the box "
                  "and triangle units it affords, so a narrower format can buy more units (0: none)")
      ->check(kFinite & CLI::Range(0.0, 1e6))
      ->capture_default_str();
  sub->add_option("--bvh-width", a->o.widths, "BVH widths to consider, comma-separated")
      ->delimiter(',')
      ->check(CLI::IsMember({2, 4, 6, 8}))
      ->capture_default_str();
  sub->add_option("--coord-bits", a->o.coord_bits, "coordinate bits to try, fewest first, comma-separated")
      ->delimiter(',')
      ->check(CLI::Range(2, 30))
      ->capture_default_str();
  sub->add_option("--child-bits", a->o.child_bits, "child-offset bits to try, comma-separated")
      ->delimiter(',')
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  sub->add_option("--rays", a->o.sweep.rays, "camera rays and as many incoherent rays per candidate")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 26))
      ->capture_default_str();
  sub->add_option("--image-width", a->o.sweep.image_width, "width of the PSNR render (0: none)")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  sub->add_option("--threads", a->o.sweep.threads, "worker threads (0 = all cores)")
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("--flatten", a->o.sweep.flatten,
                "fixed and timed devices: trace an instanced scene's flattened geometry in one image instead of "
                "its two levels (the float reference keeps them); in the JSON's flatten");
  sub->add_option(
         "--area", a->o.area,
         "RTL area table for the rtl_cells and area figures (default: the shipped bench/data/rtl_area.csv)")
      ->check(CLI::ExistingFile);
  sub->add_option("--json", a->json, "write the plan and every candidate's figures as JSON");
}

}  // namespace rtu::host::cli
