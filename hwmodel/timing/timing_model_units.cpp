// The units a slot's requests go to (TimingModel::unit_request): box units, triangle units, curve units, the
// transform unit and the cluster engine's two stages, each request's issue clocks and latency (the configured
// ones, or the clocks an attached RTL unit reported), the first free unit of its kind, and the statistics the
// tests count. simulate() calls it at a request's cycle, in the order of (cycle, slot).
#include "hwmodel/timing/timing_model.h"

#include <algorithm>
#include <vector>

#include "hwmodel/format/prim_kinds.h"

namespace rtu::hw {

uint64_t TimingModel::unit(std::vector<uint64_t>& next_free, uint64_t issue, uint64_t latency, uint64_t t) {
  size_t best = 0;
  for (size_t j = 1; j < next_free.size(); ++j)
    if (next_free[j] < next_free[best]) best = j;
  const uint64_t start = std::max(t, next_free[best]);
  next_free[best] = start + issue;
  const uint64_t wait = start - t;
  m_s->unit_wait_cycles += wait;
  if (wait > uint64_t(m_c.queue_depth)) m_s->queue_stall_cycles += wait - uint64_t(m_c.queue_depth);
  return start + latency + issue - 1;
}

uint64_t TimingModel::unit_request(const TraceEvent& e, uint32_t k, uint64_t t) {
  const Slot& sl = m_slots[k];
  if (e.kind == TraceEvent::kOmm) {  // the micromap lookup: its state's byte is there; index and decision
    ++m_s->omm_lookups;
    if (m_trace) m_trace->add(m_unit, k, "omm", t, t + uint64_t(m_c.omm_latency));
    return t + uint64_t(m_c.omm_latency);
  }
  if (!m_cluster_box_free.empty() && cluster_node(*sl.layout, e)) return cluster_box_request(e, k, t);
  if (!m_cluster_tri_free.empty() && cluster_tri(*sl.layout, e)) return cluster_tri_request(k, t);
  if (e.kind == TraceEvent::kNode) return box_request(e, k, t);
  return test_request(e.kind == TraceEvent::kPrim ? record_cost(RecordKind(e.count)) : PlanePrim::kCost, e, k, t);
}

uint64_t TimingModel::cluster_box_request(const TraceEvent& e, uint32_t k, uint64_t t) {
  // The cluster engine's box stage: the node's children at box_rate per clock.
  const uint64_t done = unit(m_cluster_box_free, m_box_cost.issue[e.count], m_box_cost.latency, t);
  if (m_trace) m_trace->add(m_unit, k, "cluster box", t, done);
  m_s->cluster_box_tests += e.count;
  ++m_s->cluster_requests;
  return done;
}

uint64_t TimingModel::cluster_tri_request(uint32_t k, uint64_t t) {
  // The cluster engine's triangle stage: this triangle and those after it of its leaf (leaf_follower), as one
  // request of ceil(n / cluster_tri_rate) clocks; the followers take no time of their own (simulate()).
  const Slot& sl = m_slots[k];
  uint64_t n = 1;
  for (size_t j = sl.pos + 1; j < sl.ev.size() && leaf_follower(*sl.layout, sl.ev[j - 1], sl.ev[j]); ++j) ++n;
  const uint64_t rate = uint64_t(m_c.cluster_tri_rate);
  const uint64_t done = unit(m_cluster_tri_free, (n + rate - 1) / rate, uint64_t(m_c.tri_latency), t);
  if (m_trace) m_trace->add(m_unit, k, "cluster triangles", t, done);
  m_s->cluster_tri_tests += n;
  ++m_s->cluster_requests;
  return done;
}

uint64_t TimingModel::box_request(const TraceEvent& e, uint32_t k, uint64_t t) {
  // The configured rate and depth, or the clocks the box unit that tested the node reported (box_unit.h).
  const uint64_t issue = e.unit_issue ? e.unit_issue : m_box_cost.issue[e.count];
  const uint64_t latency = e.unit_issue ? uint64_t(e.unit_result) - issue + 1 : m_box_cost.latency;
  const uint64_t done = unit(m_box_free, issue, latency, t);
  if (m_trace) m_trace->add(m_unit, k, "box", t, done);
  m_s->box_tests += e.count;
  m_s->box_issue_cycles += issue;
  m_s->obb_rotations += uint64_t(m_oriented);
  return done;
}

uint64_t TimingModel::test_request(TestCost cost, const TraceEvent& e, uint32_t k, uint64_t t) {
  uint64_t done, issue = 1, lat = 0;
  const char* what = nullptr;  // every case sets both (no default: -Wswitch names a new cost class)
  switch (cost) {
    case TestCost::kTransform:
      // The transform unit, pipelined: no unit to wait for.
      done = t + uint64_t(m_c.xform_latency);
      if (m_trace) m_trace->add(m_unit, k, "transform", t, done);
      ++m_s->instance_transforms;
      return done;
    case TestCost::kCurve:
      // A curve unit's slot for one clock, or without curve units a triangle unit's for curve_issue clocks.
      ++m_s->curve_tests;
      if (m_c.curve_units > 0) {
        done = unit(m_curve_free, 1, uint64_t(m_c.curve_latency), t);
      } else {
        done = unit(m_tri_free, uint64_t(m_c.curve_issue), uint64_t(m_c.curve_latency), t);
        m_s->tri_issue_cycles += uint64_t(m_c.curve_issue);
      }
      if (m_trace) m_trace->add(m_unit, k, "curve", t, done);
      return done;
    case TestCost::kTrianglePair:
      // One request of two triangle tests: two issue slots taken at once (one clock on a unit of tri_rate >= 2),
      // the result when both are done; or the clocks the triangle unit reported for the two.
      if (e.unit_issue) {
        done = unit(m_tri_free, e.unit_issue, uint64_t(e.unit_result) - e.unit_issue + 1, t);
        m_s->tri_issue_cycles += e.unit_issue;
      } else {
        done = std::max(unit(m_tri_free, 1, uint64_t(m_c.tri_latency), t),
                        unit(m_tri_free, 1, uint64_t(m_c.tri_latency), t));
        m_s->tri_issue_cycles += 2;
      }
      if (m_trace) m_trace->add(m_unit, k, "triangle pair", t, done);
      m_s->tri_tests += 2;
      ++m_s->tri_pairs;
      return done;
    case TestCost::kTriangle:
      // One clock and tri_latency, or the clocks the triangle unit that tested it reported (tri_unit.h).
      if (e.unit_issue) {
        issue = e.unit_issue;
        lat = uint64_t(e.unit_result) - issue + 1;
      } else {
        lat = uint64_t(m_c.tri_latency);
      }
      what = "triangle";
      ++m_s->tri_tests;
      break;
    case TestCost::kSphere:
      lat = uint64_t(m_c.sphere_latency);
      what = "sphere";
      ++m_s->sphere_tests;
      break;
    case TestCost::kPlane:
      lat = uint64_t(m_c.plane_latency);
      what = "plane";
      ++m_s->plane_tests;
      break;
  }
  done = unit(m_tri_free, issue, lat, t);
  if (m_trace) m_trace->add(m_unit, k, what, t, done);
  m_s->tri_issue_cycles += issue;
  return done;
}

}  // namespace rtu::hw
