// rtusim rays: write a ray file of the scene camera's primary rays or of incoherent rays.
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/io/ray_io.h"
#include "host/scene/ray_gen.h"

namespace rtu::host::cli {

namespace {

struct RaysOptions {
  std::string scene, kind = "primary", out;
  uint64_t count = 0;
  int width = 0, height = 0;
  uint64_t seed = 1;
};

void run_rays(const CLI::App& sub, const RaysOptions& o) {
  // Options of the other kind would be ignored: refused instead.
  const bool primary = o.kind == "primary";
  for (const char* name : {"--width", "--height"})
    if (!primary && sub.count(name) > 0)
      throw CLI::ValidationError(std::string(name) + " applies to --kind primary only");
  if (primary && sub.count("--seed") > 0) throw CLI::ValidationError("--seed applies to --kind incoherent only");
  const Scene scene = load_scene(o.scene);
  std::vector<hw::Ray> rays;
  if (o.kind == "primary") {
    if (o.count > 0 && (o.width > 0 || o.height > 0))
      throw Error("rays: give --count or --width/--height, not both");
    if (o.count > 0) {
      rays = primary_rays(scene.camera, o.count);
    } else {
      rays = primary_rays(scene.camera, o.width > 0 ? o.width : scene.camera.width,
                          o.height > 0 ? o.height : scene.camera.height);
    }
  } else {
    if (o.count == 0) throw Error("rays: --kind incoherent needs --count N (N > 0)");
    rays = incoherent_rays(scene.geometry.bounds(), o.count, o.seed);
  }
  write_rays(o.out, rays);
  std::printf("wrote %zu %s rays to %s\n", rays.size(), o.kind.c_str(), o.out.c_str());
}

}  // namespace

void add_rays(CLI::App& app) {
  const auto [sub, o] = add_command<RaysOptions>(
      app, "rays",
      "Write a ray file: the scene camera's primary rays, or incoherent rays (random origins inside the "
      "bounds, random directions)",
      [](RaysOptions& o, CLI::App& sub) { run_rays(sub, o); });
  sub->add_option("--scene", o->scene, "scene file, mesh file, or builtin:NAME")->required();
  sub->add_option("--kind", o->kind, "primary or incoherent")
      ->check(CLI::IsMember({"primary", "incoherent"}))
      ->capture_default_str();
  sub->add_option("--count", o->count,
                  "number of rays (primary: a grid with the camera's aspect ratio, first N in scanline order, "
                  "default the camera's image; incoherent: required)")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 32));  // 0 would mean "not given": refused
  sub->add_option("--width", o->width, "primary: image width (default: the scene camera's)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--height", o->height, "primary: image height (default: the scene camera's)")
      ->check(CLI::PositiveNumber);
  sub->add_option("--seed", o->seed, "incoherent: seed of the PCG32 generator")->capture_default_str();
  sub->add_option("--out", o->out, "ray file to write (.csv for text)")->required();
}

}  // namespace rtu::host::cli
