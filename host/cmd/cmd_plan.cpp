// rtusim plan: the cheapest format for a scene within an error budget. Skips the bits a scene does not need:
// per BVH width, the fewest coordinate bits whose error meets the budget, then the child-offset bits with the
// fewest cycles, then the width with the fewest cycles (bytes break ties). Every candidate is a sweep point
// (host/sweep.h): the same error, cycles and bytes as `rtusim sweep`.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "host/cmd/common.h"
#include "host/error.h"
#include "host/sweep.h"
#include "hwmodel/fixed_format.h"
#include "hwmodel/timing_config.h"

namespace rtu::host::cmd {

namespace {

struct PlanArgs {
  std::string scene, metric = "hit", config = "rdna2", json, area;
  double max_error = 1e-4, min_psnr = 0.0;
  std::vector<int> widths{2, 4, 8}, coord_bits{8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28}, child_bits{4, 6, 8, 12};
  SweepOptions opt;
};

double error_of(const SweepRow& r, const std::string& metric) {
  return metric == "t" ? r.t_rel_error_mean : std::max(r.hit_disagreement(), 0.0);
}

std::string spec(int b, int k) {
  return "default:coord_bits=" + std::to_string(b) + ":child_bits=" + std::to_string(k);
}

void run_plan(const PlanArgs& a) {
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
  auto meets = [&](const SweepRow& r) {
    return error_of(r, a.metric) <= a.max_error && r.box_false_negatives == 0 &&
           (a.min_psnr <= 0.0 || r.psnr_db >= a.min_psnr);
  };
  auto point = [&](const std::string& format, int width) {
    const SweepRow r = run_sweep_point(scene, SweepPoint{a.scene, format, width, a.config}, a.opt, area, *cache);
    std::printf("  %-40s w%d: %s %.3g, PSNR %.1f dB, %llu cycles, %llu bytes%s\n", format.c_str(), width,
                a.metric == "t" ? "t error" : "hit disagreement", error_of(r, a.metric), r.psnr_db,
                (unsigned long long)r.cycles, (unsigned long long)r.bvh_bytes, meets(r) ? "" : "  (over budget)");
    std::fflush(stdout);
    return r;
  };

  Json j;
  j["scene"] = scene.name;
  j["metric"] = a.metric == "t" ? "t_rel_error_mean" : "hit_disagreement";
  j["max_error"] = a.max_error;
  j["min_psnr"] = a.min_psnr;
  j["config"] = a.config;
  Json per_width = Json::array();
  std::unique_ptr<SweepRow> best;
  for (int w : a.widths) {
    std::printf("width %d: coordinate bits, fewest first (child bits 8)\n", w);
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
      std::printf("  no coordinate width meets the budget at width %d\n", w);
      continue;
    }
    const int b = hw::format_from_spec(first_ok->p.format).coord_bits;
    // Child-offset bits: the fewest cycles among those that still meet the budget.
    std::printf("width %d, %d coordinate bits: child-offset bits\n", w, b);
    SweepRow chosen = *first_ok;
    Json ks = Json::array();
    for (int k : a.child_bits) {
      SweepRow r = k == 8 ? *first_ok : point(spec(b, k), w);
      ks.push_back({{"child_bits", k},
                    {"error", error_of(r, a.metric)},
                    {"cycles", r.cycles},
                    {"bytes", r.bvh_bytes},
                    {"meets", meets(r)}});
      if (meets(r) && (r.cycles < chosen.cycles || (r.cycles == chosen.cycles && r.bvh_bytes < chosen.bvh_bytes)))
        chosen = r;
    }
    jw["feasible"] = true;
    jw["coord_bits"] = b;
    jw["error_at_coord_bits"] = error_of(*first_ok, a.metric);
    if (last_bad) {
      jw["fewer_coord_bits"] = hw::format_from_spec(last_bad->p.format).coord_bits;
      jw["error_at_fewer_coord_bits"] = error_of(*last_bad, a.metric);
    }
    jw["child_bits"] = ks;
    jw["chosen"] = {{"format", chosen.p.format}, {"cycles", chosen.cycles},
                    {"bytes", chosen.bvh_bytes}, {"error", error_of(chosen, a.metric)},
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
    if (!a.json.empty()) write_json(a.json, j);
    std::printf("plan: no format meets %s <= %g on %s\n", a.metric.c_str(), a.max_error, scene.name.c_str());
    throw ExitStatus(1);
  }
  std::printf("default format at width %d, for comparison\n", best->p.bvh_width);
  const SweepRow def = point("default", best->p.bvh_width);
  const hw::FixedFormat f = hw::format_from_spec(best->p.format);
  j["plan"] = {
      {"format", best->p.format},           {"bvh_width", best->p.bvh_width}, {"coord_bits", f.coord_bits},
      {"child_bits", f.child_bits},         {"cycles", best->cycles},         {"bytes", best->bvh_bytes},
      {"error", error_of(*best, a.metric)}, {"psnr_db", best->psnr_db},       {"rtl_cells", best->rtl_cells}};
  j["default"] = {{"cycles", def.cycles},
                  {"bytes", def.bvh_bytes},
                  {"error", error_of(def, a.metric)},
                  {"rtl_cells", def.rtl_cells}};
  std::printf(
      "plan for %s (%s <= %g%s, %s): %s at BVH width %d: %d coordinate bits, %d child-offset bits; %llu cycles, "
      "%llu bytes, error %.3g\n",
      scene.name.c_str(), a.metric == "t" ? "t error" : "hit disagreement", a.max_error,
      a.min_psnr > 0 ? (", PSNR >= " + std::to_string(a.min_psnr)).c_str() : "", a.config.c_str(),
      best->p.format.c_str(), best->p.bvh_width, f.coord_bits, f.child_bits, (unsigned long long)best->cycles,
      (unsigned long long)best->bvh_bytes, error_of(*best, a.metric));
  for (const Json& jw : per_width)
    if (jw["bvh_width"] == best->p.bvh_width && jw.contains("fewer_coord_bits"))
      std::printf("  why %d coordinate bits: %d give %s %.3g > %g\n", jw["coord_bits"].get<int>(),
                  jw["fewer_coord_bits"].get<int>(), a.metric == "t" ? "t error" : "hit disagreement",
                  jw["error_at_fewer_coord_bits"].get<double>(), a.max_error);
  std::printf("  against the default format (24 coordinate bits, 8 child bits): %+.1f%% cycles, %+.1f%% bytes\n",
              100.0 * (double(best->cycles) / double(std::max<uint64_t>(def.cycles, 1)) - 1.0),
              100.0 * (double(best->bvh_bytes) / double(std::max<uint64_t>(def.bvh_bytes, 1)) - 1.0));
  if (best->rtl_cells >= 0 && def.rtl_cells >= 0)
    std::printf("  RTL box unit: %lld cells against %lld for the default format (%+.1f%%)\n",
                (long long)best->rtl_cells, (long long)def.rtl_cells,
                100.0 * (double(best->rtl_cells) / double(def.rtl_cells) - 1.0));
  if (!a.json.empty()) write_json(a.json, j);
}

}  // namespace

void add_plan(CLI::App& app) {
  auto a = std::make_shared<PlanArgs>();
  CLI::App* sub = app.add_subcommand(
      "plan", "The cheapest format (coordinate bits, offset bits, BVH width) meeting an error budget on a scene");
  sub->add_option("--scene", a->scene, "scene file, mesh file or builtin:NAME")->required();
  sub->add_option("--max-error", a->max_error, "error budget of --metric")->required();
  sub->add_option("--metric", a->metric,
                  "hit: fraction of rays whose hit/miss differs from float; t: mean relative t error")
      ->check(CLI::IsMember({"hit", "t"}))
      ->capture_default_str();
  sub->add_option("--min-psnr", a->min_psnr, "also require the render's PSNR against float (dB; 0: no)")
      ->capture_default_str();
  sub->add_option("--config", a->config, "timing preset whose cycles are the cost")->capture_default_str();
  sub->add_option("--bvh-width", a->widths, "BVH widths to consider, comma-separated")
      ->delimiter(',')
      ->check(CLI::IsMember({2, 4, 8}))
      ->capture_default_str();
  sub->add_option("--coord-bits", a->coord_bits, "coordinate bits to try, fewest first, comma-separated")
      ->delimiter(',')
      ->check(CLI::Range(2, 30))
      ->capture_default_str();
  sub->add_option("--child-bits", a->child_bits, "child-offset bits to try, comma-separated")
      ->delimiter(',')
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  sub->add_option("--rays", a->opt.rays, "camera rays and as many incoherent rays per candidate")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 26))
      ->capture_default_str();
  sub->add_option("--image-width", a->opt.image_width, "width of the PSNR render (0: none)")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  sub->add_option("--threads", a->opt.threads, "worker threads (0 = all cores)")->check(CLI::NonNegativeNumber);
  sub->add_option("--area", a->area, "RTL area table for the rtl_cells figures (bench/data/rtl_area.csv)")
      ->check(CLI::ExistingFile);
  sub->add_option("--json", a->json, "write the plan and every candidate's figures as JSON");
  sub->callback([a] { run_plan(*a); });
}

}  // namespace rtu::host::cmd
