// rtusim render: render a scene with the firmware renderer on a device and write a PNG and statistics.
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/jobs/image_diff.h"
#include "host/jobs/render.h"

namespace rtu::host::cli {

namespace {

struct RenderArgs {
  std::string scene, out, stats, mode = "raytrace";
  DeviceArgs dev;
  int threads = 0;
  int width = 0, height = 0, spp = 1, max_depth = 4, omm_level = -1;
  uint32_t seed = 1;
  bool ao = false, no_indirect = false, compare_modes = false;
  float ao_distance = 0.0f;
  std::vector<float> background{0.0f, 0.0f, 0.0f};
  PipelineTraceArgs pipeline;
};

RenderOptions options_from(const RenderArgs& a, hw::DeviceKind device) {
  RenderOptions o;
  o.device = a.dev.options(device);
  o.hybrid = a.mode == "hybrid";
  o.omm_level = a.omm_level;
  o.threads = a.threads;
  o.width = a.width;
  o.height = a.height;
  o.spp = a.spp;
  o.max_depth = a.max_depth;
  o.seed = a.seed;
  o.ao = a.ao;
  o.indirect = !a.no_indirect;
  o.ao_distance = a.ao_distance;
  o.background = Vec3(a.background[0], a.background[1], a.background[2]);
  return o;
}

void run_render(const RenderArgs& a) {
  check_output_files({a.out, a.stats, a.pipeline.path});
  const Scene scene = load_scene(a.scene);
  RenderOptions o = options_from(a, a.dev.kind());
  o.progress = true;  // on stderr, when it is a terminal (as trace's)
  PipelineTraceArgs pt = a.pipeline;
  o.pipeline_trace = pt.make();
  const RenderResult r = render(scene, o);
  if (r.timed) pt.write(&r.timeline);
  write_png(a.out, to_image(r));
  print_render_summary(r, o);
  for (const std::string& w : render_warnings(r)) std::fprintf(stderr, "rtusim: warning: %s\n", w.c_str());
  if (r.timed) {
    std::printf("  ");
    print_timing_summary(r.timing, o.device.timing, o.device.format, &r.sampling, "  ");
    std::printf("  device clock at the end (all packets, fences included): %llu cycles\n",
                (unsigned long long)r.device_clock);
    if (o.hybrid)
      std::printf("  rasterizer: %llu cycles (limit: %s)%s", (unsigned long long)r.raster_cycles.cycles,
                  r.raster_cycles.limit, r.fw.sorted ? "\n" : "; ");
    if (r.fw.sorted)
      std::printf("  ray sorting: %llu cycles (limit: %s, %llu DRAM bytes); ",
                  (unsigned long long)r.sort_cycles.cycles, r.sort_cycles.limit,
                  (unsigned long long)r.sort_cycles.dram_bytes);
    if (o.hybrid || r.fw.sorted)
      std::printf(
          "frame: %llu cycles (%s)\n", (unsigned long long)r.frame_cycles,
          o.hybrid && r.fw.sorted ? "raster + sort + trace" : (o.hybrid ? "raster + trace" : "sort + trace"));
  }
  std::printf("  wrote %s\n", a.out.c_str());
  Json modes;
  if (a.compare_modes) {
    // The other mode on the same device, for what hybrid saves: rays, cycles (timed) and the image difference.
    RenderOptions other = o;
    other.hybrid = !o.hybrid;
    other.pipeline_trace = nullptr;
    const RenderResult r2 = render(scene, other);
    const RenderResult& rt = o.hybrid ? r2 : r;
    const RenderResult& hy = o.hybrid ? r : r2;
    auto total = [](const RenderResult& x) {
      uint64_t n = 0;
      for (uint64_t k : x.fw.rays) n += k;
      return n;
    };
    auto mode = [&](const RenderResult& x) {
      Json m = {{"rays_total", total(x)},
                {"primary_rays", x.fw.rays[int(hw::cmd::RayType::kPrimary)]},
                {"seconds", x.seconds}};
      if (x.timed) {
        m["raster_cycles"] = x.raster_cycles.cycles;
        m["trace_cycles"] = x.device_clock;
        if (x.fw.sorted) m["sort_cycles"] = x.sort_cycles.cycles;
        m["frame_cycles"] = x.frame_cycles;
      }
      return m;
    };
    const ImageDiff d = diff_images(to_image(rt), to_image(hy));
    // Saved: the primary rays hybrid did not trace. The secondary rays of the two differ a little where the
    // primary hits do (edges), so the totals' difference is reported beside it.
    const uint64_t saved =
        rt.fw.rays[int(hw::cmd::RayType::kPrimary)] - hy.fw.rays[int(hw::cmd::RayType::kPrimary)];
    modes = {{"raytrace", mode(rt)},
             {"hybrid", mode(hy)},
             {"rays_saved", saved},
             {"rays_total_difference", int64_t(total(rt)) - int64_t(total(hy))}};
    modes["psnr_db"] = d.identical() ? Json(nullptr) : Json(d.psnr_db);
    modes["pixels_differing"] = d.pixels_differing;
    char psnr[32];
    std::snprintf(psnr, sizeof psnr, d.identical() ? "inf" : "%.2f", d.psnr_db);
    std::printf(
        "  modes: raytrace %llu rays, hybrid %llu rays (%llu primary rays saved); images: PSNR %s dB, %llu "
        "pixels differ\n",
        (unsigned long long)total(rt), (unsigned long long)total(hy), (unsigned long long)saved, psnr,
        (unsigned long long)d.pixels_differing);
    if (r.timed) {
      modes["frame_cycles_ratio"] = double(hy.frame_cycles) / double(rt.frame_cycles);
      std::printf("  modes: raytrace %llu cycles, hybrid %llu cycles (raster %llu + trace %llu): %.3fx\n",
                  (unsigned long long)rt.frame_cycles, (unsigned long long)hy.frame_cycles,
                  (unsigned long long)hy.raster_cycles.cycles, (unsigned long long)hy.device_clock,
                  double(rt.frame_cycles) / double(hy.frame_cycles));
    }
  }
  if (!a.stats.empty()) {
    Json j = render_json(r, o);
    j["scene"] = scene.name;
    j["image"] = a.out;
    if (a.compare_modes) j["modes"] = modes;
    write_json(a.stats, j);
    std::printf("  wrote %s\n", a.stats.c_str());
  }
}

}  // namespace

void add_render(CLI::App& app) {
  const auto [sub, a] = add_command<RenderArgs>(
      app, "render",
      "Render a scene with the firmware renderer (wavefront path tracing: shadows, reflection, refraction, "
      "diffuse light or ambient occlusion) on a device; PNG out",
      [](RenderArgs& a, CLI::App& sub) {
        check_device_args(sub, a.dev);
        run_render(a);
      });
  sub->add_option("--scene", a->scene, "scene file, mesh file, or builtin:NAME")->required();
  sub->add_option("--out", a->out, "PNG to write")->required();
  sub->add_option("--stats", a->stats, "write statistics as JSON to this file");
  add_any_device_args(*sub, a->dev, a->pipeline);
  sub->add_option(
         "--mode", a->mode,
         "raytrace: primary rays traced by the unit; hybrid: primary visibility rasterized by the firmware "
         "into a G-buffer, only secondary rays traced")
      ->check(CLI::IsMember({"raytrace", "hybrid"}))
      ->capture_default_str();
  sub->add_flag("--compare-modes", a->compare_modes,
                "also render in the other mode on the same device and report both: rays, cycles (timed), the "
                "rays hybrid saved and the images' PSNR (stats JSON key `modes`)");
  sub->add_option("--threads", a->threads, "unit worker threads (0 = all cores); the image does not depend on it")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->add_option("--width", a->width, "image width (default: the scene camera's)")->check(CLI::Range(1, 16384));
  sub->add_option("--height", a->height, "image height (default: the scene camera's)")
      ->check(CLI::Range(1, 16384));
  sub->add_option("--spp", a->spp, "samples per pixel (1: pixel centers; more: jittered)")
      ->check(CLI::Range(1, 65536))
      ->capture_default_str();
  sub->add_option("--max-depth", a->max_depth, "bounces after the camera ray (0: direct light only)")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  sub->add_option("--seed", a->seed, "seed of the sampling generator")->capture_default_str();
  add_omm_level_arg(*sub, a->omm_level, "image is");
  CLI::Option* ao =
      sub->add_flag("--ao", a->ao, "ambient occlusion at diffuse hits instead of diffuse indirect light");
  sub->add_option("--ao-distance", a->ao_distance, "occlusion ray length (default: 1/4 of the scene diagonal)")
      ->check(CLI::PositiveNumber)
      ->needs(ao);
  sub->add_flag("--no-indirect", a->no_indirect, "no diffuse indirect bounces (direct light and specular only)")
      ->excludes(ao);  // --ao has none already
  sub->add_option("--background", a->background, "radiance R G B of rays that leave the scene")
      ->expected(3)
      ->check(CLI::Range(0.0f, 1e6f))
      ->capture_default_str();
}

void print_render_summary(const RenderResult& r, const RenderOptions& o) {
  using hw::cmd::RayType;
  const auto& ry = r.fw.rays;
  uint64_t total = 0;
  for (uint64_t n : ry) total += n;
  std::printf(
      "  %-5s device, %s: %dx%d, %d spp, depth %d: %llu rays (primary %llu, shadow %llu, reflection %llu, "
      "refraction "
      "%llu, diffuse %llu, occlusion %llu) in %.2f s; %llu TRACE, %llu fences\n",
      hw::device_kind_name(o.device.kind), o.hybrid ? "hybrid" : "raytrace", r.width, r.height, o.spp, o.max_depth,
      (unsigned long long)total, (unsigned long long)ry[int(RayType::kPrimary)],
      (unsigned long long)ry[int(RayType::kShadow)], (unsigned long long)ry[int(RayType::kReflection)],
      (unsigned long long)ry[int(RayType::kRefraction)], (unsigned long long)ry[int(RayType::kDiffuse)],
      (unsigned long long)ry[int(RayType::kOcclusion)], r.seconds, (unsigned long long)r.fw.traces,
      (unsigned long long)r.ring.fences);
  if (r.fw.sorted) {
    const fw::SortStats& ss = r.fw.sort;
    std::printf("  ray sorting by %s: %llu rays sorted in %llu sorts, %llu radix passes\n",
                hw::name_of(o.device.timing.ray_sort), (unsigned long long)ss.rays, (unsigned long long)ss.sorts,
                (unsigned long long)ss.passes);
  }
  if (o.hybrid) {
    const fw::RasterStats& rs = r.fw.raster;
    std::printf(
        "  rasterizer: %llu primary rays saved; %llu passes, %llu setups, %llu coverage tests, %llu fragments, "
        "%llu depth writes; triangles culled %llu, clipped %llu, degenerate %llu\n",
        (unsigned long long)r.fw.primary_rasterized, (unsigned long long)rs.passes, (unsigned long long)rs.setups,
        (unsigned long long)rs.samples_tested, (unsigned long long)rs.fragments,
        (unsigned long long)rs.depth_writes, (unsigned long long)rs.triangles_culled,
        (unsigned long long)rs.triangles_clipped, (unsigned long long)rs.triangles_degenerate);
  }
}

}  // namespace rtu::host::cli
