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
//
// In device memory the two levels are one position-independent block (encode(), from_bytes()), which is what
// BIND_SCENE names for an instanced scene: a TwoLevelHeader, the instance table (stored transform, mesh, the
// instance's first flattened triangle, sphere and curve segment), the mesh table (where each bottom image lies),
// the top image, then the bottom images. Every image inside is an ordinary DeviceImage (device_image.h), checked
// as one.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/instancing.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/interface/any_hit.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/bvh.h"

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

inline constexpr uint32_t kTwoLevelMagic = 0x32555452u;  // "RTU2" little-endian
inline constexpr uint16_t kTwoLevelVersion = 2;          // 2: curve_base in the instance table

struct TwoLevelHeader {
  uint32_t magic;            // kTwoLevelMagic
  uint16_t version;          // kTwoLevelVersion
  uint8_t xform_bits;        // significant bits of the stored transforms' entries (FixedFormat::xform_bits)
  uint8_t reserved;          // 0
  uint32_t instance_count;   // entries of the instance table
  uint32_t mesh_count;       // entries of the mesh table
  uint32_t num_triangles;    // the flattened scene's primitive counts (the hits' index space), as the top image's
  uint32_t num_spheres;      //
  uint64_t instance_offset;  // byte offsets from the block's start, 8-byte aligned
  uint64_t mesh_offset;      //
  uint64_t top_offset;       // the top image: top_bytes at top_offset
  uint64_t top_bytes;        //
  uint64_t total_bytes;      // size of the block
};
static_assert(sizeof(TwoLevelHeader) == 64);

struct InstanceEntry {
  float m[3][4];         // world -> object (StoredXform)
  uint32_t mesh;         // index into the mesh table
  uint32_t tri_base;     // flattened index of the instance's first triangle
  uint32_t sphere_base;  // flattened index of its first sphere
  uint32_t curve_base;   // flattened index of its first curve segment
};
static_assert(sizeof(InstanceEntry) == 64);

struct MeshEntry {
  uint64_t offset, bytes;  // the mesh's bottom image
};

// Whether a scene image is a two-level block (by its magic): what the engines' bind looks at first.
inline bool is_two_level(const uint8_t* data, size_t bytes) {
  uint32_t magic = 0;
  if (bytes >= 4) std::memcpy(&magic, data, 4);
  return magic == kTwoLevelMagic;
}

class InstancedFixedTracer final : public BottomLevels {
 public:
  // Keeps references to set and flat (the flattened scene: its planes are traced, its counts number the hits);
  // they must outlive the tracer. `opt` chooses each mesh's BVH (or brute force) as the flat devices do;
  // opt.bvh.width must be f.width. trace_opt's any-hit stage sees flattened primitive indices. Throws
  // std::invalid_argument for a set that does not validate or a bad format.
  InstancedFixedTracer(const InstanceSet& set, const Geometry& flat, const FixedFormat& f,
                       const TracerOptions& opt, const FixedTraceOptions& trace_opt = {});
  ~InstancedFixedTracer();
  // The two levels from device memory (encode()'s block, written by someone else): copied and checked so that
  // tracing them cannot read outside them or number a hit outside the flattened scene. Throws
  // std::invalid_argument naming the first problem.
  static std::unique_ptr<InstancedFixedTracer> from_bytes(const uint8_t* data, size_t bytes,
                                                          const FixedTraceOptions& trace_opt = {});
  // The block from_bytes reads (8-byte words).
  std::vector<uint64_t> encode() const;
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
  uint32_t mesh_of(uint32_t inst) const { return m_info[inst].mesh; }
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
  void trace_instance_all(uint32_t inst, const Ray& r, HitList& all, TraversalStats& s,
                          std::vector<TraceEvent>* rec) const override;
  // trace_instance with world -> object transform x instead of the instance's stored one (an instance with two
  // transforms, motion_instances.h: the transform at the ray's time); inst < instance_count().
  bool trace_instance_as(uint32_t inst, const StoredXform& x, const Ray& r, float tmax, bool any_hit, Hit& h,
                         TraversalStats& s, std::vector<TraceEvent>* rec) const;

 private:
  // A ray o (object space) whose origin is beyond mesh's frame guard range, started where it enters the mesh's
  // bounds: m, t0 (o's t of m's origin); false when it misses the bounds.
  bool rebase(const Ray& o, uint32_t mesh, Ray& m, float& t0) const;
  InstancedFixedTracer() = default;
  // A bottom image's spheres: its round records numbered before its first curve segment (from_bytes; the
  // constructor takes them from the meshes).
  static uint32_t mesh_spheres(const DeviceImage& img);
  // The tracers over the images (after m_top, m_bottoms, m_mesh_spheres, m_xforms and m_info are set).
  void make_tracers(const FixedTraceOptions& trace_opt);
  // Flattened index of instance inst's primitive `local` (its mesh's: triangles, then spheres).
  uint32_t global_prim(uint32_t inst, uint32_t local) const {
    const Info& in = m_info[inst];
    const uint32_t nt = m_bottoms[in.mesh]->header().num_triangles, ns = m_mesh_spheres[in.mesh];
    return local < nt        ? in.tri_base + local
           : local < nt + ns ? in.sphere_base + (local - nt)
                             : in.curve_base + (local - nt - ns);
  }
  class Stage;
  struct Info {
    uint32_t mesh, tri_base, sphere_base, curve_base;
  };
  FixedFormat m_format;
  Bvh m_top_bvh;
  std::unique_ptr<DeviceImage> m_top;
  std::unique_ptr<FixedTracer> m_top_tracer;
  std::vector<std::unique_ptr<DeviceImage>> m_bottoms;  // per mesh
  std::vector<Aabb> m_mesh_bounds;                      // per mesh: its frame's grid box, object space
  std::vector<uint32_t> m_mesh_spheres;                 // per mesh: its spheres (its curve segments follow them)
  std::vector<StoredXform> m_xforms;                    // per instance
  std::vector<Info> m_info;                             // per instance
  std::vector<std::unique_ptr<Stage>> m_stages;         // per instance, when an any-hit stage is attached
  std::vector<std::unique_ptr<FixedTracer>> m_tracers;  // per instance, over its mesh's image
  mutable std::unique_ptr<std::atomic<uint64_t>> m_rebased = std::make_unique<std::atomic<uint64_t>>(0);
};

}  // namespace rtu::hw
