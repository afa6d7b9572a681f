// rtusim info: what a scene holds and what its BVH looks like.
#include <cstdio>
#include <memory>

#include "host/cmd/common.h"

namespace rtu::host::cmd {

namespace {

struct InfoOptions {
  std::string scene;
  AccelOptions accel;
  std::string json;
};

void run_info(const InfoOptions& o) {
  Stopwatch load_timer;
  const Scene scene = load_scene(o.scene);
  const double load_s = load_timer.seconds();
  Stopwatch build_timer;
  const hw::FloatTracer tracer(scene.geometry, o.accel.tracer());
  const double build_s = build_timer.seconds();
  const hw::Geometry& g = scene.geometry;
  const hw::Aabb b = g.bounds();

  Json j;
  j["scene"] = scene.name;
  j["triangles"] = g.triangles.size();
  j["spheres"] = g.spheres.size();
  j["planes"] = g.planes.size();
  j["materials"] = scene.materials.size();
  j["lights"] = scene.lights.size();
  j["bounds_lo"] = {b.lo.x, b.lo.y, b.lo.z};
  j["bounds_hi"] = {b.hi.x, b.hi.y, b.hi.z};
  j["camera"] = {{"position", {scene.camera.position.x, scene.camera.position.y, scene.camera.position.z}},
                 {"look_at", {scene.camera.look_at.x, scene.camera.look_at.y, scene.camera.look_at.z}},
                 {"fov_y", scene.camera.fov_y_deg},
                 {"width", scene.camera.width},
                 {"height", scene.camera.height},
                 {"framed_automatically", !scene.has_camera}};
  j["load_seconds"] = load_s;
  j["build_seconds"] = build_s;
  j["bvh"] = bvh_json(tracer);

  std::printf("scene        %s\n", scene.name.c_str());
  std::printf("primitives   %zu triangles, %zu spheres, %zu planes\n", g.triangles.size(), g.spheres.size(),
              g.planes.size());
  std::printf("materials    %zu, lights %zu\n", scene.materials.size(), scene.lights.size());
  std::printf("bounds       (%g, %g, %g) .. (%g, %g, %g)\n", b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
  std::printf("load         %.3f s, accel build %.3f s\n", load_s, build_s);
  if (const hw::Bvh* bvh = tracer.bvh()) {
    const hw::BvhFigures f = bvh->figures();
    std::printf("bvh          width %d, %llu inner nodes, %llu leaves, depth %d\n", f.width,
                (unsigned long long)f.inner_nodes, (unsigned long long)f.leaves, f.depth);
    std::printf("leaves       %d..%d primitives, mean %.2f; node fill %.0f%%\n", f.min_leaf, f.max_leaf,
                f.mean_leaf, 100.0 * f.mean_fill);
    std::printf("sah cost     %.2f (brute force %.0f) in primitive tests per ray\n", f.sah_cost,
                tracer.brute_cost());
    std::printf("bytes        nodes %llu + index %llu = %.1f bytes per primitive (+ %llu leaf-ordered copies)\n",
                (unsigned long long)f.node_bytes, (unsigned long long)f.index_bytes,
                f.prims ? double(f.node_bytes + f.index_bytes) / double(f.prims) : 0.0,
                (unsigned long long)tracer.leaf_prim_bytes());
  } else {
    std::printf("accel        brute force (%u bounded primitives: a BVH would cost more than it saves)\n",
                g.num_bounded());
  }
  if (!o.json.empty()) write_json(o.json, j);
}

}  // namespace

void add_info(CLI::App& app) {
  auto o = std::make_shared<InfoOptions>();
  CLI::App* sub = app.add_subcommand("info", "Describe a scene: primitive counts, bounds, BVH figures");
  sub->add_option("--scene", o->scene, "scene file, mesh file, or builtin:NAME")->required();
  add_accel_options(*sub, o->accel);
  sub->add_option("--json", o->json, "also write the figures as JSON to this file");
  sub->callback([o] { run_info(*o); });
}

}  // namespace rtu::host::cmd
