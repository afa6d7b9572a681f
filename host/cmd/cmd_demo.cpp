// rtusim demo: the main job on the built-in default scene, as the README's first command runs it. Loads the
// scene, builds the BVH, traces the camera's primary rays on the float reference and writes a hit image, the
// hit file and a JSON report. Later devices (fixed, timed) and the renderer join here as they arrive.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "host/cmd/common.h"
#include "host/error.h"
#include "host/image.h"
#include "host/ray_gen.h"
#include "host/ray_io.h"
#include "host/trace_job.h"

namespace rtu::host::cmd {

namespace {

struct DemoOptions {
  std::string scene = "builtin:seed";
  std::string out = "out/demo";
  int threads = 0;
};

void run_demo(const DemoOptions& o) {
  std::error_code ec;
  std::filesystem::create_directories(o.out, ec);
  if (ec) throw Error(o.out + ": cannot create directory: " + ec.message());

  Stopwatch load_timer;
  const Scene scene = load_scene(o.scene);
  const double load_s = load_timer.seconds();
  Stopwatch build_timer;
  const std::unique_ptr<TraceDevice> tracer = make_device(scene.geometry, DeviceOptions{});
  const double build_s = build_timer.seconds();
  const int w = scene.camera.width, h = scene.camera.height;
  const std::vector<hw::Ray> rays = primary_rays(scene.camera, w, h);
  std::vector<hw::Hit> hits;
  hw::TraversalStats stats;
  const double trace_s = trace_with_progress(*tracer, rays, hits, false, o.threads, stats);

  const std::string image_path = o.out + "/primary_float.png";
  const std::string hits_path = o.out + "/primary_float.hits";
  const std::string report_path = o.out + "/report.json";
  write_png(image_path, shade_hits(scene, rays, hits, w, h));
  write_hits(hits_path, hits);

  const hw::Geometry& g = scene.geometry;
  std::printf("rtusim demo: %s (%zu triangles, %zu spheres, %zu planes, %zu lights)\n", scene.name.c_str(),
              g.triangles.size(), g.spheres.size(), g.planes.size(), scene.lights.size());
  std::printf("  float device: %dx%d primary rays, %llu hits, %.2f MRays/s (%d threads)\n", w, h,
              (unsigned long long)stats.hits, trace_s > 0 ? double(rays.size()) / trace_s * 1e-6 : 0.0,
              resolved_threads(o.threads));
  std::printf("  per ray: %.2f nodes, %.2f box tests, %.2f primitive tests (accel: %s)\n",
              double(stats.nodes_visited) / double(rays.size()), double(stats.box_tests) / double(rays.size()),
              double(stats.prim_tests) / double(rays.size()), tracer->bvh() ? "bvh" : "brute force");
  std::printf("  wrote %s, %s, %s\n", image_path.c_str(), hits_path.c_str(), report_path.c_str());

  Json j;
  j["scene"] = scene.name;
  j["image"] = image_path;
  j["width"] = w;
  j["height"] = h;
  j["load_seconds"] = load_s;
  j["build_seconds"] = build_s;
  Json dev = traversal_json(stats);
  dev["trace_seconds"] = trace_s;
  dev["rays_per_second"] = trace_s > 0 ? double(rays.size()) / trace_s : 0.0;
  j["devices"]["float"] = dev;
  j["bvh"] = bvh_json(*tracer);
  write_json(report_path, j);
}

}  // namespace

void add_demo(CLI::App& app) {
  auto o = std::make_shared<DemoOptions>();
  CLI::App* sub = app.add_subcommand("demo", "Run the main job on a built-in scene and write images and a report");
  sub->add_option("--scene", o->scene, "scene to run")->capture_default_str();
  sub->add_option("--out", o->out, "output directory")->capture_default_str();
  sub->add_option("--threads", o->threads, "worker threads (0 = all cores)")->capture_default_str();
  sub->callback([o] { run_demo(*o); });
}

}  // namespace rtu::host::cmd
