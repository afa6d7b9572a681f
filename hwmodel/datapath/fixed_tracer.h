// The fixed device's tracer: the bit-accurate fixed-point datapath (intersect_fixed.h) over a device memory image
// (device_image.h), with the traversal loop the float device uses (traverse.h). Planes first, per ray; then the
// BVH, or every record when the image has none. Reads nothing but the image.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "hwmodel/datapath/box_unit.h"
#include "hwmodel/datapath/hit_list.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/datapath/traverse.h"
#include "hwmodel/datapath/tri_unit.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/micromap.h"
#include "hwmodel/interface/any_hit.h"
#include "hwmodel/interface/ray.h"

namespace rtu::hw {

// What one ray did in the datapath, in order; the timing model replays it (timing_model.h) so the timed device's
// hits are the fixed device's by construction.
// The stack traffic comes in one of two forms (FixedTraceOptions::record_short_stack): every push and pop (kPush,
// kPop), or only what passes a short stack of a given size (kSpill: entries pushed beyond it, kRefill: one entry
// popped from beyond it), which is all the timing model charges for, in fewer events.
// The count of a curve segment's kPrim event: its record kind (a round record with round word kRoundCurve), its
// test the curve unit's.
inline constexpr uint8_t kPrimCurve = uint8_t(RecordKind::kCurve);

// t raw of world t, rounded up: a top level culls with it, so it must not cut off the hit it stands for.
inline int64_t t_raw_up(float t, const FixedRay& r) {
  const double raw = std::ceil(std::ldexp(double(t), r.t_exp));
  return raw >= double(r.t_limit) ? r.t_limit : std::max<int64_t>(0, int64_t(raw));
}

struct TraceEvent {
  // kAnyHit follows the kPrim of a non-opaque triangle whose hit went to the any-hit stage (any_hit.h): the ray
  // waits in its slot for the firmware's answer.
  // Two levels (instanced_fixed.h): the kPrim of an instance record (count kInstance: the record, its stored
  // transform and the transform) is followed by kEnter (index: the mesh whose bottom level the ray enters), the
  // bottom level's events (their indices are that image's), and kLeave (index: the same mesh).
  enum Kind : uint8_t {
    kNode = 0,
    kPrim = 1,
    kPlane = 2,
    kPush = 3,
    kPop = 4,
    kSpill = 5,
    kRefill = 6,
    kAnyHit = 7,
    kEnter = 8,
    kLeave = 9,
    kStackRef = 10,  // a node pushed on the stack (FixedTraceOptions::record_stack_refs): count its rank in pop
                     // order (0: popped first), index the node; a leaf (record_leaf_refs): unit_issue its
                     // records (>= 1, 0 for a node), index its first record
    kRestart = 11,   // a restart from the root (FixedTraceOptions::record_restart, restart_trail.h): index the
                     // nodes re-visited, whose kNode events follow
    kRayKey = 12,  // first in a ray's events when the timing model gathers rays (ray_gather.h): index its bin key
    kOmm = 13,     // the unit's opacity micromap lookup for a non-opaque triangle's candidate hit (micromap.h),
                   // after its kPrim: count the state found (MicroState), index the state's byte in the maps'
                   // section (MicromapSet::state_byte)
    kHitOut = 14   // all-hit traversal (trace_all): a hit found, after its test; count 1 when it is kept (written
                   // to the ray's hit list), 0 when only counted (the list is full); index its primitive
  };
  uint8_t kind;
  uint8_t
      count;  // kNode: child boxes tested; kPrim: the record's RecordKind (record_kind; kPrimCurve for a curve
              // segment); kPush: entries pushed; kSpill: entries spilled (pushed beyond the short stack); else 0
  // kNode tested by a BoxUnit (box_unit.h), or a triangle kPrim tested by a TriUnit (tri_unit.h): the clocks the
  // unit reported (issue, result); 0, 0 for the C++ tests, whose clocks the timing model takes from its
  // configuration.
  uint8_t unit_issue, unit_result;
  uint32_t index;  // kNode: node index; kPrim, kAnyHit: record index; kPlane: plane index; else 0
};
static_assert(sizeof(TraceEvent) == 8);

// What the unit does at an instance record of a top-level image (kImageTopLevel): transform the ray into the
// instance's object space and trace its bottom level (instanced_fixed.h). Called from every thread a batch is
// traced on, as AnyHitStage.
class BottomLevels {
 public:
  // Traces world ray r through instance `inst` over [r.tmin, tmax] (tmax: the closest hit so far, or r.tmax).
  // On a hit within that interval, fills h (world t, flattened primitive index, u, v) and returns true. Adds
  // the work (not a ray) to s, and when `rec` is not null the bottom level's events (kEnter ... kLeave).
  virtual bool trace_instance(uint32_t inst, const Ray& r, float tmax, bool any_hit, Hit& h, TraversalStats& s,
                              std::vector<TraceEvent>* rec) const = 0;
  // All-hit traversal (FixedTracer::trace_all) of world ray r through instance `inst` over [r.tmin, r.tmax]: its
  // bottom level's hits (world t, flattened primitive indices) into `all`; the work and events as above.
  virtual void trace_instance_all(uint32_t inst, const Ray& r, HitList& all, TraversalStats& s,
                                  std::vector<TraceEvent>* rec) const = 0;

 protected:
  ~BottomLevels() = default;
};

struct FixedTraceOptions {
  // Repeat every box test with the exact checker (box_test_exact) and count disagreements in the statistics
  // (box_false_negatives must stay 0). Slower; what `rtusim compare` and the tests use.
  bool check_boxes = false;
  // The traversal watchdog: node and leaf visits one ray may make before it is stopped (a miss, counted in
  // TraversalStats::watchdog_rays). 0: the image's bound, node_total() * width + 1: in a tree (what
  // DeviceImage::from_bytes accepts) every node and leaf reference is visited at most once, so only a
  // corrupted image held outside from_bytes, or a smaller configured bound, can reach it.
  uint64_t max_steps = 0;
  // Box tests by this unit instead of the C++ box test (co-simulation); not owned, must outlive the tracer's
  // use. A tracer with a unit traces on one thread (trace_batch ignores its thread count).
  BoxUnit* box_unit = nullptr;
  // Triangle tests by this unit instead of triangle_test (co-simulation; spheres and planes stay C++); not owned,
  // as box_unit. A tracer with a unit traces on one thread.
  TriUnit* tri_unit = nullptr;
  // Recording (trace_recorded): -1 records every push and pop (kPush, kPop); N >= 0 records the stack as a short
  // stack of N entries sees it: pushes and pops within it are left out, entries pushed beyond it are kSpill
  // events, entries popped from beyond it kRefill events (the timing engine sets its stack_entries here).
  int record_short_stack = -1;
  // Recording: after a push's stack event, one kStackRef per inner node pushed, nearest first (what a stack
  // prefetcher sees, prefetch/stack.h). Off: no such events.
  bool record_stack_refs = false;
  // With record_stack_refs: leaves pushed are recorded too (kStackRef with unit_issue = its record count).
  bool record_leaf_refs = false;
  // Recording with record_short_stack = N >= 0: the short stack drops its oldest entry instead of spilling it, and
  // a pop of a dropped entry restarts from the root with a trail (restart_trail.h): a kRestart event and the kNode
  // events of the nodes re-visited, no kSpill or kRefill. The hits are the same.
  bool record_restart = false;
  // Treelet-first order (traverse.h, traverse_treelet_first) over these treelets, or (null map) the default
  // depth-first, nearest-first order. Of two primitives hit at the same t it may report the other. Not with
  // record_restart or record_stack_refs (their trail and stack view are of one stack); one-level images only.
  // Not owned; must outlive the tracer's use.
  TreeletMap treelets = {};
  // A node's accepted children in slot order instead of nearest first (traverse.h): Vulkan-Sim's order. Of two
  // primitives hit at the same t it may report the other.
  bool slot_order = false;
  // The any-hit stage of non-opaque triangles (records with kRecordNonOpaque), or null: they are opaque. Not
  // owned; must outlive the tracer's use.
  const AnyHitStage* any_hit = nullptr;
  // Opacity micromaps of the non-opaque triangles (micromap.h), indexed by their primitive index, or null: a
  // candidate hit in a known micro-triangle is resolved without the stage (one-level images; a top level's
  // bottom levels get none). Not owned.
  const MicromapSet* micromaps = nullptr;
  // A top-level image's bottom levels; required by one (its instance records miss without it). Not owned.
  const BottomLevels* bottom = nullptr;
};

class FixedTracer {
 public:
  // Keeps a reference to `image`: it must outlive the tracer.
  explicit FixedTracer(const DeviceImage& image, const FixedTraceOptions& opt = {});

  // Traces one ray. Rays rejected at setup (setup_ray) miss and are counted by reason.
  Hit trace(const Ray& r, bool any_hit, TraversalStats& s) const;
  // As FloatTracer::trace_batch: results and summed statistics do not depend on the thread count.
  void trace_batch(const Ray* rays, Hit* hits, size_t n, bool any_hit, int threads, TraversalStats& s) const;

  // Traces a ray already set up in the image's format and frame (setup_ray, or built on the grid). The hit's t
  // is world t (t_to_world); u, v of spheres are not filled (they need the float ray).
  Hit trace_fixed(const FixedRay& r, bool any_hit, TraversalStats& s) const;
  // All-hit traversal (hit_list.h): every intersection in [tmin, tmax] into `all`, in traversal order, one per
  // record (its first crossing in the interval); the interval is never narrowed. The any-hit stage and micromaps
  // still decide non-opaque triangles. `events` (if not null) gets the datapath's events, as trace_recorded's.
  // A top level traces every instance the ray enters through its bottom level's all-hit traversal. Returns
  // all.count.
  uint64_t trace_all(const Ray& r, HitList& all, TraversalStats& s,
                     std::vector<TraceEvent>* events = nullptr) const;
  // trace() that also appends the ray's datapath events to `events` (nothing for a ray rejected at setup).
  Hit trace_recorded(const Ray& r, bool any_hit, TraversalStats& s, std::vector<TraceEvent>& events) const;

  // Where the watchdog stopped a ray.
  struct WatchState {
    uint64_t steps = 0;  // node and leaf visits so far
    uint32_t ref = 0;    // the node or leaf reference it was about to visit when stopped
    int depth = 0;       // traversal stack entries then
    bool fired = false;
  };
  // The step bound in force (max_steps, or the image's own).
  uint64_t step_limit() const { return m_step_limit; }
  // After a batch in which the watchdog stopped rays: which ray was first and where it stood (node, stack
  // depth, steps), for the WatchdogError the engines throw.
  std::string watchdog_report(const Ray* rays, size_t n, bool any_hit, uint64_t stopped) const;

  // Attaches (or with null detaches) the any-hit stage (FixedTraceOptions::any_hit).
  void set_any_hit(const AnyHitStage* stage) { m_opt.any_hit = stage; }
  void set_micromaps(const MicromapSet* maps) { m_opt.micromaps = maps; }

  const DeviceImage& image() const { return m_image; }
  const FixedFormat& format() const { return m_format; }
  const QuantFrame& frame() const { return m_frame; }

 private:
  // Ray setup, then trace_counted; rejected rays are counted by reason.
  Hit trace_world(const Ray& r, bool any_hit, TraversalStats& s, std::vector<TraceEvent>* rec,
                  WatchState* ws = nullptr) const;
  // Counts the ray and the saturations of trace_valid. r (the world ray) is only for sphere u, v; may be null.
  Hit trace_counted(const Ray* r, const FixedRay& fr, bool any_hit, TraversalStats& s,
                    std::vector<TraceEvent>* rec = nullptr, WatchState* ws = nullptr) const;
  Hit trace_valid(const Ray* r, const FixedRay& fr, bool any_hit, TraversalStats& s, std::vector<TraceEvent>* rec,
                  WatchState& ws) const;
  // The hit of a record's test (t raw, prim, u, v, the record): world t, and a sphere's u, v from the world ray.
  Hit world_hit(int64_t t, uint32_t prim, float u, float v, const uint8_t* record, const FixedRay& fr,
                const Ray* r) const;

  const DeviceImage& m_image;
  FixedFormat m_format;
  QuantFrame m_frame;
  RaySetup m_setup;  // setup_ray for m_frame and m_format
  FixedTraceOptions m_opt;
  uint64_t m_step_limit = 0;
};

}  // namespace rtu::hw
