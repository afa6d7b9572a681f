#include "hwmodel/datapath/fixed_tracer.h"

#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <new>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "hwmodel/datapath/batch.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/node_test.h"
#include "hwmodel/datapath/prim_test.h"
#include "hwmodel/datapath/restart_trail.h"
#include "hwmodel/datapath/traverse.h"

namespace rtu::hw {

namespace {

// The alpha test of a candidate hit on a non-opaque triangle: the triangle's opacity micromap (micromap.h) where
// it knows the micro-triangle's state, else the any-hit stage (`asked`; any_hit.h). True when the hit counts.
struct AlphaTest {
  const AnyHitStage* stage;
  const MicromapSet* maps;
  // `looked`: the map's state (MicroState) + 1 when the triangle has a map, else 0; `at`: the state's byte in the
  // maps' section (MicromapSet::state_byte).
  bool accept(uint32_t prim, float u, float v, TraversalStats& s, bool& asked, uint8_t& looked,
              uint32_t& at) const {
    if (maps && prim < maps->map_of.size() && maps->map_of[prim] != MicromapSet::kNoMap) {
      const uint32_t index = micro_index(maps->maps[maps->map_of[prim]].level, u, v);
      const MicroState ms = maps->maps[maps->map_of[prim]].state(index);
      looked = uint8_t(uint8_t(ms) + 1);
      at = uint32_t(maps->state_byte(prim, index));
      if (ms == MicroState::kOpaque) {
        ++s.omm_opaque;
        return true;
      }
      if (ms == MicroState::kTransparent) {
        ++s.omm_transparent;
        return false;
      }
    }
    asked = true;
    ++s.any_hit_calls;
    if (stage->accept(prim, u, v)) return true;
    ++s.any_hit_ignored;
    return false;
  }
};

struct Closest {
  int64_t t;  // t raw; starts at the ray's tmax
  uint32_t prim = kMissPrim;
  float u = 0.0f, v = 0.0f;
  const uint8_t* record = nullptr;  // the hit's primitive record (null for a plane)
  float world_t = 0.0f;             // a hit in an instance: its world t, as the bottom level found it
};

// An instance record: its bottom level traced over what is left of the interval; a hit at or before the closest
// so far (as the float reference's rule) becomes the closest.
inline bool test_instance(const uint8_t* rec, const FixedRay& r, const Ray* world, Closest& c,
                          const BottomLevels* bottom, bool any_hit, TraversalStats& s,
                          std::vector<TraceEvent>* events) {
  if (!bottom || !world) return false;
  uint32_t word;
  std::memcpy(&word, rec + 36, 4);
  float limit = world->tmax;
  if (c.prim != kMissPrim)
    limit = c.record && record_kind(c.record) == RecordKind::kInstance ? c.world_t : t_to_world(c.t, r);
  Hit h;
  if (!bottom->trace_instance(word & kRecordPrimMask, *world, limit, any_hit, h, s, events) || !(h.t <= limit))
    return false;
  c.t = t_raw_up(h.t, r);
  c.prim = h.prim;
  c.u = h.u;
  c.v = h.v;
  c.record = rec;
  c.world_t = h.t;
  return true;
}

// A triangle through the triangle-unit seam: hit and t as the unit answers, u and v formed from its e1, e2 and det
// as triangle_test forms them, and its clocks (checked: the trace event holds them in 8 bits).
inline bool unit_triangle(TriUnit& unit, const FixedRay& r, const int32_t v[3][3], int64_t tmin, int64_t tlim,
                          FixedPrimHit& h, uint8_t& issue, uint8_t& result) {
  TriUnitResult out;
  unit.test(r, v, tmin, tlim, out);
  if (out.issue < 1 || out.issue > 255 || out.result < out.issue || out.result > 255)
    throw std::logic_error(std::string("triangle unit ") + unit.name() + ": clocks (issue " +
                           std::to_string(out.issue) + ", result " + std::to_string(out.result) +
                           ") outside 1 <= issue <= result <= 255");
  issue = uint8_t(out.issue);
  result = uint8_t(out.result);
  if (!out.hit) return false;
  h.t = out.t;
  triangle_barycentrics(out.e1, out.e2, out.det, h.u, h.v);
  return true;
}

// Tests one primitive record; on a closer (or equally near) hit updates c. A triangle goes to `unit` when one is
// attached (its clocks in issue and result; 0 otherwise).
// A hit on a non-opaque triangle goes to the any-hit stage when one is attached (`asked`), and counts only when it
// accepts (any_hit.h).
// An instance record goes to the bottom levels (test_instance).
inline bool test_record(const uint8_t* rec, const FixedRay& r, Closest& c, bool short_edges, TriUnit* unit,
                        uint8_t& issue, uint8_t& result, AlphaTest stage, TraversalStats& s, bool& asked,
                        uint8_t& looked, uint32_t& omm_at, const Ray* world, const BottomLevels* bottom,
                        bool any_hit, std::vector<TraceEvent>* events) {
  uint32_t word;
  FixedPrimHit h;
  bool hit;
  issue = result = 0;
  if (record_kind(rec) == RecordKind::kInstance) {
    asked = false;
    looked = 0;
    return test_instance(rec, r, world, c, bottom, any_hit, s, events);
  }
  switch (record_kind(rec)) {  // the kind's test inlined; the image check admits no other kind here
    case RecordKind::kTriangle:
    case RecordKind::kTrianglePair:
      if (unit) {
        TriangleRecord t;
        std::memcpy(&t, rec, sizeof t);
        word = t.prim;
        hit = unit_triangle(*unit, r, t.v, r.tmin, c.t, h, issue, result);
      } else {
        hit = PrimTest<TrianglePrim>::test_fixed(r, rec, r.tmin, c.t, h, short_edges, word);
      }
      break;
    case RecordKind::kCurve:
      hit = PrimTest<CurvePrim>::test_fixed(r, rec, r.tmin, c.t, h, short_edges, word);
      break;
    default:
      hit = PrimTest<SpherePrim>::test_fixed(r, rec, r.tmin, c.t, h, short_edges, word);
      break;
  }
  asked = false;
  looked = 0;
  if (hit && (word & kRecordNonOpaque) && stage.stage)
    hit = stage.accept(word & kRecordPrimMask, h.u, h.v, s, asked, looked, omm_at);
  if (hit) {
    c.t = h.t;
    c.prim = word & kRecordPrimMask;
    c.u = h.u;
    c.v = h.v;
    c.record = rec;
  }
  return hit;
}

// Tests record `index` and appends its events to rec (when not null): kPrim, and kAnyHit when the stage was
// asked; an instance's kPrim comes before its bottom level's events.
inline bool test_recorded(const uint8_t* record, uint32_t index, const FixedRay& r, Closest& c, bool short_edges,
                          TriUnit* unit, AlphaTest stage, TraversalStats& s, const Ray* world,
                          const BottomLevels* bottom, bool any_hit, std::vector<TraceEvent>* rec);

// Records [first, first + count) of a leaf (or of an image without a BVH) in order. A triangle pair with its
// second in the range is one request: both tested in order (the second skipped once an any-hit query has its
// hit, as without pairs), one kPrim event of kind kTrianglePair whose clocks are the two tests'; a pair's first
// at the range's end is tested alone.
inline bool test_records(const DeviceImage& image, uint32_t first, uint32_t count, const FixedRay& r, Closest& c,
                         bool short_edges, TriUnit* unit, AlphaTest stage, TraversalStats& s, const Ray* world,
                         const BottomLevels* bottom, bool any_hit, std::vector<TraceEvent>* rec) {
  bool found = false;
  for (uint32_t i = first; i < first + count; ++i) {
    const uint8_t* a = image.record(i);
    if (record_kind(a) != RecordKind::kTrianglePair || i + 1 == first + count) {
      found |= test_recorded(a, i, r, c, short_edges, unit, stage, s, world, bottom, any_hit, rec);
      if (found && any_hit) return true;
      continue;
    }
    uint8_t issue = 0, result = 0, issue2 = 0, result2 = 0;
    bool asked = false, asked2 = false;
    uint8_t looked = 0, looked2 = 0;
    uint32_t at = 0, at2 = 0;
    found |= test_record(a, r, c, short_edges, unit, issue, result, stage, s, asked, looked, at, world, bottom,
                         any_hit, rec);
    if (!(found && any_hit))
      found |= test_record(image.record(i + 1), r, c, short_edges, unit, issue2, result2, stage, s, asked2,
                           looked2, at2, world, bottom, any_hit, rec);
    if (rec) {
      const uint8_t is = uint8_t(std::min(255, issue + issue2)),
                    res = uint8_t(std::min(255, std::max<int>(result, issue + result2)));
      rec->push_back(TraceEvent{TraceEvent::kPrim, uint8_t(RecordKind::kTrianglePair), is, res, i});
      if (looked) rec->push_back(TraceEvent{TraceEvent::kOmm, uint8_t(looked - 1), 0, 0, at});
      if (asked) rec->push_back(TraceEvent{TraceEvent::kAnyHit, 0, 0, 0, i});
      if (looked2) rec->push_back(TraceEvent{TraceEvent::kOmm, uint8_t(looked2 - 1), 0, 0, at2});
      if (asked2) rec->push_back(TraceEvent{TraceEvent::kAnyHit, 0, 0, 0, i + 1});
    }
    if (found && any_hit) return true;
    ++i;
  }
  return found;
}

inline bool test_recorded(const uint8_t* record, uint32_t index, const FixedRay& r, Closest& c, bool short_edges,
                          TriUnit* unit, AlphaTest stage, TraversalStats& s, const Ray* world,
                          const BottomLevels* bottom, bool any_hit, std::vector<TraceEvent>* rec) {
  uint8_t issue, result, looked;
  uint32_t at = 0;
  bool asked;
  const bool instance = record_kind(record) == RecordKind::kInstance;
  if (rec && instance) rec->push_back(TraceEvent{TraceEvent::kPrim, uint8_t(RecordKind::kInstance), 0, 0, index});
  const bool hit = test_record(record, r, c, short_edges, unit, issue, result, stage, s, asked, looked, at, world,
                               bottom, any_hit, rec);
  if (rec && !instance) {
    rec->push_back(TraceEvent{TraceEvent::kPrim, uint8_t(record_kind(record)), issue, result, index});
    if (looked) rec->push_back(TraceEvent{TraceEvent::kOmm, uint8_t(looked - 1), 0, 0, at});
    if (asked) rec->push_back(TraceEvent{TraceEvent::kAnyHit, 0, 0, 0, index});
  }
  return hit;
}

// The traversal's datapath policy (traverse.h) over nodes of kind K (node_test.h).
template <NodeKind K>
struct FixedPolicy {
  using Dist = int64_t;
  using Node = typename K::Node;
  using Test = NodeTest<K>;
  static constexpr int N = K::kWidth;
  static constexpr int kWidth = N;

  const Node* nodes;
  const DeviceImage& image;
  const FixedRay& r;
  bool any_hit;
  bool check;
  Closest& closest;
  TraversalStats& s;
  std::vector<TraceEvent>* rec;  // the timing model's recorder, or null
  BoxUnit* unit;                 // box tests by this unit instead of box_test_delta, or null
  TriUnit* tri_unit;             // triangle tests by this unit instead of triangle_test, or null
  AlphaTest stage;               // the any-hit stage and micromaps of non-opaque triangles
  const Ray* world;              // the world ray (null when traced from a FixedRay)
  const BottomLevels* bottom;    // a top level's instances, or null
  FixedTracer::WatchState& watch;
  uint64_t step_limit;

  // The watchdog: one step per node or leaf visit; past the bound the ray stops (nothing more is tested and
  // limit() drops below every stacked entry, so the traversal loop empties its stack and ends).
  bool stopped(uint32_t ref) const {
    if (watch.fired) return true;
    if (++watch.steps <= step_limit) return false;
    watch.fired = true;
    watch.ref = ref;
    return true;
  }

  typename Test::RayState nr;         // the node kernels' constants for the ray
  bool short_edges;                   // short_edges_known for the ray
  int short_stack = -1;               // FixedTraceOptions::record_short_stack
  bool stack_refs = false;            // FixedTraceOptions::record_stack_refs
  bool leaf_refs = false;             // FixedTraceOptions::record_leaf_refs
  mutable int rec_depth[2] = {0, 0};  // each stack's entries, as the recorder counts them (traverse.h)
  RestartTrail* trail = nullptr;      // recording with FixedTraceOptions::record_restart: the restarts' costs
  // All-hit traversal: called with each record index of a leaf, it tests the record with its own interval (an
  // instance: its bottom level's all-hit traversal) and keeps its hits; the closest is never narrowed. Null
  // otherwise.
  const std::function<void(uint32_t)>* all = nullptr;

  // A constructor, not aggregate initialization: GCC 12 clears the whole object before an aggregate's fields
  // (rep stos, a stall once per ray).
  FixedPolicy(const Node* nodes_, const DeviceImage& image_, const FixedRay& r_, bool any_hit_, bool check_,
              Closest& closest_, TraversalStats& s_, std::vector<TraceEvent>* rec_, BoxUnit* unit_,
              TriUnit* tri_unit_, AlphaTest stage_, const Ray* world_, const BottomLevels* bottom_,
              FixedTracer::WatchState& watch_, uint64_t step_limit_, const FixedFormat& f, int short_stack_)
      : nodes(nodes_),
        image(image_),
        r(r_),
        any_hit(any_hit_),
        check(check_),
        closest(closest_),
        s(s_),
        rec(rec_),
        unit(unit_),
        tri_unit(tri_unit_),
        stage(stage_),
        world(world_),
        bottom(bottom_),
        watch(watch_),
        step_limit(step_limit_),
        nr(Test::ray(r_, f)),
        short_edges(short_edges_known(r_, f.coord_bits)),
        short_stack(short_stack_) {
    nr.fast = nr.fast && !check && !unit;
  }

  int expand(uint32_t node, uint32_t refs[N], int64_t dists[N], int& tested) const {
    if (stopped(node)) return 0;
    const int k = expand_recorded(node, refs, dists, tested);
    if (trail) trail->expanded(rec->back(), k);
    return k;
  }

  int expand_recorded(uint32_t node, uint32_t refs[N], int64_t dists[N], int& tested) const {
    if (unit) return expand_unit(node, refs, dists, tested);
    const Node& n = nodes[node];
    if (rec) rec->push_back(TraceEvent{TraceEvent::kNode, uint8_t(K::count(n)), 0, 0, node});
    if (nr.fast) {
      const int k = Test::fast(nr, n, r.tmin, closest.t, refs, dists);
      if (k >= 0) {
        tested += K::count(n);
        prefetch(refs, k);
        return k;
      }
    }
    return r.narrow ? expand_ref<int64_t>(n, refs, dists, tested) : expand_ref<Wide>(n, refs, dists, tested);
  }

  // Asks the cache for the accepted children's nodes or first records (a hint: no effect on any result).
  void prefetch(const uint32_t refs[N], int k) const {
    for (int j = 0; j < k; ++j) {
      const char* p = is_leaf(refs[j]) ? reinterpret_cast<const char*>(image.record(leaf_first(refs[j])))
                                       : reinterpret_cast<const char*>(&nodes[refs[j]]);
      __builtin_prefetch(p);
      __builtin_prefetch(p + 63);
    }
  }

  // Repeats child i's box test exactly and counts a disagreement with the datapath's answer.
  void check_child(const Node& n, int i, bool hit) const {
    ++s.box_checks;
    const bool exact = Test::exact(nr, r, n, i, r.tmin, closest.t);
    s.box_false_negatives += uint64_t(exact && !hit);
    s.box_false_positives += uint64_t(hit && !exact);
  }

  // The node through the box unit seam: the same decoded inputs, the hit children in slot order as the reference
  // path keeps them, and the unit's clocks in the recorded event.
  int expand_unit(uint32_t node, uint32_t refs[N], int64_t dists[N], int& tested) const {
    const Node& n = nodes[node];
    const BoxUnitNode in = Test::unit_input(nr, r, n);
    BoxUnitResult out;
    unit->test(r, in, r.tmin, closest.t, out);
    if (out.issue < 1 || out.issue > 255 || out.result < out.issue || out.result > 255)
      throw std::logic_error(std::string("box unit ") + unit->name() + ": clocks (issue " +
                             std::to_string(out.issue) + ", result " + std::to_string(out.result) +
                             ") outside 1 <= issue <= result <= 255");
    const int count = K::count(n);
    if (rec)
      rec->push_back(TraceEvent{TraceEvent::kNode, uint8_t(count), uint8_t(out.issue), uint8_t(out.result), node});
    int k = 0;
    for (int i = 0; i < count; ++i) {
      ++tested;
      const bool hit = (out.hit >> i) & 1u;
      if (check) check_child(n, i, hit);
      refs[k] = K::child(n, i);
      dists[k] = out.t_near[i];
      k += int(hit);
    }
    return k;
  }

  template <class Int>
  int expand_ref(const Node& n, uint32_t refs[N], int64_t dists[N], int& tested) const {
    return Test::template test<Int>(nr, r, n, r.tmin, closest.t, refs, dists, [&](int i, bool hit) {
      ++tested;
      if (check) check_child(n, i, hit);
    });
  }

  bool leaf(uint32_t ref) const {
    if (stopped(ref)) return false;
    const uint32_t first = leaf_first(ref), count = leaf_count(ref);
    if (!bottom) s.prim_tests += count;  // an instance record is not a test: its bottom level counts its own
    if (all) {
      for (uint32_t i = first; i < first + count; ++i) (*all)(i);
      return false;
    }
    return test_records(image, first, count, r, closest, short_edges, tri_unit, stage, s, world, bottom, any_hit,
                        rec);
  }

  int64_t limit() const { return watch.fired ? INT64_MIN : closest.t; }
  // Stack b's traffic (traverse.h: 0, or 1 for treelet-first order's other treelets). Each stack is a short
  // stack of its own in treelet-first order; their spills go to the slot's one spill area (the timing model
  // counts entries spilled, not which stack they came from).
  void pushed(const uint32_t* refs, int n, int b) const {
    if (!watch.fired) watch.depth += n;
    if (rec) {
      int& depth = rec_depth[b];
      if (trail) {
        trail->pushed(n);
      } else if (short_stack < 0) {
        rec->push_back(TraceEvent{TraceEvent::kPush, uint8_t(n), 0, 0, 0});
      } else {
        // Entries beyond the short stack after the push, less those beyond it before.
        const int over = std::max(0, depth + n - short_stack) - std::max(0, depth - short_stack);
        if (over > 0) rec->push_back(TraceEvent{TraceEvent::kSpill, uint8_t(over), 0, 0, 0});
      }
      depth += n;
      if (stack_refs)
        for (int j = 0; j < n; ++j) {
          if (!is_leaf(refs[j]))
            rec->push_back(TraceEvent{TraceEvent::kStackRef, uint8_t(j), 0, 0, refs[j]});
          else if (leaf_refs)
            rec->push_back(TraceEvent{TraceEvent::kStackRef, uint8_t(j), uint8_t(leaf_count(refs[j])), 0,
                                      leaf_first(refs[j])});
        }
    }
  }
  void popped(int b) const {
    if (!watch.fired) --watch.depth;
    if (rec) {
      int& depth = rec_depth[b];
      if (trail) {
        if (!watch.fired) trail->popped(*rec);  // a stopped ray ends: no restart
      } else if (short_stack < 0)
        rec->push_back(TraceEvent{TraceEvent::kPop, 0, 0, 0, 0});
      else if (depth > short_stack)
        rec->push_back(TraceEvent{TraceEvent::kRefill, 0, 0, 0, 0});
      --depth;
    }
  }
};

}  // namespace

FixedTracer::FixedTracer(const DeviceImage& image, const FixedTraceOptions& opt)
    : m_image(image), m_format(image.format()), m_frame(image.frame()), m_setup(m_frame, m_format), m_opt(opt) {
  if (m_opt.box_unit && !(image.header().flags & kImageNoBvh))
    m_opt.box_unit->check_format(m_format, int(image.header().width));
  if (m_opt.tri_unit) m_opt.tri_unit->check_format(m_format);
  if (m_opt.treelets.of && (m_opt.record_restart || m_opt.record_stack_refs))
    throw std::invalid_argument(
        "treelet-first traversal keeps two stacks; the restart trail and the stack prefetchers see one");
  if (m_opt.treelets.of && m_opt.treelets.count != image.header().node_count)
    throw std::invalid_argument("treelet-first traversal: the treelet map has " +
                                std::to_string(m_opt.treelets.count) + " nodes, the image " +
                                std::to_string(image.header().node_count));
  m_step_limit = opt.max_steps > 0 ? opt.max_steps : uint64_t(image.node_total()) * image.header().width + 1;
}

Hit FixedTracer::trace(const Ray& r, bool any_hit, TraversalStats& s) const {
  return trace_world(r, any_hit, s, nullptr);
}

Hit FixedTracer::trace_fixed(const FixedRay& r, bool any_hit, TraversalStats& s) const {
  return trace_counted(nullptr, r, any_hit, s);
}

Hit FixedTracer::trace_recorded(const Ray& r, bool any_hit, TraversalStats& s,
                                std::vector<TraceEvent>& events) const {
  return trace_world(r, any_hit, s, &events);
}

Hit FixedTracer::trace_world(const Ray& r, bool any_hit, TraversalStats& s, std::vector<TraceEvent>* rec,
                             WatchState* ws) const {
  FixedRay fr;
  if (s.rejected(m_setup(r, fr))) return Hit{};
  return trace_counted(&r, fr, any_hit, s, rec, ws);
}

Hit FixedTracer::trace_counted(const Ray* r, const FixedRay& fr, bool any_hit, TraversalStats& s,
                               std::vector<TraceEvent>* rec, WatchState* ws) const {
  const uint64_t sat0 = saturation_count();
  ++s.rays;
  WatchState local;
  WatchState& w = ws ? *ws : local;
  Hit h = trace_valid(r, fr, any_hit, s, rec, w);
  s.saturations += saturation_count() - sat0;
  if (w.fired) {  // stopped by the watchdog: a miss, counted; the engines turn it into an error
    ++s.watchdog_rays;
    if (h.prim != kMissPrim) --s.hits;
    h = Hit{};
  }
  return h;
}

std::string FixedTracer::watchdog_report(const Ray* rays, size_t n, bool any_hit, uint64_t stopped) const {
  for (size_t i = 0; i < n; ++i) {
    TraversalStats s;
    WatchState w;
    trace_world(rays[i], any_hit, s, nullptr, &w);
    if (!w.fired) continue;
    const Ray& r = rays[i];
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "traversal watchdog: ray %zu of %zu (origin %g %g %g, direction %g %g %g, t [%g, %g]) exceeded "
                  "the step bound of %llu node and leaf visits; stopped before %s %u with %d stack entries; %llu "
                  "rays of the batch were stopped",
                  i, n, double(r.origin.x), double(r.origin.y), double(r.origin.z), double(r.dir.x),
                  double(r.dir.y), double(r.dir.z), double(r.tmin), double(r.tmax),
                  (unsigned long long)m_step_limit, is_leaf(w.ref) ? "leaf of record" : "node",
                  is_leaf(w.ref) ? leaf_first(w.ref) : w.ref, w.depth, (unsigned long long)stopped);
    return buf;
  }
  return "traversal watchdog: " + std::to_string(stopped) + " rays exceeded the step bound of " +
         std::to_string(m_step_limit) + " node and leaf visits";
}

Hit FixedTracer::trace_valid(const Ray* r, const FixedRay& fr, bool any_hit, TraversalStats& s,
                             std::vector<TraceEvent>* rec, WatchState& watch) const {
  const ImageHeader& hd = m_image.header();
  Closest c{fr.tmax};
  if (fr.tmin > fr.tmax) return Hit{};
  const PlaneRecord* planes = m_image.planes();
  for (uint32_t i = 0; i < hd.plane_count; ++i) {
    FixedPrimHit h;
    ++s.prim_tests;
    if (rec) rec->push_back(TraceEvent{TraceEvent::kPlane, 0, 0, 0, i});
    if (PrimTest<PlanePrim>::test_fixed(fr, planes[i], fr.tmin, c.t, h)) {
      c = Closest{h.t, planes[i].prim, 0.0f, 0.0f, nullptr};
      if (any_hit) break;
    }
  }
  if (!(any_hit && c.prim != kMissPrim) && hd.record_count > 0) {
    if (hd.flags & kImageNoBvh) {
      const bool short_brute = short_edges_known(fr, m_format.coord_bits);
      if (!m_opt.bottom) s.prim_tests += hd.record_count;
      test_records(m_image, 0, hd.record_count, fr, c, short_brute, m_opt.tri_unit,
                   AlphaTest{m_opt.any_hit, m_opt.micromaps}, s, r, m_opt.bottom, any_hit, rec);
    } else {
      with_node_kind(node_kind(hd), hd.width, hd.q_bytes, [&](auto kind) {
        using K = decltype(kind);
        FixedPolicy<K> p(m_image.nodes<typename K::Node>(), m_image, fr, any_hit, m_opt.check_boxes, c, s, rec,
                         m_opt.box_unit, m_opt.tri_unit, AlphaTest{m_opt.any_hit, m_opt.micromaps}, r,
                         m_opt.bottom, watch, m_step_limit, m_format, m_opt.record_short_stack);
        p.stack_refs = m_opt.record_stack_refs;
        p.leaf_refs = m_opt.record_leaf_refs;
        // Built in place only when recorded: GCC 12 zeroes a std::optional's 6 KB payload on every ray (a
        // quarter of the traversal's time on camera rays), and an empty trail needs none of it.
        static_assert(std::is_trivially_destructible_v<RestartTrail>);
        alignas(RestartTrail) unsigned char trail_storage[sizeof(RestartTrail)];
        if (rec && m_opt.record_restart && m_opt.record_short_stack >= 0)
          p.trail = new (trail_storage) RestartTrail(m_opt.record_short_stack);
        if (m_opt.treelets.of)
          traverse_treelet_first(p, hd.root_ref, any_hit, s, m_opt.treelets, !m_opt.slot_order);
        else
          traverse(p, hd.root_ref, any_hit, s, !m_opt.slot_order);
      });
    }
  }
  if (c.prim == kMissPrim) return Hit{};
  ++s.hits;
  if (c.record && record_kind(c.record) == RecordKind::kInstance)
    return Hit{c.world_t, c.prim, c.u, c.v};  // the bottom level's t and u, v (of a sphere too)
  return world_hit(c.t, c.prim, c.u, c.v, c.record, fr, r);
}

Hit FixedTracer::world_hit(int64_t t, uint32_t prim, float u, float v, const uint8_t* record, const FixedRay& fr,
                           const Ray* r) const {
  Hit h{t_to_world(t, fr), prim, u, v};
  if (r && record && record_kind(record) == RecordKind::kSphere) {
    // u, v of a sphere hit from its world center (a shading output, not part of the datapath).
    SphereRecord sr;
    std::memcpy(&sr, record, sizeof sr);
    Vec3 center;
    for (int a = 0; a < 3; ++a)
      center[a] = float(m_frame.to_world(0, a) + std::ldexp(double(sr.center[a]), m_frame.step_exp - fr.frac));
    sphere_uv(center, r->origin + h.t * r->dir, h.u, h.v);
  }
  return h;
}

uint64_t FixedTracer::trace_all(const Ray& r, HitList& all, TraversalStats& s,
                                std::vector<TraceEvent>* rec) const {
  if ((m_image.header().flags & kImageTopLevel) && !m_opt.bottom)
    throw std::invalid_argument("all-hit traversal of a top level needs its bottom levels");
  FixedRay fr;
  if (s.rejected(m_setup(r, fr))) return all.count;
  ++s.rays;
  const uint64_t before = all.count;
  const ImageHeader& hd = m_image.header();
  if (fr.tmin > fr.tmax) return all.count;
  // The walk's state: the callback below captures one pointer to it, which std::function holds in place (no
  // allocation per ray).
  struct Walk {
    const FixedTracer& t;
    const Ray& r;
    const FixedRay& fr;
    HitList& all;
    TraversalStats& s;
    std::vector<TraceEvent>* rec;
    AlphaTest stage;
    bool short_edges;
    void collect(const Closest& c) const {
      if (rec) rec->push_back(TraceEvent{TraceEvent::kHitOut, uint8_t(all.count < all.max), 0, 0, c.prim});
      all.add(t.world_hit(c.t, c.prim, c.u, c.v, c.record, fr, &r));
    }
    // Record i: a primitive's hit kept, or an instance's bottom level traced for all of its own.
    void one(uint32_t i) const {
      const uint8_t* record = t.m_image.record(i);
      if (record_kind(record) == RecordKind::kInstance) {
        if (rec) rec->push_back(TraceEvent{TraceEvent::kPrim, uint8_t(RecordKind::kInstance), 0, 0, i});
        uint32_t word;
        std::memcpy(&word, record + 36, 4);
        if (t.m_opt.bottom) t.m_opt.bottom->trace_instance_all(word & kRecordPrimMask, r, all, s, rec);
        return;
      }
      Closest c{fr.tmax};
      if (test_recorded(record, i, fr, c, short_edges, t.m_opt.tri_unit, stage, s, &r, nullptr, false, rec))
        collect(c);
    }
  };
  const AlphaTest stage{m_opt.any_hit, m_opt.micromaps};
  const Walk walk{*this, r, fr, all, s, rec, stage, short_edges_known(fr, m_format.coord_bits)};
  const PlaneRecord* planes = m_image.planes();
  for (uint32_t i = 0; i < hd.plane_count; ++i) {
    FixedPrimHit h;
    ++s.prim_tests;
    if (rec) rec->push_back(TraceEvent{TraceEvent::kPlane, 0, 0, 0, i});
    if (PrimTest<PlanePrim>::test_fixed(fr, planes[i], fr.tmin, fr.tmax, h))
      walk.collect(Closest{h.t, planes[i].prim, 0.0f, 0.0f, nullptr});
  }
  const std::function<void(uint32_t)> one = [w = &walk](uint32_t i) { w->one(i); };
  if (hd.record_count > 0 && (hd.flags & kImageNoBvh)) {
    if (!m_opt.bottom) s.prim_tests += hd.record_count;
    for (uint32_t i = 0; i < hd.record_count; ++i) walk.one(i);
  } else if (hd.record_count > 0) {
    WatchState watch;
    Closest interval{fr.tmax};  // never narrowed: every subtree the ray enters in [tmin, tmax] is visited
    with_node_kind(node_kind(hd), hd.width, hd.q_bytes, [&](auto kind) {
      using K = decltype(kind);
      FixedPolicy<K> p(m_image.nodes<typename K::Node>(), m_image, fr, false, m_opt.check_boxes, interval, s, rec,
                       m_opt.box_unit, m_opt.tri_unit, stage, &r, m_opt.bottom, watch, m_step_limit, m_format, -1);
      p.all = &one;
      traverse(p, hd.root_ref, false, s, !m_opt.slot_order);
    });
    if (watch.fired) ++s.watchdog_rays;
  }
  s.hits += all.count > before;
  return all.count;
}

void FixedTracer::trace_batch(const Ray* rays, Hit* hits, size_t n, bool any_hit, int threads,
                              TraversalStats& s) const {
  if (m_opt.box_unit || m_opt.tri_unit) threads = 1;  // a unit is not thread-safe
  run_batch(n, threads, s, [&](size_t i, TraversalStats& local) { hits[i] = trace(rays[i], any_hit, local); });
}

}  // namespace rtu::hw
