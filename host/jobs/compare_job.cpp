#include "host/jobs/compare_job.h"

#include "host/devices/device_json.h"
#include "host/io/error.h"
#include "host/jobs/trace_job.h"

namespace rtu::host {

namespace {

double ratio_minus_one(uint64_t a, uint64_t b) {
  return b ? double(a) / double(b) - 1.0 : 0.0;
}

}  // namespace

CompareRun compare_devices(const CompareRequest& req) {
  const Scene& scene = *req.scene;
  const std::vector<hw::Ray>& rays = *req.rays;
  CompareRun run;
  DeviceOptions ref_opt = req.settings.options(hw::DeviceKind::kFloat);
  ref_opt.instances = &scene.instances;  // float and fixed trace two levels; timed the flattened scene
  run.dut_options = req.settings.options(req.kind);
  run.dut_options.instances = &scene.instances;
  run.dut_options.check_boxes = true;
  run.alpha = std::make_unique<SceneAnyHit>(scene);
  ref_opt.any_hit = run.dut_options.any_hit = run.alpha->stage();
  run.ref = make_device(scene.geometry, ref_opt);
  run.dut = make_device(scene.geometry, run.dut_options);
  const DirectDevice& ref = *run.ref;
  const DirectDevice& dut = *run.dut;

  run.ref_seconds =
      trace_with_progress(ref, rays, run.ref_hits, req.any_hit, req.threads, run.ref_stats, req.poll);
  run.dut_seconds =
      trace_with_progress(dut, rays, run.dut_hits, req.any_hit, req.threads, run.dut_stats, req.poll);

  // Rays either device rejected are not compared (counted as invalid_rays).
  std::vector<bool> valid(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    valid[i] = ref.ray_status(rays[i]) == hw::RayStatus::kOk && dut.ray_status(rays[i]) == hw::RayStatus::kOk;
    run.invalid_either += !valid[i];
  }
  run.grid_step = dut.image() ? dut.image()->frame().step() : 0.0;
  run.t = compare_hits(run.ref_hits, run.dut_hits, valid, req.any_hit, &rays, run.grid_step);
  const HitComparison& t = run.t;
  const double grid_step = run.grid_step;
  const hw::TraversalStats& ref_stats = run.ref_stats;
  const hw::TraversalStats& dut_stats = run.dut_stats;
  // The fixed device repeats its box tests exactly (check_boxes); the timed device's datapath is the fixed
  // device's, bit for bit, and does not repeat them.
  run.boxes_checked = dut.kind() == hw::DeviceKind::kFixed;
  const bool boxes_checked = run.boxes_checked;
  const double n = t.compared ? double(t.compared) : 1.0;
  Json list = Json::array();
  for (const RayDisagreement& d : t.disagreements) {
    const hw::Hit& a = run.ref_hits[d.ray];
    const hw::Hit& b = run.dut_hits[d.ray];
    if (list.size() < req.max_list)
      list.push_back(
          {{"ray", d.ray},
           {"kind", disagreement_name(d.kind)},
           {"float", {{"prim", a.hit() ? Json(a.prim) : Json(nullptr)}, {"t", a.hit() ? a.t : -1.0f}}},
           {dut.name(), {{"prim", b.hit() ? Json(b.prim) : Json(nullptr)}, {"t", b.hit() ? b.t : -1.0f}}}});
    run.replay.push_back(rays[d.ray]);
  }

  Json& j = run.json;
  j["scene"] = scene.name;
  const std::string grid = grid_warning(device_grid_check(scene.geometry, run.dut_options));
  j["warnings"] = grid.empty() ? Json::array() : Json::array({grid});
  j["rays_spec"] = req.rays_name;
  j["reference"] = "float";
  j["device"] = dut.name();
  j["mode"] = req.any_hit ? "any_hit" : "closest_hit";
  j["format"] = format_json(run.dut_options.format);
  j["rays"] = t.rays;
  j["compared_rays"] = t.compared;
  j["invalid_rays"] = run.invalid_either;
  // Undefined (null) when no ray was valid on both devices.
  j["hit_agreement"] = t.compared ? Json(double(t.hit_agree) / n) : Json(nullptr);
  // Any-hit queries return some hit, not the closest: primitives and t are not compared there (null).
  j["prim_agreement"] = t.compared && !req.any_hit ? Json(double(t.prim_agree) / n) : Json(nullptr);
  j["false_misses"] = t.false_misses;
  j["false_hits"] = t.false_hits;
  j["other_primitive"] = t.other_prim;
  const bool t_compared = t.compared && !req.any_hit;
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
  j["seconds"] = {{"float", run.ref_seconds}, {dut.name(), run.dut_seconds}};
  j["stats"] = {{"float", traversal_json(ref_stats)}, {dut.name(), traversal_json(dut_stats)}};
  j["bvh"] = bvh_json(dut);
  j["disagreements_total"] = t.disagreements.size();
  j["disagreements"] = list;
  return run;
}

void check_compared(const CompareRun& run) {
  if (run.t.compared > 0) return;
  throw Error("no ray was valid on both devices: nothing compared" +
              std::string(run.dut_stats.invalid_by_reason[size_t(hw::RayStatus::kOutOfFrame)] > 0
                              ? " (out_of_frame: the ray origins lie beyond the format's guard range around the "
                                "scene; move them closer or raise --guard-bits)"
                              : ""));
}

void check_box_false_negatives(const CompareRun& run) {
  if (run.dut_stats.box_false_negatives > 0)
    throw Error("the fixed box test rejected " + std::to_string(run.dut_stats.box_false_negatives) +
                " boxes that exact arithmetic accepts (conservative traversal broken)");
}

}  // namespace rtu::host
