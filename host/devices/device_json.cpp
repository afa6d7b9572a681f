#include "host/devices/device_json.h"

namespace rtu::host {

Json bvh_json(const DirectDevice& d) {
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
  if (const hw::InstancedFixedTracer* t = d.instanced()) j["image"]["two_level"] = two_level_json(*t);
  return j;
}

ImageBytes device_image_bytes(const DirectDevice& d) {
  ImageBytes b;
  if (const hw::InstancedFixedTracer* t = d.instanced()) {
    const hw::ImageHeader& h = t->top().header();
    const uint64_t prims = uint64_t(h.num_triangles) + h.num_spheres;
    b.total = t->bytes();
    b.per_prim = prims ? double(b.total - t->top().planes_size()) / double(prims) : 0.0;
  } else if (const hw::DeviceImage* img = d.image()) {
    b.total = img->size();
    b.per_prim = image_bytes_per_prim(*img);
  }
  return b;
}

}  // namespace rtu::host
