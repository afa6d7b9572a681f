// A BVH over float boxes on the unit, for queries that want every box a probe meets rather than a closest hit:
// box overlap, and the candidates of spatial joins (spatial_join.h). Boxes are rounded outward to floats' and then
// the grid's planes (lo down, hi up), node boxes are the integer bounds of the boxes below them, and a traversal
// visits every node whose box the probe meets, so it finds every box the exact probe meets:
// - a ray over [tmin, tmax] by the fixed datapath's conservative slab test (intersect_fixed.h), as RayJoin casts
//   segments and point-in-polygon rays;
// - a query box by integer comparison of its grid box (rounded outward the same way) with each child's, six
//   comparators a child, as a box unit could hold beside its slab test.
// Candidates are then decided exactly by the caller. Leaves hold at most `width` boxes and are tested as a node's
// children are.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/aabb.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

struct QueryStats {
  uint64_t queries = 0;
  uint64_t nodes_visited = 0;  // inner nodes and leaf blocks tested
  uint64_t box_tests = 0;      // child boxes and indexed boxes tested
  uint64_t candidates = 0;     // indexed boxes the probe met: each decided exactly (point queries: in the shader)
  uint64_t results = 0;        // candidates that are answers (for k nearest: the k reported)
  uint64_t overflows = 0;      // queries with more results than their bound (the rest not reported)
  void add(const QueryStats& o);
};

// Runs fn(i, stats) for probes i in [0, n) on `threads` threads (0: all cores) in chunks, summing each chunk's
// statistics in chunk order: the same totals on any number of threads.
template <class Fn>
void run_probes(size_t n, int threads, QueryStats& s, Fn&& fn) {
  constexpr size_t kChunk = 512;
  const size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<QueryStats> per(chunks);
  std::atomic<size_t> next{0};
  const auto work = [&] {
    for (size_t c; (c = next.fetch_add(1)) < chunks;)
      for (size_t i = c * kChunk; i < std::min(n, (c + 1) * kChunk); ++i) fn(i, per[c]);
  };
  const int hw = std::max(1, int(std::thread::hardware_concurrency()));
  const int nt = std::max(1, std::min<int>(threads > 0 ? threads : hw, int(chunks)));
  std::vector<std::thread> pool;
  for (int t = 1; t < nt; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  for (const QueryStats& p : per) s.add(p);
}

class BoxIndex {
 public:
  // Throws std::invalid_argument for no boxes, more than 2^27, an empty box (lo > hi) or a coordinate that is not
  // finite or beyond kMaxCoordinate (naming the box), or a bad format. `frame` (if not empty) is fitted instead of
  // the boxes' bounds: probes far outside the boxes then still fit the frame.
  BoxIndex(const std::vector<Aabb>& boxes, const FixedFormat& f, const Aabb& frame = Aabb{});

  // The probes. on_candidate(id) is called for every box the probe may meet (every one it meets exactly), in
  // traversal order. Statistics: nodes_visited, box_tests, candidates. `rec`: kNode for each node and leaf block
  // tested, kPush and kPop (the caller adds what it does with a candidate).
  template <class F>
  void ray_candidates(const FixedRay& r, F&& on_candidate, QueryStats& s, std::vector<TraceEvent>* rec) const {
    walk([&](const int64_t* b) { return ray_meets(r, b); }, on_candidate, s, rec);
  }
  template <class F>
  void box_candidates(const Aabb& q, F&& on_candidate, QueryStats& s, std::vector<TraceEvent>* rec) const {
    int64_t g[6];
    grid_box(q, g);
    walk([&](const int64_t* b) { return overlaps(g, b); }, on_candidate, s, rec);
  }
  // Ray setup in the index's frame and format (setup_ray).
  RayStatus setup(const Ray& r, FixedRay& out) const { return setup_ray(r, m_frame, m_format, out); }

  const QuantFrame& frame() const { return m_frame; }
  int width() const { return m_width; }
  uint64_t inner_nodes() const { return m_child.size() / uint64_t(m_width); }
  uint64_t leaves() const { return m_leaf_count; }
  size_t size() const { return m_ids.size(); }

 private:
  // A float box's grid planes, rounded outward (saturating beyond the frame, which only widens it).
  void grid_box(const Aabb& b, int64_t g[6]) const;
  static bool ray_meets(const FixedRay& r, const int64_t* b) {
    int64_t tn = 0;
    return box_test(r, b, b + 3, r.tmin, r.tmax, tn);
  }
  static bool overlaps(const int64_t* a, const int64_t* b) {
    return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] && b[2] <= a[5];
  }
  template <class Test, class F>
  void walk(Test&& meets, F&& on_candidate, QueryStats& s, std::vector<TraceEvent>* rec) const {
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
          if (meets(&m_box[6 * size_t(i)])) {
            ++s.candidates;
            on_candidate(m_ids[i]);
          }
      } else {
        int tested = 0, pushed = 0;
        for (size_t c = 0; c < W; ++c) {
          const uint32_t ref = m_child[size_t(cur) * W + c];
          if (ref == kEmptyChild) continue;
          ++tested;
          if (meets(&m_child_box[(size_t(cur) * W + c) * 6])) {
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
      if (sp == 0) return;
      cur = stack[--sp];
      if (rec) rec->push_back(TraceEvent{TraceEvent::kPop, 0, 0, 0, 0});
    }
  }
  uint32_t leaf_block(uint32_t ref) const { return uint32_t(inner_nodes()) + m_leaf_ordinal[leaf_first(ref)]; }

  FixedFormat m_format;
  QuantFrame m_frame;
  int m_width = 4;
  uint32_t m_root = kEmptyChild;
  std::vector<uint32_t> m_child;     // node * width + slot
  std::vector<int64_t> m_child_box;  // 6 per slot: grid lo xyz, hi xyz
  std::vector<uint32_t> m_ids;       // leaf order -> box index
  std::vector<int64_t> m_box;        // 6 per box, in leaf order
  uint64_t m_leaf_count = 0;
  std::vector<uint32_t> m_leaf_ordinal;  // by leaf_first: its ordinal among the leaves
};

}  // namespace rtu::hw
