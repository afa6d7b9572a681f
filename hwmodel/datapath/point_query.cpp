#include "hwmodel/datapath/point_query.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "hwmodel/datapath/exact_compare.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

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

// The points' boxes [p - r, p + r], built in double and rounded outward to floats; the checks of the constructor.
std::vector<Aabb> point_boxes(const std::vector<Vec3>& points, float radius) {
  if (!(radius > 0.0f && radius <= kMaxCoordinate))
    throw std::invalid_argument("query radius must be positive, finite and at most 2^62 (got " +
                                std::to_string(radius) + ")");
  if (points.empty()) throw std::invalid_argument("a point index needs at least one point");
  if (points.size() > kMaxBvhPrims) throw std::invalid_argument("a point index holds at most 2^27 points");
  std::vector<Aabb> boxes(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3& p = points[i];
    if (!finite_point(p))
      throw std::invalid_argument("point " + std::to_string(i) + " is not finite or beyond 2^62");
    for (int a = 0; a < 3; ++a) {
      boxes[i].lo[a] = round_out(double(p[a]) - double(radius), false);
      boxes[i].hi[a] = round_out(double(p[a]) + double(radius), true);
    }
  }
  return boxes;
}

}  // namespace

PointIndex::PointIndex(std::vector<Vec3> points, float radius, const FixedFormat& f)
    : m_points(std::move(points)), m_radius(radius), m_index(point_boxes(m_points, radius), f) {}

PointAnswer PointIndex::query(const Vec3& q, const PointQuery& what, QueryStats& s,
                              std::vector<TraceEvent>* rec) const {
  if (!finite_point(q)) throw std::invalid_argument("a query point is not finite or beyond 2^62");
  if (what.kind == PointQuery::kNearest && what.max_results == 0)
    throw std::invalid_argument("k nearest needs k >= 1");
  ++s.queries;
  PointAnswer out;
  // A ray of zero length from q: the slab test accepts a box exactly when q lies in it (conservatively).
  FixedRay r;
  if (m_index.setup(Ray{q, 0.0f, Vec3(1.0f, 0.0f, 0.0f), 0.0f}, r) != RayStatus::kOk)
    return out;  // beyond the frame's guard range: no box holds it, so no point is within the radius
  std::vector<uint32_t>& ids = out.ids;
  const auto candidate = [&](uint32_t id) {
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
  m_index.ray_candidates(r, candidate, s, rec);
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
  run_probes(qs.size(), threads, s, [&](size_t i, QueryStats& st) { out[i] = query(qs[i], what, st); });
  return out;
}

}  // namespace rtu::hw
