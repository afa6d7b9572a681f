// Motion blur in the unit: rays with a shutter time through moving triangles, spheres and curve segments
// (scene/motion.h), on the float reference and on the fixed-point datapath. The fixed unit quantizes the ray's
// time to MotionFormat::time_bits, interpolates each triangle's grid vertices at that time (the triangle unit),
// and each node's key-frame grid boxes at the top box_time_bits of it, widened to the whole interval those bits
// stand for (the box unit): so a box contains every primitive below it at every time the box unit cannot tell
// apart, and no hit is lost (docs/numerics.md, "Motion blur"). box_time_bits = 0 is a unit that does not
// interpolate boxes at all: it tests the box over the whole shutter (the time-oblivious unit of
// docs/timing-model.md, "Motion blur").
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "hwmodel/datapath/batch.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/format/prim_curve.h"
#include "hwmodel/format/prim_sphere.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/motion.h"

namespace rtu::hw {

struct MotionFormat {
  int time_bits = 16;     // the ray's time register: round(time * 2^time_bits), 1..24
  int box_time_bits = 6;  // the box unit's time: the top box_time_bits of the register, 0..time_bits
  // Throws std::invalid_argument naming the rule broken.
  void validate() const;
  std::string describe() const;  // "time_bits=16 box_time_bits=6"
};

// The ray's time register: round(time * 2^time_bits) to nearest (ties up), in [0, 2^time_bits]. time must be
// valid (valid_shutter_time).
uint32_t quantize_time(float time, int time_bits);

// The box unit's interval for a time register value: [s0, s1] in units of 2^-box_time_bits, s0 = tq >>
// (time_bits - box_time_bits), s1 = s0 + 1 (s0 at the end of the shutter). It holds tq / 2^time_bits.
struct BoxTime {
  int64_t s0, s1;
  int bits;
};
BoxTime box_time(uint32_t tq, const MotionFormat& m);

// A child's grid box over the interval t: each plane the extreme of its key-frame interpolation over [s0, s1],
// floor for lo and ceil for hi. key: lo0[3], hi0[3], lo1[3], hi1[3].
inline void motion_box(const int32_t key[12], const BoxTime& t, int64_t lo[3], int64_t hi[3]) {
  for (int a = 0; a < 3; ++a) {
    const int64_t dl = int64_t(key[6 + a]) - key[a], dh = int64_t(key[9 + a]) - key[3 + a];
    lo[a] = key[a] + ((dl * (dl < 0 ? t.s1 : t.s0)) >> t.bits);       // floor: arithmetic shift
    hi[a] = key[3 + a] - ((-dh * (dh > 0 ? t.s1 : t.s0)) >> t.bits);  // ceil(x) = -floor(-x)
  }
}

// The box unit at a node of a motion BVH: each child's grid box at box time bt (motion_box) tested against r over
// [r.tmin, tlim]; the accepted children's references and entry distances into refs and dists, their count
// returned; `tested` counts the children tested. With `check`, each test is repeated exactly (box_test_exact) and
// disagreements counted in s. Records the node's kNode event when `rec` is not null.
template <int N>
int motion_expand(const std::vector<uint32_t>& child, const std::vector<int32_t>& boxes, uint32_t node,
                  const BoxTime& bt, const FixedRay& r, int64_t tlim, bool check, TraversalStats& s,
                  std::vector<TraceEvent>* rec, uint32_t refs[N], int64_t dists[N], int& tested) {
  int k = 0;
  for (int i = 0; i < N; ++i) {
    const size_t slot = size_t(node) * N + size_t(i);
    if (child[slot] == kEmptyChild) continue;
    ++tested;
    int64_t lo[3], hi[3], tn = 0;
    motion_box(&boxes[slot * 12], bt, lo, hi);
    const bool accepted = box_test(r, lo, hi, r.tmin, tlim, tn);
    if (check) {
      ++s.box_checks;
      const bool exact = box_test_exact(r, lo, hi, r.tmin, tlim);
      s.box_false_negatives += exact && !accepted;
      s.box_false_positives += accepted && !exact;
    }
    if (accepted) {
      refs[k] = child[slot];
      dists[k] = tn;
      ++k;
    }
  }
  if (rec) rec->push_back(TraceEvent{TraceEvent::kNode, uint8_t(tested), 0, 0, node});
  return k;
}

// A triangle's grid vertices at time register tq: v0 + round((v1 - v0) tq / 2^time_bits), ties up. key: the
// three vertices' xyz at key frame 0, then at key frame 1.
inline void motion_vertices(const int32_t key[18], uint32_t tq, int time_bits, int32_t v[3][3]) {
  const int64_t half = int64_t(1) << (time_bits - 1);
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a) {
      const int64_t k0 = key[3 * i + a], d = int64_t(key[9 + 3 * i + a]) - k0;
      v[i][a] = int32_t(k0 + ((d * int64_t(tq) + half) >> time_bits));
    }
}

// A sphere's record at time register tq: center c0 + round((c1 - c0) tq / 2^time_bits) (nearest, ties up) and
// radius r0 + ceil((r1 - r0) tq / 2^time_bits), in grid.F units. key: center xyz and radius at key frame 0,
// then 1.
inline SphereRecord motion_sphere(const int64_t key[8], uint32_t tq, int time_bits) {
  SphereRecord s{};
  const int64_t half = int64_t(1) << (time_bits - 1);
  for (int a = 0; a < 3; ++a) s.center[a] = key[a] + (((key[4 + a] - key[a]) * int64_t(tq) + half) >> time_bits);
  s.radius = key[3] - ((-(key[7] - key[3]) * int64_t(tq)) >> time_bits);
  return s;
}

// A curve segment's record at time register tq: end points k0 + round((k1 - k0) tq / 2^time_bits) (nearest,
// ties up) on the grid, radii r0 + ceil((r1 - r0) tq / 2^time_bits) in grid.F units, stored as the record's
// radius fields (rounded up). key: p0 xyz, p1 xyz, r0, r1 at key frame 0, then 1; round: the record's round word.
inline CurveRecord motion_curve(const int64_t key[16], uint32_t round, uint32_t prim, uint32_t tq, int time_bits) {
  CurveRecord c{};
  const int64_t half = int64_t(1) << (time_bits - 1);
  auto near = [&](int i) { return key[i] + (((key[8 + i] - key[i]) * int64_t(tq) + half) >> time_bits); };
  auto up = [&](int i) { return key[i] - ((-(key[8 + i] - key[i]) * int64_t(tq)) >> time_bits); };
  for (int a = 0; a < 3; ++a) {
    c.p0[a] = int32_t(near(a));
    c.p1[a] = int32_t(near(3 + a));
  }
  c.r0 = curve_radius_field(up(6));
  c.r1 = curve_radius_field(up(7));
  c.round = round;
  c.prim = record_word(RecordKind::kCurve, prim);
  return c;
}

// Fills `boxes` (12 a child slot, motion_box's key) bottom up over a motion BVH's child array: a leaf slot's from
// leaf(ref, out), an inner slot's the union of its child node's slots. Children must follow their parent (the
// builder's order; std::logic_error otherwise).
void sweep_motion_boxes(const std::vector<uint32_t>& child, int width,
                        const std::function<void(uint32_t ref, int32_t out[12])>& leaf,
                        std::vector<int32_t>& boxes);

// The fixed-point image of a moving scene: the frame over both key frames, grid vertices and grid boxes at both.
struct MotionImage {
  FixedFormat format;
  MotionFormat motion;
  QuantFrame frame;
  int width = 4;
  uint32_t root_ref = kEmptyChild;
  std::vector<uint32_t> child;        // as MotionBvh::child
  std::vector<int32_t> boxes;         // 12 per child slot (motion_box's key)
  std::vector<uint32_t> prim_ids;     // leaf order -> triangle index
  std::vector<int32_t> vertices;      // 18 per triangle (motion_vertices' key)
  std::vector<int64_t> spheres;       // 8 per sphere (motion_sphere's key): center to nearest, radius up, grid.F
  std::vector<int64_t> curves;        // 16 per curve segment (motion_curve's key): end points nearest, radii up
  std::vector<uint32_t> curve_round;  // per curve segment: its record's round word (kRoundCurve, kRoundCapStart)
  std::vector<uint8_t> moving;        // per primitive: 1 when its grid key frames differ
  uint32_t triangles() const { return uint32_t(vertices.size() / 18); }
  uint32_t round_prims() const { return uint32_t(spheres.size() / 8); }  // spheres; curve segments follow them

  // Vertices rounded to the nearest grid point; each box the integer bounds of its primitives' grid vertices at
  // that key frame, a sphere's box its grid center -+ (radius + 2 grid.F units: the slack of its interpolation's
  // roundings, docs/numerics.md "Motion blur"), a curve segment's its grid end points -+ (radius, up to grid
  // units,
  // + 2: the end points' rounding at a time in between, half a unit, and the radius's). Throws
  // std::invalid_argument for an invalid format, curves the format cannot hold (curve_limits) or a scene the frame
  // cannot hold.
  static MotionImage encode(const MotionGeometry& g, const MotionBvh& bvh, const FixedFormat& f,
                            const MotionFormat& m);
  uint64_t node_count() const { return child.size() / uint64_t(width); }
};

// Counts a ray that is invalid (validate_ray) or whose shutter time is not in [0, 1] (as kNanInterval) in s's
// rejections; true when it is.
bool reject_motion_ray(const Ray& r, float time, TraversalStats& s);

// Calls f(std::integral_constant<int, N>) for a motion BVH's width N; std::invalid_argument for another width.
template <class F>
void with_motion_width(int width, F&& f) {
  switch (width) {
    case 2:
      return f(std::integral_constant<int, 2>{});
    case 4:
      return f(std::integral_constant<int, 4>{});
    case 6:
      return f(std::integral_constant<int, 6>{});
    case 8:
      return f(std::integral_constant<int, 8>{});
    default:
      throw std::invalid_argument("motion BVH width must be 2, 4, 6 or 8");
  }
}

// Shutter times of a batch: empty (every ray at time 0) or one per ray. Throws std::invalid_argument naming the
// first ray whose time is not in [0, 1].
void validate_shutter_times(const std::vector<float>& times, size_t rays);

// The float reference at a node of a motion BVH: each child's box at `time` (MotionBvh::box_at, rounded outward)
// tested against the ray over [tmin, tmax]; the accepted children's references and entry distances into refs and
// dists, their count returned; `tested` counts the children tested.
template <int N>
int motion_expand_float(const MotionBvh& b, uint32_t node, float time, const RayPrecomp& rp, float tmin,
                        float tmax, uint32_t refs[N], float dists[N], int& tested) {
  int k = 0;
  for (int i = 0; i < N; ++i) {
    const size_t slot = size_t(node) * N + size_t(i);
    if (b.child[slot] == kEmptyChild) continue;
    ++tested;
    float lo[3], hi[3], t;
    b.box_at(slot, time, lo, hi);
    if (intersect_box(lo, hi, rp, tmin, tmax, t)) {
      refs[k] = b.child[slot];
      dists[k] = t;
      ++k;
    }
  }
  return k;
}

// A batch of rays at their shutter times (validate_shutter_times; empty: all at 0) traced by t.trace(ray, time,
// any_hit, stats) on `threads` host threads (run_batch): hits in ray order, whatever the thread count.
template <class Tracer>
void trace_motion_batch(const Tracer& t, const std::vector<Ray>& rays, const std::vector<float>& times,
                        std::vector<Hit>& hits, bool any_hit, int threads, TraversalStats& s) {
  validate_shutter_times(times, rays.size());
  hits.assign(rays.size(), Hit{});
  run_batch(rays.size(), threads, s, [&](size_t i, TraversalStats& ls) {
    hits[i] = t.trace(rays[i], times.empty() ? 0.0f : times[i], any_hit, ls);
  });
}

// The float reference: boxes interpolated at the ray's time (in double, rounded outward), triangles at it
// (lerp_point), the watertight float test.
class MotionFloatTracer {
 public:
  MotionFloatTracer(const MotionGeometry& g, const MotionBvh& bvh) : m_geom(g), m_bvh(bvh) {}
  Hit trace(const Ray& r, float time, bool any_hit, TraversalStats& s) const;
  void trace_batch(const std::vector<Ray>& rays, const std::vector<float>& times, std::vector<Hit>& hits,
                   bool any_hit, int threads, TraversalStats& s) const;

 private:
  const MotionGeometry& m_geom;
  const MotionBvh& m_bvh;
};

// The fixed-point unit over a MotionImage (see the top of this file).
class MotionFixedTracer {
 public:
  // check_boxes: repeat every box test with box_test_exact (box_false_negatives must stay 0), as FixedTracer.
  explicit MotionFixedTracer(const MotionImage& image, bool check_boxes = false);
  Hit trace(const Ray& r, float time, bool any_hit, TraversalStats& s) const;
  void trace_batch(const std::vector<Ray>& rays, const std::vector<float>& times, std::vector<Hit>& hits,
                   bool any_hit, int threads, TraversalStats& s) const;
  // trace() that also appends the ray's events for the timing model (fixed_tracer.h's TraceEvent: kNode with the
  // node index, kPrim with the record index in leaf order, every kPush and kPop). moving_to_shader: a moving
  // triangle's kPrim is followed by kAnyHit, the round trip to the shader of a unit that cannot interpolate
  // (docs/timing-model.md, "Motion blur"); the hit is the same.
  Hit trace_recorded(const Ray& r, float time, bool any_hit, TraversalStats& s, std::vector<TraceEvent>& events,
                     bool moving_to_shader = false) const;
  // Every triangle tested at the ray's time without the BVH: the closest hit (the smallest t, then the smallest
  // index) the datapath can find. What the tree must give: tests check that traversal loses none.
  Hit trace_all(const Ray& r, float time) const;

 private:
  Hit trace_impl(const Ray& r, float time, bool any_hit, TraversalStats& s, std::vector<TraceEvent>* rec,
                 bool shader) const;
  const MotionImage& m_image;
  bool m_check;
};

}  // namespace rtu::hw
