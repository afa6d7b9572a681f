#include "hwmodel/instanced_fixed.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "hwmodel/intersect_fixed.h"

namespace rtu::hw {

float round_significant(double x, int bits) {
  if (bits < 8 || bits > 24) throw std::invalid_argument("round_significant: bits outside 8..24");
  if (x == 0.0 || !std::isfinite(x)) return float(x);
  // x = m * 2^e with |m| in [2^(bits-1), 2^bits): m rounded to an integer (nearest even) is exact in double.
  const int e = std::ilogb(x) - (bits - 1);
  const double m = std::nearbyint(std::ldexp(x, -e));
  return float(std::ldexp(m, e));  // at most 24 significant bits: exact in float unless it over- or underflows
}

StoredXform StoredXform::from_inverse(const AffineD& inv, int xform_bits) {
  StoredXform x;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) {
      x.m[r][c] = round_significant(inv.m[r][c], xform_bits);
      if (!std::isfinite(x.m[r][c]))
        throw std::invalid_argument("instance transform: an inverse entry beyond the float range");
    }
  return x;
}

Ray StoredXform::apply(const Ray& w) const {
  Ray o = w;
  // Products of two floats are exact in double; the sums of three or four of them are rounded once in double
  // (53 bits), then once to float: the result is the correctly rounded fused dot product except when the double
  // sum lands exactly on a float rounding boundary it did not start on (probability about 2^-29 per component).
  for (int k = 0; k < 3; ++k) {
    const double px = double(m[k][0]) * double(w.origin.x), py = double(m[k][1]) * double(w.origin.y),
                 pz = double(m[k][2]) * double(w.origin.z);
    o.origin[k] = float(px + py + pz + double(m[k][3]));
    const double dx = double(m[k][0]) * double(w.dir.x), dy = double(m[k][1]) * double(w.dir.y),
                 dz = double(m[k][2]) * double(w.dir.z);
    o.dir[k] = float(dx + dy + dz);
  }
  return o;
}

uint32_t StoredXform::bytes(int xform_bits) {
  return (12 * uint32_t(1 + 8 + xform_bits - 1) + 7) / 8;
}

InstancedFixedTracer::InstancedFixedTracer(const InstanceSet& set, const Geometry& flat, const FixedFormat& f,
                                           const TracerOptions& opt, const FixedTraceOptions& trace_opt)
    : m_set(set), m_format(f), m_rebased(std::make_unique<std::atomic<uint64_t>>(0)) {
  f.validate();
  set.validate();
  if (opt.bvh.width != f.width)
    throw std::invalid_argument("InstancedFixedTracer: BVH width " + std::to_string(opt.bvh.width) +
                                " differs from the format's width " + std::to_string(f.width));
  for (const Geometry& g : set.meshes) {
    const std::optional<Bvh> bvh = choose_accel(g, opt);
    m_bottoms.push_back(std::make_unique<DeviceImage>(encode_scene(g, f, bvh ? &*bvh : nullptr)));
    m_mesh_bounds.push_back(g.bounds());
  }
  // The top level as the float reference builds it (instancing.cpp): one instance per leaf, empty ones left out.
  std::vector<Aabb> kept;
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < set.instances.size(); ++i) {
    AffineD inv;
    invert(set.instances[i].to_world, inv);  // validate() has proven it invertible
    m_xforms.push_back(StoredXform::from_inverse(inv, f.xform_bits));
    const Aabb b = set.world_bounds(i);
    if (b.empty()) continue;
    kept.push_back(b);
    ids.push_back(i);
  }
  BvhBuildParams top = opt.bvh;
  top.max_leaf_size = 1;
  top.prim_cost = 1.0f;
  m_top_bvh = Bvh::build(kept, top);
  m_top = std::make_unique<DeviceImage>(encode_top_level(kept, ids, flat, f, m_top_bvh));
  FixedTraceOptions to = trace_opt;
  to.bottom = this;
  to.box_unit = nullptr;  // co-simulated units are for flat images (one thread, one image)
  to.tri_unit = nullptr;
  m_top_tracer = std::make_unique<FixedTracer>(*m_top, to);
  for (uint32_t i = 0; i < set.instances.size(); ++i) {
    FixedTraceOptions bo = trace_opt;
    bo.bottom = nullptr;
    bo.box_unit = nullptr;
    bo.tri_unit = nullptr;
    bo.any_hit = nullptr;
    m_tracers.push_back(std::make_unique<FixedTracer>(*m_bottoms[set.instances[i].mesh], bo));
  }
  set_any_hit(trace_opt.any_hit);
}

void InstancedFixedTracer::set_any_hit(const AnyHitStage* stage) {
  m_stages.clear();
  for (uint32_t i = 0; i < m_tracers.size(); ++i) {
    if (stage) m_stages.push_back(std::make_unique<InstanceAnyHit>(*stage, m_set, i));
    m_tracers[i]->set_any_hit(stage ? m_stages.back().get() : nullptr);
  }
}

InstancedFixedTracer::~InstancedFixedTracer() = default;

uint64_t InstancedFixedTracer::transform_bytes() const {
  return uint64_t(m_xforms.size()) * (StoredXform::bytes(m_format.xform_bits) + 8);
}

uint64_t InstancedFixedTracer::bytes() const {
  uint64_t b = m_top->size() + transform_bytes();
  for (const auto& img : m_bottoms) b += img->size();
  return b;
}

uint64_t InstancedFixedTracer::rebased() const {
  return m_rebased->load();
}

bool InstancedFixedTracer::trace_instance(uint32_t inst, const Ray& r, float tmax, bool any_hit, Hit& h,
                                          TraversalStats& s, std::vector<TraceEvent>* rec) const {
  if (inst >= m_xforms.size()) return false;  // cannot come from an image this tracer encoded
  Ray o = m_xforms[inst].apply(r);
  o.tmax = tmax;
  const FixedTracer& tracer = *m_tracers[inst];
  const uint32_t mesh = m_set.instances[inst].mesh;
  // The bottom level's events between kEnter and kLeave; a ray its setup rejects records none.
  auto trace = [&](const Ray& ray, TraversalStats& st) {
    if (!rec) return tracer.trace(ray, any_hit, st);
    rec->push_back(TraceEvent{TraceEvent::kEnter, 0, 0, 0, mesh});
    const Hit hit = tracer.trace_recorded(ray, any_hit, st, *rec);
    rec->push_back(TraceEvent{TraceEvent::kLeave, 0, 0, 0, mesh});
    return hit;
  };
  TraversalStats inner;
  h = trace(o, inner);
  const bool far = inner.invalid_by_reason[size_t(RayStatus::kOutOfFrame)] > 0;
  s.add_work(inner);
  if (!far) {
    if (h.hit()) h.prim = m_set.global_prim(inst, h.prim);
    return h.hit();
  }
  // The origin is beyond the mesh frame's guard range: start the ray where it enters the mesh's bounds.
  const Aabb& b = m_mesh_bounds[mesh];
  double t_in = double(o.tmin), t_out = double(tmax);
  for (int a = 0; a < 3; ++a) {
    const double d = double(o.dir[a]);
    if (d == 0.0) {
      if (o.origin[a] < b.lo[a] || o.origin[a] > b.hi[a]) return false;
      continue;
    }
    double t0 = (double(b.lo[a]) - double(o.origin[a])) / d, t1 = (double(b.hi[a]) - double(o.origin[a])) / d;
    if (t0 > t1) std::swap(t0, t1);
    t_in = std::max(t_in, t0);
    t_out = std::min(t_out, t1);
  }
  if (!(t_in <= t_out)) return false;
  ++*m_rebased;
  const float t0 = float(t_in);
  Ray m = o;
  for (int a = 0; a < 3; ++a) m.origin[a] = float(double(o.origin[a]) + double(t0) * double(o.dir[a]));
  m.tmin = std::max(0.0f, float(double(o.tmin) - double(t0)));
  m.tmax = float(double(tmax) - double(t0));
  TraversalStats again;
  h = trace(m, again);
  s.add_work(again);
  if (!h.hit()) return false;
  h.t = float(double(t0) + double(h.t));
  h.prim = m_set.global_prim(inst, h.prim);
  return true;
}

}  // namespace rtu::hw
