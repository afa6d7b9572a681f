// rtusim info: what a scene holds and what its BVH looks like.
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/devices/device_json.h"
#include "host/io/error.h"
#include "host/jobs/suite.h"
#include "hwmodel/format/hw_format.h"
#include "hwmodel/format/packed_layout.h"

namespace rtu::host::cli {

namespace {

struct InfoOptions {
  std::string scene;
  DeviceArgs dev;
  std::string json;
  std::string suite;
  bool formats = false;
};

// The suite's entries: available or skipped (with the reason), what makes each hard; --json lists them.
void list_suite(const InfoOptions& o) {
  const Suite suite = load_suite(o.suite);
  const SuiteCheck check = check_suite(suite);
  Json j;
  j["suite"] = o.suite;
  j["description"] = suite.description;
  j["entries"] = Json::array();
  std::printf("suite        %s: %zu scenes, %zu available, %zu skipped\n", o.suite.c_str(), suite.entries.size(),
              check.available.size(), check.skipped.size());
  for (const SuiteEntry& e : suite.entries) {
    std::string reason;
    for (const SuiteSkip& s : check.skipped)
      if (s.entry.name == e.name) reason = s.reason;
    std::printf("%-16s %s  %s\n%-16s hard because: %s\n", e.name.c_str(), reason.empty() ? "ok     " : "skipped",
                e.scene.c_str(), "", e.hard_because.c_str());
    if (!reason.empty()) std::printf("%-16s %s\n", "", reason.c_str());
    j["entries"].push_back({{"name", e.name},
                            {"scene", e.scene},
                            {"hard_because", e.hard_because},
                            {"source", e.source},
                            {"available", reason.empty()},
                            {"skipped_because", reason}});
  }
  if (!o.json.empty()) write_json(o.json, j);
}

void list_formats() {
  std::printf("%-9s %5s %5s %5s %5s %5s %5s %5s %7s  %-22s %s\n", "preset", "width", "coord", "child", "guard",
              "frac", "dir", "rcp", "t", "layout", "node bytes");
  bool scene_sized = false;
  for (const hw::FixedFormat& f : hw::format_presets()) {
    // Bit-packed nodes size their bases by the scene: here at 2^20 nodes and primitive units, groups of 128.
    const bool sized = f.node_layout_id() == hw::NodeLayout::kBitPacked && f.node_align < 64;
    scene_sized = scene_sized || sized;
    const uint64_t bytes = f.node_layout_id() == hw::NodeLayout::kStructs
                               ? hw::qnode_bytes(f.width, f.offset_bytes())
                               : hw::node_fields(f, 20, 20, 7).bytes(f.node_align);
    const std::string layout =
        std::string(node_layout_name(f.node_layout)) +
        (f.prim_layout_id() == hw::PrimLayout::kRecords ? "" : "+") +
        (f.prim_layout_id() == hw::PrimLayout::kRecords ? "" : prim_layout_name(f.prim_layout));
    std::printf("%-9s %5d %5d %5d %5d %5d %5d %5d %4d.%-2d  %-22s %llu%s\n", f.name.c_str(), f.width, f.coord_bits,
                f.child_bits, f.guard_bits, f.frac_bits, f.dir_bits, f.rcp_bits, f.t_bits, f.t_frac_bits,
                layout.c_str(), (unsigned long long)bytes, sized ? " *" : "");
  }
  if (scene_sized)
    std::printf(
        "* bit-packed: at 2^20 nodes and primitive units; a scene's own: rtusim info --scene S --format F\n");
}

// Two levels (the float reference's): what instancing saves against the flattened scene, and the fixed images.
Json instancing_json(const Scene& scene, const DeviceOptions& dopt) {
  hw::TracerOptions topt = dopt.tracer;
  topt.bvh.width = dopt.format.width;
  const hw::InstancedFloatTracer two(scene.instances, scene.geometry, topt);
  uint64_t mesh_tris = 0;
  for (const hw::Geometry& m : scene.instances.meshes) mesh_tris += m.triangles.size();
  const hw::InstancedFixedTracer fixed_two(scene.instances, scene.geometry, dopt.format, topt);
  return {{"instances", scene.instances.instances.size()},
          {"meshes", scene.instances.meshes.size()},
          {"mesh_triangles", mesh_tris},
          {"top_nodes_bytes", two.top().figures().node_bytes},
          {"float_bytes", two.bytes()},
          {"fixed", two_level_json(fixed_two)}};
}

// What --json writes: the scene's contents, bounds and camera, the load and build times, the BVH and the format.
Json info_json(const Scene& scene, const DeviceOptions& dopt, const DirectDevice& device, double load_s,
               double build_s) {
  const hw::Geometry& g = scene.geometry;
  const hw::Aabb b = g.bounds();
  Json j;
  j["scene"] = scene.name;
  j["triangles"] = g.triangles.size();
  j["spheres"] = g.spheres.size();
  if (!g.curves.empty()) j["curve_segments"] = g.curves.size();
  j["planes"] = g.planes.size();
  j["materials"] = scene.materials.size();
  j["lights"] = scene.lights.size();
  j["textures"] = scene.textures.size();
  uint64_t non_opaque = 0;
  for (const uint8_t f : g.non_opaque) non_opaque += f;
  j["non_opaque_triangles"] = non_opaque;  // alpha-tested: their candidate hits go to the any-hit stage
  if (scene.instanced()) j["instancing"] = instancing_json(scene, dopt);
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
  j["bvh"] = bvh_json(device);
  j["format"] = format_json(dopt.format);
  return j;
}

// The scene's lines of the report: its primitives, materials, alpha-tested triangles, instances and bounds.
void print_scene(const Scene& scene, const Json& j) {
  const hw::Geometry& g = scene.geometry;
  const hw::Aabb b = g.bounds();
  std::printf("scene        %s\n", scene.name.c_str());
  std::printf("primitives   %zu triangles, %zu spheres, %zu planes", g.triangles.size(), g.spheres.size(),
              g.planes.size());
  if (!g.curves.empty()) std::printf(", %zu curve segments", g.curves.size());
  std::printf("\n");
  std::printf("materials    %zu, lights %zu, textures %zu\n", scene.materials.size(), scene.lights.size(),
              scene.textures.size());
  const uint64_t non_opaque = j["non_opaque_triangles"].get<uint64_t>();
  if (non_opaque > 0)
    std::printf("alpha        %llu alpha-tested triangles (their candidate hits go to the any-hit stage)\n",
                (unsigned long long)non_opaque);
  if (scene.instanced()) {
    const Json& in = j["instancing"];
    std::printf(
        "instances    %llu of %llu meshes (%llu triangles in the meshes); two levels (float): top nodes "
        "%llu bytes, all %llu bytes\n",
        (unsigned long long)in["instances"].get<uint64_t>(), (unsigned long long)in["meshes"].get<uint64_t>(),
        (unsigned long long)in["mesh_triangles"].get<uint64_t>(),
        (unsigned long long)in["top_nodes_bytes"].get<uint64_t>(),
        (unsigned long long)in["float_bytes"].get<uint64_t>());
    const Json& fx = in["fixed"];
    std::printf(
        "two levels   fixed: top %llu + bottoms %llu + transforms %llu = %llu bytes (the image below is the "
        "flattened scene's, as --flatten traces it)\n",
        (unsigned long long)fx["top_bytes"].get<uint64_t>(),
        (unsigned long long)fx["bottom_bytes"].get<uint64_t>(),
        (unsigned long long)fx["transform_bytes"].get<uint64_t>(),
        (unsigned long long)fx["total_bytes"].get<uint64_t>());
  }
  std::printf("bounds       (%g, %g, %g) .. (%g, %g, %g)\n", b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
}

// The device's lines of the report: the float BVH (or brute force), the format, its frame and layout, and the
// fixed image's bytes against the float BVH's.
void print_device(const DirectDevice& device, const DeviceOptions& dopt, const hw::Geometry& g) {
  if (const hw::Bvh* bvh = device.bvh()) {
    const hw::BvhFigures f = bvh->figures();
    std::printf("bvh          width %d, %llu inner nodes, %llu leaves, depth %d\n", f.width,
                (unsigned long long)f.inner_nodes, (unsigned long long)f.leaves, f.depth);
    std::printf("leaves       %d..%d primitives, mean %.2f; node fill %.0f%%\n", f.min_leaf, f.max_leaf,
                f.mean_leaf, 100.0 * f.mean_fill);
    std::printf("sah cost     %.2f (brute force %.0f) in primitive tests per ray\n", f.sah_cost,
                device.brute_cost());
    std::printf("float bvh    nodes %llu + index %llu bytes = %.1f bytes per primitive\n",
                (unsigned long long)f.node_bytes, (unsigned long long)f.index_bytes,
                f.prims ? double(f.node_bytes + f.index_bytes) / double(f.prims) : 0.0);
  } else {
    std::printf("accel        brute force (%u bounded primitives: a BVH would cost more than it saves)\n",
                g.num_bounded());
  }
  const hw::DeviceImage& img = *device.image();
  std::printf("format       %s\n", dopt.format.describe().c_str());
  std::printf("frame        2^%d grid steps of 2^%d world units per axis\n", dopt.format.coord_bits,
              img.header().step_exp);
  std::printf(
      "layout       nodes %s, %zu bytes per node; primitives %s; %.1f bytes per primitive (nodes + "
      "primitives)\n",
      node_layout_name(img.header().node_layout), img.node_bytes(), prim_layout_name(img.header().prim_layout),
      image_bytes_per_prim(img));
  std::printf("fixed image  %zu bytes per node: nodes %llu + primitives %llu + planes %llu = %llu bytes\n",
              img.node_bytes(), (unsigned long long)img.nodes_size(), (unsigned long long)img.records_size(),
              (unsigned long long)img.planes_size(), (unsigned long long)img.size());
  if (const hw::Bvh* bvh = device.bvh()) {
    const hw::BvhFigures f = bvh->figures();
    std::printf("bvh bytes    fixed nodes / float nodes = %.1f%% (%.1f%% of float nodes + index)\n",
                100.0 * double(img.nodes_size()) / double(f.node_bytes),
                100.0 * double(img.nodes_size()) / double(f.node_bytes + f.index_bytes));
  }
}

void run_info(const InfoOptions& o) {
  if (!o.json.empty() && o.scene.empty() && o.suite.empty()) throw Error("info: --json needs --scene or --suite");
  if (!o.suite.empty()) return list_suite(o);
  if (o.formats) {
    list_formats();
    if (o.scene.empty()) return;
  }
  if (o.scene.empty()) throw Error("info: --scene is required (or --formats)");
  Stopwatch load_timer;
  const Scene scene = load_scene(o.scene);
  const double load_s = load_timer.seconds();
  Stopwatch build_timer;
  const DeviceOptions dopt = o.dev.options(hw::DeviceKind::kFixed);
  const std::unique_ptr<DirectDevice> device = make_device(scene.geometry, dopt);
  const double build_s = build_timer.seconds();

  const Json j = info_json(scene, dopt, *device, load_s, build_s);
  print_scene(scene, j);
  std::printf("load         %.3f s, accel build %.3f s\n", load_s, build_s);
  print_device(*device, dopt, scene.geometry);
  if (!o.json.empty()) write_json(o.json, j);
}

}  // namespace

void add_info(CLI::App& app) {
  const auto [sub, o] =
      add_command<InfoOptions>(app, "info", "Describe a scene: primitive counts, bounds, BVH figures",
                               [](InfoOptions& o, CLI::App&) { run_info(o); });
  CLI::Option* scene = sub->add_option("--scene", o->scene, "scene file, mesh file, or builtin:NAME");
  sub->add_flag("--formats", o->formats, "list the fixed-point format presets");
  add_device_args(*sub, o->dev, "");
  sub->add_option("--suite", o->suite,
                  "list a benchmark suite manifest's scenes (scenes/suite.json): available or skipped, and why")
      ->excludes(scene);
  sub->add_option("--json", o->json,
                  "also write the scene's figures (or the suite's entries) as JSON to this file");
}

}  // namespace rtu::host::cli
