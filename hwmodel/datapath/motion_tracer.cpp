#include "hwmodel/datapath/motion_tracer.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <stdexcept>
#include <type_traits>

#include "hwmodel/datapath/batch.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/traverse.h"

namespace rtu::hw {

void MotionFormat::validate() const {
  if (time_bits < 1 || time_bits > 24)
    throw std::invalid_argument("time_bits must be in 1..24 (got " + std::to_string(time_bits) + ")");
  if (box_time_bits < 0 || box_time_bits > time_bits)
    throw std::invalid_argument("box_time_bits must be in 0..time_bits (got " + std::to_string(box_time_bits) +
                                ")");
}

std::string MotionFormat::describe() const {
  return "time_bits=" + std::to_string(time_bits) + " box_time_bits=" + std::to_string(box_time_bits);
}

uint32_t quantize_time(float time, int time_bits) {
  // time * 2^time_bits is exact in double (a float times a power of two); + 1/2 and floor: nearest, ties up.
  return uint32_t(std::floor(double(time) * double(int64_t(1) << time_bits) + 0.5));
}

BoxTime box_time(uint32_t tq, const MotionFormat& m) {
  const int64_t s0 = int64_t(tq) >> (m.time_bits - m.box_time_bits);
  const int64_t end = int64_t(1) << m.box_time_bits;
  return BoxTime{s0, s0 < end ? s0 + 1 : s0, m.box_time_bits};
}

void validate_shutter_times(const std::vector<float>& times, size_t rays) {
  if (!times.empty() && times.size() != rays)
    throw std::invalid_argument(std::to_string(times.size()) + " shutter times for " + std::to_string(rays) +
                                " rays");
  for (size_t i = 0; i < times.size(); ++i)
    if (!valid_shutter_time(times[i]))
      throw std::invalid_argument("ray " + std::to_string(i) + ": shutter time " + std::to_string(times[i]) +
                                  " is not in [0, 1]");
}

namespace {

// A moving scene's spheres and curve segments as key records (MotionImage::spheres, curves, curve_round) and
// their moving flags, after the triangles'.
void encode_round_keys(const MotionGeometry& g, MotionImage& im) {
  const size_t nt = g.triangles.size();
  const int64_t top = im.frame.grid_max();
  const int F = im.format.frac_bits;
  const FixedFormat& f = im.format;
  im.spheres.resize(g.spheres.size() * 8);
  for (size_t i = 0; i < g.spheres.size(); ++i) {
    for (int k = 0; k < 2; ++k) {
      const MotionSphere& m = g.spheres[i];
      int64_t* out = &im.spheres[8 * i + size_t(4 * k)];
      for (int a = 0; a < 3; ++a) out[a] = im.frame.to_grid(m.center[k][a], a, Round::kNearestEven, F);
      // As a static sphere's record: grid.F units, rounded up, at least one.
      out[3] = std::max<int64_t>(1, int64_t(std::ceil(std::ldexp(double(m.radius[k]), F - im.frame.step_exp))));
    }
    for (int j = 0; j < 4; ++j)
      im.moving[nt + i] |= uint8_t(im.spheres[8 * i + size_t(j)] != im.spheres[8 * i + 4 + size_t(j)]);
  }
  const size_t ns = g.spheres.size();
  if (!g.curves.empty())
    if (const std::string why = f.curve_limits(); !why.empty()) throw std::invalid_argument(why);
  im.curves.resize(g.curves.size() * 16);
  for (size_t i = 0; i < g.curves.size(); ++i) {
    for (int k = 0; k < 2; ++k) {
      const CurveSegment& c = g.curves[i].key[k];
      int64_t* out = &im.curves[16 * i + size_t(8 * k)];
      const Vec3* ends[2] = {&c.p0, &c.p1};
      for (int e = 0; e < 2; ++e)
        for (int a = 0; a < 3; ++a) {
          const int64_t q = im.frame.to_grid((*ends[e])[a], a, Round::kNearestEven);
          if (q < 0 || q > top) throw std::invalid_argument("a moving curve segment lies outside the frame");
          out[3 * e + a] = q;
        }
      // As a static curve record's radii: grid.F units, rounded up, then to the field's significant bits, up.
      const float radii[2] = {c.r0, c.r1};
      for (int e = 0; e < 2; ++e) {
        const double rs = std::ceil(std::ldexp(double(radii[e]), F - im.frame.step_exp));
        if (!(rs < std::ldexp(1.0, 58)))
          throw std::invalid_argument("moving curve segment " + std::to_string(i) + ": radius beyond the record");
        out[6 + e] = curve_radius(curve_radius_field(int64_t(rs)));
      }
    }
    im.curve_round.push_back(kRoundCurve | ((g.curves[i].key[0].flags & kCurveCapStart) ? kRoundCapStart : 0u));
    for (int j = 0; j < 8; ++j)
      im.moving[nt + ns + i] |= uint8_t(im.curves[16 * i + size_t(j)] != im.curves[16 * i + 8 + size_t(j)]);
  }
}

}  // namespace

void sweep_motion_boxes(const std::vector<uint32_t>& child, int width,
                        const std::function<void(uint32_t ref, int32_t out[12])>& leaf,
                        std::vector<int32_t>& boxes) {
  const size_t slots = child.size(), W = size_t(width);
  boxes.assign(slots * 12, 0);
  for (size_t node = slots / W; node-- > 0;) {
    for (size_t s = 0; s < W; ++s) {
      const uint32_t ref = child[node * W + s];
      int32_t* out = &boxes[(node * W + s) * 12];
      if (ref == kEmptyChild) continue;
      if (is_leaf(ref)) {
        leaf(ref, out);
        continue;
      }
      if (size_t(ref) <= node) throw std::logic_error("motion BVH: a child node before its parent");
      for (int k = 0; k < 2; ++k)
        for (int a = 0; a < 3; ++a) {
          out[6 * k + a] = INT32_MAX;
          out[6 * k + 3 + a] = INT32_MIN;
        }
      for (size_t c = 0; c < W; ++c) {
        if (child[size_t(ref) * W + c] == kEmptyChild) continue;
        const int32_t* in = &boxes[(size_t(ref) * W + c) * 12];
        for (int k = 0; k < 2; ++k)
          for (int a = 0; a < 3; ++a) {
            out[6 * k + a] = std::min(out[6 * k + a], in[6 * k + a]);
            out[6 * k + 3 + a] = std::max(out[6 * k + 3 + a], in[6 * k + 3 + a]);
          }
      }
    }
  }
}

MotionImage MotionImage::encode(const MotionGeometry& g, const MotionBvh& bvh, const FixedFormat& f,
                                const MotionFormat& m) {
  f.validate();
  m.validate();
  if (bvh.width != f.width)
    throw std::invalid_argument("motion image: the BVH is " + std::to_string(bvh.width) + " wide, the format " +
                                std::to_string(f.width));
  MotionImage im;
  im.format = f;
  im.motion = m;
  Aabb all = bvh.key_bounds[0];
  all.extend(bvh.key_bounds[1]);
  im.frame = QuantFrame::fit(all, f.coord_bits);
  im.width = bvh.width;
  im.root_ref = bvh.root_ref;
  im.child = bvh.child;
  im.prim_ids = bvh.prim_ids;
  const int64_t top = im.frame.grid_max();
  const int F = f.frac_bits;
  const size_t nt = g.triangles.size();
  im.vertices.resize(nt * 18);
  im.moving.assign(g.num_prims(), 0);
  for (size_t i = 0; i < nt; ++i)
    for (int k = 0; k < 2; ++k) {
      const Triangle& t = g.triangles[i].key[k];
      const Vec3* v[3] = {&t.v0, &t.v1, &t.v2};
      for (int j = 0; j < 3; ++j)
        for (int a = 0; a < 3; ++a) {
          const int64_t q = im.frame.to_grid((*v[j])[a], a, Round::kNearestEven);
          if (q < 0 || q > top) throw std::invalid_argument("a moving triangle lies outside the frame");
          im.vertices[i * 18 + size_t(9 * k + 3 * j + a)] = int32_t(q);
        }
    }
  for (size_t i = 0; i < nt; ++i)
    for (int j = 0; j < 9; ++j)
      im.moving[i] |= uint8_t(im.vertices[i * 18 + size_t(j)] != im.vertices[i * 18 + 9 + size_t(j)]);
  encode_round_keys(g, im);
  const size_t ns = g.spheres.size();
  // Each slot's boxes: the integer bounds of the primitives below it, bottom up (children have larger indices
  // than their parent in the builder's order, so a reverse sweep sees every child first).
  const auto bounds_of_leaf = [&](uint32_t ref, int32_t out[12]) {
    for (int k = 0; k < 2; ++k)
      for (int a = 0; a < 3; ++a) {
        out[6 * k + a] = INT32_MAX;
        out[6 * k + 3 + a] = INT32_MIN;
      }
    for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) {
      const uint32_t p = im.prim_ids[i];
      for (int k = 0; k < 2; ++k) {
        if (p < nt) {
          const int32_t* v = &im.vertices[size_t(p) * 18 + size_t(9 * k)];
          for (int j = 0; j < 3; ++j)
            for (int a = 0; a < 3; ++a) {
              out[6 * k + a] = std::min(out[6 * k + a], v[3 * j + a]);
              out[6 * k + 3 + a] = std::max(out[6 * k + 3 + a], v[3 * j + a]);
            }
          continue;
        }
        if (p >= nt + ns) {
          const int64_t* cv = &im.curves[16 * size_t(p - nt - ns) + size_t(8 * k)];
          for (int e = 0; e < 2; ++e)
            for (int a = 0; a < 3; ++a) {
              const int64_t lo = floor_shift((cv[3 * e + a] << F) - cv[6 + e], F) - 2;
              const int64_t hi = ceil_shift((cv[3 * e + a] << F) + cv[6 + e], F) + 2;
              out[6 * k + a] = std::min(out[6 * k + a], int32_t(lo));
              out[6 * k + 3 + a] = std::max(out[6 * k + 3 + a], int32_t(hi));
            }
          continue;
        }
        const int64_t* sp = &im.spheres[8 * size_t(p - nt) + size_t(4 * k)];
        for (int a = 0; a < 3; ++a) {
          // Within a step of the frame (the slack may pass its edge): int32 holds it.
          const int64_t lo = floor_shift(sp[a] - sp[3] - 2, F), hi = ceil_shift(sp[a] + sp[3] + 2, F);
          out[6 * k + a] = std::min(out[6 * k + a], int32_t(lo));
          out[6 * k + 3 + a] = std::max(out[6 * k + 3 + a], int32_t(hi));
        }
      }
    }
  };
  sweep_motion_boxes(bvh.child, bvh.width, bounds_of_leaf, im.boxes);
  return im;
}

namespace {

struct FloatClosest {
  float tmax;
  uint32_t prim = kMissPrim;
  float u = 0.0f, v = 0.0f;
};

template <int N>
struct MotionFloatPolicy {
  using Dist = float;
  static constexpr int kWidth = N;
  const MotionGeometry& g;
  const MotionBvh& b;
  const RayPrecomp& rp;
  float time, tmin;
  bool any_hit;
  FloatClosest& c;
  TraversalStats& s;

  int expand(uint32_t node, uint32_t refs[N], float dists[N], int& tested) const {
    return motion_expand_float<N>(b, node, time, rp, tmin, c.tmax, refs, dists, tested);
  }
  bool leaf(uint32_t ref) const {
    bool found = false;
    for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) {
      ++s.prim_tests;
      const uint32_t p = b.prim_ids[i];
      PrimHit h;
      const size_t nt = g.triangles.size(), ns = g.spheres.size();
      bool hit;
      if (p < nt) {
        hit = intersect_triangle(g.triangles[p].at(time), rp, tmin, c.tmax, h);
      } else if (p < nt + ns) {
        const Sphere sp = g.spheres[p - nt].at(time);
        hit = intersect_sphere(sp.center, sp.radius, rp, tmin, c.tmax, h);
      } else {
        const CurveSegment cs = g.curves[p - nt - ns].at(time);
        hit = intersect_swept_sphere(cs.p0, cs.r0, cs.p1, cs.r1, (cs.flags & kCurveCapStart) != 0, rp, tmin,
                                     c.tmax, h);
      }
      if (!hit) continue;
      c = FloatClosest{h.t, p, h.u, h.v};
      found = true;
      if (any_hit) return true;
    }
    return found;
  }
  float limit() const { return c.tmax; }
  void pushed(const uint32_t*, int, int) const {}
  void popped(int) const {}
};

struct FixedClosest {
  int64_t t;
  uint32_t prim = kMissPrim;
  float u = 0.0f, v = 0.0f;
};

// Primitive p of the image at time register tq: a triangle's grid vertices or a sphere's record interpolated.
bool test_prim(const MotionImage& im, uint32_t p, const FixedRay& r, uint32_t tq, int64_t tlim, FixedPrimHit& h) {
  const uint32_t nt = im.triangles(), ns = im.round_prims();
  if (p < nt) {
    int32_t v[3][3];
    motion_vertices(&im.vertices[size_t(p) * 18], tq, im.motion.time_bits, v);
    return triangle_test(r, v, r.tmin, tlim, h);
  }
  if (p >= nt + ns) {
    const size_t c = p - nt - ns;
    return swept_sphere_test(r, motion_curve(&im.curves[16 * c], im.curve_round[c], p, tq, im.motion.time_bits),
                             r.tmin, tlim, h);
  }
  return sphere_test(r, motion_sphere(&im.spheres[8 * size_t(p - nt)], tq, im.motion.time_bits), r.tmin, tlim, h);
}

template <int N>
struct MotionFixedPolicy {
  using Dist = int64_t;
  static constexpr int kWidth = N;
  const MotionImage& im;
  const FixedRay& r;
  BoxTime bt;
  uint32_t tq;
  bool check, any_hit;
  FixedClosest& c;
  TraversalStats& s;
  std::vector<TraceEvent>* rec;
  bool shader;

  int expand(uint32_t node, uint32_t refs[N], int64_t dists[N], int& tested) const {
    return motion_expand<N>(im.child, im.boxes, node, bt, r, c.t, check, s, rec, refs, dists, tested);
  }
  bool leaf(uint32_t ref) const {
    bool found = false;
    for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) {
      ++s.prim_tests;
      const uint32_t p = im.prim_ids[i];
      const uint32_t nt = im.triangles(), ns = im.round_prims();
      if (rec) {
        const uint8_t kind = p < nt        ? uint8_t(RecordKind::kTriangle)
                             : p < nt + ns ? uint8_t(RecordKind::kSphere)
                                           : kPrimCurve;
        rec->push_back(TraceEvent{TraceEvent::kPrim, kind, 0, 0, i});
        if (shader && im.moving[p]) rec->push_back(TraceEvent{TraceEvent::kAnyHit, 0, 0, 0, i});
      }
      FixedPrimHit h;
      if (!test_prim(im, p, r, tq, c.t, h)) continue;
      c = FixedClosest{h.t, p, h.u, h.v};
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

bool reject_motion_ray(const Ray& r, float time, TraversalStats& s) {
  RayStatus status = validate_ray(r);
  if (status == RayStatus::kOk && !valid_shutter_time(time)) status = RayStatus::kNanInterval;
  return s.rejected(status);
}

Hit MotionFloatTracer::trace(const Ray& r, float time, bool any_hit, TraversalStats& s) const {
  if (reject_motion_ray(r, time, s)) return Hit{};
  ++s.rays;
  const RayPrecomp rp(r);
  FloatClosest c{r.tmax};
  with_motion_width(m_bvh.width, [&](auto n) {
    MotionFloatPolicy<decltype(n)::value> p{m_geom, m_bvh, rp, time, r.tmin, any_hit, c, s};
    traverse(p, m_bvh.root_ref, any_hit, s);
  });
  if (c.prim == kMissPrim) return Hit{};
  ++s.hits;
  return Hit{c.tmax, c.prim, c.u, c.v};
}

void MotionFloatTracer::trace_batch(const std::vector<Ray>& rays, const std::vector<float>& times,
                                    std::vector<Hit>& hits, bool any_hit, int threads, TraversalStats& s) const {
  trace_motion_batch(*this, rays, times, hits, any_hit, threads, s);
}

MotionFixedTracer::MotionFixedTracer(const MotionImage& image, bool check_boxes)
    : m_image(image), m_check(check_boxes) {
  image.motion.validate();
}

Hit MotionFixedTracer::trace(const Ray& r, float time, bool any_hit, TraversalStats& s) const {
  return trace_impl(r, time, any_hit, s, nullptr, false);
}

Hit MotionFixedTracer::trace_recorded(const Ray& r, float time, bool any_hit, TraversalStats& s,
                                      std::vector<TraceEvent>& events, bool moving_to_shader) const {
  return trace_impl(r, time, any_hit, s, &events, moving_to_shader);
}

Hit MotionFixedTracer::trace_impl(const Ray& r, float time, bool any_hit, TraversalStats& s,
                                  std::vector<TraceEvent>* rec, bool shader) const {
  if (reject_motion_ray(r, time, s)) return Hit{};
  FixedRay fr;
  if (s.rejected(setup_ray(r, m_image.frame, m_image.format, fr))) return Hit{};
  ++s.rays;
  const uint32_t tq = quantize_time(time, m_image.motion.time_bits);
  FixedClosest c{fr.tmax};
  with_motion_width(m_image.width, [&](auto n) {
    MotionFixedPolicy<decltype(n)::value> p{
        m_image, fr, box_time(tq, m_image.motion), tq, m_check, any_hit, c, s, rec, shader};
    traverse(p, m_image.root_ref, any_hit, s);
  });
  if (c.prim == kMissPrim) return Hit{};
  ++s.hits;
  return Hit{t_to_world(c.t, fr), c.prim, c.u, c.v};
}

void MotionFixedTracer::trace_batch(const std::vector<Ray>& rays, const std::vector<float>& times,
                                    std::vector<Hit>& hits, bool any_hit, int threads, TraversalStats& s) const {
  trace_motion_batch(*this, rays, times, hits, any_hit, threads, s);
}

Hit MotionFixedTracer::trace_all(const Ray& r, float time) const {
  FixedRay fr;
  if (validate_ray(r) != RayStatus::kOk || !valid_shutter_time(time) ||
      setup_ray(r, m_image.frame, m_image.format, fr) != RayStatus::kOk)
    return Hit{};
  const uint32_t tq = quantize_time(time, m_image.motion.time_bits);
  FixedClosest c{fr.tmax};
  for (uint32_t p = 0; p < m_image.moving.size(); ++p) {
    FixedPrimHit h;
    if (test_prim(m_image, p, fr, tq, c.t, h) && (h.t < c.t || c.prim == kMissPrim))
      c = FixedClosest{h.t, p, h.u, h.v};
  }
  if (c.prim == kMissPrim) return Hit{};
  return Hit{t_to_world(c.t, fr), c.prim, c.u, c.v};
}

}  // namespace rtu::hw
