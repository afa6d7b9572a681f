// rtusim compare: lockstep comparison of the float reference and another device on identical rays. Per-ray
// agreement (hit/miss, primitive, t), the fixed device's box-test check against exact arithmetic, and the
// traversal overhead of quantized boxes. Disagreeing rays are listed by index so they can be replayed.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/compare.h"
#include "host/error.h"
#include "host/ray_io.h"
#include "host/shading.h"
#include "host/trace_job.h"

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

double ratio_minus_one(uint64_t a, uint64_t b) {
  return b ? double(a) / double(b) - 1.0 : 0.0;
}

void run_compare(const CompareOptions& o) {
  const Scene scene = load_scene(o.scene);
  const std::vector<hw::Ray> rays = rays_from_spec(o.rays, scene, o.seed);
  const SceneAnyHit alpha(scene);  // alpha-tested materials: both devices ask the same any-hit stage
  const DeviceOptions ref_opt = [&] {
    DeviceOptions d = o.dev.options(hw::DeviceKind::kFloat);
    d.instances = &scene.instances;  // the reference traces two levels; fixed and timed the flattened scene
    d.any_hit = alpha.stage();
    return d;
  }();
  const DeviceOptions dut_opt = [&] {
    DeviceOptions d = o.dev.options(o.dev.kind());
    d.check_boxes = true;
    d.any_hit = alpha.stage();
    return d;
  }();
  const std::unique_ptr<DirectDevice> ref = make_device(scene.geometry, ref_opt);
  const std::unique_ptr<DirectDevice> dut = make_device(scene.geometry, dut_opt);

  std::vector<hw::Hit> ref_hits, dut_hits;
  hw::TraversalStats ref_stats, dut_stats;
  const double ref_s = trace_with_progress(*ref, rays, ref_hits, o.any_hit, o.threads, ref_stats);
  const double dut_s = trace_with_progress(*dut, rays, dut_hits, o.any_hit, o.threads, dut_stats);

  // Rays either device rejected are not compared (counted as invalid_rays).
  std::vector<bool> valid(rays.size());
  uint64_t invalid_either = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    valid[i] = ref->ray_status(rays[i]) == hw::RayStatus::kOk && dut->ray_status(rays[i]) == hw::RayStatus::kOk;
    invalid_either += !valid[i];
  }
  const double grid_step = dut->image() ? dut->image()->frame().step() : 0.0;
  const HitComparison t = compare_hits(ref_hits, dut_hits, valid, o.any_hit, &rays, grid_step);
  // The fixed device repeats its box tests exactly (check_boxes); the timed device's datapath is the fixed
  // device's, bit for bit, and does not repeat them.
  const bool boxes_checked = dut->kind() == hw::DeviceKind::kFixed;
  const double n = t.compared ? double(t.compared) : 1.0;
  const uint64_t disagreements = t.disagreements.size();
  Json list = Json::array();
  std::vector<hw::Ray> replay;
  for (const RayDisagreement& d : t.disagreements) {
    const hw::Hit& a = ref_hits[d.ray];
    const hw::Hit& b = dut_hits[d.ray];
    if (list.size() < o.max_list)
      list.push_back(
          {{"ray", d.ray},
           {"kind", disagreement_name(d.kind)},
           {"float", {{"prim", a.hit() ? Json(a.prim) : Json(nullptr)}, {"t", a.hit() ? a.t : -1.0f}}},
           {dut->name(), {{"prim", b.hit() ? Json(b.prim) : Json(nullptr)}, {"t", b.hit() ? b.t : -1.0f}}}});
    replay.push_back(rays[d.ray]);
  }

  Json j;
  j["scene"] = scene.name;
  j["rays_spec"] = o.rays;
  j["reference"] = "float";
  j["device"] = dut->name();
  j["mode"] = o.any_hit ? "any_hit" : "closest_hit";
  j["format"] = format_json(dut_opt.format);
  j["rays"] = t.rays;
  j["compared_rays"] = t.compared;
  j["invalid_rays"] = invalid_either;
  // Undefined (null) when no ray was valid on both devices.
  j["hit_agreement"] = t.compared ? Json(double(t.hit_agree) / n) : Json(nullptr);
  // Any-hit queries return some hit, not the closest: primitives and t are not compared there (null).
  j["prim_agreement"] = t.compared && !o.any_hit ? Json(double(t.prim_agree) / n) : Json(nullptr);
  j["false_misses"] = t.false_misses;
  j["false_hits"] = t.false_hits;
  j["other_primitive"] = t.other_prim;
  const bool t_compared = t.compared && !o.any_hit;
  j["t_compared_rays"] = t.t_compared;
  j["t_rel_error_max"] = t_compared ? Json(t.t_rel_max) : Json(nullptr);
  j["t_rel_error_max_ray"] = t_compared ? Json(t.t_rel_max_ray) : Json(nullptr);
  j["t_rel_error_mean"] = t_compared ? Json(t.t_rel_mean) : Json(nullptr);
  j["grid_step"] = grid_step > 0.0 ? Json(grid_step) : Json(nullptr);
  j["t_abs_error_steps_max"] = t_compared && grid_step > 0.0 ? Json(t.t_abs_steps_max) : Json(nullptr);
  j["t_abs_error_steps_max_ray"] = t_compared && grid_step > 0.0 ? Json(t.t_abs_steps_max_ray) : Json(nullptr);
  j["t_abs_error_steps_mean"] = t_compared && grid_step > 0.0 ? Json(t.t_abs_steps_mean) : Json(nullptr);
  // Null where the device did not check its box tests (the timed device).
  j["box_checks"] = boxes_checked ? Json(dut_stats.box_checks) : Json(nullptr);
  j["box_false_negatives"] = boxes_checked ? Json(dut_stats.box_false_negatives) : Json(nullptr);
  j["box_false_positives"] = boxes_checked ? Json(dut_stats.box_false_positives) : Json(nullptr);
  j["node_visit_overhead"] = ratio_minus_one(dut_stats.nodes_visited, ref_stats.nodes_visited);
  j["prim_test_overhead"] = ratio_minus_one(dut_stats.prim_tests, ref_stats.prim_tests);
  j["box_test_overhead"] = ratio_minus_one(dut_stats.box_tests, ref_stats.box_tests);
  j["saturations"] = dut_stats.saturations;
  j["seconds"] = {{"float", ref_s}, {dut->name(), dut_s}};
  j["stats"] = {{"float", traversal_json(ref_stats)}, {dut->name(), traversal_json(dut_stats)}};
  j["bvh"] = bvh_json(*dut);
  j["disagreements_total"] = disagreements;
  j["disagreements"] = list;

  std::printf("compare %s: float vs %s (%s) on %llu rays (%llu compared, %llu invalid)\n", scene.name.c_str(),
              dut->name(), dut_opt.format.name.c_str(), (unsigned long long)t.rays, (unsigned long long)t.compared,
              (unsigned long long)invalid_either);
  if (invalid_either > 0) {
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
    throw Error("no ray was valid on both devices: nothing compared" +
                std::string(dut_stats.invalid_by_reason[size_t(hw::RayStatus::kOutOfFrame)] > 0
                                ? " (out_of_frame: the ray origins lie beyond the format's guard range around the "
                                  "scene; move them closer or raise --guard-bits)"
                                : ""));
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
  if (t_compared) {
    std::printf("  t error on %llu rays hitting the same primitive: relative max %.3g (ray %llu), mean %.3g",
                (unsigned long long)t.t_compared, t.t_rel_max, (unsigned long long)t.t_rel_max_ray, t.t_rel_mean);
    if (grid_step > 0.0)
      std::printf("; distance max %.3g grid steps (ray %llu), mean %.3g (a step is %.3g world units)",
                  t.t_abs_steps_max, (unsigned long long)t.t_abs_steps_max_ray, t.t_abs_steps_mean, grid_step);
    std::printf("\n");
  }
  if (boxes_checked)
    std::printf("  box tests checked exactly: %llu, false negatives %llu, false positives %llu\n",
                (unsigned long long)dut_stats.box_checks, (unsigned long long)dut_stats.box_false_negatives,
                (unsigned long long)dut_stats.box_false_positives);
  else if (dut->kind() == hw::DeviceKind::kTimed)
    std::printf(
        "  box tests: not checked on the timed device (its datapath is the fixed device's; --device fixed "
        "checks them)\n");
  std::printf("  overhead vs float: nodes %+.3f%%, primitive tests %+.3f%%; saturations %llu\n",
              100.0 * ratio_minus_one(dut_stats.nodes_visited, ref_stats.nodes_visited),
              100.0 * ratio_minus_one(dut_stats.prim_tests, ref_stats.prim_tests),
              (unsigned long long)dut_stats.saturations);
  if (!o.json.empty()) write_json(o.json, j);
  if (!o.disagreements.empty()) {
    write_rays(o.disagreements, replay);
    std::printf("  wrote %zu disagreeing rays to %s\n", replay.size(), o.disagreements.c_str());
  }
  if (dut_stats.box_false_negatives > 0)
    throw Error("the fixed box test rejected " + std::to_string(dut_stats.box_false_negatives) +
                " boxes that exact arithmetic accepts (conservative traversal broken)");
}

}  // namespace

void add_compare(CLI::App& app) {
  auto o = std::make_shared<CompareOptions>();
  CLI::App* sub = app.add_subcommand(
      "compare",
      "Trace identical rays on the float reference and a device; per-ray agreement, t error, overheads");
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
  sub->callback([o, sub] {
    check_device_args(*sub, o->dev);
    if (sub->count("--seed") > 0 && o->rays.rfind("incoherent", 0) != 0)
      throw CLI::ValidationError("--seed applies to --rays incoherent[:N] only");
    run_compare(*o);
  });
}

}  // namespace rtu::host::cli
