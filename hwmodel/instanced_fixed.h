// The fixed device over two levels: a top-level image (a BVH over the instances' world bounds, whose leaves are
// instance records, and the scene's planes), one bottom-level image per mesh, each in its own quantization frame
// fitted to the mesh in object space, and one stored transform per instance (world -> object).
//
// At an instance record the unit transforms the world ray it holds (float32, as received) into object space,
// the transform unit: every entry of the stored 3x4 matrix has the format's xform_bits significant bits; the
// three products and sums of a row are formed exactly (a fused dot product) and rounded once to float32. The
// object ray then goes through the bottom level's own ray setup (fixed point from there on). t is unchanged by
// the transform (the direction is not normalized), so the bottom level's t is world t.
//
// An origin far outside a small mesh's frame (beyond its guard bits) cannot be set up on that grid: the unit then
// moves the origin along the ray to where it enters the mesh's bounds (t0, in float) and adds t0 back to the hit's
// t. Both roundings are part of the model and of the error compare measures.
//
// Primitive indices are the flattened scene's (instancing.h), so hits compare with every other device's.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hwmodel/any_hit.h"
#include "hwmodel/bvh.h"
#include "hwmodel/device_image.h"
#include "hwmodel/fixed_format.h"
#include "hwmodel/fixed_tracer.h"
#include "hwmodel/float_tracer.h"
#include "hwmodel/instancing.h"
#include "hwmodel/ray.h"
#include "hwmodel/stats.h"

namespace rtu::hw {

// x rounded to `bits` significant bits (nearest, ties to even), as the transform unit stores it; bits 8..24.
float round_significant(double x, int bits);

// A world -> object transform as the unit stores it.
struct StoredXform {
  float m[3][4] = {};  // row-major as Affine; each entry has at most xform_bits significant bits

  // The inverse of an instance's object -> world transform (computed in double), each entry rounded.
  static StoredXform from_inverse(const AffineD& inv, int xform_bits);
  // The transform unit: each output component as the exact dot product (plus translation for the origin),
  // rounded once to float.
  Ray apply(const Ray& world) const;
  // Bytes of one stored transform: 12 entries of 1 sign, 8 exponent and xform_bits - 1 stored significand bits,
  // rounded up to whole bytes.
  static uint32_t bytes(int xform_bits);
};

class InstancedFixedTracer final : public BottomLevels {
 public:
  // Keeps references to set and flat (the flattened scene: its planes are traced, its counts number the hits);
  // they must outlive the tracer. `opt` chooses each mesh's BVH (or brute force) as the flat devices do;
  // opt.bvh.width must be f.width. trace_opt's any-hit stage sees flattened primitive indices. Throws
  // std::invalid_argument for a set that does not validate or a bad format.
  InstancedFixedTracer(const InstanceSet& set, const Geometry& flat, const FixedFormat& f,
                       const TracerOptions& opt, const FixedTraceOptions& trace_opt = {});
  ~InstancedFixedTracer();
  InstancedFixedTracer(const InstancedFixedTracer&) = delete;
  InstancedFixedTracer& operator=(const InstancedFixedTracer&) = delete;

  Hit trace(const Ray& r, bool any_hit, TraversalStats& s) const { return m_top_tracer->trace(r, any_hit, s); }
  // trace() with the datapath events of both levels (TraceEvent: kEnter and kLeave around a bottom level's).
  Hit trace_recorded(const Ray& r, bool any_hit, TraversalStats& s, std::vector<TraceEvent>& events) const {
    return m_top_tracer->trace_recorded(r, any_hit, s, events);
  }
  // Attaches (or with null detaches) the any-hit stage (FixedTraceOptions::any_hit) to every bottom level.
  void set_any_hit(const AnyHitStage* stage);
  // The mesh instance `inst` places.
  uint32_t mesh_of(uint32_t inst) const { return m_set.instances[inst].mesh; }
  size_t instance_count() const { return m_xforms.size(); }
  // As FixedTracer::trace_batch.
  void trace_batch(const Ray* rays, Hit* hits, size_t n, bool any_hit, int threads, TraversalStats& s) const {
    m_top_tracer->trace_batch(rays, hits, n, any_hit, threads, s);
  }
  std::string watchdog_report(const Ray* rays, size_t n, bool any_hit, uint64_t stopped) const {
    return m_top_tracer->watchdog_report(rays, n, any_hit, stopped);
  }

  const DeviceImage& top() const { return *m_top; }
  const FixedTracer& top_tracer() const { return *m_top_tracer; }
  const Bvh& top_bvh() const { return m_top_bvh; }
  const DeviceImage& bottom(uint32_t mesh) const { return *m_bottoms[mesh]; }
  size_t bottom_count() const { return m_bottoms.size(); }
  const StoredXform& xform(uint32_t inst) const { return m_xforms[inst]; }
  // Bytes of the two levels: the top image, every bottom image, and a stored transform and bottom-level address
  // (8 bytes) per instance.
  uint64_t bytes() const;
  uint64_t transform_bytes() const;
  // Instance visits that had to move the origin to the mesh's bounds (see the header comment); summed over all
  // threads, so only meaningful after a batch.
  uint64_t rebased() const;

  bool trace_instance(uint32_t inst, const Ray& r, float tmax, bool any_hit, Hit& h, TraversalStats& s,
                      std::vector<TraceEvent>* rec) const override;

 private:
  const InstanceSet& m_set;
  FixedFormat m_format;
  Bvh m_top_bvh;
  std::unique_ptr<DeviceImage> m_top;
  std::unique_ptr<FixedTracer> m_top_tracer;
  std::vector<std::unique_ptr<DeviceImage>> m_bottoms;    // per mesh
  std::vector<Aabb> m_mesh_bounds;                        // per mesh, object space
  std::vector<StoredXform> m_xforms;                      // per instance
  std::vector<std::unique_ptr<InstanceAnyHit>> m_stages;  // per instance, when an any-hit stage is attached
  std::vector<std::unique_ptr<FixedTracer>> m_tracers;    // per instance, over its mesh's image
  mutable std::unique_ptr<std::atomic<uint64_t>> m_rebased;
};

}  // namespace rtu::hw
