// Neighbour queries on the unit, as RTNN maps them onto ray-tracing hardware (Zhu, "RTNN: Accelerating Neighbor
// Search Using Hardware Ray Tracing", PPoPP 2022): each data point p becomes the box [p - r, p + r] of the search
// radius r, a query point q a ray of zero length from q; the unit's traversal finds every box that holds q (the
// candidates), and a shader checks each candidate's distance. Here the boxes are quantized outward to the grid and
// tested by the fixed datapath's conservative slab test (intersect_fixed.h), so every true neighbour is a
// candidate, and the distance check is exact (exact_compare.h): the answer is the exact one, whatever the format
// (docs/numerics.md, "Neighbour queries"). The points' boxes are a BoxIndex (box_index.h).
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/datapath/box_index.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

// What a query asks.
struct PointQuery {
  enum Kind : uint8_t { kRadius = 0, kCount = 1, kNearest = 2 };
  Kind kind = kRadius;
  uint32_t max_results = 64;  // kRadius: the output bound per query; kNearest: k (1..max)
};

// One query's answer: kRadius the ids within the radius in increasing order (at most max_results; overflow set
// when there were more, and `count` is then the whole count); kCount only `count`; kNearest the k nearest within
// the radius, nearest first, ties by smaller id (fewer when fewer are within it).
struct PointAnswer {
  std::vector<uint32_t> ids;
  uint64_t count = 0;
  bool overflow = false;
};

class PointIndex {
 public:
  // The index of `points` for queries of radius `radius` (> 0, finite): a BVH over their boxes of width
  // f.width, leaves of at most f.width points, the frame over the boxes at f.coord_bits. Throws
  // std::invalid_argument naming the first point that is not finite or beyond kMaxCoordinate, an empty set, more
  // than 2^27 points, or a bad radius or format.
  PointIndex(std::vector<Vec3> points, float radius, const FixedFormat& f);

  // One query from q (finite; else std::invalid_argument). `rec`: the unit's events for the timing model (kNode
  // for each node and leaf block tested, kAnyHit for each candidate's distance check in the shader, kPush, kPop).
  PointAnswer query(const Vec3& q, const PointQuery& what, QueryStats& s,
                    std::vector<TraceEvent>* rec = nullptr) const;
  // Queries over threads: the answers and the summed statistics do not depend on the thread count.
  std::vector<PointAnswer> query_batch(const std::vector<Vec3>& qs, const PointQuery& what, int threads,
                                       QueryStats& s) const;

  const std::vector<Vec3>& points() const { return m_points; }
  float radius() const { return m_radius; }
  int width() const { return m_index.width(); }
  uint64_t inner_nodes() const { return m_index.inner_nodes(); }
  uint64_t leaves() const { return m_index.leaves(); }
  const BoxIndex& index() const { return m_index; }

 private:
  std::vector<Vec3> m_points;
  float m_radius;
  BoxIndex m_index;  // the points' boxes of the radius
};

}  // namespace rtu::hw
