// The float BVH: a binned-SAH binary tree collapsed to 2, 4, 6 or 8 children per node. Built on the host side of
// the flow but defined here because the float reference traverses it and the fixed-point encoder reads it.
//
// Node layout (WideNode<N>): child boxes structure-of-arrays, one 32-bit child reference per slot.
// Child reference: bit 31 = leaf; a leaf holds prim_ids[first .. first+count) with count-1 in bits 27..30 and
// first in bits 0..26; an inner child is a node index < 2^31. Empty slots hold kEmptyChild and an inverted box
// (lo = +inf, hi = -inf) that no slab test accepts.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <variant>
#include <vector>

#include "hwmodel/scene/aabb.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

// Upper bound of a traversal stack (traverse.h): at most width-1 entries per level; the builder keeps the depth
// below 48 SAH levels plus log2(2^27) median levels.
inline constexpr int kTraversalStackSize = 8 * 80;

inline constexpr uint32_t kLeafBit = 0x80000000u;
inline constexpr uint32_t kEmptyChild = 0xFFFFFFFFu;
inline constexpr int kMaxLeafSize = 16;
inline constexpr uint32_t kMaxLeafFirst = (1u << 27) - 1;  // so that no leaf encodes to kEmptyChild
inline constexpr uint32_t kMaxBvhPrims = 1u << 27;

constexpr bool is_leaf(uint32_t ref) {
  return (ref & kLeafBit) != 0;
}
constexpr uint32_t leaf_first(uint32_t ref) {
  return ref & kMaxLeafFirst;
}
constexpr uint32_t leaf_count(uint32_t ref) {
  return ((ref >> 27) & 15u) + 1;
}
constexpr uint32_t make_leaf(uint32_t first, uint32_t count) {
  return kLeafBit | ((count - 1) << 27) | first;
}

struct BvhBuildParams {
  int width = 4;           // children per node: 2, 4, 6 or 8
  int max_leaf_size = 8;   // primitives per leaf, 1..16
  int bins = 32;           // SAH bins per axis, 2..256
  float node_cost = 1.0f;  // SAH cost of visiting one node (all its child boxes) relative to one primitive test
  float prim_cost = 1.0f;  // SAH cost of one primitive test
  int max_sah_depth = 48;  // below this depth splits are object medians, which bounds the depth by log2
};

// Throws std::invalid_argument naming the bad parameter.
void validate(const BvhBuildParams& p);

template <int N>
struct WideNode {
  float bounds[6][N];  // rows lo_x, hi_x, lo_y, hi_y, lo_z, hi_z; column = child slot
  uint32_t child[N];   // child reference per slot (see above)

  Aabb child_box(int i) const {
    return Aabb{Vec3(bounds[0][i], bounds[2][i], bounds[4][i]), Vec3(bounds[1][i], bounds[3][i], bounds[5][i])};
  }
};
static_assert(sizeof(WideNode<2>) == 56 && sizeof(WideNode<4>) == 112 && sizeof(WideNode<6>) == 168 &&
              sizeof(WideNode<8>) == 224);

template <int N>
struct WideBvh {
  static constexpr int kWidth = N;
  std::vector<WideNode<N>> nodes;   // node 0 is the root when root_ref is not a leaf
  std::vector<uint32_t> prim_ids;   // leaf order -> scene primitive index
  uint32_t root_ref = kEmptyChild;  // a node index (0) or, for a scene of one leaf, a leaf reference
  Aabb bounds;                      // bounds of all bounded primitives
};

// What `rtusim info` reports of a BVH.
struct BvhFigures {
  int width = 0;
  uint64_t inner_nodes = 0;
  uint64_t leaves = 0;
  uint64_t prims = 0;
  int depth = 0;  // inner-node levels on the longest root-to-leaf path (0 for a single leaf)
  int min_leaf = 0, max_leaf = 0;
  double mean_leaf = 0.0;
  double mean_fill = 0.0;    // occupied child slots per inner node / width
  double sah_cost = 0.0;     // expected cost of a random ray through the bounds (params' node and prim costs)
  uint64_t node_bytes = 0;   // bytes of nodes
  uint64_t index_bytes = 0;  // bytes of the leaf -> primitive index array
};

class Bvh {
 public:
  // Builds over the bounded primitives (triangles, spheres) of `g`. Deterministic: same input, same tree.
  static Bvh build(const Geometry& g, const BvhBuildParams& params = {});
  // Builds over boxes (e.g. the world bounds of instances): leaf index i is boxes[i]. Throws
  // std::invalid_argument for an empty box or more than 2^27 boxes.
  static Bvh build(const std::vector<Aabb>& boxes, const BvhBuildParams& params = {});

  int width() const;
  const BvhBuildParams& params() const { return m_params; }
  BvhFigures figures() const;
  // Calls f(const WideBvh<N>&) with the concrete width.
  template <class F>
  decltype(auto) visit(F&& f) const {
    return std::visit(std::forward<F>(f), m_tree);
  }

 private:
  template <class BoundsOf>
  static Bvh build_over(uint32_t n, BoundsOf bounds_of, const BvhBuildParams& params);
  BvhBuildParams m_params;
  std::variant<WideBvh<2>, WideBvh<4>, WideBvh<6>, WideBvh<8>> m_tree;
};

}  // namespace rtu::hw
