#include "host/cmd/common.h"

#include <cstdio>
#include <fstream>

#include "host/error.h"
#include "host/ray_gen.h"
#include "host/ray_io.h"

namespace rtu::host::cmd {

hw::FixedFormat DeviceArgs::fixed_format() const {
  hw::FixedFormat f = hw::format_preset(format);
  std::string changed;
  auto set = [&](int& field, int value, const char* key) {
    if (value < 0) return;
    field = value;
    changed += std::string(changed.empty() ? "+" : ",") + key + "=" + std::to_string(value);
  };
  set(f.coord_bits, coord_bits, "coord_bits");
  set(f.child_bits, child_bits, "child_bits");
  set(f.guard_bits, guard_bits, "guard_bits");
  set(f.frac_bits, frac_bits, "frac_bits");
  set(f.dir_bits, dir_bits, "dir_bits");
  set(f.rcp_bits, rcp_bits, "rcp_bits");
  set(f.t_frac_bits, t_frac_bits, "t_frac_bits");
  set(f.t_bits, t_bits, "t_bits");
  set(f.width, bvh_width > 0 ? bvh_width : -1, "width");
  f.name += changed;
  f.validate();
  return f;
}

DeviceOptions DeviceArgs::options(const std::string& device_name) const {
  DeviceOptions d;
  d.name = device_name;
  d.format = fixed_format();
  d.tracer.bvh.width = d.format.width;
  d.tracer.bvh.max_leaf_size = leaf_size;
  d.tracer.accel =
      accel == "bvh" ? hw::AccelMode::kBvh : (accel == "brute" ? hw::AccelMode::kBrute : hw::AccelMode::kAuto);
  return d;
}

void add_device_args(CLI::App& app, DeviceArgs& o, const std::string& device_help) {
  if (!device_help.empty())
    app.add_option("--device", o.device, device_help)->check(CLI::IsMember(device_names()))->capture_default_str();
  app.add_option("--bvh-width", o.bvh_width, "BVH children per node (default: the format's width, 4)")
      ->check(CLI::IsMember({2, 4, 8}));
  app.add_option("--leaf-size", o.leaf_size, "maximum primitives per BVH leaf")
      ->check(CLI::Range(1, hw::kMaxLeafSize))
      ->capture_default_str();
  app.add_option("--accel", o.accel,
                 "acceleration: bvh, brute (for each primitive), or auto (brute force when a BVH costs more)")
      ->check(CLI::IsMember({"auto", "bvh", "brute"}))
      ->capture_default_str();
  std::vector<std::string> presets;
  for (const hw::FixedFormat& f : hw::format_presets()) presets.push_back(f.name);
  app.add_option("--format", o.format, "fixed-point format preset (rtusim info --formats lists them)")
      ->check(CLI::IsMember(presets))
      ->capture_default_str();
  auto field = [&](const char* flag, int& v, const char* help) {
    app.add_option(flag, v, help)->check(CLI::NonNegativeNumber)->group("Fixed-point format (overrides)");
  };
  field("--coord-bits", o.coord_bits, "B: grid bits of scene coordinates (2..30)");
  field("--child-bits", o.child_bits, "k: bits of child box offsets (1..16)");
  field("--guard-bits", o.guard_bits, "G: ray origins may lie 2^G scene extents out (1..16)");
  field("--frac-bits", o.frac_bits, "F: fraction bits of origins, sphere centers/radii, plane offsets (0..24)");
  field("--dir-bits", o.dir_bits, "D: fraction bits of the scaled direction (4..30)");
  field("--rcp-bits", o.rcp_bits, "R: fraction bits of the reciprocal (4..40)");
  field("--t-frac-bits", o.t_frac_bits, "T: fraction bits of t (0..32)");
  field("--t-bits", o.t_bits, "magnitude bits of the t register (8..62)");
}

std::vector<hw::Ray> rays_from_spec(const std::string& spec, const Scene& scene, uint64_t seed) {
  auto number = [&](const std::string& text) {
    size_t used = 0;
    unsigned long long v = 0;
    try {
      v = std::stoull(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != text.size() || v == 0 || text[0] == '-')
      throw Error("--rays " + spec + ": bad count '" + text + "'");
    return uint64_t(v);
  };
  if (spec == "primary") return primary_rays(scene.camera, scene.camera.width, scene.camera.height);
  if (spec.rfind("primary:", 0) == 0) {
    const std::string arg = spec.substr(8);
    const size_t x = arg.find('x');
    if (x == std::string::npos) return primary_rays(scene.camera, number(arg));
    const uint64_t w = number(arg.substr(0, x)), h = number(arg.substr(x + 1));
    if (w > 65536 || h > 65536) throw Error("--rays " + spec + ": image larger than 65536 x 65536");
    return primary_rays(scene.camera, int(w), int(h));
  }
  if (spec.rfind("incoherent:", 0) == 0)
    return incoherent_rays(scene.geometry.bounds(), number(spec.substr(11)), seed);
  return read_rays(spec);
}

Json bvh_json(const TraceDevice& d) {
  Json j;
  j["accel"] = d.bvh() ? "bvh" : "brute";
  j["brute_cost"] = d.brute_cost();
  if (const hw::Bvh* b = d.bvh()) {
    const hw::BvhFigures f = b->figures();
    j["width"] = f.width;
    j["inner_nodes"] = f.inner_nodes;
    j["leaves"] = f.leaves;
    j["prims"] = f.prims;
    j["depth"] = f.depth;
    j["leaf_size_min"] = f.min_leaf;
    j["leaf_size_max"] = f.max_leaf;
    j["leaf_size_mean"] = f.mean_leaf;
    j["node_fill"] = f.mean_fill;
    j["sah_cost"] = f.sah_cost;
    j["node_bytes"] = f.node_bytes;
    j["index_bytes"] = f.index_bytes;
    j["bytes_per_prim"] = f.prims ? double(f.node_bytes + f.index_bytes) / double(f.prims) : 0.0;
  }
  j["prim_bytes"] = d.prim_bytes();
  if (const hw::DeviceImage* img = d.image()) j["image"] = image_json(*img, d.bvh());
  return j;
}

Json format_json(const hw::FixedFormat& f) {
  Json j;
  j["name"] = f.name;
  j["width"] = f.width;
  j["coord_bits"] = f.coord_bits;
  j["child_bits"] = f.child_bits;
  j["guard_bits"] = f.guard_bits;
  j["frac_bits"] = f.frac_bits;
  j["dir_bits"] = f.dir_bits;
  j["rcp_bits"] = f.rcp_bits;
  j["t_frac_bits"] = f.t_frac_bits;
  j["t_bits"] = f.t_bits;
  j["box_product_bits"] = f.box_product_bits();
  j["edge_function_bits"] = f.edge_function_bits();
  return j;
}

Json image_json(const hw::DeviceImage& img, const hw::Bvh* bvh) {
  const hw::ImageHeader& h = img.header();
  Json j;
  j["bytes_per_node"] = img.node_bytes();
  j["nodes"] = h.node_count;
  j["node_bytes"] = img.nodes_size();
  j["records"] = h.record_count;
  j["record_bytes"] = img.records_size();
  j["plane_bytes"] = img.planes_size();
  j["total_bytes"] = img.size();
  j["frame"] = {{"coord_bits", h.coord_bits},
                {"step_exp", h.step_exp},
                {"origin", {h.frame_origin[0], h.frame_origin[1], h.frame_origin[2]}}};
  if (bvh) {
    const hw::BvhFigures f = bvh->figures();
    j["float_node_bytes"] = f.node_bytes;
    j["float_index_bytes"] = f.index_bytes;
    // Nodes against nodes (the strict figure); the image also needs no leaf index array (its records carry
    // their primitive index), which the second figure credits.
    j["node_bytes_ratio"] = f.node_bytes ? double(img.nodes_size()) / double(f.node_bytes) : 0.0;
    j["bvh_bytes_ratio"] = f.node_bytes ? double(img.nodes_size()) / double(f.node_bytes + f.index_bytes) : 0.0;
  }
  return j;
}

Json traversal_json(const hw::TraversalStats& s) {
  Json j;
  j["rays"] = s.rays + s.invalid_rays;
  j["valid_rays"] = s.rays;
  j["hits"] = s.hits;
  j["invalid_rays"] = s.invalid_rays;
  Json reasons = Json::object();
  for (size_t i = 1; i < s.invalid_by_reason.size(); ++i)
    if (s.invalid_by_reason[i]) reasons[hw::ray_status_name(hw::RayStatus(i))] = s.invalid_by_reason[i];
  j["invalid_by_reason"] = reasons;
  j["nodes_visited"] = s.nodes_visited;
  j["leaves_visited"] = s.leaves_visited;
  j["box_tests"] = s.box_tests;
  j["prim_tests"] = s.prim_tests;
  j["saturations"] = s.saturations;
  if (s.box_checks) {
    j["box_checks"] = s.box_checks;
    j["box_false_negatives"] = s.box_false_negatives;
    j["box_false_positives"] = s.box_false_positives;
  }
  const double n = s.rays ? double(s.rays) : 1.0;
  j["nodes_per_ray"] = double(s.nodes_visited) / n;
  j["box_tests_per_ray"] = double(s.box_tests) / n;
  j["prim_tests_per_ray"] = double(s.prim_tests) / n;
  return j;
}

void write_json(const std::string& path, const Json& j) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot open for writing");
  out << j.dump(2) << '\n';
  if (!out.flush()) throw Error(path + ": write error");
}

}  // namespace rtu::host::cmd
