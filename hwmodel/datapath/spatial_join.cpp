#include "hwmodel/datapath/spatial_join.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "hwmodel/datapath/box_index.h"
#include "hwmodel/datapath/exact_compare.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

int exact_orient2d(const Point2& a, const Point2& b, const Point2& c) {
  // (b - a) x (c - a) = (bx - ax)(cy - ay) - (by - ay)(cx - ax): each difference a double-double, each product of
  // two double-doubles four exact products.
  using namespace exact_detail;
  double p[2], q[2], r[2], t[2];
  two_sum(double(b.x), -double(a.x), p[0], p[1]);
  two_sum(double(c.y), -double(a.y), q[0], q[1]);
  two_sum(double(b.y), -double(a.y), r[0], r[1]);
  two_sum(double(c.x), -double(a.x), t[0], t[1]);
  Expansion<20> e;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      double h, l;
      two_product(p[i], q[j], h, l);
      e.add(h);
      e.add(l);
      two_product(r[i], t[j], h, l);
      e.add(-h);
      e.add(-l);
    }
  return e.sign();
}

namespace {

// c lies in the closed box of segment s (for collinear points: on the segment).
bool in_box(const Segment2& s, const Point2& c) {
  return std::min(s.a.x, s.b.x) <= c.x && c.x <= std::max(s.a.x, s.b.x) && std::min(s.a.y, s.b.y) <= c.y &&
         c.y <= std::max(s.a.y, s.b.y);
}

// Throws naming `what` and its index i (SIZE_MAX: a single probe, no index) when p is not finite or beyond 2^62.
void check_point(const Point2& p, const char* what, size_t i) {
  if (!(std::fabs(p.x) <= kMaxCoordinate && std::fabs(p.y) <= kMaxCoordinate))
    throw std::invalid_argument(std::string(what) + (i == SIZE_MAX ? "" : " " + std::to_string(i)) +
                                " has a coordinate that is not finite or beyond 2^62");
}

Aabb box_of(const Segment2& s) {
  Aabb b;
  b.extend(Vec3(s.a.x, s.a.y, 0.0f));
  b.extend(Vec3(s.b.x, s.b.y, 0.0f));
  return b;
}

}  // namespace

bool exact_segments_meet(const Segment2& s, const Segment2& t) {
  const int o1 = exact_orient2d(s.a, s.b, t.a), o2 = exact_orient2d(s.a, s.b, t.b);
  const int o3 = exact_orient2d(t.a, t.b, s.a), o4 = exact_orient2d(t.a, t.b, s.b);
  if (o1 * o2 < 0 && o3 * o4 < 0) return true;
  return (o1 == 0 && in_box(s, t.a)) || (o2 == 0 && in_box(s, t.b)) || (o3 == 0 && in_box(t, s.a)) ||
         (o4 == 0 && in_box(t, s.b));
}

namespace {

std::vector<Aabb> segment_boxes(const std::vector<Segment2>& segs, const char* what) {
  if (segs.empty()) throw std::invalid_argument(std::string("no ") + what + "s");
  std::vector<Aabb> boxes(segs.size());
  for (size_t i = 0; i < segs.size(); ++i) {
    check_point(segs[i].a, what, i);
    check_point(segs[i].b, what, i);
    boxes[i] = box_of(segs[i]);
  }
  return boxes;
}

// The polygons' edges, and each edge's polygon.
std::vector<Segment2> polygon_edges(const std::vector<Polygon2>& polygons, std::vector<uint32_t>& owner) {
  if (polygons.empty()) throw std::invalid_argument("point in polygon needs at least one polygon");
  std::vector<Segment2> edges;
  for (size_t k = 0; k < polygons.size(); ++k) {
    const Polygon2& p = polygons[k];
    if (p.size() < 3) throw std::invalid_argument("polygon " + std::to_string(k) + " has fewer than 3 vertices");
    for (size_t v = 0; v < p.size(); ++v) {
      check_point(p[v], "polygon vertex of polygon", k);
      edges.push_back(Segment2{p[v], p[(v + 1) % p.size()]});
      owner.push_back(uint32_t(k));
    }
  }
  return edges;
}

}  // namespace

SegmentIndex::SegmentIndex(std::vector<Segment2> segments, const FixedFormat& f, const Aabb& frame)
    : m_segments(std::move(segments)), m_index(segment_boxes(m_segments, "segment"), f, frame) {}

std::vector<uint32_t> SegmentIndex::probe(const Segment2& b, QueryStats& s, std::vector<TraceEvent>* rec) const {
  check_point(b.a, "a probe segment", SIZE_MAX);
  check_point(b.b, "a probe segment", SIZE_MAX);
  ++s.queries;
  std::vector<uint32_t> out;
  m_index.box_candidates(
      box_of(b),
      [&](uint32_t i) {
        if (rec) rec->push_back(TraceEvent{TraceEvent::kAnyHit, 0, 0, 0, i});
        if (exact_segments_meet(m_segments[i], b)) out.push_back(i);
      },
      s, rec);
  std::sort(out.begin(), out.end());
  s.results += out.size();
  return out;
}

PolygonIndex::PolygonIndex(const std::vector<Polygon2>& polygons, const FixedFormat& f, const Aabb& frame)
    : m_edges(polygon_edges(polygons, m_owner)), m_index(segment_boxes(m_edges, "polygon edge"), f, frame) {}

std::vector<uint32_t> PolygonIndex::probe(const Point2& q, QueryStats& s, std::vector<TraceEvent>* rec) const {
  check_point(q, "a point", SIZE_MAX);
  ++s.queries;
  std::vector<uint32_t> in;
  FixedRay r;
  if (m_index.setup(Ray{Vec3(q.x, q.y, 0.0f), 0.0f, Vec3(1.0f, 0.0f, 0.0f), INFINITY}, r) != RayStatus::kOk)
    return in;
  // Crossings per polygon (parity), and polygons whose boundary holds q.
  std::vector<uint32_t> crossed, boundary;
  m_index.ray_candidates(
      r,
      [&](uint32_t i) {
        if (rec) rec->push_back(TraceEvent{TraceEvent::kAnyHit, 0, 0, 0, i});
        const Segment2& e = m_edges[i];
        const int o = exact_orient2d(e.a, e.b, q);
        if (o == 0 && in_box(e, q)) {
          boundary.push_back(m_owner[i]);
          return;
        }
        // Half-open: the edge counts when exactly one end lies above q's line; it crosses the +x half-line when
        // q lies on the side of the edge that faces -x (left of an upward edge, right of a downward one).
        const bool up = e.b.y > q.y, was_up = e.a.y > q.y;
        if (up == was_up) return;
        if (up ? o > 0 : o < 0) crossed.push_back(m_owner[i]);
      },
      s, rec);
  std::sort(crossed.begin(), crossed.end());
  for (size_t a = 0; a < crossed.size();) {
    size_t b = a;
    while (b < crossed.size() && crossed[b] == crossed[a]) ++b;
    if ((b - a) % 2 == 1) in.push_back(crossed[a]);
    a = b;
  }
  in.insert(in.end(), boundary.begin(), boundary.end());
  std::sort(in.begin(), in.end());
  in.erase(std::unique(in.begin(), in.end()), in.end());
  s.results += in.size();
  return in;
}

std::vector<std::pair<uint32_t, uint32_t>> segment_join(const std::vector<Segment2>& A,
                                                        const std::vector<Segment2>& B, const FixedFormat& f,
                                                        int threads, QueryStats& s) {
  const std::vector<Aabb> probes = segment_boxes(B, "probe segment");
  Aabb frame;
  for (const Aabb& b : probes) frame.extend(b);
  const SegmentIndex index(A, f, frame);
  std::vector<std::vector<uint32_t>> hits(B.size());
  run_probes(B.size(), threads, s, [&](size_t j, QueryStats& st) { hits[j] = index.probe(B[j], st); });
  std::vector<std::pair<uint32_t, uint32_t>> out;
  for (size_t j = 0; j < B.size(); ++j)
    for (uint32_t i : hits[j]) out.emplace_back(i, uint32_t(j));
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<std::vector<uint32_t>> point_in_polygons(const std::vector<Polygon2>& polygons,
                                                     const std::vector<Point2>& points, const FixedFormat& f,
                                                     int threads, QueryStats& s) {
  Aabb frame;
  for (size_t j = 0; j < points.size(); ++j) {
    check_point(points[j], "point", j);
    frame.extend(Vec3(points[j].x, points[j].y, 0.0f));
  }
  const PolygonIndex index(polygons, f, frame);
  std::vector<std::vector<uint32_t>> out(points.size());
  run_probes(points.size(), threads, s, [&](size_t j, QueryStats& st) { out[j] = index.probe(points[j], st); });
  return out;
}

}  // namespace rtu::hw
