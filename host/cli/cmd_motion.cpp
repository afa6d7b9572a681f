// rtusim motion: the built-in moving scene with motion blur on the float and fixed devices, and its cycles on a
// static, a time-aware and a time-oblivious unit (host/jobs/motion.h).
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "host/cli/common.h"
#include "host/io/files.h"
#include "host/io/image.h"
#include "host/io/ray_io.h"
#include "host/jobs/image_diff.h"
#include "host/jobs/motion.h"

namespace rtu::host::cli {

namespace {

struct MotionArgs {
  DeviceArgs dev;
  int width = 320, height = 240, samples = 4, level = 4;
  float motion_scale = 1.0f;
  bool instances = false;
  std::string scene;
  std::vector<float> move;
  int time_bits = 16, box_time_bits = 6;
  uint64_t seed = 1;
  int threads = 0;
  std::string image, json;
  std::string rays, times, out;  // the user's rays, their shutter times, the hit file
};

void run_motion(const MotionArgs& a) {
  MotionJobOptions o;
  o.width = a.width;
  o.height = a.height;
  o.samples = a.samples;
  o.level = a.level;
  o.motion_scale = a.motion_scale;
  o.scene = a.scene;
  o.instances = a.instances;
  if (!a.move.empty()) o.move = hw::Vec3(a.move[0], a.move[1], a.move[2]);
  o.seed = a.seed;
  o.threads = a.threads;
  o.format = a.dev.fixed_format();
  o.motion = hw::MotionFormat{a.time_bits, a.box_time_bits};
  o.timing = timing_config_from(a.dev.config, a.dev.sets);
  check_output_files({a.out, a.json});
  if (!a.rays.empty() && !std::filesystem::exists(a.rays)) {  // generated rays, of the moving scene
    o.ray_spec = a.rays;
    o.time_spec = a.times;
  } else if (!a.rays.empty()) {
    o.rays = read_rays(a.rays);
    o.times = read_shutter_times(a.times, o.rays.size(), a.seed);
  }
  const MotionJobResult r = run_motion_job(o);
  const bool frame = a.rays.empty();
  const ImageDiff d = frame ? diff_images(r.float_image, r.fixed_image) : ImageDiff{};
  const std::string what = a.rays.empty() ? std::to_string(o.width) + "x" + std::to_string(o.height) + ", " +
                                                std::to_string(o.samples) + " shutter times per pixel"
                                          : std::to_string(r.rays) + " rays of " + a.rays + " at times " + a.times;
  const std::string name = !o.scene.empty() ? o.scene
                           : o.instances    ? std::string("builtin moving instances")
                                            : std::string("builtin motion");
  if (r.instances > 0)
    std::printf("instances    %llu, %llu of them with two transforms\n", (unsigned long long)r.instances,
                (unsigned long long)r.moving_instances);
  std::printf("scene        %s: %llu triangles, %llu spheres, %llu curve segments, %llu moving; %s\n",
              name.c_str(), (unsigned long long)r.triangles, (unsigned long long)r.spheres,
              (unsigned long long)r.curves, (unsigned long long)r.moving, what.c_str());
  std::printf("format       %s, %s\n", o.format.describe().c_str(), o.motion.describe().c_str());
  std::printf("fixed/float  %llu of %llu rays agree on hit/miss; of %llu hits on both, %llu on the same primitive",
              (unsigned long long)r.hits_agree, (unsigned long long)r.rays, (unsigned long long)r.both_hit,
              (unsigned long long)r.same_prim);
  if (frame)
    std::printf("; image PSNR %.2f dB, %llu pixels differ", d.psnr_db, (unsigned long long)d.pixels_differing);
  std::printf("\n");
  std::printf("%-15s %12s %8s %10s %10s %10s %12s %10s\n", "unit", "cycles", "ratio", "nodes/ray", "tris/ray",
              "shader", "node bytes", "interp mm2");
  for (const MotionDesign& m : r.designs)
    std::printf("%-15s %12llu %7.3fx %10.2f %10.2f %10llu %12llu %10.4f\n", hw::motion_unit_name(m.unit),
                (unsigned long long)m.cycles, m.ratio, double(m.traversal.nodes_visited) / double(r.rays),
                double(m.traversal.prim_tests) / double(r.rays), (unsigned long long)m.timing.any_hit_requests,
                (unsigned long long)m.node_bytes, m.interp_mm2);
  if (!a.out.empty()) {
    write_hits(a.out, r.hits);
    std::printf("wrote        %s (the fixed unit's hits)\n", a.out.c_str());
  }
  if (!a.image.empty()) {
    write_png(a.image + "_float.png", r.float_image);
    write_png(a.image + "_fixed.png", r.fixed_image);
    std::printf("wrote        %s_float.png, %s_fixed.png\n", a.image.c_str(), a.image.c_str());
  }
  if (!a.json.empty()) {
    Json j = motion_json(o, r);
    if (frame) j["image_psnr_db"] = std::isinf(d.psnr_db) ? Json(nullptr) : Json(d.psnr_db);
    j["config"] = a.dev.config;
    if (!a.rays.empty()) {
      j["rays_file"] = a.rays;
      j["times"] = a.times;
    }
    write_json(a.json, j);
  }
}

}  // namespace

void add_motion(CLI::App& app) {
  const auto [sub, a] = add_command<MotionArgs>(
      app, "motion",
      "Motion blur: the built-in moving scene on the float and fixed devices (images, agreement), and its cycles "
      "on a static, a time-aware and a time-oblivious unit",
      [](MotionArgs& a, CLI::App& sub) {
        if (a.scene.empty() && sub.count("--move") > 0)
          throw CLI::ValidationError("--move applies to --scene only");
        if (!a.scene.empty() && sub.count("--motion-scale") > 0)
          throw CLI::ValidationError(
              "--motion-scale applies to the built-in scene only (use --move with --scene)");
        if (!a.scene.empty() && sub.count("--level") > 0)
          throw CLI::ValidationError("--level applies to the built-in scene only");
        if (!a.scene.empty() && a.instances)
          throw CLI::ValidationError(
              "--instances chooses the built-in moving instances; a scene with instances moves as instances");
        if (a.rays.empty() != a.times.empty())
          throw CLI::ValidationError("--rays and --times go together (a shutter time for every ray)");
        if (a.rays.empty() && !a.out.empty()) throw CLI::ValidationError("--out needs --rays");
        if (!a.rays.empty() &&
            (!a.image.empty() || sub.count("--width") || sub.count("--height") || sub.count("--samples")))
          throw CLI::ValidationError(
              "--rays traces the rays given: no frame (--image, --width, --height, --samples)");
        run_motion(a);
      });
  sub->add_option("--scene", a->scene,
                  "a scene of triangles to set in motion (scene file, mesh file or builtin:NAME; default: the "
                  "built-in moving scene)");
  sub->add_option("--move", a->move,
                  "with --scene: every triangle's move between the key frames, X Y Z (world); a scene with "
                  "instances: every instance's (its transform at time 1 moved by it)")
      ->expected(3);
  sub->add_flag(
      "--instances", a->instances,
      "the built-in moving instances: the balls as instances of one mesh, each placed by two transforms");
  add_format_args(*sub, a->dev);
  add_timing_args(*sub, a->dev);
  sub->add_option("--width", a->width, "image width")->check(CLI::Range(1, 8192))->capture_default_str();
  sub->add_option("--height", a->height, "image height")->check(CLI::Range(1, 8192))->capture_default_str();
  sub->add_option("--samples", a->samples, "shutter times per pixel (stratified)")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  sub->add_option("--level", a->level, "subdivision of the balls (8 x 4^level triangles each)")
      ->check(CLI::Range(0, 7))
      ->capture_default_str();
  sub->add_option("--motion-scale", a->motion_scale, "the balls' moves scaled by this factor (0..1)")
      ->check(CLI::Range(0.0f, 1.0f))
      ->capture_default_str();
  sub->add_option("--time-bits", a->time_bits, "bits of the ray's time register (1..24)")
      ->check(CLI::Range(1, 24))
      ->capture_default_str();
  sub->add_option("--box-time-bits", a->box_time_bits,
                  "bits of time the box unit interpolates at (0..time bits; 0: boxes over the whole shutter)")
      ->check(CLI::Range(0, 24))
      ->capture_default_str();
  sub->add_option("--seed", a->seed, "seed of the shutter times' jitter")->capture_default_str();
  sub->add_option("--threads", a->threads, "host threads (0: all); results do not depend on it")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  sub->add_option("--image", a->image, "write PREFIX_float.png and PREFIX_fixed.png");
  sub->add_option("--rays", a->rays,
                  "trace this ray file (docs/file-formats.md), or generated rays (primary[:N|:WxH], "
                  "incoherent[:N]) of the moving scene, instead of the camera's frame, each ray at its --times "
                  "shutter time, on the float and fixed units and the three timed units");
  sub->add_option("--times", a->times,
                  "with --rays: the rays' shutter times in [0, 1]: a file of float32 (one a ray) or CSV with a "
                  "header 'time', 'uniform' (random, --seed), or one number for every ray");
  sub->add_option("--out", a->out, "with --rays: write the fixed unit's hits (a hit file)");
  sub->add_option("--json", a->json, "write the figures as JSON");
}

}  // namespace rtu::host::cli
