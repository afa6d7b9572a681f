#include "hwmodel/datapath/box_index.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

namespace {

bool finite_box(const Aabb& b) {
  for (int a = 0; a < 3; ++a)
    if (!(std::fabs(b.lo[a]) <= kMaxCoordinate && std::fabs(b.hi[a]) <= kMaxCoordinate)) return false;
  return true;
}

}  // namespace

void QueryStats::add(const QueryStats& o) {
  queries += o.queries;
  nodes_visited += o.nodes_visited;
  box_tests += o.box_tests;
  candidates += o.candidates;
  results += o.results;
  overflows += o.overflows;
}

void BoxIndex::grid_box(const Aabb& b, int64_t g[6]) const {
  for (int a = 0; a < 3; ++a) {
    g[a] = m_frame.to_grid(b.lo[a], a, Round::kDown);
    g[3 + a] = m_frame.to_grid(b.hi[a], a, Round::kUp);
  }
}

BoxIndex::BoxIndex(const std::vector<Aabb>& boxes, const FixedFormat& f, const Aabb& frame) : m_format(f) {
  f.validate();
  if (boxes.empty()) throw std::invalid_argument("a box index needs at least one box");
  if (boxes.size() > kMaxBvhPrims) throw std::invalid_argument("a box index holds at most 2^27 boxes");
  Aabb all = frame;
  for (size_t i = 0; i < boxes.size(); ++i) {
    if (!finite_box(boxes[i]))
      throw std::invalid_argument("box " + std::to_string(i) + " is not finite or beyond 2^62");
    if (boxes[i].empty()) throw std::invalid_argument("box " + std::to_string(i) + " is empty (lo > hi)");
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
  m_box.resize(m_ids.size() * 6);
  for (size_t i = 0; i < m_ids.size(); ++i) grid_box(boxes[m_ids[i]], &m_box[6 * i]);
  // Leaf ordinals, and each slot's grid box: the bounds of the boxes below it, bottom up (the builder puts
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
        for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) extend(&m_box[6 * i]);
        continue;
      }
      if (size_t(ref) <= node) throw std::logic_error("box index: a child node before its parent");
      for (size_t c = 0; c < W; ++c)
        if (m_child[size_t(ref) * W + c] != kEmptyChild) extend(&m_child_box[(size_t(ref) * W + c) * 6]);
    }
}

}  // namespace rtu::hw
