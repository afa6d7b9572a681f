// rtusim demo: the main job on the built-in default scene, as the README's first command runs it
// (host/jobs/demo.h); prints what each step found as it finishes.
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/jobs/demo.h"
#include "host/jobs/trace_job.h"

namespace rtu::host::cli {

namespace {

void print_stage(DemoStage stage, const DemoResult& r, const DemoOptions& o) {
  switch (stage) {
    case DemoStage::kLoaded:
      std::printf("rtusim demo: %s (%zu triangles, %zu spheres, %zu planes, %zu lights), %dx%d primary rays\n",
                  r.scene.c_str(), r.triangles, r.spheres, r.planes, r.lights, r.width, r.height);
      break;
    case DemoStage::kTraced: {
      const DemoTrace& t = r.traces.back();
      const hw::TraversalStats& stats = t.stats;
      const double n = double(uint64_t(r.width) * uint64_t(r.height)), trace_s = t.seconds;
      std::printf(
          "  %-5s device: %llu hits, %.2f MRays/s (%d threads); per ray %.2f nodes, %.2f box tests, %.2f "
          "primitive tests (%s)\n",
          hw::device_kind_name(t.device), (unsigned long long)stats.hits, trace_s > 0 ? n / trace_s * 1e-6 : 0.0,
          resolved_threads(o.threads), double(stats.nodes_visited) / n, double(stats.box_tests) / n,
          double(stats.prim_tests) / n, t.bvh ? "bvh" : "brute force");
      break;
    }
    case DemoStage::kCompared: {
      const HitComparison& c = r.fixed_vs_float;
      std::printf(
          "  fixed vs float: hit agreement %.4f%%, primitive agreement %.4f%%, t relative error mean %.2g "
          "max %.2g; %zu pixels differ\n",
          100.0 * c.hit_agreement(), 100.0 * c.prim_agreement(), c.t_rel_mean, c.t_rel_max,
          c.disagreements.size());
      break;
    }
    case DemoStage::kRendered: {
      const RenderOptions& ro = r.renders.back().options;
      const RenderResult& rr = r.renders.back().result;
      print_render_summary(rr, ro);
      if (rr.timed) {
        std::printf("        ");
        print_timing_summary(rr.timing, ro.device.timing, ro.device.format, &rr.sampling, "        ");
        std::printf("        cycles per frame (every packet, fences included): %llu = %.3f ms at %.1f GHz\n",
                    (unsigned long long)rr.device_clock,
                    double(rr.device_clock) / (ro.device.timing.clock_ghz * 1e6), ro.device.timing.clock_ghz);
      }
      break;
    }
    case DemoStage::kHybrid: {
      const RenderResult& rr = r.renders.back().result;
      print_render_summary(rr, r.renders.back().options);
      uint64_t raytrace_cycles = 0;
      for (const DemoRender& x : r.renders)
        if (x.name != "hybrid" && x.result.timed) raytrace_cycles = x.result.device_clock;
      std::printf("        hybrid frame: %llu cycles (raster %llu + trace %llu) against %llu ray-traced: %.2fx\n",
                  (unsigned long long)rr.frame_cycles, (unsigned long long)rr.raster_cycles.cycles,
                  (unsigned long long)rr.device_clock, (unsigned long long)raytrace_cycles,
                  double(raytrace_cycles) / double(rr.frame_cycles));
      break;
    }
    case DemoStage::kRenderDiff: {
      const ImageDiff& d = r.render_fixed_vs_float;
      char psnr[32];
      std::snprintf(psnr, sizeof psnr, d.identical() ? "inf" : "%.2f", d.psnr_db);
      std::printf(
          "  fixed vs float render: PSNR %s dB, max abs %d, mean abs %.4f (of 255), %llu of %d pixels differ\n",
          psnr, d.max_abs, d.mean_abs, (unsigned long long)d.pixels_differing, d.width * d.height);
      break;
    }
  }
}

void run(const DemoOptions& o) {
  const DemoResult r =
      run_demo(o, [&](DemoStage stage, const DemoResult& sofar) { print_stage(stage, sofar, o); });
  std::printf("  wrote");
  for (const std::string& f : r.written) std::printf(" %s", f.c_str());
  std::printf("\n");
}

}  // namespace

void add_demo(CLI::App& app) {
  const auto [sub, o] =
      add_command<DemoOptions>(app, "demo", "Run the main job on a built-in scene and write images and a report",
                               [](DemoOptions& o, CLI::App&) { run(o); });
  sub->add_option("--scene", o->scene, "scene to run")->capture_default_str();
  sub->add_option("--out", o->out, "output directory")->capture_default_str();
  sub->add_option("--threads", o->threads, "worker threads (0 = all cores)")->capture_default_str();
  sub->add_option("--config", o->config, "timing preset of the timed device's renders (cycles)")
      ->check(CLI::IsMember(hw::timing_preset_names()))
      ->capture_default_str();
  sub->add_option("--spp", o->spp, "render: samples per pixel")->check(CLI::Range(1, 1024))->capture_default_str();
  sub->add_option("--max-depth", o->max_depth, "render: bounces after the camera ray")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
}

}  // namespace rtu::host::cli
