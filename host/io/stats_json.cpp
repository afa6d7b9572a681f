#include "host/io/stats_json.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <variant>

#include "host/io/error.h"
#include "host/io/files.h"
#include "hwmodel/interface/enum_names.h"

namespace rtu::host {

Json two_level_json(const hw::InstancedFixedTracer& t) {
  Json j;
  uint64_t bottoms = 0;
  size_t meshes = 0;
  for (; meshes < t.bottom_count(); ++meshes) bottoms += t.bottom(uint32_t(meshes)).size();
  j["top_bytes"] = t.top().size();
  j["bottom_bytes"] = bottoms;
  j["meshes"] = meshes;
  j["transform_bytes"] = t.transform_bytes();
  j["total_bytes"] = t.bytes();
  j["rebased_visits"] = t.rebased();
  return j;
}

Json format_json(const hw::FixedFormat& f) {
  Json j;
  j["name"] = f.name;
  for (const hw::FormatField& field : hw::format_fields()) j[field.key] = f.*field.member;
  j["box_product_bits"] = f.box_product_bits();
  j["edge_function_bits"] = f.edge_function_bits();
  return j;
}

const char* node_layout_name(int layout) {
  static constexpr const char* names[] = {"structs", "bit-packed", "compressed-wide"};
  static_assert(hw::count_of(names) == size_t(hw::NodeLayout::kCompressedWide) + 1, "a name for every layout");
  return hw::enum_name(names, layout);  // a negative int converts to a huge index: "unknown"
}

const char* prim_layout_name(int layout) {
  static constexpr const char* names[] = {"records", "blocks", "clusters"};
  static_assert(hw::count_of(names) == size_t(hw::PrimLayout::kClusters) + 1, "a name for every layout");
  return hw::enum_name(names, layout);
}

double image_bytes_per_prim(const hw::DeviceImage& img) {
  const uint64_t prims = uint64_t(img.header().num_triangles) + img.header().num_spheres;
  return prims ? double(img.nodes_size() + img.records_size()) / double(prims) : 0.0;
}

Json image_json(const hw::DeviceImage& img, const hw::Bvh* bvh) {
  const hw::ImageHeader& h = img.header();
  Json j;
  j["node_layout"] = node_layout_name(h.node_layout);
  j["node_align"] = h.node_align;
  j["prim_layout"] = prim_layout_name(h.prim_layout);
  j["bytes_per_node"] = img.node_bytes();
  j["nodes"] = h.node_count;
  j["node_bytes"] = img.nodes_size();
  j["records"] = h.record_count;
  j["record_bytes"] = img.records_size();
  j["plane_bytes"] = img.planes_size();
  j["total_bytes"] = img.size();
  j["bytes_per_prim"] = image_bytes_per_prim(img);
  if (hw::PrimLayout(h.prim_layout) == hw::PrimLayout::kClusters) {
    // Triangle clusters: their internal nodes (in record_bytes, not in nodes) and the clusters that have some.
    uint64_t clusters = 0;
    for (const hw::DeviceImage::Span& s : img.cluster_node_spans()) clusters += s.bytes > 0;
    j["cluster_nodes"] = img.cluster_node_spans().size();
    j["clusters"] = clusters;
  }
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
  // Candidate hits on alpha-tested (non-opaque) triangles sent to the any-hit stage, and those it ignored.
  j["any_hit_calls"] = s.any_hit_calls;
  j["any_hit_ignored"] = s.any_hit_ignored;
  if (s.omm_opaque + s.omm_transparent) {  // opacity micromaps resolved these without the stage
    j["omm_opaque"] = s.omm_opaque;
    j["omm_transparent"] = s.omm_transparent;
  }
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
  std::ofstream out = open_output(path);
  out << j.dump(2) << '\n';
  finish_output(out, path);
}

}  // namespace rtu::host
