// Scene files: instancing (scenes/README.md, "prototypes" and "instances"): prototypes of meshes and instances,
// instances nested in prototypes under composed transforms, and the mesh files whose node trees place a mesh more
// than once, added as instances of their meshes.
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "host/io/error.h"
#include "host/scene/scene.h"
#include "host/scene/scene_file_reader.h"

namespace rtu::host::scene_file_detail {
namespace {

// A transform as an affine map in double.
struct Xform {
  glm::dmat3 linear{1.0};
  DVec3 translate{0.0};
  Xform then(const Transform& t) const {  // this map applied after t: x -> this(t(x))
    return Xform{linear * t.linear, linear * t.translate + translate};
  }
};

constexpr size_t kMaxInstances = size_t(1) << 20;

// An instance of mesh `mesh` placed by x, with its mesh's materials and texture coordinates.
void add_instance(Builder& b, uint32_t mesh, const Xform& x, const std::string& path) {
  const Reader& r = b.reader;
  hw::InstanceSet& set = b.scene.instances;
  if (set.instances.size() >= kMaxInstances)
    r.fail(path, "more than " + std::to_string(kMaxInstances) + " instances");
  hw::Instance in;
  in.mesh = mesh;
  for (int row = 0; row < 3; ++row) {
    for (int c = 0; c < 3; ++c) in.to_world.m[row][c] = float(x.linear[c][row]);
    in.to_world.m[row][3] = float(x.translate[row]);
  }
  hw::AffineD inv;
  if (!hw::invert(in.to_world, inv))
    r.fail(path, "the composed transform is not finite or is singular (in float)");
  const uint64_t before = b.instance_prims;
  b.instance_prims += set.meshes[mesh].num_bounded();
  if (b.instance_prims >= hw::kMaxBvhPrims) r.fail(path, "instances hold more than 2^27 - 1 primitives in all");
  // Each instance triangle takes its material and texture coordinates here and its world-space copy when the
  // scene is flattened: the flattened scene's budget (check_scene_size) is applied as the count grows, each time
  // it passes a multiple of 2^16 triangles (reading the limit is a file read), before that memory is taken.
  if ((before >> 16) != (b.instance_prims >> 16)) {
    try {
      check_scene_size("the instances so far", b.instance_prims);
    } catch (const Error& e) {
      r.fail(path, e.what());
    }
  }
  set.instances.push_back(in);
  const std::vector<uint32_t>& mats = b.mesh_tri_material[mesh];
  b.instance_tri_material.insert(b.instance_tri_material.end(), mats.begin(), mats.end());
  const std::vector<TriangleUv>& uvs = b.mesh_tri_uv[mesh];
  b.instance_tri_uv.insert(b.instance_tri_uv.end(), uvs.begin(), uvs.end());
  if (const auto it = b.mesh_curve_material.find(mesh); it != b.mesh_curve_material.end())
    b.instance_curve_material.insert(b.instance_curve_material.end(), it->second.begin(), it->second.end());
  if (const auto it = b.mesh_sphere_material.find(mesh); it != b.mesh_sphere_material.end())
    b.instance_sphere_material.insert(b.instance_sphere_material.end(), it->second.begin(), it->second.end());
}

// One instance entry at `path` under the transform `parent`, at nesting depth `depth` (1 at the top level).
void expand_instance(Builder& b, const Json& e, const std::string& path, const Xform& parent, int depth) {
  const Reader& r = b.reader;
  r.object(e, path);
  r.check_keys(e, path, {"prototype", "transform"});
  if (!e.contains("prototype")) r.fail(path, "missing key 'prototype'");
  const std::string name = r.string(e["prototype"], join(path, "prototype"));
  auto it = b.prototypes.find(name);
  if (it == b.prototypes.end()) {
    std::string known;
    for (const auto& [n, p] : b.prototypes) known += (known.empty() ? "" : ", ") + n;
    r.fail(join(path, "prototype"),
           "unknown prototype '" + name + "' (known: " + (known.empty() ? "none" : known) + ")");
  }
  Builder::Prototype& proto = it->second;
  if (proto.visiting) r.fail(join(path, "prototype"), "instance loop: '" + name + "' contains itself");
  if (depth > hw::kMaxInstanceNesting)
    r.fail(path, "instances nested deeper than " + std::to_string(hw::kMaxInstanceNesting) + " levels");
  const Xform x =
      e.contains("transform") ? parent.then(read_transform(r, e["transform"], join(path, "transform"))) : parent;
  if (proto.empty) return;  // its one full walk checked its entries and placed nothing
  const size_t placed = b.scene.instances.instances.size();
  if (proto.mesh != UINT32_MAX) add_instance(b, proto.mesh, x, path);
  if (proto.json->contains("instances")) {
    const Json& subs = (*proto.json)["instances"];
    proto.visiting = true;
    for (size_t i = 0; i < subs.size(); ++i)
      expand_instance(b, subs[i], join(join(proto.path, "instances"), i), x, depth + 1);
    proto.visiting = false;
  }
  proto.empty = b.scene.instances.instances.size() == placed;
}

// How many instances the entry `e` places, counted from the prototypes' entries without placing them and
// saturating above kMaxInstances, so that a fan of nested prototypes is refused before its instances are built.
// Entries the expansion refuses (not objects, unknown prototypes, loops, nesting deeper than its limit) count none
// here: it names them. The count may then fall short; add_instance's own check stays the bound.
uint64_t count_placements(const Builder& b, const Json& e, std::map<std::string, uint64_t>& memo,
                          std::set<std::string>& visiting, int depth) {
  if (depth > hw::kMaxInstanceNesting) return 0;
  if (!e.is_object() || !e.contains("prototype") || !e["prototype"].is_string()) return 0;
  const std::string name = e["prototype"].get<std::string>();
  const auto it = b.prototypes.find(name);
  if (it == b.prototypes.end() || visiting.count(name)) return 0;
  if (const auto m = memo.find(name); m != memo.end()) return m->second;
  const Builder::Prototype& proto = it->second;
  uint64_t n = proto.mesh != UINT32_MAX ? 1 : 0;
  if (proto.json->contains("instances") && (*proto.json)["instances"].is_array()) {
    visiting.insert(name);
    for (const Json& sub : (*proto.json)["instances"])
      n = std::min<uint64_t>(n + count_placements(b, sub, memo, visiting, depth + 1), kMaxInstances + 1);
    visiting.erase(name);
  }
  memo[name] = n;
  return n;
}

}  // namespace

void read_prototypes(Builder& b, const Json& j, const std::filesystem::path& base_dir) {
  const Reader& r = b.reader;
  r.object(j, "prototypes");
  for (const auto& item : j.items()) {
    const std::string path = join("prototypes", item.key());
    const Json& p = r.object(item.value(), path);
    if (item.key().empty()) r.fail(path, "prototype names must not be empty");
    r.check_keys(p, path, {"meshes", "spheres", "curves", "instances"});
    const bool own = p.contains("meshes") || p.contains("spheres") || p.contains("curves");
    if (!own && !p.contains("instances")) r.fail(path, "needs 'meshes', 'spheres', 'curves' or 'instances'");
    Builder::Prototype proto;
    proto.json = &item.value();
    proto.path = path;
    if (own) {  // its own geometry, in its object space: one mesh of the two levels
      hw::Geometry g;
      std::vector<uint32_t> mats;
      std::vector<TriangleUv> uvs;
      std::vector<uint32_t> curve_mats, sphere_mats;
      if (p.contains("meshes"))
        read_mesh_entries(b, p["meshes"], join(path, "meshes"), base_dir, g, mats, uvs, curve_mats);
      if (p.contains("spheres")) read_spheres(b, p["spheres"], join(path, "spheres"), g, sphere_mats);
      if (p.contains("curves")) read_curves(b, p["curves"], join(path, "curves"), g, curve_mats);
      uvs.resize(g.triangles.size());
      proto.mesh = uint32_t(b.scene.instances.meshes.size());
      if (!curve_mats.empty()) b.mesh_curve_material[proto.mesh] = std::move(curve_mats);
      if (!sphere_mats.empty()) b.mesh_sphere_material[proto.mesh] = std::move(sphere_mats);
      b.scene.instances.meshes.push_back(std::move(g));
      b.mesh_tri_material.push_back(std::move(mats));
      b.mesh_tri_uv.push_back(std::move(uvs));
    }
    if (p.contains("instances")) r.array(p["instances"], join(path, "instances"));
    b.prototypes[item.key()] = proto;
  }
}

// The mesh files kept two-level (Builder::instanced_files): their meshes after mesh 0, an instance per placement,
// its node transform composed after the entry's.
void add_file_instances(Builder& b) {
  for (Builder::InstancedFile& f : b.instanced_files) {
    const uint32_t base = uint32_t(b.scene.instances.meshes.size());
    for (size_t m = 0; m < f.set.meshes.size(); ++m) {
      b.mesh_tri_uv.push_back(std::move(f.mesh_uv[m]));
      b.mesh_tri_uv.back().resize(f.set.meshes[m].triangles.size());
      b.mesh_tri_material.push_back(std::move(f.mesh_material[m]));
      b.scene.instances.meshes.push_back(std::move(f.set.meshes[m]));
    }
    const Xform entry{f.transform.linear, f.transform.translate};
    for (const hw::Instance& in : f.set.instances) {
      Transform node;
      node.identity = false;
      for (int row = 0; row < 3; ++row) {
        for (int c = 0; c < 3; ++c) node.linear[c][row] = double(in.to_world.m[row][c]);
        node.translate[row] = double(in.to_world.m[row][3]);
      }
      add_instance(b, base + in.mesh, entry.then(node), f.path);
    }
  }
  b.instanced_files.clear();
}

void read_instances(Builder& b, const Json& j) {
  b.reader.array(j, "instances");
  std::map<std::string, uint64_t> memo;
  std::set<std::string> visiting;
  uint64_t total = b.scene.instances.instances.size();
  for (const Json& e : j)
    total = std::min<uint64_t>(total + count_placements(b, e, memo, visiting, 1), kMaxInstances + 1);
  if (total > kMaxInstances)
    b.reader.fail("instances", "more than " + std::to_string(kMaxInstances) + " instances");
  for (size_t i = 0; i < j.size(); ++i) expand_instance(b, j[i], join("instances", i), Xform{}, 1);
}

}  // namespace rtu::host::scene_file_detail
