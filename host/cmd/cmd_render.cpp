// rtusim render: render a scene with the firmware renderer on a device and write a PNG and statistics.
#include <cstdio>
#include <memory>

#include "host/cmd/common.h"
#include "host/error.h"
#include "host/image_diff.h"
#include "host/render.h"

namespace rtu::host::cmd {

namespace {

struct RenderArgs {
  std::string scene, out, stats, mode = "raytrace";
  DeviceArgs dev;
  int threads = 0;
  int width = 0, height = 0, spp = 1, max_depth = 4;
  uint32_t seed = 1;
  bool ao = false, no_indirect = false, compare_modes = false;
  float ao_distance = 0.0f;
  std::vector<float> background{0.0f, 0.0f, 0.0f};
  PipelineTraceArgs pipeline;
};

RenderOptions options_from(const RenderArgs& a, const std::string& device) {
  RenderOptions o;
  o.device = a.dev.options(device);
  o.hybrid = a.mode == "hybrid";
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
  const Scene scene = load_scene(a.scene);
  RenderOptions o = options_from(a, a.dev.device);
  PipelineTraceArgs pt = a.pipeline;
  o.pipeline_trace = pt.make();
  const RenderResult r = render(scene, o);
  if (r.timed) pt.write();
  write_png(a.out, to_image(r));
  print_render_summary(r, o);
  if (r.timed) {
    std::printf("  ");
    print_timing_summary(r.timing, o.device.timing);
    std::printf("  device clock at the end (all packets, fences included): %llu cycles\n",
                (unsigned long long)r.device_clock);
    if (o.hybrid)
      std::printf("  rasterizer: %llu cycles (limit: %s); frame: %llu cycles (raster + trace)\n",
                  (unsigned long long)r.raster_cycles.cycles, r.raster_cycles.limit,
                  (unsigned long long)r.frame_cycles);
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
  auto a = std::make_shared<RenderArgs>();
  CLI::App* sub = app.add_subcommand(
      "render",
      "Render a scene with the firmware renderer (wavefront path tracing: shadows, reflection, refraction, "
      "diffuse light or ambient occlusion) on a device; PNG out");
  sub->add_option("--scene", a->scene, "scene file, mesh file, or builtin:NAME")->required();
  sub->add_option("--out", a->out, "PNG to write")->required();
  sub->add_option("--stats", a->stats, "write statistics as JSON to this file");
  add_pipeline_trace_args(*sub, a->pipeline);
  add_device_args(*sub, a->dev,
                  "device: float (the reference), fixed (bit-accurate fixed point) or timed (fixed point with the "
                  "cycle-approximate timing model; --config, --set)");
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
  sub->add_flag("--ao", a->ao, "ambient occlusion at diffuse hits instead of diffuse indirect light");
  sub->add_option("--ao-distance", a->ao_distance, "occlusion ray length (default: 1/4 of the scene diagonal)")
      ->check(CLI::PositiveNumber);
  sub->add_flag("--no-indirect", a->no_indirect, "no diffuse indirect bounces (direct light and specular only)");
  sub->add_option("--background", a->background, "radiance R G B of rays that leave the scene")
      ->expected(3)
      ->check(CLI::Range(0.0f, 1e6f))
      ->capture_default_str();
  sub->callback([a] { run_render(*a); });
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
      o.device.name.c_str(), o.hybrid ? "hybrid" : "raytrace", r.width, r.height, o.spp, o.max_depth,
      (unsigned long long)total, (unsigned long long)ry[int(RayType::kPrimary)],
      (unsigned long long)ry[int(RayType::kShadow)], (unsigned long long)ry[int(RayType::kReflection)],
      (unsigned long long)ry[int(RayType::kRefraction)], (unsigned long long)ry[int(RayType::kDiffuse)],
      (unsigned long long)ry[int(RayType::kOcclusion)], r.seconds, (unsigned long long)r.fw.traces,
      (unsigned long long)r.ring.fences);
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

Json render_json(const RenderResult& r, const RenderOptions& o) {
  using hw::cmd::RayType;
  Json j;
  j["device"] = o.device.name;
  j["width"] = r.width;
  j["height"] = r.height;
  j["spp"] = o.spp;
  j["max_depth"] = o.max_depth;
  j["seed"] = o.seed;
  j["mode"] = o.ao ? "ambient_occlusion" : (o.indirect ? "path_tracing" : "direct_and_specular");
  j["render_mode"] = o.hybrid ? "hybrid" : "raytrace";
  j["seconds"] = r.seconds;
  Json rays;
  uint64_t total = 0;
  for (int t = 0; t < hw::cmd::kRayTypeCount; ++t) {
    rays[hw::cmd::ray_type_name(RayType(t))] = r.fw.rays[t];
    total += r.fw.rays[t];
  }
  j["rays"] = rays;
  j["rays_total"] = total;
  j["rays_per_second"] = r.seconds > 0 ? double(total) / r.seconds : 0.0;
  // Primary rays the rasterizer made unnecessary (hybrid: every camera sample; raytrace: none).
  j["rays_saved"] = {{"primary", r.fw.primary_rasterized}};
  if (o.hybrid) {
    const fw::RasterStats& rs = r.fw.raster;
    j["raster"] = {{"passes", rs.passes},
                   {"prims_read", rs.prims_read},
                   {"setups", rs.setups},
                   {"samples_tested", rs.samples_tested},
                   {"fragments", rs.fragments},
                   {"depth_writes", rs.depth_writes},
                   {"clears", rs.clears},
                   {"triangles_culled", rs.triangles_culled},
                   {"triangles_clipped", rs.triangles_clipped},
                   {"triangles_degenerate", rs.triangles_degenerate}};
  }
  j["paths"] = r.fw.paths;
  j["batches"] = r.fw.batches;
  j["batch_paths"] = r.fw.batch_paths;
  j["bounces"] = r.fw.bounces;
  j["commands"] = {{"packets", r.ring.packets},
                   {"trace", r.fw.traces},
                   {"fences", r.ring.fences},
                   {"doorbells", r.ring.doorbells},
                   {"ring_full", r.ring.full}};
  // What the scene did not need, and why: decided before any ray was built.
  Json skipped = Json::object();
  const bool any_diffuse = r.fw.need_shadow || r.fw.need_diffuse || r.fw.need_occlusion;
  if (!r.fw.need_shadow)
    skipped["shadow"] =
        r.fw.rays[int(RayType::kShadow)] == 0 && any_diffuse ? "no lights" : "no lights or no diffuse surface";
  if (!r.fw.need_reflection)
    skipped["reflection"] = o.max_depth == 0 ? "max depth 0" : "no mirror or glass material";
  if (!r.fw.need_refraction) skipped["refraction"] = o.max_depth == 0 ? "max depth 0" : "no glass material";
  if (!r.fw.need_diffuse)
    skipped["diffuse"] = o.ao ? "ambient occlusion instead"
                              : (!o.indirect ? "indirect light off" : "no diffuse material or max depth 0");
  if (!r.fw.need_occlusion) skipped["occlusion"] = o.ao ? "no diffuse material" : "ambient occlusion off";
  if (r.fw.hybrid) skipped["primary"] = "rasterized (hybrid mode)";
  if (r.counts.triangles == 0) skipped["triangle_unit"] = "no triangles";
  if (r.counts.spheres == 0) skipped["sphere_unit"] = "no spheres";
  if (r.counts.planes == 0) skipped["plane_unit"] = "no planes";
  if (!r.uses_bvh) skipped["bvh"] = "brute force is cheaper for this scene (hw::choose_accel)";
  j["skipped"] = skipped;
  Json unit;
  unit["primitives"] = {
      {"triangles", r.counts.triangles}, {"spheres", r.counts.spheres}, {"planes", r.counts.planes}};
  unit["accel"] = r.uses_bvh ? "bvh" : "brute_force";
  unit["memory_bytes"] = r.device_memory_bytes;
  unit["scene_image_bytes"] = r.scene_image_bytes;
  unit["packets"] = r.device.packets;
  Json by_type;
  for (int t = 0; t < hw::cmd::kRayTypeCount; ++t) {
    if (r.device.rays_by_type[t] == 0) continue;
    by_type[hw::cmd::ray_type_name(RayType(t))] = traversal_json(r.device.stats_by_type[t]);
  }
  unit["by_ray_type"] = by_type;
  unit["total"] = traversal_json(r.device.total());
  j["unit"] = unit;
  j["spawn_offset"] = {{"abs", r.offset_abs}, {"rel", r.offset_rel}};
  if (o.device.name != "float") j["format"] = format_json(o.device.format);
  if (r.timed) {
    Json t = timing_stats_json(r.timing, o.device.timing);
    Json by_type = Json::object();
    for (int k = 0; k < hw::cmd::kRayTypeCount; ++k)
      if (r.timing_by_type[size_t(k)].rays > 0)
        by_type[hw::cmd::ray_type_name(RayType(k))] =
            timing_stats_json(r.timing_by_type[size_t(k)], o.device.timing);
    t["by_ray_type"] = by_type;
    Json by_bounce = Json::object();
    for (const auto& [b, s] : r.timing_by_bounce)
      by_bounce[std::to_string(b)] = timing_stats_json(s, o.device.timing);
    t["by_bounce"] = by_bounce;
    t["device_clock"] = r.device_clock;
    // Fence interrupts: the host sees the frame's last fence irq_latency after the device clock's end.
    t["fence_irqs"] = r.device.fence_irqs;
    t["last_irq_cycle"] = r.device.last_irq_cycle;
    t["sample"] = sample_json(r.sampling);
    // The frame: the rasterizer's cycles (hybrid) and the unit's (every packet), which do not overlap.
    const hw::RasterCycles& rc = r.raster_cycles;
    t["raster"] = {{"cycles", rc.cycles},
                   {"latency_cycles", rc.latency_cycles},
                   {"setup_cycles", rc.setup_cycles},
                   {"scan_cycles", rc.scan_cycles},
                   {"fragment_cycles", rc.fragment_cycles},
                   {"dram_cycles", rc.dram_cycles},
                   {"dram_bytes", rc.dram_bytes},
                   {"limit", rc.limit}};
    t["raster_cycles"] = rc.cycles;
    t["trace_cycles"] = r.device_clock;
    t["frame_cycles"] = r.frame_cycles;
    t["config"] = timing_json(o.device.timing);
    j["timing"] = t;
  }
  return j;
}

}  // namespace rtu::host::cmd
