#include "hwmodel/datapath/point_query.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>

#include "hwmodel/datapath/exact_compare.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

void QueryStats::add(const QueryStats& o) {
  queries += o.queries;
  nodes_visited += o.nodes_visited;
  box_tests += o.box_tests;
  candidates += o.candidates;
  results += o.results;
  overflows += o.overflows;
}

namespace {

// x rounded to a float no greater (up false) or no smaller (up true) than it.
float round_out(double x, bool up) {
  float f = float(x);
  if (up ? double(f) < x : double(f) > x) f = std::nextafter(f, up ? INFINITY : -INFINITY);
  return f;
}

bool finite_point(const Vec3& p) {
  for (int a = 0; a < 3; ++a)
    if (!(std::fabs(p[a]) <= kMaxCoordinate)) return false;
  return true;
}

}  // namespace

PointIndex::PointIndex(std::vector<Vec3> points, float radius, const FixedFormat& f)
    : m_points(std::move(points)), m_radius(radius), m_format(f) {
  f.validate();
  if (!(radius > 0.0f && radius <= kMaxCoordinate))
    throw std::invalid_argument("query radius must be positive, finite and at most 2^62 (got " +
                                std::to_string(radius) + ")");
  if (m_points.empty()) throw std::invalid_argument("a point index needs at least one point");
  if (m_points.size() > kMaxBvhPrims) throw std::invalid_argument("a point index holds at most 2^27 points");
  std::vector<Aabb> boxes(m_points.size());
  Aabb all;
  for (size_t i = 0; i < m_points.size(); ++i) {
    const Vec3& p = m_points[i];
    if (!finite_point(p))
      throw std::invalid_argument("point " + std::to_string(i) + " is not finite or beyond 2^62");
    for (int a = 0; a < 3; ++a) {
      boxes[i].lo[a] = round_out(double(p[a]) - double(radius), false);
      boxes[i].hi[a] = round_out(double(p[a]) + double(radius), true);
    }
    all.extend(boxes[i]);
  }
  m_frame = QuantFrame::fit(all, f.coord_bits);
  BvhBuildParams bp;
  bp.width = f.width;
  bp.max_leaf_size = f.width;
  const Bvh bvh = Bvh::build(boxes, bp);
  bvh.visit([&](const auto& t) {
    constexpr int N = std::decay_t<decltype(t)>::kWidth;
    m_width = N;
    m_root = t.root_ref;
    m_ids = t.prim_ids;
    m_child.assign(t.nodes.size() * N, kEmptyChild);
    for (size_t n = 0; n < t.nodes.size(); ++n)
      for (int s = 0; s < N; ++s) m_child[n * N + size_t(s)] = t.nodes[n].child[s];
  });
  m_point_box.resize(m_ids.size() * 6);
  for (size_t i = 0; i < m_ids.size(); ++i)
    for (int a = 0; a < 3; ++a) {
      m_point_box[6 * i + size_t(a)] = m_frame.to_grid(boxes[m_ids[i]].lo[a], a, Round::kDown);
      m_point_box[6 * i + 3 + size_t(a)] = m_frame.to_grid(boxes[m_ids[i]].hi[a], a, Round::kUp);
    }
  // Leaf ordinals, and each slot's grid box: the bounds of the point boxes below it, bottom up (the builder puts
  // children after their parent).
  m_leaf_ordinal.assign(m_ids.size(), 0);
  const auto number_leaf = [&](uint32_t ref) { m_leaf_ordinal[leaf_first(ref)] = uint32_t(m_leaf_count++); };
  if (is_leaf(m_root)) number_leaf(m_root);
  for (uint32_t ref : m_child)
    if (ref != kEmptyChild && is_leaf(ref)) number_leaf(ref);
  const size_t W = size_t(m_width), slots = m_child.size();
  m_child_box.assign(slots * 6, 0);
  for (size_t node = slots / W; node-- > 0;)
    for (size_t s = 0; s < W; ++s) {
      const uint32_t ref = m_child[node * W + s];
      if (ref == kEmptyChild) continue;
      int64_t* out = &m_child_box[(node * W + s) * 6];
      for (int a = 0; a < 3; ++a) {
        out[a] = INT64_MAX;
        out[3 + a] = INT64_MIN;
      }
      const auto extend = [&](const int64_t* in) {
        for (int a = 0; a < 3; ++a) {
          out[a] = std::min(out[a], in[a]);
          out[3 + a] = std::max(out[3 + a], in[3 + a]);
        }
      };
      if (is_leaf(ref)) {
        for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) extend(&m_point_box[6 * i]);
        continue;
      }
      if (size_t(ref) <= node) throw std::logic_error("point index: a child node before its parent");
      for (size_t c = 0; c < W; ++c)
        if (m_child[size_t(ref) * W + c] != kEmptyChild) extend(&m_child_box[(size_t(ref) * W + c) * 6]);
    }
}

uint32_t PointIndex::leaf_block(uint32_t ref) const {
  return uint32_t(inner_nodes()) + m_leaf_ordinal[leaf_first(ref)];
}

PointAnswer PointIndex::query(const Vec3& q, const PointQuery& what, QueryStats& s,
                              std::vector<TraceEvent>* rec) const {
  if (!finite_point(q)) throw std::invalid_argument("a query point is not finite or beyond 2^62");
  if (what.kind == PointQuery::kNearest && what.max_results == 0)
    throw std::invalid_argument("k nearest needs k >= 1");
  ++s.queries;
  PointAnswer out;
  // A ray of zero length from q: the slab test accepts a box exactly when q lies in it (conservatively).
  FixedRay r;
  if (setup_ray(Ray{q, 0.0f, Vec3(1.0f, 0.0f, 0.0f), 0.0f}, m_frame, m_format, r) != RayStatus::kOk)
    return out;  // beyond the frame's guard range: no box holds it, so no point is within the radius
  const auto inside = [&](const int64_t* box) {
    int64_t tn = 0;
    return box_test(r, box, box + 3, r.tmin, r.tmax, tn);
  };
  std::vector<uint32_t>& ids = out.ids;
  const auto candidate = [&](uint32_t id) {
    ++s.candidates;
    if (rec) rec->push_back(TraceEvent{TraceEvent::kAnyHit, 0, 0, 0, id});
    if (!exact_within(m_points[id], q, m_radius)) return;
    ++out.count;
    if (what.kind == PointQuery::kCount) return;
    if (what.kind == PointQuery::kRadius) {
      if (ids.size() < what.max_results) ids.push_back(id);
      return;
    }
    // k nearest: insert by exact distance, ties by id; keep k.
    size_t at = ids.size();
    while (at > 0) {
      const int c = exact_compare_distance(q, m_points[id], m_points[ids[at - 1]]);
      if (c > 0 || (c == 0 && id > ids[at - 1])) break;
      --at;
    }
    if (at < what.max_results) {
      ids.insert(ids.begin() + std::ptrdiff_t(at), id);
      if (ids.size() > what.max_results) ids.pop_back();
    }
  };
  uint32_t stack[kTraversalStackSize];
  int sp = 0;
  uint32_t cur = m_root;
  const size_t W = size_t(m_width);
  for (;;) {
    ++s.nodes_visited;
    if (is_leaf(cur)) {
      if (rec) rec->push_back(TraceEvent{TraceEvent::kNode, uint8_t(leaf_count(cur)), 0, 0, leaf_block(cur)});
      s.box_tests += leaf_count(cur);
      for (uint32_t i = leaf_first(cur); i < leaf_first(cur) + leaf_count(cur); ++i)
        if (inside(&m_point_box[6 * size_t(i)])) candidate(m_ids[i]);
    } else {
      int tested = 0, pushed = 0;
      for (size_t c = 0; c < W; ++c) {
        const uint32_t ref = m_child[size_t(cur) * W + c];
        if (ref == kEmptyChild) continue;
        ++tested;
        if (inside(&m_child_box[(size_t(cur) * W + c) * 6])) {
          stack[sp++] = ref;
          ++pushed;
        }
      }
      s.box_tests += uint64_t(tested);
      if (rec) {
        rec->push_back(TraceEvent{TraceEvent::kNode, uint8_t(tested), 0, 0, cur});
        if (pushed > 0) rec->push_back(TraceEvent{TraceEvent::kPush, uint8_t(pushed), 0, 0, 0});
      }
    }
    if (sp == 0) break;
    cur = stack[--sp];
    if (rec) rec->push_back(TraceEvent{TraceEvent::kPop, 0, 0, 0, 0});
  }
  if (what.kind == PointQuery::kRadius) {
    out.overflow = out.count > what.max_results;
    s.overflows += out.overflow;
    std::sort(ids.begin(), ids.end());
  }
  s.results += what.kind == PointQuery::kNearest ? ids.size() : out.count;
  return out;
}

std::vector<PointAnswer> PointIndex::query_batch(const std::vector<Vec3>& qs, const PointQuery& what, int threads,
                                                 QueryStats& s) const {
  for (size_t i = 0; i < qs.size(); ++i)
    if (!finite_point(qs[i]))
      throw std::invalid_argument("query " + std::to_string(i) + " is not finite or beyond 2^62");
  std::vector<PointAnswer> out(qs.size());
  constexpr size_t kChunk = 1024;
  const size_t chunks = (qs.size() + kChunk - 1) / kChunk;
  std::vector<QueryStats> per(chunks);  // summed in chunk order: the same totals on any number of threads
  std::atomic<size_t> next{0};
  const auto work = [&] {
    for (size_t c; (c = next.fetch_add(1)) < chunks;)
      for (size_t i = c * kChunk; i < std::min(qs.size(), (c + 1) * kChunk); ++i)
        out[i] = query(qs[i], what, per[c]);
  };
  const int hw = std::max(1, int(std::thread::hardware_concurrency()));
  const int nt = std::max(1, std::min<int>(threads > 0 ? threads : hw, int(chunks)));
  std::vector<std::thread> pool;
  for (int t = 1; t < nt; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  for (const QueryStats& p : per) s.add(p);
  return out;
}

}  // namespace rtu::hw
