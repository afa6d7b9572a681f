// Binned SAH builder (Wald, "On fast construction of SAH-based bounding volume hierarchies", 2007) followed by
// a collapse of the binary tree into 2-, 4-, 6- or 8-wide nodes: a node's children are expanded, largest surface
// area first, until the node is full (as in the wide BVHs of Embree). One expansion adds one child, so any width
// N >= 2 fills, a power of two or not.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

void validate(const BvhBuildParams& p) {
  if (p.width != 2 && p.width != 4 && p.width != 6 && p.width != 8)
    throw std::invalid_argument("bvh width must be 2, 4, 6 or 8");
  if (p.max_leaf_size < 1 || p.max_leaf_size > kMaxLeafSize)
    throw std::invalid_argument("bvh max_leaf_size must be in [1, 16]");
  if (p.bins < 2 || p.bins > 256) throw std::invalid_argument("bvh bins must be in [2, 256]");
  if (!(p.node_cost >= 0.0f) || !(p.prim_cost > 0.0f))
    throw std::invalid_argument("bvh node_cost must be >= 0 and prim_cost > 0");
  if (p.max_sah_depth < 1 || p.max_sah_depth > 64)
    throw std::invalid_argument("bvh max_sah_depth must be in [1, 64]");
}

namespace {

struct PrimRef {
  Aabb box;
  uint32_t prim;
  float centroid(int a) const { return 0.5f * (axis(box.lo, a) + axis(box.hi, a)); }
};

struct BinNode {
  Aabb box;
  uint32_t left = 0, right = 0;   // children (inner node)
  uint32_t first = 0, count = 0;  // primitive range in refs (leaf when count > 0)
};

class BinaryBuilder {
 public:
  BinaryBuilder(std::vector<PrimRef>& refs, const BvhBuildParams& p) : m_refs(refs), m_p(p) {
    m_nodes.reserve(2 * refs.size() / std::max(1, p.max_leaf_size / 2) + 2);
  }
  std::vector<BinNode> run() {
    Aabb box, cbox;
    for (const PrimRef& r : m_refs) {
      box.extend(r.box);
      cbox.extend(r.box.center());
    }
    m_nodes.push_back({});
    build(0, 0, uint32_t(m_refs.size()), box, cbox, 0);
    return std::move(m_nodes);
  }

 private:
  struct Split {
    int axis = -1;
    int bin = 0;  // refs with bin index < bin go left
    float cost = 0.0f;
  };

  int bin_of(const PrimRef& r, int a, float cmin, float scale) const {
    // Compared as float before converting: a NaN or an out-of-range value would make the conversion undefined.
    const float x = (r.centroid(a) - cmin) * scale;
    return x >= 0.0f ? (x < float(m_p.bins) ? int(x) : m_p.bins - 1) : 0;
  }

  [[gnu::noinline]] Split find_split(uint32_t begin, uint32_t end, const Aabb& cbox) const {
    const int nb = m_p.bins;
    Split best;
    best.cost = std::numeric_limits<float>::infinity();
    Aabb bin_box[3][256];
    uint32_t bin_count[3][256] = {};
    float cmin[3], scale[3];
    for (int a = 0; a < 3; ++a) {
      cmin[a] = axis(cbox.lo, a);
      float ext = axis(cbox.hi, a) - cmin[a];
      scale[a] = ext > 0.0f ? float(nb) / ext : 0.0f;
    }
    for (uint32_t i = begin; i < end; ++i) {
      const PrimRef& r = m_refs[i];
      for (int a = 0; a < 3; ++a) {
        if (scale[a] == 0.0f) continue;
        int b = bin_of(r, a, cmin[a], scale[a]);
        bin_box[a][b].extend(r.box);
        ++bin_count[a][b];
      }
    }
    float right_area[256];
    for (int a = 0; a < 3; ++a) {
      if (scale[a] == 0.0f) continue;
      Aabb acc;
      uint32_t cnt = 0;
      for (int b = nb - 1; b > 0; --b) {
        acc.extend(bin_box[a][b]);
        cnt += bin_count[a][b];
        right_area[b] = acc.half_area() * float(cnt);
      }
      acc = Aabb{};
      cnt = 0;
      for (int b = 1; b < nb; ++b) {
        acc.extend(bin_box[a][b - 1]);
        cnt += bin_count[a][b - 1];
        if (cnt == 0 || cnt == end - begin) continue;
        float cost = acc.half_area() * float(cnt) + right_area[b];
        if (cost < best.cost) best = Split{a, b, cost};
      }
    }
    return best;
  }

  void make_leaf(uint32_t node, uint32_t begin, uint32_t end, const Aabb& box) {
    m_nodes[node].box = box;
    m_nodes[node].first = begin;
    m_nodes[node].count = end - begin;
  }

  static void range_bounds(const PrimRef* b, const PrimRef* e, Aabb& box, Aabb& cbox) {
    for (; b != e; ++b) {
      box.extend(b->box);
      cbox.extend(b->box.center());
    }
  }

  void build(uint32_t node, uint32_t begin, uint32_t end, const Aabb& box, const Aabb& cbox, int depth) {
    const uint32_t n = end - begin;
    const bool may_be_leaf = n <= uint32_t(m_p.max_leaf_size);
    if (n == 1) return make_leaf(node, begin, end, box);

    uint32_t mid = begin;
    bool split_found = false;
    if (depth < m_p.max_sah_depth) {
      Split s = find_split(begin, end, cbox);
      if (s.axis >= 0) {
        const float area = box.half_area();
        const float split_cost = m_p.node_cost + (area > 0.0f ? s.cost / area : float(n)) * m_p.prim_cost;
        if (may_be_leaf && float(n) * m_p.prim_cost <= split_cost) return make_leaf(node, begin, end, box);
        const int a = s.axis;
        const float cmin = axis(cbox.lo, a);
        const float ext = axis(cbox.hi, a) - cmin;
        const float scale = float(m_p.bins) / ext;
        PrimRef* p = std::partition(m_refs.data() + begin, m_refs.data() + end,
                                    [&](const PrimRef& r) { return bin_of(r, a, cmin, scale) < s.bin; });
        mid = uint32_t(p - m_refs.data());
        split_found = mid > begin && mid < end;
      }
    }
    if (!split_found) {
      if (may_be_leaf) return make_leaf(node, begin, end, box);
      // Object median on the largest centroid axis: always possible, halves the range.
      const int a = cbox.largest_axis();
      mid = begin + n / 2;
      std::nth_element(m_refs.begin() + begin, m_refs.begin() + mid, m_refs.begin() + end,
                       [a](const PrimRef& x, const PrimRef& y) {
                         float cx = x.centroid(a), cy = y.centroid(a);
                         return cx < cy || (cx == cy && x.prim < y.prim);
                       });
    }
    Aabb lbox, lcbox, rbox, rcbox;
    range_bounds(m_refs.data() + begin, m_refs.data() + mid, lbox, lcbox);
    range_bounds(m_refs.data() + mid, m_refs.data() + end, rbox, rcbox);
    const uint32_t l = uint32_t(m_nodes.size());
    m_nodes.push_back({});
    m_nodes.push_back({});
    m_nodes[node].box = box;
    m_nodes[node].left = l;
    m_nodes[node].right = l + 1;
    build(l, begin, mid, lbox, lcbox, depth + 1);
    build(l + 1, mid, end, rbox, rcbox, depth + 1);
  }

  std::vector<PrimRef>& m_refs;
  const BvhBuildParams& m_p;
  std::vector<BinNode> m_nodes;
};

template <int N>
class Collapser {
 public:
  Collapser(const std::vector<BinNode>& bin, WideBvh<N>& out) : m_bin(bin), m_out(out) {}

  uint32_t ref_of(uint32_t b) {
    const BinNode& n = m_bin[b];
    return n.count > 0 ? make_leaf(n.first, n.count) : collapse(b);
  }

 private:
  uint32_t collapse(uint32_t b) {
    uint32_t kids[N];
    int k = 0;
    kids[k++] = m_bin[b].left;
    kids[k++] = m_bin[b].right;
    while (k < N) {
      int best = -1;
      float best_area = -1.0f;
      for (int i = 0; i < k; ++i) {
        const BinNode& c = m_bin[kids[i]];
        if (c.count == 0 && c.box.half_area() > best_area) {
          best = i;
          best_area = c.box.half_area();
        }
      }
      if (best < 0) break;
      const uint32_t expand = kids[best];
      for (int i = k; i > best + 1; --i) kids[i] = kids[i - 1];
      kids[best] = m_bin[expand].left;
      kids[best + 1] = m_bin[expand].right;
      ++k;
    }
    const uint32_t index = uint32_t(m_out.nodes.size());
    m_out.nodes.emplace_back();
    for (int i = 0; i < N; ++i) {
      WideNode<N>& node = m_out.nodes[index];
      if (i >= k) {
        node.child[i] = kEmptyChild;
        Aabb empty;
        set_box(node, i, empty);
        continue;
      }
      set_box(node, i, m_bin[kids[i]].box);
      const uint32_t ref = ref_of(kids[i]);  // may grow m_out.nodes
      m_out.nodes[index].child[i] = ref;
    }
    return index;
  }

  static void set_box(WideNode<N>& node, int i, const Aabb& b) {
    for (int a = 0; a < 3; ++a) {
      node.bounds[2 * a][i] = axis(b.lo, a);
      node.bounds[2 * a + 1][i] = axis(b.hi, a);
    }
  }

  const std::vector<BinNode>& m_bin;
  WideBvh<N>& m_out;
};

// Builds over n boxes, box i = bounds_of(i).
template <int N, class BoundsOf>
WideBvh<N> build_wide(uint32_t n, BoundsOf bounds_of, const BvhBuildParams& p) {
  WideBvh<N> out;
  if (n == 0) return out;
  if (n > kMaxBvhPrims) throw std::invalid_argument("too many primitives for the BVH (limit 2^27)");
  std::vector<BinNode> bin;
  {
    std::vector<PrimRef> refs(n);
    for (uint32_t i = 0; i < n; ++i) refs[i] = PrimRef{bounds_of(i), i};
    bin = BinaryBuilder(refs, p).run();
    out.prim_ids.resize(n);
    for (uint32_t i = 0; i < n; ++i) out.prim_ids[i] = refs[i].prim;
  }
  out.bounds = bin[0].box;
  out.nodes.reserve(bin.size() / 2 + 1);
  out.root_ref = Collapser<N>(bin, out).ref_of(0);
  out.nodes.shrink_to_fit();
  return out;
}

template <int N>
void add_figures(const WideBvh<N>& t, const BvhBuildParams& p, BvhFigures& f) {
  f.width = N;
  f.prims = t.prim_ids.size();
  f.node_bytes = t.nodes.size() * sizeof(WideNode<N>);
  f.index_bytes = t.prim_ids.size() * sizeof(uint32_t);
  f.inner_nodes = t.nodes.size();
  if (t.root_ref == kEmptyChild) return;
  const float root_area = t.bounds.half_area();
  auto rel = [&](const Aabb& b) { return root_area > 0.0f ? double(b.half_area()) / root_area : 1.0; };
  uint64_t slots = 0, leaf_prims = 0;
  f.min_leaf = kMaxLeafSize + 1;
  struct Item {
    uint32_t ref;
    Aabb box;
    int depth;
  };
  std::vector<Item> stack{{t.root_ref, t.bounds, 0}};
  while (!stack.empty()) {
    Item it = stack.back();
    stack.pop_back();
    if (is_leaf(it.ref)) {
      const int c = int(leaf_count(it.ref));
      ++f.leaves;
      leaf_prims += uint64_t(c);
      f.min_leaf = std::min(f.min_leaf, c);
      f.max_leaf = std::max(f.max_leaf, c);
      f.sah_cost += rel(it.box) * c * p.prim_cost;
      f.depth = std::max(f.depth, it.depth);
      continue;
    }
    f.sah_cost += rel(it.box) * p.node_cost;
    const WideNode<N>& node = t.nodes[it.ref];
    for (int i = 0; i < N; ++i) {
      if (node.child[i] == kEmptyChild) continue;
      ++slots;
      stack.push_back({node.child[i], node.child_box(i), it.depth + 1});
    }
  }
  f.mean_leaf = f.leaves ? double(leaf_prims) / double(f.leaves) : 0.0;
  f.mean_fill = f.inner_nodes ? double(slots) / double(f.inner_nodes * N) : 0.0;
}

}  // namespace

template <class BoundsOf>
Bvh Bvh::build_over(uint32_t n, BoundsOf bounds_of, const BvhBuildParams& params) {
  validate(params);
  Bvh b;
  b.m_params = params;
  switch (params.width) {
    case 2:
      b.m_tree = build_wide<2>(n, bounds_of, params);
      break;
    case 4:
      b.m_tree = build_wide<4>(n, bounds_of, params);
      break;
    case 6:
      b.m_tree = build_wide<6>(n, bounds_of, params);
      break;
    default:
      b.m_tree = build_wide<8>(n, bounds_of, params);
      break;
  }
  return b;
}

Bvh Bvh::build(const Geometry& g, const BvhBuildParams& params) {
  return build_over(
      g.num_bounded(), [&](uint32_t i) { return g.prim_bounds(i); }, params);
}

Bvh Bvh::build(const std::vector<Aabb>& boxes, const BvhBuildParams& params) {
  for (const Aabb& b : boxes)
    if (b.empty()) throw std::invalid_argument("a BVH over boxes needs non-empty boxes");
  return build_over(
      uint32_t(std::min<size_t>(boxes.size(), size_t(kMaxBvhPrims) + 1)), [&](uint32_t i) { return boxes[i]; },
      params);
}

int Bvh::width() const {
  return visit([](const auto& t) { return std::decay_t<decltype(t)>::kWidth; });
}

BvhFigures Bvh::figures() const {
  BvhFigures f;
  visit([&](const auto& t) { add_figures(t, m_params, f); });
  return f;
}

}  // namespace rtu::hw
