// Instancing: a two-level scene. Bottom levels are meshes in object space, each with its own BVH; the top level
// is a BVH over instances, each a mesh placed by an affine object-to-world transform. A ray that reaches an
// instance is transformed into the mesh's object space (t is unchanged: the direction is transformed without
// normalizing, so o' + t d' is the object-space image of o + t d) and traced through the mesh's BVH.
//
// Primitive indices: hits name primitives of the flattened scene (flatten()), the index space of hit files and
// of the renderer: instance i's triangles are [tri_base, tri_base + triangles) in instance order; spheres
// follow every triangle, instance by instance; planes (never instanced) come last. So a scene gives the same
// hits, up to rounding, traced two-level or flattened.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/hit_list.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/interface/any_hit.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/scene/aabb.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

// x' = L x + t, row-major: m[r] = (L[r][0], L[r][1], L[r][2], t[r]), the layout of Embree's FLOAT3X4_ROW_MAJOR.
struct Affine {
  float m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};

  bool is_identity() const;
  // In double, rounded once to float.
  Vec3 point(const Vec3& p) const;
  Vec3 vector(const Vec3& v) const;
};

// The same transform in double, for the inverse the reference traces with.
struct AffineD {
  double m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
};

// The inverse of `a` in double. Returns false when a has a non-finite entry or is singular: |det L| at most
// 2^-40 of the product of its rows' lengths (a scale that flat loses 40 bits of every coordinate).
bool invert(const Affine& a, AffineD& inv);
bool invert(const AffineD& a, AffineD& inv);

// World ray r in the object space of an instance whose world -> object transform is x: origin and direction
// transformed in double, rounded once to float; t unchanged (the direction is not normalized).
Ray object_ray(const AffineD& x, const Ray& r);

// An object-space box placed by to_world: the eight corners transformed in double, rounded outward, widened by
// 2^-20 of the largest coordinate magnitude (InstanceSet::world_bounds). Empty for an empty box.
Aabb world_bounds(const Aabb& object, const AffineD& to_world);

// The largest depth of nested transforms a scene may have before flattening them into one per instance (node
// hierarchies of imported files, instance groups of scene files): deeper is refused at import.
inline constexpr int kMaxInstanceNesting = 32;

struct Instance {
  uint32_t mesh = 0;         // index into InstanceSet::meshes
  Affine to_world;           // object -> world
  uint32_t tri_base = 0;     // flattened index of its first triangle (set by InstanceSet::finish)
  uint32_t sphere_base = 0;  // flattened index of its first sphere
  uint32_t curve_base = 0;   // flattened index of its first curve segment
};

// Whether a's linear part is a similarity (L L^T = s^2 I within 2^-20 of s^2: a rotation, maybe a reflection,
// times a uniform scale), and its scale s. Spheres and curve segments stay round under a similarity, so they may
// be instanced with one.
bool similarity_scale(const Affine& a, double& scale);

struct InstanceSet {
  std::vector<Geometry> meshes;  // object space; triangles, spheres and curve segments, no planes
  std::vector<Instance> instances;

  // Sets every instance's tri_base, sphere_base and curve_base (triangles of instance 0, 1, ..., then spheres in
  // the same order, then curve segments). Call after filling meshes and instances.
  void finish();
  // Throws std::invalid_argument naming the first problem: a mesh index out of range, a mesh with planes, a
  // transform that is not finite or singular (invert), a sphere or curve segment under a transform that is not a
  // similarity (similarity_scale: it would not stay round), a world coordinate beyond kMaxCoordinate, more than
  // kMaxBvhPrims primitives, bases not set by finish().
  void validate() const;

  uint32_t num_triangles() const;
  uint32_t num_spheres() const;
  // Flattened index of instance i's primitive `local` (its mesh's index space: triangles, then spheres, then curve
  // segments).
  uint32_t global_prim(uint32_t inst, uint32_t local) const {
    const Instance& in = instances[inst];
    const Geometry& m = meshes[in.mesh];
    const uint32_t nt = uint32_t(m.triangles.size()), ns = uint32_t(m.spheres.size());
    return local < nt        ? in.tri_base + local
           : local < nt + ns ? in.sphere_base + (local - nt)
                             : in.curve_base + (local - nt - ns);
  }
  // World bounds of instance i: its mesh's bounds transformed (the eight corners, in double), rounded outward,
  // then widened by 2^-20 of its largest coordinate magnitude, for the rounding of transformed rays (each of
  // their coordinates within a few ulps of float, far below 2^-20).
  Aabb world_bounds(uint32_t inst) const;
  // The flattened scene: every instance's primitives in world space (Affine::point; a sphere's or curve segment's
  // radius times the similarity's scale), in the order above, then `planes`.
  Geometry flatten(const std::vector<Plane>& planes) const;
};

// The any-hit stage as a mesh's tracer sees it: its triangle indices are the mesh's, the stage's the flattened
// scene's (instance `inst` of `set`).
class InstanceAnyHit final : public AnyHitStage {
 public:
  InstanceAnyHit(const AnyHitStage& stage, const InstanceSet& set, uint32_t inst)
      : m_stage(stage), m_set(set), m_inst(inst) {}
  bool accept(uint32_t prim, float u, float v) const override {
    return m_stage.accept(m_set.global_prim(m_inst, prim), u, v);
  }

 private:
  const AnyHitStage& m_stage;
  const InstanceSet& m_set;
  uint32_t m_inst;
};

// The float reference at an instance: object ray o (object_ray of the world ray, its tmax the closest hit so far)
// traced by instance `inst`'s mesh tracer with `stage`; a hit at or before closest.t becomes the closest (the
// flattened scene's index). The work (not a ray) goes to s. Returns whether the closest changed.
bool trace_instance_float(const FloatTracer& mesh, const Ray& o, const InstanceSet& set, uint32_t inst,
                          bool any_hit, const AnyHitStage* stage, Hit& closest, TraversalStats& s);

// The float reference over an instance set: the top level (a BVH over the instances' world bounds) traversed as
// every float BVH is (traverse.h); at an instance, the ray is transformed to object space in double, rounded to
// float once, and traced by that mesh's FloatTracer (BVH or brute force by its own choice) over the interval
// still open. Planes of the flattened scene are tested first, as FloatTracer does.
class InstancedFloatTracer {
 public:
  // Keeps references to both: they must outlive the tracer. `flat` is the flattened scene (its planes are
  // traced; its other primitives only number the hits).
  InstancedFloatTracer(const InstanceSet& set, const Geometry& flat, const TracerOptions& opt = {});
  ~InstancedFloatTracer();
  InstancedFloatTracer(const InstancedFloatTracer&) = delete;
  InstancedFloatTracer& operator=(const InstancedFloatTracer&) = delete;

  Hit trace(const Ray& r, bool any_hit, TraversalStats& s) const;
  void trace_batch(const Ray* rays, Hit* hits, size_t n, bool any_hit, int threads, TraversalStats& s) const;
  // All-hit traversal (FloatTracer::trace_all) over both levels: every instance the ray enters traced for all of
  // its mesh's hits (flattened primitive indices). Returns all.count.
  uint64_t trace_all(const Ray& r, HitList& all, TraversalStats& s) const;

  // The any-hit stage for non-opaque triangles (the meshes' Geometry::non_opaque; the stage sees flattened
  // primitive indices), or null: they are opaque. Not owned.
  void set_any_hit(const AnyHitStage* stage) { m_any_hit = stage; }

  const Bvh& top() const { return m_top; }
  const FloatTracer& mesh_tracer(uint32_t mesh) const { return *m_mesh_tracers[mesh]; }
  // Bytes of the two levels: the top BVH's nodes, every mesh's BVH nodes and leaf primitives.
  uint64_t bytes() const;

 private:
  template <int N>
  void trace_top(const WideBvh<N>& t, const Ray& r, bool any_hit, Hit& h, TraversalStats& s,
                 HitList* all = nullptr) const;

  const InstanceSet& m_set;
  const Geometry& m_flat;
  Geometry m_planes;  // the flattened scene's planes alone
  std::unique_ptr<FloatTracer> m_plane_tracer;
  std::vector<std::unique_ptr<FloatTracer>> m_mesh_tracers;
  std::vector<AffineD> m_to_object;  // per instance
  Bvh m_top;                         // over the instances with bounded primitives
  std::vector<uint32_t> m_top_ids;   // the top level's leaf index -> instance
  const AnyHitStage* m_any_hit = nullptr;
};

}  // namespace rtu::hw
