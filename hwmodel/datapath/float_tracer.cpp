#include "hwmodel/datapath/float_tracer.h"

#include "hwmodel/datapath/batch.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/prim_test.h"
#include "hwmodel/datapath/traverse.h"

namespace rtu::hw {

namespace {

// The closest hit so far, shared by the leaf tests of one ray.
struct Closest {
  float tmax;
  uint32_t prim = kMissPrim;
  float u = 0.0f, v = 0.0f;
};

// A candidate hit on a non-opaque triangle counts only when the any-hit stage accepts it (any_hit.h).
inline bool test_leaf_prim(const LeafPrim& lp, uint32_t num_tris, const RayPrecomp& rp, float tmin, Closest& c,
                           const AnyHitStage* stage, TraversalStats& s) {
  PrimHit h;
  const uint32_t prim = lp.prim & kLeafPrimMask;
  // The kind from the leaf copy (index below num_tris, or kLeafCurve), each kind's test inlined.
  const bool hit = prim < num_tris          ? PrimTest<TrianglePrim>::test_float(lp, rp, tmin, c.tmax, h)
                   : (lp.prim & kLeafCurve) ? PrimTest<CurvePrim>::test_float(lp, rp, tmin, c.tmax, h)
                                            : PrimTest<SpherePrim>::test_float(lp, rp, tmin, c.tmax, h);
  if (!hit) return false;
  if ((lp.prim & kLeafNonOpaque) && stage) {
    ++s.any_hit_calls;
    if (!stage->accept(prim, h.u, h.v)) {
      ++s.any_hit_ignored;
      return false;
    }
  }
  c.tmax = h.t;
  c.prim = prim;
  c.u = h.u;
  c.v = h.v;
  return true;
}

template <int N>
struct FloatPolicy {
  using Dist = float;
  static constexpr int kWidth = N;

  const WideNode<N>* nodes;
  const LeafPrim* prims;
  uint32_t num_tris;
  const RayPrecomp& rp;
  float tmin;
  bool any_hit;
  Closest& closest;
  TraversalStats& s;
  const AnyHitStage* stage;
  HitList* all;  // all-hit traversal: every hit goes here and the closest is never narrowed; null otherwise

  int expand(uint32_t node, uint32_t refs[N], float dists[N], int& tested) const {
    return expand_wide_node(nodes[node], rp, tmin, closest.tmax, refs, dists, tested);
  }

  bool leaf(uint32_t ref) const {
    const uint32_t first = leaf_first(ref), count = leaf_count(ref);
    s.prim_tests += count;
    if (all) {
      for (uint32_t i = 0; i < count; ++i) {
        Closest c{closest.tmax};
        if (test_leaf_prim(prims[first + i], num_tris, rp, tmin, c, stage, s))
          all->add(Hit{c.tmax, c.prim, c.u, c.v});
      }
      return false;
    }
    bool found = false;
    for (uint32_t i = 0; i < count; ++i) {
      found |= test_leaf_prim(prims[first + i], num_tris, rp, tmin, closest, stage, s);
      if (found && any_hit) return true;
    }
    return found;
  }

  float limit() const { return closest.tmax; }
  void pushed(const uint32_t*, int, int) const {}
  void popped(int) const {}
};

}  // namespace

std::optional<Bvh> choose_accel(const Geometry& g, const TracerOptions& opt, double* bvh_cost,
                                double* brute_cost) {
  const uint32_t n = g.num_bounded();
  const double brute = double(n) * opt.bvh.prim_cost;
  double cost = 0.0;
  std::optional<Bvh> bvh;
  // Automatic choice: no BVH when the whole scene fits in one leaf (a BVH would add its node visits to the same
  // primitive tests; not even built then), or when its SAH cost is not below the cost of testing every primitive.
  const bool small = n <= uint32_t(opt.bvh.max_leaf_size);
  if (n > 0 && (opt.accel == AccelMode::kBvh || (opt.accel == AccelMode::kAuto && !small))) {
    bvh = Bvh::build(g, opt.bvh);
    cost = bvh->figures().sah_cost;
  }
  if (bvh && opt.accel == AccelMode::kAuto && !(cost < brute)) bvh.reset();
  if (bvh_cost) *bvh_cost = cost;
  if (brute_cost) *brute_cost = brute;
  return bvh;
}

FloatTracer::FloatTracer(const Geometry& g, const TracerOptions& opt) : m_geom(g) {
  const uint32_t n = g.num_bounded();
  m_bvh = choose_accel(g, opt, &m_bvh_cost, &m_brute_cost);

  auto record = [&](uint32_t p) {
    return with_prim_kind(g.kind(p), [&](auto k) {
      using K = decltype(k);
      if constexpr (PrimitiveKind<K>)
        return PrimTest<K>::leaf(g, p);
      else
        return LeafPrim{};  // planes are not in the BVH
    });
  };
  m_leaf_prims.resize(n);
  if (m_bvh) {
    m_bvh->visit([&](const auto& t) {
      for (uint32_t i = 0; i < n; ++i) m_leaf_prims[i] = record(t.prim_ids[i]);
    });
  } else {
    for (uint32_t i = 0; i < n; ++i) m_leaf_prims[i] = record(i);
  }
}

template <int N>
void FloatTracer::trace_bvh(const WideBvh<N>& t, const RayPrecomp& rp, float tmin, bool any_hit, Hit& h,
                            TraversalStats& s, const AnyHitStage* stage, HitList* all) const {
  Closest c{h.t, h.prim, h.u, h.v};
  FloatPolicy<N> policy{
      t.nodes.data(), m_leaf_prims.data(), uint32_t(m_geom.triangles.size()), rp, tmin, any_hit, c, s, stage, all};
  traverse(policy, t.root_ref, any_hit, s);
  h = Hit{c.tmax, c.prim, c.u, c.v};
}

Hit FloatTracer::trace(const Ray& r, bool any_hit, TraversalStats& s, const AnyHitStage* stage) const {
  Hit h;
  if (s.rejected(validate_ray(r))) return h;
  ++s.rays;
  const RayPrecomp rp(r);
  h.t = r.tmax;
  // Planes first: they are few, often near (a ground), and shorten the interval for the BVH.
  for (uint32_t i = 0; i < m_geom.planes.size(); ++i) {
    PrimHit ph;
    ++s.prim_tests;
    if (PrimTest<PlanePrim>::test_float(m_geom.planes[i], rp, r.tmin, h.t, ph)) {
      h = Hit{ph.t, m_geom.plane_prim(i), 0.0f, 0.0f};
      if (any_hit) break;
    }
  }
  if (!(any_hit && h.hit()) && !m_leaf_prims.empty()) {
    if (m_bvh) {
      m_bvh->visit([&](const auto& t) { trace_bvh(t, rp, r.tmin, any_hit, h, s, stage); });
    } else {
      Closest c{h.t, h.prim, h.u, h.v};
      const uint32_t num_tris = uint32_t(m_geom.triangles.size());
      s.prim_tests += m_leaf_prims.size();
      for (const LeafPrim& lp : m_leaf_prims) {
        if (test_leaf_prim(lp, num_tris, rp, r.tmin, c, stage, s) && any_hit) break;
      }
      h = Hit{c.tmax, c.prim, c.u, c.v};
    }
  }
  if (!h.hit()) return Hit{};
  ++s.hits;
  if (m_geom.kind(h.prim) == PrimKind::kSphere) {
    const Sphere& sp = m_geom.spheres[h.prim - m_geom.triangles.size()];
    sphere_uv(sp.center, r.origin + h.t * r.dir, h.u, h.v);
  }
  return h;
}

uint64_t FloatTracer::trace_all(const Ray& r, HitList& all, TraversalStats& s, const AnyHitStage* stage) const {
  if (s.rejected(validate_ray(r))) return all.count;
  ++s.rays;
  const uint64_t before = all.count;
  const RayPrecomp rp(r);
  for (uint32_t i = 0; i < m_geom.planes.size(); ++i) {
    PrimHit ph;
    ++s.prim_tests;
    if (PrimTest<PlanePrim>::test_float(m_geom.planes[i], rp, r.tmin, r.tmax, ph))
      all.add(Hit{ph.t, m_geom.plane_prim(i), 0.0f, 0.0f});
  }
  if (!m_leaf_prims.empty()) {
    if (m_bvh) {
      Hit h{r.tmax};
      m_bvh->visit([&](const auto& t) { trace_bvh(t, rp, r.tmin, false, h, s, stage, &all); });
    } else {
      const uint32_t num_tris = uint32_t(m_geom.triangles.size());
      s.prim_tests += m_leaf_prims.size();
      for (const LeafPrim& lp : m_leaf_prims) {
        Closest c{r.tmax};
        if (test_leaf_prim(lp, num_tris, rp, r.tmin, c, stage, s)) all.add(Hit{c.tmax, c.prim, c.u, c.v});
      }
    }
  }
  // Spheres' u, v as trace() gives them (a shading output).
  for (uint64_t i = before; i < std::min<uint64_t>(all.count, all.max); ++i)
    if (m_geom.kind(all.out[i].prim) == PrimKind::kSphere) {
      const Sphere& sp = m_geom.spheres[all.out[i].prim - m_geom.triangles.size()];
      sphere_uv(sp.center, r.origin + all.out[i].t * r.dir, all.out[i].u, all.out[i].v);
    }
  s.hits += all.count > before;
  return all.count;
}

void FloatTracer::trace_batch(const Ray* rays, Hit* hits, size_t n, bool any_hit, int threads,
                              TraversalStats& s) const {
  run_batch(n, threads, s, [&](size_t i, TraversalStats& local) { hits[i] = trace(rays[i], any_hit, local); });
}

}  // namespace rtu::hw
