// The datapath behind the command processor (command_processor.h): a TraceEngine binds a scene image from device
// memory and traces ray batches. One engine per device kind (device_kind.h): `float` (the reference), `fixed` (the
// bit-accurate fixed-point datapath) and `timed` (the fixed datapath with the timing model, timed_engine.h).
//
// Scene images, written by the host into device memory and named by BIND_SCENE:
// - fixed: the DeviceImage of device_image.h (hardware BVH nodes, fixed-point records), checked field by field
//   at bind (DeviceImage::from_bytes);
// - float: a FloatSceneHeader followed by the float triangles, spheres, planes and curve segments of
//   geometry.h. The float device builds its BVH when the scene is bound (it is the reference, not a model of a
//   memory format), with the options it was made with.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "hwmodel/datapath/box_unit.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/datapath/tri_unit.h"
#include "hwmodel/datapath/watchdog.h"
#include "hwmodel/device/device_kind.h"
#include "hwmodel/format/micromap.h"
#include "hwmodel/interface/any_hit.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

inline constexpr uint32_t kFloatSceneMagic = 0x46555452u;  // "RTUF" little-endian
inline constexpr uint16_t kFloatSceneVersion = 1;

struct FloatSceneHeader {
  uint32_t magic;          // kFloatSceneMagic
  uint16_t version;        // kFloatSceneVersion
  uint16_t reserved;       // 0
  uint32_t num_triangles;  // Triangle records (36 B) follow the header
  uint32_t num_spheres;    // then Sphere records (16 B)
  uint32_t num_planes;     // then Plane records (16 B)
  uint32_t flags;          // kFloatScene* (other bits 0)
  uint64_t total_bytes;    // header + records (+ flags), rounded up to a multiple of 8
};
// After the planes, one byte per triangle: 1 = non-opaque (Geometry::non_opaque), else 0.
inline constexpr uint32_t kFloatSceneNonOpaque = 1u << 0;
// Curve segments: after the planes (and the opacity bytes), at the next multiple of 4 bytes, a uint32 count (> 0)
// and that many CurveSegment records (36 B). Scenes without curves leave the flag clear and the bytes as before.
inline constexpr uint32_t kFloatSceneCurves = 1u << 1;
static_assert(sizeof(FloatSceneHeader) == 32);
static_assert(sizeof(Triangle) == 36 && sizeof(Sphere) == 16 && sizeof(Plane) == 16 && sizeof(CurveSegment) == 36);

// The float scene image of g (8-byte words so it can be copied anywhere aligned).
std::vector<uint64_t> encode_float_scene(const Geometry& g);
// Geometry from a float scene image; throws std::invalid_argument naming the problem (bad header, sizes,
// non-finite values, non-positive radii, zero plane normals).
Geometry decode_float_scene(const uint8_t* data, size_t bytes);

struct EngineOptions {
  int threads = 1;           // worker threads per TRACE (0 = all cores); results do not depend on it
  TracerOptions tracer;      // float: acceleration choice and BVH build
  bool check_boxes = false;  // fixed: repeat every box test exactly and count false negatives
  // fixed and timed: the traversal watchdog, node and leaf visits one ray may make (FixedTraceOptions);
  // 0: the image's own bound (every node and leaf reference once), which no valid image can exceed.
  uint64_t max_steps = 0;
};

class TraceEngine {
 public:
  virtual ~TraceEngine() = default;
  virtual const char* name() const = 0;
  // Capability bits (regs.h kCap*).
  virtual uint32_t caps() const = 0;
  // Binds the scene image [data, data + bytes); on failure keeps nothing bound and throws std::invalid_argument.
  virtual void bind(const uint8_t* data, size_t bytes) = 0;
  virtual bool bound() const = 0;
  virtual void unbind() = 0;
  // Attaches the any-hit stage that answers candidate hits on non-opaque triangles (any_hit.h), or with null
  // detaches it (they are then opaque); kept across bind and unbind. Not owned: must outlive its use.
  virtual void set_any_hit(const AnyHitStage* stage) = 0;
  // The fixed datapath (fixed and timed engines, one-level images): the non-opaque triangles' opacity micromaps
  // (micromap.h), read before the stage is asked; null: none. The float reference ignores them (it always asks).
  // Kept across bind and unbind. Not owned.
  virtual void set_micromaps(const MicromapSet* maps) { (void)maps; }
  // Traces n rays of the bound scene (rays and hits do not overlap).
  virtual void trace(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s) const = 0;
  // Timing. Functional engines count one clock per packet; the timed engine returns simulated cycles.
  // Cycles of a packet other than TRACE:
  virtual uint64_t packet_cycles(uint8_t opcode) const {
    (void)opcode;
    return 1;
  }
  // Cycles from a FENCE's value write to its interrupt reaching the host (timed: irq_latency; else 0).
  virtual uint64_t irq_latency() const { return 0; }
  // trace() that returns the cycles the TRACE packet took; ray_type and bounce are for per-type statistics.
  virtual uint64_t trace_cycles(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                uint8_t ray_type, uint8_t bounce) {
    (void)ray_type;
    (void)bounce;
    trace(rays, hits, n, any_hit, s);
    return 1;
  }
  // All-hit traversal of n rays (commands.h kTraceAllHits; FloatTracer::trace_all, FixedTracer::trace_all): every
  // intersection in [tmin, tmax], the any-hit stage and micromaps deciding non-opaque triangles as for closest
  // hits; one level or two. Returns the packet's cycles (functional engines: 1). Throws WatchdogError as trace
  // does.
  virtual uint64_t trace_all_cycles(const Ray* rays, size_t n, const AllHitsOut& out, TraversalStats& s,
                                    uint8_t ray_type, uint8_t bounce) = 0;
  // What the bound scene holds, for stats: primitive counts by kind, whether a BVH is used.
  virtual Geometry::Counts counts() const = 0;
  virtual bool uses_bvh() const = 0;
};

struct TimingConfig;

// The engine of a device kind. `c` configures the timed engine, `unit` answers its box tests when c.box_unit is
// "rtl" and `tri` its triangle tests when c.tri_unit is "rtl" (TimedEngine); the float and fixed engines take no
// unit (std::invalid_argument when one is given).
std::unique_ptr<TraceEngine> make_engine(DeviceKind kind, const EngineOptions& o, const TimingConfig& c,
                                         std::unique_ptr<BoxUnit> unit = nullptr,
                                         std::unique_ptr<TriUnit> tri = nullptr);
std::unique_ptr<TraceEngine> make_float_engine(const EngineOptions& o);
std::unique_ptr<TraceEngine> make_fixed_engine(const EngineOptions& o);

}  // namespace rtu::hw
