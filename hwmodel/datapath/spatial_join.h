// Spatial joins on the unit, exact, as RayJoin maps them onto ray-tracing hardware (Geng et al., "RayJoin: Fast
// and Precise Spatial Join", ICS 2024): the edges of one map in a box index (box_index.h), the other map's
// segments or points as probes, every candidate decided by exact predicates (exact_compare.h's expansions):
// - segment intersection: every pair (a in A, b in B) of closed segments that meet, a probe per b by its box;
// - point in polygon: for each point, every polygon that holds it (boundary included), by the parity of the edges
// a
//   ray from the point in +x crosses (a half-open rule at vertices), the unit's slab test finding the edges.
// Coordinates are 2D floats (z = 0 in the index). docs/numerics.md, "Spatial joins", argues the exactness.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "hwmodel/datapath/box_index.h"
#include "hwmodel/numeric/fixed_format.h"

namespace rtu::hw {

struct Point2 {
  float x, y;
  bool operator==(const Point2&) const = default;
};
struct Segment2 {
  Point2 a, b;
};
using Polygon2 = std::vector<Point2>;  // a simple polygon's vertices in order (closed implicitly), at least 3

// The sign of the orientation of (a, b, c): +1 counter-clockwise, -1 clockwise, 0 collinear, exactly.
int exact_orient2d(const Point2& a, const Point2& b, const Point2& c);
// Closed segments a and b meet (touching and collinear overlap included), exactly.
bool exact_segments_meet(const Segment2& a, const Segment2& b);

// The edges of map A in a box index, probed by segments: every A segment that meets a probe (closed segments).
// `frame` (if not empty) is fitted besides the segments' boxes, so that probes within it fit the frame.
class SegmentIndex {
 public:
  // Throws std::invalid_argument for no segments or a coordinate that is not finite or beyond 2^62.
  SegmentIndex(std::vector<Segment2> segments, const FixedFormat& f, const Aabb& frame = Aabb{});
  // The ids of the segments b meets, in increasing order. `rec`: the index's events (box_index.h) and a kAnyHit
  // for each candidate's exact test in the shader.
  std::vector<uint32_t> probe(const Segment2& b, QueryStats& s, std::vector<TraceEvent>* rec = nullptr) const;
  const BoxIndex& index() const { return m_index; }

 private:
  std::vector<Segment2> m_segments;
  BoxIndex m_index;
};

// Polygons' edges in a box index, probed by points: the polygons that hold a point (boundary included).
class PolygonIndex {
 public:
  // Throws std::invalid_argument for no polygons, one of fewer than 3 vertices, or a coordinate out of range.
  PolygonIndex(const std::vector<Polygon2>& polygons, const FixedFormat& f, const Aabb& frame = Aabb{});
  // The polygons that hold q, in increasing order; `rec` as SegmentIndex::probe. A point beyond the frame's guard
  // range (ray setup refuses it) is in no polygon.
  std::vector<uint32_t> probe(const Point2& q, QueryStats& s, std::vector<TraceEvent>* rec = nullptr) const;
  const BoxIndex& index() const { return m_index; }

 private:
  std::vector<uint32_t> m_owner;  // edge -> polygon (before m_edges: their initializer fills it)
  std::vector<Segment2> m_edges;
  BoxIndex m_index;
};

// Every (i, j) with segment A[i] meeting B[j], sorted. Throws std::invalid_argument for a coordinate that is not
// finite or beyond 2^62, or empty inputs.
std::vector<std::pair<uint32_t, uint32_t>> segment_join(const std::vector<Segment2>& A,
                                                        const std::vector<Segment2>& B, const FixedFormat& f,
                                                        int threads, QueryStats& s);
// For each point, the polygons that hold it (inside or on the boundary), in increasing order. Throws
// std::invalid_argument for a polygon of fewer than 3 vertices, a coordinate out of range, or no polygons.
std::vector<std::vector<uint32_t>> point_in_polygons(const std::vector<Polygon2>& polygons,
                                                     const std::vector<Point2>& points, const FixedFormat& f,
                                                     int threads, QueryStats& s);

}  // namespace rtu::hw
