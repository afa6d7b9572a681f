// rtusim compare: lockstep comparison of the float reference and another device on identical rays. Per-ray
// agreement (hit/miss, primitive, t), the fixed device's box-test check against exact arithmetic, and the
// traversal overhead of quantized boxes. Disagreeing rays are listed by index so they can be replayed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/ray_io.h"
#include "host/jobs/compare_job.h"

namespace rtu::host::cli {

namespace {

struct CompareOptions {
  std::string scene, rays, json, disagreements;
  bool any_hit = false;
  int threads = 0;
  size_t max_list = 1000;
  uint64_t seed = 1;
  DeviceArgs dev;
};

void run_compare(const CompareOptions& o) {
  check_output_files({o.json, o.disagreements});
  const Scene scene = load_scene(o.scene);
  const std::vector<hw::Ray> rays = rays_from_spec(o.rays, scene, o.seed);
  CompareRequest req;
  req.scene = &scene;
  req.rays = &rays;
  req.rays_name = o.rays;
  req.settings = o.dev;
  req.kind = o.dev.kind();
  req.any_hit = o.any_hit;
  req.threads = o.threads;
  req.max_list = o.max_list;
  const CompareRun run = compare_devices(req);
  for (const auto& w : run.json["warnings"])
    std::fprintf(stderr, "rtusim: warning: %s\n", w.get<std::string>().c_str());
  const HitComparison& t = run.t;
  const DirectDevice* dut = run.dut.get();
  const hw::TraversalStats& ref_stats = run.ref_stats;
  const hw::TraversalStats& dut_stats = run.dut_stats;
  const double grid_step = run.grid_step;
  const double n = t.compared ? double(t.compared) : 1.0;
  const Json& j = run.json;

  std::printf("compare %s: float vs %s (%s) on %llu rays (%llu compared, %llu invalid)\n", scene.name.c_str(),
              dut->name(), run.dut_options.format.name.c_str(), (unsigned long long)t.rays,
              (unsigned long long)t.compared, (unsigned long long)run.invalid_either);
  if (run.invalid_either > 0) {
    std::printf("  invalid rays (not compared) by reason on float / %s:", dut->name());
    for (size_t k = 1; k < ref_stats.invalid_by_reason.size(); ++k)
      if (ref_stats.invalid_by_reason[k] + dut_stats.invalid_by_reason[k] > 0)
        std::printf(" %s %llu / %llu", hw::ray_status_name(hw::RayStatus(k)),
                    (unsigned long long)ref_stats.invalid_by_reason[k],
                    (unsigned long long)dut_stats.invalid_by_reason[k]);
    std::printf("\n");
  }
  if (t.compared == 0) {
    if (!o.json.empty()) write_json(o.json, j);
    check_compared(run);
  }
  if (o.any_hit)
    std::printf(
        "  hit agreement %.6f%%: %llu false misses, %llu false hits (any-hit: only hit/miss is compared)\n",
        100.0 * double(t.hit_agree) / n, (unsigned long long)t.false_misses, (unsigned long long)t.false_hits);
  else
    std::printf(
        "  hit agreement %.6f%%, primitive agreement %.6f%%: %llu false misses, %llu false hits, %llu other "
        "primitive\n",
        100.0 * double(t.hit_agree) / n, 100.0 * double(t.prim_agree) / n, (unsigned long long)t.false_misses,
        (unsigned long long)t.false_hits, (unsigned long long)t.other_prim);
  if (t.compared && !o.any_hit) {
    std::printf("  t error on %llu rays hitting the same primitive: relative max %.3g (ray %llu), mean %.3g",
                (unsigned long long)t.t_compared, t.t_rel_max, (unsigned long long)t.t_rel_max_ray, t.t_rel_mean);
    if (grid_step > 0.0)
      std::printf("; distance max %.3g grid steps (ray %llu), mean %.3g (a step is %.3g world units)",
                  t.t_abs_steps_max, (unsigned long long)t.t_abs_steps_max_ray, t.t_abs_steps_mean, grid_step);
    std::printf("\n");
  }
  if (run.boxes_checked)
    std::printf("  box tests checked exactly: %llu, false negatives %llu, false positives %llu\n",
                (unsigned long long)dut_stats.box_checks, (unsigned long long)dut_stats.box_false_negatives,
                (unsigned long long)dut_stats.box_false_positives);
  else if (dut->kind() == hw::DeviceKind::kTimed)
    std::printf(
        "  box tests: not checked on the timed device (its datapath is the fixed device's; --device fixed "
        "checks them)\n");
  std::printf("  overhead vs float: nodes %+.3f%%, primitive tests %+.3f%%; saturations %llu\n",
              100.0 * j["node_visit_overhead"].get<double>(), 100.0 * j["prim_test_overhead"].get<double>(),
              (unsigned long long)dut_stats.saturations);
  if (!o.json.empty()) write_json(o.json, j);
  if (!o.disagreements.empty()) {
    write_rays(o.disagreements, run.replay);
    std::printf("  wrote %zu disagreeing rays to %s\n", run.replay.size(), o.disagreements.c_str());
  }
  check_box_false_negatives(run);
}

}  // namespace

void add_compare(CLI::App& app) {
  const auto [sub, o] = add_command<CompareOptions>(
      app, "compare",
      "Trace identical rays on the float reference and a device; per-ray agreement, t error, overheads",
      [](CompareOptions& o, CLI::App& sub) {
        check_device_args(sub, o.dev);
        if (sub.count("--seed") > 0 && o.rays.rfind("incoherent", 0) != 0)
          throw CLI::ValidationError("--seed applies to --rays incoherent[:N] only");
        run_compare(o);
      });
  sub->add_option("--scene", o->scene, "scene file, mesh file, or builtin:NAME")->required();
  sub->add_option("--rays", o->rays, kRaySpecHelp)->required();
  sub->add_option("--seed", o->seed, "seed of generated incoherent rays")->capture_default_str();
  o->dev.device = "fixed";
  add_device_args(*sub, o->dev, "device to compare with the float reference");
  add_timing_args(*sub, o->dev);  // the timed device's format and BVH width; compare reports no cycles
  add_watchdog_args(*sub, o->dev);
  sub->add_flag("--any-hit", o->any_hit, "any-hit queries (only hit/miss is compared)");
  sub->add_option("--threads", o->threads, "worker threads (0 = all cores); results do not depend on it")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->add_option("--json", o->json, "write the comparison as JSON to this file");
  sub->add_option("--max-list", o->max_list, "disagreeing rays listed in the JSON")->capture_default_str();
  sub->add_option("--disagreements", o->disagreements, "write the disagreeing rays to this ray file (replay)");
}

}  // namespace rtu::host::cli
