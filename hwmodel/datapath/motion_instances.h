// Instances with two transforms: a mesh placed by one object -> world transform at shutter time 0 and another at
// time 1, the transform at a time between them their entrywise linear interpolation (Embree 3's instances with two
// time steps; DXR's and Vulkan's matrix motion instances interpolate the same way). Each point of the mesh then
// moves on a line between its two key-frame places, so the instance at any time lies inside the linear
// interpolation of its two key-frame boxes, and the top level is a MotionBvh over them (scene/motion.h). The
// meshes themselves are static (moving primitives are MotionGeometry's).
//
// The float reference interpolates the transform at the ray's time in double, inverts it (invert), and traces the
// mesh's FloatTracer with the object ray (object_ray). The fixed unit is the time-aware one: its box unit
// interpolates the top level's grid key boxes at the top box_time_bits of the ray's time register (motion_box, as
// for moving primitives); at an instance record its transform unit interpolates the two stored object -> world
// transforms at the register's time, each entry rounded to xform_bits significant bits, inverts that, each entry
// rounded again (StoredXform::from_inverse), and hands the object ray to the mesh's bottom level as a static
// instance's (InstancedFixedTracer::trace_instance_as). The roundings move the instance by a few of those bits'
// ulps of its coordinates: the key boxes are widened by 2^-min(20, xform_bits - 4) of their largest coordinate
// (docs/numerics.md, "Motion blur").
//
// Primitive indices are the flattened scene's (InstanceSet::flatten), as for static instances.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "hwmodel/datapath/instanced_fixed.h"
#include "hwmodel/datapath/instancing.h"
#include "hwmodel/datapath/motion_tracer.h"
#include "hwmodel/scene/motion.h"

namespace rtu::hw {

struct MotionInstanceSet {
  InstanceSet set;          // meshes and instances; instance i's to_world is its transform at shutter time 0
  std::vector<Affine> end;  // per instance: its object -> world transform at shutter time 1

  // Instance inst's object -> world transform at `time`: each entry (1 - time) a + time b, in double.
  AffineD at(uint32_t inst, double time) const;
  // Whether instance inst's two transforms differ.
  bool moving(uint32_t inst) const;
  // Instance inst's world box at key frame k (world_bounds of its mesh's box), widened by 2^-pad_exp of its
  // largest coordinate magnitude (pad_exp <= 20).
  Aabb key_bounds(uint32_t inst, int k, int pad_exp = 20) const;
  // Throws std::invalid_argument naming the first problem: set.validate()'s, a count of end transforms other than
  // the instances', an end transform that is not finite, a world coordinate beyond kMaxCoordinate at time 1, a
  // transform singular at some time of the shutter (|det| at most invert's bound at some t in [0, 1]), spheres or
  // curve segments in an instance whose transforms differ (they would not stay round).
  void validate() const;
  // The flattened moving scene: every instance's triangles at both key frames (their vertices placed by each key
  // transform), its spheres and curve segments still; the same primitive numbering.
  MotionGeometry flatten() const;
};

// The float reference (see the top of this file). Keeps a reference to set: it must outlive the tracer.
class MotionInstancedFloatTracer {
 public:
  // Throws std::invalid_argument for a set that does not validate.
  explicit MotionInstancedFloatTracer(const MotionInstanceSet& set, const TracerOptions& opt = {});
  ~MotionInstancedFloatTracer();
  Hit trace(const Ray& r, float time, bool any_hit, TraversalStats& s) const;
  void trace_batch(const std::vector<Ray>& rays, const std::vector<float>& times, std::vector<Hit>& hits,
                   bool any_hit, int threads, TraversalStats& s) const;
  const MotionBvh& top() const { return m_top; }

 private:
  const MotionInstanceSet& m_set;
  std::vector<std::unique_ptr<FloatTracer>> m_mesh_tracers;
  MotionBvh m_top;
  std::vector<uint32_t> m_ids;  // the top level's items -> instance
};

// The time-aware fixed unit over instances with two transforms (see the top of this file). Keeps a reference to
// set: it must outlive the tracer.
class MotionInstancedFixedTracer {
 public:
  // `opt` chooses each mesh's BVH as InstancedFixedTracer does (opt.bvh.width must be f.width); check_boxes
  // repeats every box test exactly, both levels (box_false_negatives must stay 0). Throws std::invalid_argument
  // for a set that does not validate or a bad format.
  MotionInstancedFixedTracer(const MotionInstanceSet& set, const FixedFormat& f, const MotionFormat& m,
                             const TracerOptions& opt, bool check_boxes = false);
  ~MotionInstancedFixedTracer();
  Hit trace(const Ray& r, float time, bool any_hit, TraversalStats& s) const;
  void trace_batch(const std::vector<Ray>& rays, const std::vector<float>& times, std::vector<Hit>& hits,
                   bool any_hit, int threads, TraversalStats& s) const;
  // trace() with the events for the timing model: the top level's kNode (node index), kPrim (count kInstance,
  // index the instance's record in leaf order), kPush and kPop; each instance's bottom level between kEnter and
  // kLeave. moving_to_shader: a moving instance's kPrim is followed by kAnyHit, the round trip to the shader that
  // interpolates its transform on a unit that cannot (docs/timing-model.md, "Motion blur"); the hit is the same.
  Hit trace_recorded(const Ray& r, float time, bool any_hit, TraversalStats& s, std::vector<TraceEvent>& events,
                     bool moving_to_shader = false) const;
  // Every instance traced at the ray's time without the top level: the closest hit the unit can find (of equal t,
  // the later instance). What the top level must give: tests check that it loses none.
  Hit trace_all(const Ray& r, float time) const;
  // The transform unit's world -> object transform of instance inst at time register tq.
  StoredXform xform_at(uint32_t inst, uint32_t tq) const;

  const InstancedFixedTracer& bottoms() const { return *m_bottoms; }
  const MotionFormat& motion() const { return m_motion; }
  const FixedFormat& format() const { return m_format; }
  int width() const { return m_width; }
  uint64_t node_count() const { return m_child.size() / uint64_t(m_width); }
  uint32_t record_count() const { return uint32_t(m_prim_ids.size()); }
  // The instance behind top-level record i (leaf order), and whether it moves.
  uint32_t record_instance(uint32_t i) const { return m_ids[m_prim_ids[i]]; }
  bool record_moving(uint32_t i) const { return m_set.moving(record_instance(i)); }

 private:
  Hit trace_impl(const Ray& r, float time, bool any_hit, TraversalStats& s, std::vector<TraceEvent>* rec,
                 bool shader) const;
  const MotionInstanceSet& m_set;
  FixedFormat m_format;
  MotionFormat m_motion;
  bool m_check;
  Geometry m_flat;  // the flattened scene at time 0: numbers the hits
  std::unique_ptr<InstancedFixedTracer> m_bottoms;
  QuantFrame m_frame;  // the top level's, over both key frames
  int m_width = 4;
  uint32_t m_root = kEmptyChild;
  std::vector<uint32_t> m_child;     // node * width + slot
  std::vector<int32_t> m_boxes;      // 12 per slot (motion_box's key)
  std::vector<uint32_t> m_prim_ids;  // leaf order -> item
  std::vector<uint32_t> m_ids;       // item -> instance
};

}  // namespace rtu::hw
