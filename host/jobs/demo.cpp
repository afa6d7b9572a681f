#include "host/jobs/demo.h"

#include <filesystem>
#include <memory>
#include <utility>

#include "host/cost/timing_json.h"
#include "host/devices/device_json.h"
#include "host/devices/direct_device.h"
#include "host/io/error.h"
#include "host/io/image.h"
#include "host/io/ray_io.h"
#include "host/jobs/stopwatch.h"
#include "host/jobs/trace_job.h"
#include "host/scene/ray_gen.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

namespace {

// The demo under way: its options, what it found so far, and the progress callback.
struct DemoRun {
  const DemoOptions& o;
  DemoResult& res;
  const std::function<void(DemoStage, const DemoResult&)>& progress;
  void done(DemoStage stage) const {
    if (progress) progress(stage, res);
  }
};

// The scene's primary rays on one direct device: the image and hit file, the report's entry for the device.
// Clears valid[i] where the device refuses ray i. Returns the hits.
std::vector<hw::Hit> trace_primary(const DemoRun& run, const Scene& scene, const std::vector<hw::Ray>& rays,
                                   hw::DeviceKind kind, std::vector<bool>& valid) {
  const std::string name = hw::device_kind_name(kind);
  DeviceOptions dopt;
  dopt.kind = kind;
  Stopwatch build_timer;
  const std::unique_ptr<DirectDevice> device = make_device(scene.geometry, dopt);
  const double build_s = build_timer.seconds();
  for (size_t i = 0; i < rays.size(); ++i)
    valid[i] = valid[i] && device->ray_status(rays[i]) == hw::RayStatus::kOk;
  std::vector<hw::Hit> hits;
  hw::TraversalStats stats;
  const double trace_s = trace_with_progress(*device, rays, hits, false, run.o.threads, stats);
  const std::string image_path = run.o.out + "/primary_" + name + ".png";
  const std::string hits_path = run.o.out + "/primary_" + name + ".hits";
  write_png(image_path, shade_hits(scene, rays, hits, run.res.width, run.res.height));
  write_hits(hits_path, hits);
  run.res.written.push_back(image_path);
  run.res.written.push_back(hits_path);
  const double n = double(rays.size());
  run.res.traces.push_back(DemoTrace{kind, stats, trace_s, device->bvh() != nullptr});
  run.done(DemoStage::kTraced);
  Json dev = traversal_json(stats);
  dev["image"] = image_path;
  dev["build_seconds"] = build_s;
  dev["trace_seconds"] = trace_s;
  dev["rays_per_second"] = trace_s > 0 ? n / trace_s : 0.0;
  dev["bvh"] = bvh_json(*device);
  if (kind == hw::DeviceKind::kFixed) dev["format"] = format_json(dopt.format);
  run.res.report["devices"][name] = dev;
  return hits;
}

Json comparison_json(const HitComparison& c) {
  return {{"hit_agreement", c.hit_agreement()},
          {"prim_agreement", c.prim_agreement()},
          {"false_misses", c.false_misses},
          {"false_hits", c.false_hits},
          {"t_rel_error_mean", c.t_rel_mean},
          {"t_rel_error_max", c.t_rel_max},
          {"pixels_differing", c.disagreements.size()}};
}

// A render of the demo on a device, ray traced or hybrid, with the --config preset's timing and format.
RenderOptions demo_render_options(const DemoOptions& o, hw::DeviceKind kind, bool hybrid) {
  RenderOptions ro;
  ro.device.kind = kind;
  ro.device.timing = hw::timing_preset(o.config);
  if (kind != hw::DeviceKind::kFloat) {
    ro.device.format = hw::format_from_spec(ro.device.timing.format);
    ro.device.format.width = ro.device.timing.bvh_width;
    ro.device.tracer.bvh.width = ro.device.format.width;
  }
  ro.hybrid = hybrid;
  ro.threads = o.threads;
  ro.spp = o.spp;
  ro.max_depth = o.max_depth;
  ro.background = Vec3(0.02f, 0.02f, 0.03f);
  return ro;
}

// The firmware renderer on the float reference and on the fixed datapath with the timing model (the timed
// device: the fixed device's hits and image, plus cycles), named by datapath: "fixed" is the fixed datapath on the
// timed device. Appends their images to `renders`; returns the timed render's cycles.
uint64_t render_raytraced(const DemoRun& run, const Scene& scene, std::vector<Image>& renders) {
  uint64_t raytrace_cycles = 0;
  for (const auto& [name, kind] : {std::pair<std::string, hw::DeviceKind>{"float", hw::DeviceKind::kFloat},
                                   {"fixed", hw::DeviceKind::kTimed}}) {
    const RenderOptions ro = demo_render_options(run.o, kind, false);
    run.res.renders.push_back(DemoRender{name, ro, render(scene, ro)});
    const RenderResult& r = run.res.renders.back().result;
    if (r.timed) raytrace_cycles = r.device_clock;
    renders.push_back(to_image(r));
    const std::string path = run.o.out + "/render_" + name + ".png";
    write_png(path, renders.back());
    run.res.written.push_back(path);
    run.done(DemoStage::kRendered);
    Json rj = render_json(r, ro);
    rj["image"] = path;
    if (r.timed) {
      rj["timing"] = timing_stats_json(r.timing, ro.device.timing, ro.device.format);
      rj["timing"]["cycles_per_frame"] = r.device_clock;
      rj["timing"]["config"] = timing_json(ro.device.timing);
    }
    run.res.report["renders"][name] = rj;
  }
  return raytrace_cycles;
}

// Hybrid: the same frame on the timed device with primary visibility rasterized by the firmware, against the ray
// traced one (`raytraced`, its cycles `raytrace_cycles`).
void render_hybrid(const DemoRun& run, const Scene& scene, const Image& raytraced, uint64_t raytrace_cycles) {
  const RenderOptions ro = demo_render_options(run.o, hw::DeviceKind::kTimed, true);
  run.res.renders.push_back(DemoRender{"hybrid", ro, render(scene, ro)});
  const RenderResult& r = run.res.renders.back().result;
  run.done(DemoStage::kHybrid);
  const Image img = to_image(r);
  const std::string path = run.o.out + "/render_hybrid.png";
  write_png(path, img);
  run.res.written.push_back(path);
  const ImageDiff hd = diff_images(raytraced, img);
  Json rj = render_json(r, ro);
  rj["image"] = path;
  Json& j = run.res.report;
  j["renders"]["hybrid"] = rj;
  j["hybrid_vs_raytrace"] = {{"primary_rays_saved", r.fw.primary_rasterized},
                             {"raytrace_cycles", raytrace_cycles},
                             {"hybrid_cycles", r.frame_cycles},
                             {"raster_cycles", r.raster_cycles.cycles},
                             {"psnr_db", hd.identical() ? Json(nullptr) : Json(hd.psnr_db)},
                             {"pixels_differing", hd.pixels_differing}};
}

// The image error of the fixed render against the float one, and its heatmap.
void diff_renders(const DemoRun& run, const Image& float_render, const Image& fixed_render) {
  const ImageDiff& d = run.res.render_fixed_vs_float = diff_images(float_render, fixed_render);
  const std::string heat_path = run.o.out + "/render_heatmap.png";
  write_png(heat_path, diff_heatmap(float_render, fixed_render, 16.0));
  run.res.written.push_back(heat_path);
  run.done(DemoStage::kRenderDiff);
  run.res.report["render_fixed_vs_float"] = {{"psnr_db", d.identical() ? Json(nullptr) : Json(d.psnr_db)},
                                             {"max_abs", d.max_abs},
                                             {"mean_abs", d.mean_abs},
                                             {"pixels_differing", d.pixels_differing},
                                             {"frac_pixels_differing", d.frac_pixels_differing},
                                             {"heatmap", heat_path},
                                             {"heatmap_full_scale", 16}};
}

}  // namespace

DemoResult run_demo(const DemoOptions& o, const std::function<void(DemoStage, const DemoResult&)>& progress) {
  DemoResult res;
  const DemoRun run{o, res, progress};
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec) throw Error(o.out + ": cannot create directory: " + ec.message());

  Stopwatch load_timer;
  const Scene scene = load_scene(o.scene);
  const double load_s = load_timer.seconds();
  const int w = scene.camera.width, h = scene.camera.height;
  const std::vector<hw::Ray> rays = primary_rays(scene.camera, w, h);
  const hw::Geometry& g = scene.geometry;
  res.scene = scene.name;
  res.triangles = g.triangles.size();
  res.spheres = g.spheres.size();
  res.planes = g.planes.size();
  res.lights = scene.lights.size();
  res.width = w;
  res.height = h;
  run.done(DemoStage::kLoaded);

  Json& j = res.report;
  j["scene"] = scene.name;
  j["width"] = w;
  j["height"] = h;
  j["load_seconds"] = load_s;
  std::vector<bool> valid(rays.size(), true);  // on both devices: only those are compared
  const std::vector<hw::Hit> float_hits = trace_primary(run, scene, rays, hw::DeviceKind::kFloat, valid);
  const std::vector<hw::Hit> fixed_hits = trace_primary(run, scene, rays, hw::DeviceKind::kFixed, valid);
  // Error of the fixed device against the float reference, per ray and per image.
  res.fixed_vs_float = compare_hits(float_hits, fixed_hits, valid, false);
  run.done(DemoStage::kCompared);
  j["fixed_vs_float"] = comparison_json(res.fixed_vs_float);

  std::vector<Image> renders;
  const uint64_t raytrace_cycles = render_raytraced(run, scene, renders);
  render_hybrid(run, scene, renders[1], raytrace_cycles);
  diff_renders(run, renders[0], renders[1]);

  const std::string report_path = o.out + "/report.json";
  write_json(report_path, j);
  res.written.push_back(report_path);
  return res;
}

}  // namespace rtu::host
