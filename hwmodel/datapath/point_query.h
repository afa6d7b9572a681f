// Neighbour queries on the unit, as RTNN maps them onto ray-tracing hardware (Zhu, "RTNN: Accelerating Neighbor
// Search Using Hardware Ray Tracing", PPoPP 2022): each data point p becomes the box [p - r, p + r] of the search
// radius r, a query point q a ray of zero length from q; the unit's traversal finds every box that holds q (the
// candidates), and a shader checks each candidate's distance. Here the boxes are quantized outward to the grid and
// tested by the fixed datapath's conservative slab test (intersect_fixed.h), so every true neighbour is a
// candidate, and the distance check is exact (exact_compare.h): the answer is the exact one, whatever the format
// (docs/numerics.md, "Neighbour queries"). Leaves hold at most `width` points, stored and tested as a node's
// child boxes are.
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

struct QueryStats {
  uint64_t queries = 0;
  uint64_t nodes_visited = 0;  // inner nodes and leaf blocks tested
  uint64_t box_tests = 0;      // child boxes and point boxes tested
  uint64_t candidates = 0;     // point boxes that held the query: distance checks in the shader
  uint64_t results = 0;        // candidates within the radius (for k nearest: the k reported)
  uint64_t overflows = 0;      // queries with more results than their bound (the rest not reported)
  void add(const QueryStats& o);
};

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
  int width() const { return m_width; }
  uint64_t inner_nodes() const { return m_child.size() / uint64_t(m_width); }
  uint64_t leaves() const { return m_leaf_count; }
  const QuantFrame& frame() const { return m_frame; }
  // The kNode index of the leaf block of leaf reference `ref` (inner_nodes() + its leaf ordinal).
  uint32_t leaf_block(uint32_t ref) const;

 private:
  std::vector<Vec3> m_points;
  float m_radius;
  FixedFormat m_format;
  QuantFrame m_frame;
  int m_width = 4;
  uint32_t m_root = kEmptyChild;
  std::vector<uint32_t> m_child;     // node * width + slot
  std::vector<int64_t> m_child_box;  // 6 per slot: grid lo xyz, hi xyz
  std::vector<uint32_t> m_ids;       // leaf order -> point index
  std::vector<int64_t> m_point_box;  // 6 per point, in leaf order
  uint64_t m_leaf_count = 0;
  std::vector<uint32_t> m_leaf_ordinal;  // by leaf_first: its ordinal among the leaves
};

}  // namespace rtu::hw
