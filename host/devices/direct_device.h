// The devices a host job drives directly, without firmware (trace, compare, stress, sweep), behind one interface:
// `float` (the reference), `fixed` (the bit-accurate fixed-point datapath over a device memory image) and `timed`
// (the fixed datapath with the timing model, called as the command processor would call it). All choose BVH or
// brute force by the same rule (hw::choose_accel) and traverse the same tree, so they differ only in their
// numbers.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "host/devices/grid_check.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/instanced_fixed.h"
#include "hwmodel/datapath/instancing.h"
#include "hwmodel/device/device_kind.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

struct DeviceOptions {
  hw::DeviceKind kind = hw::DeviceKind::kFloat;
  hw::TracerOptions tracer;  // acceleration choice and BVH build (bvh.width is the format's width)
  hw::FixedFormat format;    // the fixed device's number formats
  bool check_boxes = false;  // fixed: repeat box tests exactly and count false negatives
  hw::TimingConfig timing;   // timed: the unit's configuration (its format and width are in `format`)
  hw::SampleOptions sample;  // timed: sampled timing (fraction 0: every ray simulated)
  uint64_t max_steps = 0;    // fixed, timed: traversal watchdog, node and leaf visits per ray (0: automatic)
  // The scene's two levels (Scene::instances), or null. Every device traces them (the geometry passed to
  // make_device must then be their flattened form), except a timed device with a co-simulated (rtl) unit, which
  // traces the flattened geometry.
  const hw::InstanceSet* instances = nullptr;
  bool flatten = false;  // fixed, timed: ignore `instances` (trace the flattened geometry in one image)
  // The any-hit stage for the geometry's non-opaque triangles (alpha-tested materials: host/scene/shading.h), or
  // null: they are then opaque. Not owned: must outlive the device.
  const hw::AnyHitStage* any_hit = nullptr;
  // Fixed and timed devices, one level: the non-opaque triangles' opacity micromaps (hwmodel/format/micromap.h,
  // host/scene/micromap_bake.h), which the unit reads before asking the stage; null: none. Not owned.
  const hw::MicromapSet* micromaps = nullptr;
};

class DirectDevice {
 public:
  virtual ~DirectDevice() = default;
  virtual hw::DeviceKind kind() const = 0;
  const char* name() const { return hw::device_kind_name(kind()); }
  virtual void trace_batch(const hw::Ray* rays, hw::Hit* hits, size_t n, bool any_hit, int threads,
                           hw::TraversalStats& s) const = 0;
  // All-hit traversal (hit_list.h): every intersection of each ray in [tmin, tmax], up to out.k kept per ray. The
  // timed device times it as a TRACE with kTraceAllHits (never sampled).
  virtual void trace_all_batch(const hw::Ray* rays, size_t n, const hw::AllHitsOut& out, int threads,
                               hw::TraversalStats& s) const = 0;
  // What the device's ray setup says of r (a rejected ray is traced as a miss and counted by this reason).
  virtual hw::RayStatus ray_status(const hw::Ray& r) const = 0;
  // The BVH the device traverses (null: brute force), with its SAH and brute-force costs.
  virtual const hw::Bvh* bvh() const = 0;
  virtual double bvh_cost() const = 0;
  virtual double brute_cost() const = 0;
  // The fixed and timed devices' memory image (null for float).
  virtual const hw::DeviceImage* image() const { return nullptr; }
  // The fixed device over two levels (null for the others; its image() is the top level).
  virtual const hw::InstancedFixedTracer* instanced() const { return nullptr; }
  // The timed device's engine: cycles and timing statistics of what it traced (null for the others).
  virtual const hw::TimedEngine* timed() const { return nullptr; }
  hw::TimedEngine* timed() { return const_cast<hw::TimedEngine*>(std::as_const(*this).timed()); }
  // Timed device: record pipeline spans into `trace` (see hw::PipelineTrace); no effect on the others.
  virtual void set_pipeline_trace(hw::PipelineTrace* trace) { (void)trace; }
  // Bytes the float device keeps beside its BVH (leaf-ordered primitive copies).
  virtual uint64_t prim_bytes() const = 0;
};

// Throws std::invalid_argument for a bad format or timing configuration, Error for a box unit this build lacks.
// trace_batch throws hw::WatchdogError (with the unit's state) when the watchdog stops a ray (fixed: step bound;
// timed: that or the timing config's watchdog_cycles).
std::unique_ptr<DirectDevice> make_device(const hw::Geometry& g, const DeviceOptions& o);

// Throws Error (check_memory) when the timing model of configuration c (hw::TimedEngine::state_bytes: its units'
// caches and slots, the L2, the recording buffers; `sampled`: with sampled timing on one unit), with `beside`
// bytes held beside it, passes the memory budget; the message names the configuration and its sizing keys.
// make_device calls it for the timed device; render for its firmware device, beside the device memory.
void check_timing_memory(const hw::TimingConfig& c, bool sampled, uint64_t beside = 0);

// The fixed and timed devices' quantization frames for make_device(g, o) (grid_check.h: one frame, or one per
// mesh over two levels) and the primitives below their grid step; the float device has none (an empty check).
// Throws Error for a frame below the smallest normal float, as make_device does.
GridCheck device_grid_check(const hw::Geometry& g, const DeviceOptions& o);

}  // namespace rtu::host
