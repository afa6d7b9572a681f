// rtusim demo: the main job on the built-in default scene, as the README's first command runs it. Loads the
// scene; traces the camera's primary rays on the float reference and on the fixed device (default format) and
// compares them ray by ray; renders the scene with the firmware renderer on both devices and compares the
// images (PSNR, heatmap); the fixed render runs on the timed device (same hits, plus cycles per frame), and
// again in hybrid mode (primary visibility rasterized by the firmware: cycles of both modes); writes
// images, hit files and a JSON report.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "host/cmd/common.h"
#include "host/compare.h"
#include "host/error.h"
#include "host/image.h"
#include "host/image_diff.h"
#include "host/ray_gen.h"
#include "host/ray_io.h"
#include "host/render.h"
#include "host/trace_job.h"

namespace rtu::host::cmd {

namespace {

struct DemoOptions {
  std::string scene = "builtin:seed";
  std::string out = "out/demo";
  int threads = 0;
  int spp = 4, max_depth = 4;
  std::string config = "rdna2";
};

void run_demo(const DemoOptions& o) {
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec) throw Error(o.out + ": cannot create directory: " + ec.message());

  Stopwatch load_timer;
  const Scene scene = load_scene(o.scene);
  const double load_s = load_timer.seconds();
  const int w = scene.camera.width, h = scene.camera.height;
  const std::vector<hw::Ray> rays = primary_rays(scene.camera, w, h);
  const hw::Geometry& g = scene.geometry;
  std::printf("rtusim demo: %s (%zu triangles, %zu spheres, %zu planes, %zu lights), %dx%d primary rays\n",
              scene.name.c_str(), g.triangles.size(), g.spheres.size(), g.planes.size(), scene.lights.size(), w,
              h);

  Json j;
  j["scene"] = scene.name;
  j["width"] = w;
  j["height"] = h;
  j["load_seconds"] = load_s;
  std::vector<std::vector<hw::Hit>> all_hits;
  std::vector<std::string> written;
  std::vector<bool> valid(rays.size(), true);  // on both devices: only those are compared
  for (const std::string& name : {std::string("float"), std::string("fixed")}) {
    DeviceOptions dopt;
    dopt.kind = hw::parse_device_kind(name);
    Stopwatch build_timer;
    const std::unique_ptr<TraceDevice> device = make_device(g, dopt);
    const double build_s = build_timer.seconds();
    for (size_t i = 0; i < rays.size(); ++i)
      valid[i] = valid[i] && device->ray_status(rays[i]) == hw::RayStatus::kOk;
    std::vector<hw::Hit> hits;
    hw::TraversalStats stats;
    const double trace_s = trace_with_progress(*device, rays, hits, false, o.threads, stats);
    const std::string image_path = o.out + "/primary_" + name + ".png";
    const std::string hits_path = o.out + "/primary_" + name + ".hits";
    write_png(image_path, shade_hits(scene, rays, hits, w, h));
    write_hits(hits_path, hits);
    written.push_back(image_path);
    written.push_back(hits_path);
    const double n = double(rays.size());
    std::printf(
        "  %-5s device: %llu hits, %.2f MRays/s (%d threads); per ray %.2f nodes, %.2f box tests, %.2f "
        "primitive tests (%s)\n",
        name.c_str(), (unsigned long long)stats.hits, trace_s > 0 ? n / trace_s * 1e-6 : 0.0,
        resolved_threads(o.threads), double(stats.nodes_visited) / n, double(stats.box_tests) / n,
        double(stats.prim_tests) / n, device->bvh() ? "bvh" : "brute force");
    Json dev = traversal_json(stats);
    dev["image"] = image_path;
    dev["build_seconds"] = build_s;
    dev["trace_seconds"] = trace_s;
    dev["rays_per_second"] = trace_s > 0 ? n / trace_s : 0.0;
    dev["bvh"] = bvh_json(*device);
    if (name == "fixed") dev["format"] = format_json(dopt.format);
    j["devices"][name] = dev;
    all_hits.push_back(std::move(hits));
  }
  // Error of the fixed device against the float reference, per ray and per image.
  const HitComparison c = compare_hits(all_hits[0], all_hits[1], valid, false);
  std::printf(
      "  fixed vs float: hit agreement %.4f%%, primitive agreement %.4f%%, t relative error mean %.2g "
      "max %.2g; %zu pixels differ\n",
      100.0 * c.hit_agreement(), 100.0 * c.prim_agreement(), c.t_rel_mean, c.t_rel_max, c.disagreements.size());
  j["fixed_vs_float"] = {{"hit_agreement", c.hit_agreement()},
                         {"prim_agreement", c.prim_agreement()},
                         {"false_misses", c.false_misses},
                         {"false_hits", c.false_hits},
                         {"t_rel_error_mean", c.t_rel_mean},
                         {"t_rel_error_max", c.t_rel_max},
                         {"pixels_differing", c.disagreements.size()}};

  // The firmware renderer on the float reference and on the fixed datapath with the timing model (the timed
  // device: the fixed device's hits and image, plus cycles), and the image error of fixed against float.
  std::vector<Image> renders;
  auto render_options = [&](const std::string& name, bool hybrid) {
    RenderOptions ro;
    ro.device.kind = name == "float" ? hw::DeviceKind::kFloat : hw::DeviceKind::kTimed;
    ro.device.timing = hw::timing_preset(o.config);
    if (name != "float") {
      ro.device.format = hw::format_preset(ro.device.timing.format);
      ro.device.format.width = ro.device.timing.bvh_width;
      ro.device.tracer.bvh.width = ro.device.format.width;
    }
    ro.hybrid = hybrid;
    ro.threads = o.threads;
    ro.spp = o.spp;
    ro.max_depth = o.max_depth;
    ro.background = Vec3(0.02f, 0.02f, 0.03f);
    return ro;
  };
  uint64_t raytrace_cycles = 0;
  for (const std::string& name : {std::string("float"), std::string("fixed")}) {
    const RenderOptions ro = render_options(name, false);
    const RenderResult r = render(scene, ro);
    print_render_summary(r, ro);
    if (r.timed) {
      std::printf("        ");
      print_timing_summary(r.timing, ro.device.timing);
      std::printf("        cycles per frame (every packet, fences included): %llu = %.3f ms at %.1f GHz\n",
                  (unsigned long long)r.device_clock, double(r.device_clock) / (ro.device.timing.clock_ghz * 1e6),
                  ro.device.timing.clock_ghz);
      raytrace_cycles = r.device_clock;
    }
    renders.push_back(to_image(r));
    const std::string path = o.out + "/render_" + name + ".png";
    write_png(path, renders.back());
    written.push_back(path);
    Json rj = render_json(r, ro);
    rj["image"] = path;
    if (r.timed) {
      rj["timing"] = timing_stats_json(r.timing, ro.device.timing);
      rj["timing"]["cycles_per_frame"] = r.device_clock;
      rj["timing"]["config"] = timing_json(ro.device.timing);
    }
    j["renders"][name] = rj;
  }
  // Hybrid: the same frame on the timed device with primary visibility rasterized by the firmware.
  {
    const RenderOptions ro = render_options("hybrid", true);
    const RenderResult r = render(scene, ro);
    print_render_summary(r, ro);
    std::printf("        hybrid frame: %llu cycles (raster %llu + trace %llu) against %llu ray-traced: %.2fx\n",
                (unsigned long long)r.frame_cycles, (unsigned long long)r.raster_cycles.cycles,
                (unsigned long long)r.device_clock, (unsigned long long)raytrace_cycles,
                double(raytrace_cycles) / double(r.frame_cycles));
    const Image img = to_image(r);
    const std::string path = o.out + "/render_hybrid.png";
    write_png(path, img);
    written.push_back(path);
    const ImageDiff hd = diff_images(renders[1], img);
    Json rj = render_json(r, ro);
    rj["image"] = path;
    j["renders"]["hybrid"] = rj;
    j["hybrid_vs_raytrace"] = {{"primary_rays_saved", r.fw.primary_rasterized},
                               {"raytrace_cycles", raytrace_cycles},
                               {"hybrid_cycles", r.frame_cycles},
                               {"raster_cycles", r.raster_cycles.cycles},
                               {"psnr_db", hd.identical() ? Json(nullptr) : Json(hd.psnr_db)},
                               {"pixels_differing", hd.pixels_differing}};
  }
  const ImageDiff d = diff_images(renders[0], renders[1]);
  const std::string heat_path = o.out + "/render_heatmap.png";
  write_png(heat_path, diff_heatmap(renders[0], renders[1], 16.0));
  written.push_back(heat_path);
  char psnr[32];
  std::snprintf(psnr, sizeof psnr, d.identical() ? "inf" : "%.2f", d.psnr_db);
  std::printf(
      "  fixed vs float render: PSNR %s dB, max abs %d, mean abs %.4f (of 255), %llu of %d pixels differ\n", psnr,
      d.max_abs, d.mean_abs, (unsigned long long)d.pixels_differing, d.width * d.height);
  j["render_fixed_vs_float"] = {{"psnr_db", d.identical() ? Json(nullptr) : Json(d.psnr_db)},
                                {"max_abs", d.max_abs},
                                {"mean_abs", d.mean_abs},
                                {"pixels_differing", d.pixels_differing},
                                {"frac_pixels_differing", d.frac_pixels_differing},
                                {"heatmap", heat_path},
                                {"heatmap_full_scale", 16}};

  const std::string report_path = o.out + "/report.json";
  write_json(report_path, j);
  written.push_back(report_path);
  std::printf("  wrote");
  for (const std::string& f : written) std::printf(" %s", f.c_str());
  std::printf("\n");
}

}  // namespace

void add_demo(CLI::App& app) {
  auto o = std::make_shared<DemoOptions>();
  CLI::App* sub = app.add_subcommand("demo", "Run the main job on a built-in scene and write images and a report");
  sub->add_option("--scene", o->scene, "scene to run")->capture_default_str();
  sub->add_option("--out", o->out, "output directory")->capture_default_str();
  sub->add_option("--threads", o->threads, "worker threads (0 = all cores)")->capture_default_str();
  sub->add_option("--config", o->config, "timing preset of the fixed device's render (cycles)")
      ->check(CLI::IsMember(hw::timing_preset_names()))
      ->capture_default_str();
  sub->add_option("--spp", o->spp, "render: samples per pixel")->check(CLI::Range(1, 1024))->capture_default_str();
  sub->add_option("--max-depth", o->max_depth, "render: bounces after the camera ray")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  sub->callback([o] { run_demo(*o); });
}

}  // namespace rtu::host::cmd
