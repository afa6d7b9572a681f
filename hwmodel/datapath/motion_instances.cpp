#include "hwmodel/datapath/motion_instances.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <stdexcept>
#include <string>

#include "hwmodel/datapath/batch.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/traverse.h"

namespace rtu::hw {

namespace {

AffineD to_double(const Affine& a) {
  AffineD d;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) d.m[r][c] = a.m[r][c];
  return d;
}

// det(A + t B) of 3x3 matrices = det A + t tr(adj(A) B) + t^2 tr(adj(B) A) + t^3 det B.
void adjugate(const double m[3][3], double adj[3][3]) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      const int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
      adj[r][c] = m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1];
    }
}

double trace_product(const double a[3][3], const double b[3][3]) {
  double t = 0.0;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) t += a[i][k] * b[k][i];
  return t;
}

double det3(const double m[3][3]) {
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

// Whether L(t) = (1 - t) L0 + t L1 is invertible by invert's rule (|det| above 2^-40 of the product of its rows'
// lengths) at the extremes of det L(t) over [0, 1], and det keeps its sign between them: det L(t) is a cubic in t,
// whose extremes lie at the ends and at the roots of its derivative; each is evaluated as the determinant of L(t)
// itself (the expanded cubic would cancel where the scale changes much).
bool invertible_over_shutter(const Affine& a0, const Affine& a1) {
  double l0[3][3], d[3][3];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      l0[r][c] = a0.m[r][c];
      d[r][c] = double(a1.m[r][c]) - double(a0.m[r][c]);
    }
  double adj0[3][3], adjd[3][3];
  adjugate(l0, adj0);
  adjugate(d, adjd);
  const double c1 = trace_product(adj0, d), c2 = trace_product(adjd, l0), c3 = det3(d);
  std::vector<double> ts = {0.0, 1.0};
  // The derivative 3 c3 t^2 + 2 c2 t + c1.
  const double qa = 3.0 * c3, qb = 2.0 * c2, qc = c1;
  if (qa != 0.0) {
    const double disc = qb * qb - 4.0 * qa * qc;
    if (disc >= 0.0)
      for (const double sgn : {-1.0, 1.0}) ts.push_back((-qb + sgn * std::sqrt(disc)) / (2.0 * qa));
  } else if (qb != 0.0) {
    ts.push_back(-qc / qb);
  }
  std::sort(ts.begin(), ts.end());
  double prev = 0.0;
  bool first = true;
  for (const double t : ts) {
    if (!(t >= 0.0 && t <= 1.0)) continue;
    double l[3][3], rows = 1.0;
    for (int r = 0; r < 3; ++r) {
      double n = 0.0;
      for (int c = 0; c < 3; ++c) {
        l[r][c] = (1.0 - t) * double(a0.m[r][c]) + t * double(a1.m[r][c]);  // as MotionInstanceSet::at
        n += l[r][c] * l[r][c];
      }
      rows *= std::sqrt(n);
    }
    const double v = det3(l);
    if (!(std::fabs(v) > std::ldexp(rows, -40)) || !std::isfinite(v)) return false;
    if (!first && (v > 0.0) != (prev > 0.0)) return false;
    prev = v;
    first = false;
  }
  return true;
}

}  // namespace

AffineD MotionInstanceSet::at(uint32_t inst, double time) const {
  const Affine& a = set.instances[inst].to_world;
  const Affine& b = end[inst];
  AffineD m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) m.m[r][c] = (1.0 - time) * a.m[r][c] + time * b.m[r][c];
  return m;
}

bool MotionInstanceSet::moving(uint32_t inst) const {
  const Affine& a = set.instances[inst].to_world;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      if (a.m[r][c] != end[inst].m[r][c]) return true;
  return false;
}

Aabb MotionInstanceSet::key_bounds(uint32_t inst, int k, int pad_exp) const {
  const Instance& in = set.instances[inst];
  const Aabb b = world_bounds(set.meshes[in.mesh].bounds(), to_double(k ? end[inst] : in.to_world));
  if (b.empty() || pad_exp >= 20) return b;
  double mag = 0.0;
  for (int a = 0; a < 3; ++a) mag = std::max({mag, std::fabs(double(b.lo[a])), std::fabs(double(b.hi[a]))});
  const double pad = std::ldexp(mag, -pad_exp);
  Aabb w;
  for (int a = 0; a < 3; ++a) {
    w.lo[a] = std::nextafter(float(double(b.lo[a]) - pad), -INFINITY);
    w.hi[a] = std::nextafter(float(double(b.hi[a]) + pad), INFINITY);
  }
  return w;
}

void MotionInstanceSet::validate() const {
  set.validate();
  if (end.size() != set.instances.size())
    throw std::invalid_argument(std::to_string(end.size()) + " end transforms for " +
                                std::to_string(set.instances.size()) + " instances");
  for (uint32_t i = 0; i < end.size(); ++i) {
    const std::string name = "instance " + std::to_string(i) + ": ";
    AffineD inv;
    if (!invert(end[i], inv))
      throw std::invalid_argument(name + "its transform at time 1 is not finite or singular");
    if (!moving(i)) continue;
    const Geometry& m = set.meshes[set.instances[i].mesh];
    if (!m.spheres.empty() || !m.curves.empty())
      throw std::invalid_argument(name + "spheres and curve segments cannot move by transform");
    const Aabb b = key_bounds(i, 1);
    for (int a = 0; a < 3; ++a)
      if (!(std::fabs(b.lo[a]) <= kMaxCoordinate && std::fabs(b.hi[a]) <= kMaxCoordinate))
        throw std::invalid_argument(name + "a world coordinate at time 1 is beyond 2^62");
    if (!invertible_over_shutter(set.instances[i].to_world, end[i]))
      throw std::invalid_argument(name + "its transform is singular at some time of the shutter");
  }
}

MotionGeometry MotionInstanceSet::flatten() const {
  const Geometry still = set.flatten({});
  MotionGeometry g;
  g.triangles.reserve(still.triangles.size());
  for (uint32_t i = 0; i < set.instances.size(); ++i)
    for (const Triangle& t : set.meshes[set.instances[i].mesh].triangles) {
      MotionTriangle m;
      for (int k = 0; k < 2; ++k) {
        const Affine& x = k ? end[i] : set.instances[i].to_world;
        m.key[k] = Triangle{x.point(t.v0), x.point(t.v1), x.point(t.v2)};
      }
      g.triangles.push_back(m);
    }
  for (const Sphere& s : still.spheres)
    g.spheres.push_back(MotionSphere{{s.center, s.center}, {s.radius, s.radius}});
  for (const CurveSegment& c : still.curves) g.curves.push_back(MotionCurve{{c, c}});
  return g;
}

namespace {

// The top level's items: every instance with a non-empty box, its key boxes widened by 2^-pad_exp.
void top_items(const MotionInstanceSet& ms, int pad_exp, std::vector<Aabb> key[2], std::vector<uint32_t>& ids) {
  for (uint32_t i = 0; i < ms.set.instances.size(); ++i) {
    const Aabb b0 = ms.key_bounds(i, 0, pad_exp);
    if (b0.empty()) continue;
    key[0].push_back(b0);
    key[1].push_back(ms.key_bounds(i, 1, pad_exp));
    ids.push_back(i);
  }
  if (ids.empty()) throw std::invalid_argument("moving instances: no instance holds a bounded primitive");
}

// One instance per leaf, as the static top levels (instancing.cpp).
BvhBuildParams top_params(const TracerOptions& opt) {
  BvhBuildParams top = opt.bvh;
  top.max_leaf_size = 1;
  top.prim_cost = 1.0f;
  return top;
}

template <int N>
struct FloatTop {
  using Dist = float;
  static constexpr int kWidth = N;
  const MotionInstanceSet& ms;
  const MotionBvh& b;
  const std::vector<uint32_t>& ids;
  const std::vector<std::unique_ptr<FloatTracer>>& tracers;
  const Ray& ray;
  const RayPrecomp& rp;
  float time;
  bool any_hit;
  Hit& closest;
  TraversalStats& s;

  int expand(uint32_t node, uint32_t refs[N], float dists[N], int& tested) const {
    return motion_expand_float<N>(b, node, time, rp, ray.tmin, closest.t, refs, dists, tested);
  }
  bool leaf(uint32_t ref) const {
    bool found = false;
    for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) {
      const uint32_t inst = ids[b.prim_ids[i]];
      AffineD inv;
      if (!invert(ms.at(inst, time), inv)) continue;  // validate() bounds |det| away from 0 over the shutter
      Ray o = object_ray(inv, ray);
      o.tmax = closest.t;
      if (trace_instance_float(*tracers[ms.set.instances[inst].mesh], o, ms.set, inst, any_hit, nullptr, closest,
                               s)) {
        found = true;
        if (any_hit) return true;
      }
    }
    return found;
  }
  float limit() const { return closest.t; }
  void pushed(const uint32_t*, int, int) const {}
  void popped(int) const {}
};

}  // namespace

MotionInstancedFloatTracer::MotionInstancedFloatTracer(const MotionInstanceSet& set, const TracerOptions& opt)
    : m_set(set) {
  set.validate();
  for (const Geometry& g : set.set.meshes) m_mesh_tracers.push_back(std::make_unique<FloatTracer>(g, opt));
  std::vector<Aabb> key[2];
  top_items(set, 20, key, m_ids);
  m_top = MotionBvh::build(key[0], key[1], top_params(opt));
}

MotionInstancedFloatTracer::~MotionInstancedFloatTracer() = default;

Hit MotionInstancedFloatTracer::trace(const Ray& r, float time, bool any_hit, TraversalStats& s) const {
  if (reject_motion_ray(r, time, s)) return Hit{};
  ++s.rays;
  const RayPrecomp rp(r);
  Hit closest;
  closest.t = r.tmax;
  with_motion_width(m_top.width, [&](auto n) {
    FloatTop<decltype(n)::value> p{m_set, m_top, m_ids, m_mesh_tracers, r, rp, time, any_hit, closest, s};
    traverse(p, m_top.root_ref, any_hit, s);
  });
  if (!closest.hit()) return Hit{};
  ++s.hits;
  return closest;
}

void MotionInstancedFloatTracer::trace_batch(const std::vector<Ray>& rays, const std::vector<float>& times,
                                             std::vector<Hit>& hits, bool any_hit, int threads,
                                             TraversalStats& s) const {
  trace_motion_batch(*this, rays, times, hits, any_hit, threads, s);
}

namespace {

// The fixed unit's top level (MotionInstancedFixedTracer).
struct Closest {
  int64_t t;    // the top level's cull limit, t raw of the top frame (t_raw_up of the hit's world t)
  Hit hit;      // world t, flattened primitive
  float limit;  // the bottom levels' interval end: the closest hit's world t, or the ray's tmax
};

struct TopView {
  const std::vector<uint32_t>& child;
  const std::vector<int32_t>& boxes;
  const std::vector<uint32_t>& prim_ids;
  const std::vector<uint32_t>& ids;
};

template <int N>
struct FixedTop {
  using Dist = int64_t;
  static constexpr int kWidth = N;
  const MotionInstancedFixedTracer& t;
  const TopView& v;
  const Ray& world;
  const FixedRay& r;
  BoxTime bt;
  uint32_t tq;
  bool check, any_hit;
  Closest& c;
  TraversalStats& s;
  std::vector<TraceEvent>* rec;
  bool shader;

  int expand(uint32_t node, uint32_t refs[N], int64_t dists[N], int& tested) const {
    return motion_expand<N>(v.child, v.boxes, node, bt, r, c.t, check, s, rec, refs, dists, tested);
  }
  bool leaf(uint32_t ref) const {
    bool found = false;
    for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) {
      ++s.prim_tests;
      const uint32_t inst = v.ids[v.prim_ids[i]];
      if (rec) {
        rec->push_back(TraceEvent{TraceEvent::kPrim, uint8_t(RecordKind::kInstance), 0, 0, i});
        if (shader && t.record_moving(i)) rec->push_back(TraceEvent{TraceEvent::kAnyHit, 0, 0, 0, i});
      }
      Hit h;
      if (!t.bottoms().trace_instance_as(inst, t.xform_at(inst, tq), world, c.limit, any_hit, h, s, rec) ||
          !(h.t <= c.limit))
        continue;
      c.hit = h;
      c.limit = h.t;
      c.t = t_raw_up(h.t, r);
      found = true;
      if (any_hit) return true;
    }
    return found;
  }
  int64_t limit() const { return c.t; }
  void pushed(const uint32_t*, int n, int) const {
    if (rec) rec->push_back(TraceEvent{TraceEvent::kPush, uint8_t(n), 0, 0, 0});
  }
  void popped(int) const {
    if (rec) rec->push_back(TraceEvent{TraceEvent::kPop, 0, 0, 0, 0});
  }
};

}  // namespace

MotionInstancedFixedTracer::MotionInstancedFixedTracer(const MotionInstanceSet& set, const FixedFormat& f,
                                                       const MotionFormat& m, const TracerOptions& opt,
                                                       bool check_boxes)
    : m_set(set), m_format(f), m_motion(m), m_check(check_boxes) {
  f.validate();
  m.validate();
  set.validate();
  m_flat = set.set.flatten({});
  FixedTraceOptions bottom;
  bottom.check_boxes = check_boxes;  // the bottom levels' box tests checked as the top level's
  m_bottoms = std::make_unique<InstancedFixedTracer>(set.set, m_flat, f, opt, bottom);
  std::vector<Aabb> key[2];
  top_items(set, std::min(20, f.xform_bits - 4), key, m_ids);
  const MotionBvh bvh = MotionBvh::build(key[0], key[1], top_params(opt));
  Aabb all = bvh.key_bounds[0];
  all.extend(bvh.key_bounds[1]);
  m_frame = QuantFrame::fit(all, f.coord_bits);
  m_width = bvh.width;
  m_root = bvh.root_ref;
  m_child = bvh.child;
  m_prim_ids = bvh.prim_ids;
  // Each instance's key boxes on the grid, rounded outward.
  std::vector<int32_t> grid(m_ids.size() * 12);
  for (size_t i = 0; i < m_ids.size(); ++i)
    for (int k = 0; k < 2; ++k)
      for (int a = 0; a < 3; ++a) {
        grid[i * 12 + size_t(6 * k + a)] = int32_t(m_frame.to_grid(key[k][i].lo[a], a, Round::kDown));
        grid[i * 12 + size_t(6 * k + 3 + a)] = int32_t(m_frame.to_grid(key[k][i].hi[a], a, Round::kUp));
      }
  sweep_motion_boxes(
      m_child, m_width,
      [&](uint32_t ref, int32_t out[12]) {
        for (int j = 0; j < 6; ++j) {
          out[j] = out[6 + j] = j < 3 ? INT32_MAX : INT32_MIN;
        }
        for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i)
          for (int j = 0; j < 12; ++j) {
            const int32_t g = grid[size_t(m_prim_ids[i]) * 12 + size_t(j)];
            out[j] = (j % 6) < 3 ? std::min(out[j], g) : std::max(out[j], g);
          }
      },
      m_boxes);
}

MotionInstancedFixedTracer::~MotionInstancedFixedTracer() = default;

StoredXform MotionInstancedFixedTracer::xform_at(uint32_t inst, uint32_t tq) const {
  // The interpolator: a + (b - a) tq / 2^time_bits per entry, rounded to xform_bits significant bits; then the
  // inverse, its entries rounded as a static instance's stored transform.
  const Affine& a = m_set.set.instances[inst].to_world;
  const Affine& b = m_set.end[inst];
  const double s = std::ldexp(double(tq), -m_motion.time_bits);
  Affine x;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      x.m[r][c] =
          round_significant(double(a.m[r][c]) + (double(b.m[r][c]) - double(a.m[r][c])) * s, m_format.xform_bits);
  // validate() bounds |det| away from 0; an inverse entry near the float range's end (a transform of tiny scale)
  // leaves the transform unit's output zero, a ray every bottom level refuses (a miss), as rounding's edge would.
  AffineD inv;
  if (!invert(x, inv)) return StoredXform{};
  for (const auto& row : inv.m)
    for (const double e : row)
      if (!(std::fabs(e) < 0x1p127)) return StoredXform{};  // rounded to xform_bits, still a finite float
  return StoredXform::from_inverse(inv, m_format.xform_bits);
}

Hit MotionInstancedFixedTracer::trace(const Ray& r, float time, bool any_hit, TraversalStats& s) const {
  return trace_impl(r, time, any_hit, s, nullptr, false);
}

Hit MotionInstancedFixedTracer::trace_recorded(const Ray& r, float time, bool any_hit, TraversalStats& s,
                                               std::vector<TraceEvent>& events, bool moving_to_shader) const {
  return trace_impl(r, time, any_hit, s, &events, moving_to_shader);
}

Hit MotionInstancedFixedTracer::trace_impl(const Ray& r, float time, bool any_hit, TraversalStats& s,
                                           std::vector<TraceEvent>* rec, bool shader) const {
  if (reject_motion_ray(r, time, s)) return Hit{};
  FixedRay fr;
  if (s.rejected(setup_ray(r, m_frame, m_format, fr))) return Hit{};
  ++s.rays;
  const uint32_t tq = quantize_time(time, m_motion.time_bits);
  Closest c{fr.tmax, Hit{}, r.tmax};
  const TopView v{m_child, m_boxes, m_prim_ids, m_ids};
  with_motion_width(m_width, [&](auto n) {
    FixedTop<decltype(n)::value> p{*this, v, r,   fr,    box_time(tq, m_motion), tq, m_check, any_hit,
                                   c,     s, rec, shader};
    traverse(p, m_root, any_hit, s);
  });
  if (!c.hit.hit()) return Hit{};
  ++s.hits;
  return c.hit;
}

void MotionInstancedFixedTracer::trace_batch(const std::vector<Ray>& rays, const std::vector<float>& times,
                                             std::vector<Hit>& hits, bool any_hit, int threads,
                                             TraversalStats& s) const {
  trace_motion_batch(*this, rays, times, hits, any_hit, threads, s);
}

Hit MotionInstancedFixedTracer::trace_all(const Ray& r, float time) const {
  TraversalStats s;
  FixedRay fr;  // a ray the top level's setup rejects reaches no instance
  if (reject_motion_ray(r, time, s) || setup_ray(r, m_frame, m_format, fr) != RayStatus::kOk) return Hit{};
  const uint32_t tq = quantize_time(time, m_motion.time_bits);
  Hit best;
  float limit = r.tmax;
  for (const uint32_t inst : m_ids) {
    Hit h;
    if (m_bottoms->trace_instance_as(inst, xform_at(inst, tq), r, limit, false, h, s, nullptr) && h.t <= limit) {
      best = h;
      limit = h.t;
    }
  }
  return best;
}

}  // namespace rtu::hw
