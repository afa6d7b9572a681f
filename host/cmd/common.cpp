#include "host/cmd/common.h"

#include <cstdio>
#include <fstream>

#include "host/error.h"

namespace rtu::host::cmd {

hw::TracerOptions AccelOptions::tracer() const {
  hw::TracerOptions t;
  t.bvh.width = bvh_width;
  t.bvh.max_leaf_size = leaf_size;
  t.accel =
      accel == "bvh" ? hw::AccelMode::kBvh : (accel == "brute" ? hw::AccelMode::kBrute : hw::AccelMode::kAuto);
  return t;
}

void add_accel_options(CLI::App& app, AccelOptions& o) {
  app.add_option("--bvh-width", o.bvh_width, "BVH children per node")
      ->check(CLI::IsMember({2, 4, 8}))
      ->capture_default_str();
  app.add_option("--leaf-size", o.leaf_size, "maximum primitives per BVH leaf")
      ->check(CLI::Range(1, hw::kMaxLeafSize))
      ->capture_default_str();
  app.add_option("--accel", o.accel,
                 "acceleration: bvh, brute (for each primitive), or auto (brute force when a BVH costs more)")
      ->check(CLI::IsMember({"auto", "bvh", "brute"}))
      ->capture_default_str();
}

Json bvh_json(const hw::FloatTracer& t) {
  Json j;
  j["accel"] = t.uses_bvh() ? "bvh" : "brute";
  j["brute_cost"] = t.brute_cost();
  if (const hw::Bvh* b = t.bvh()) {
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
    j["leaf_prim_bytes"] = t.leaf_prim_bytes();
    j["bytes_per_prim"] = f.prims ? double(f.node_bytes + f.index_bytes) / double(f.prims) : 0.0;
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
