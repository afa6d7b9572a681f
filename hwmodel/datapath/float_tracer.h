// The float device's tracer: the golden result. Planes (unbounded) are tested per ray first, only when the
// scene has any; triangles and spheres through the BVH, or by brute force ("for each primitive") when the scene
// is so small that a BVH costs more than it saves: all of it fits in one leaf, or the BVH's SAH cost is not
// below the cost of testing every primitive.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "hwmodel/datapath/hit_list.h"
#include "hwmodel/datapath/prim_test_base.h"  // LeafPrim
#include "hwmodel/datapath/stats.h"
#include "hwmodel/interface/any_hit.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

struct RayPrecomp;

enum class AccelMode : uint8_t { kAuto, kBvh, kBrute };

struct TracerOptions {
  AccelMode accel = AccelMode::kAuto;
  BvhBuildParams bvh;
};

// The automatic choice of every device: a BVH, or none ("for each primitive") when the whole scene fits in one
// leaf or the BVH's SAH cost is not below the cost of testing every primitive (opt.accel forces either).
// Writes both costs (in primitive tests per ray; bvh_cost 0 when none was built) when asked.
std::optional<Bvh> choose_accel(const Geometry& g, const TracerOptions& opt, double* bvh_cost = nullptr,
                                double* brute_cost = nullptr);

class FloatTracer {
 public:
  // Keeps a reference to `g`: it must outlive the tracer.
  FloatTracer(const Geometry& g, const TracerOptions& opt = {});

  // Traces one ray. Invalid rays (validate_ray) miss and are counted in s.invalid_rays.
  Hit trace(const Ray& r, bool any_hit, TraversalStats& s) const { return trace(r, any_hit, s, m_any_hit); }
  // trace() with this any-hit stage instead of the tracer's own (null: every triangle opaque).
  Hit trace(const Ray& r, bool any_hit, TraversalStats& s, const AnyHitStage* stage) const;
  // Traces rays[0, n) into hits with `threads` threads (0 = all cores). Results and summed statistics do not
  // depend on the thread count.
  void trace_batch(const Ray* rays, Hit* hits, size_t n, bool any_hit, int threads, TraversalStats& s) const;
  // All-hit traversal (hit_list.h): every intersection in [tmin, tmax] into `all`, in traversal order, one per
  // primitive (its first crossing in the interval); the interval is never narrowed, so no subtree is skipped. The
  // any-hit stage still decides non-opaque triangles. Returns the number found (all.count).
  uint64_t trace_all(const Ray& r, HitList& all, TraversalStats& s) const {
    return trace_all(r, all, s, m_any_hit);
  }
  // trace_all with this any-hit stage (null: opaque).
  uint64_t trace_all(const Ray& r, HitList& all, TraversalStats& s, const AnyHitStage* stage) const;

  // The any-hit stage for non-opaque triangles (Geometry::non_opaque), or null: they are opaque. Not owned.
  void set_any_hit(const AnyHitStage* stage) { m_any_hit = stage; }
  const AnyHitStage* any_hit_stage() const { return m_any_hit; }

  bool uses_bvh() const { return m_bvh.has_value(); }
  const Bvh* bvh() const { return m_bvh ? &*m_bvh : nullptr; }
  // SAH-style cost estimates behind the automatic choice, in primitive-test units.
  double bvh_cost() const { return m_bvh_cost; }
  double brute_cost() const { return m_brute_cost; }
  uint64_t leaf_prim_bytes() const { return m_leaf_prims.size() * sizeof(LeafPrim); }

 private:
  template <int N>
  void trace_bvh(const WideBvh<N>& t, const RayPrecomp& rp, float tmin, bool any_hit, Hit& h, TraversalStats& s,
                 const AnyHitStage* stage, HitList* all = nullptr) const;

  const Geometry& m_geom;
  std::optional<Bvh> m_bvh;            // present exactly when the tracer uses it
  std::vector<LeafPrim> m_leaf_prims;  // leaf order (BVH) or scene order (brute force)
  double m_bvh_cost = 0.0;
  double m_brute_cost = 0.0;
  const AnyHitStage* m_any_hit = nullptr;
};

}  // namespace rtu::hw
