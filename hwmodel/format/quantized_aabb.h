// The quantized axis-aligned node kind (node_kind.h): QNode<N, Q> of hw_format.h, child boxes as k-bit offsets
// from a common origin at a power-of-two scale per axis. Its test is datapath/quantized_aabb_test.h.
#pragma once

#include <cstring>
#include <string>
#include <type_traits>

#include "hwmodel/format/hw_format.h"
#include "hwmodel/format/node_build.h"
#include "hwmodel/format/node_kind.h"
#include "hwmodel/numeric/fixed.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

// Child i's box of a node that stores k-bit offsets from an origin at a power-of-two scale per axis (fields
// origin, exp, q: the axis-aligned and the oriented kinds), grid units.
template <class Node>
inline void offset_box(const Node& n, int i, int64_t lo[3], int64_t hi[3]) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = int64_t(n.origin[a]) + (int64_t(n.q[2 * a][i]) << n.exp[a]);
    hi[a] = int64_t(n.origin[a]) + (int64_t(n.q[2 * a + 1][i]) << n.exp[a]);
  }
}

// The packed layouts' fields of such a node (origin, scales, count, offsets); references are the caller's.
template <class Node>
inline void offset_fields_to_packed(const Node& n, PackedNode& pn) {
  for (int a = 0; a < 3; ++a) {
    pn.origin[a] = n.origin[a];
    pn.exp[a] = n.exp[a];
  }
  pn.count = n.count;
  for (int i = 0; i < n.count; ++i)
    for (int r = 0; r < 6; ++r) pn.q[r][i] = n.q[r][i];
}
// Such a node, cleared, from a packed node's fields (unpack_node has checked the count against the width);
// references are the caller's.
template <class Node>
inline std::string offset_fields_from_packed(const PackedNode& pn, Node& n) {
  using Q = std::remove_cvref_t<decltype(n.q[0][0])>;
  constexpr int N = int(sizeof(n.child) / sizeof(n.child[0]));
  std::memset(&n, 0, sizeof n);
  for (int a = 0; a < 3; ++a) {
    if (pn.exp[a] > 127) return "scale out of range";
    n.origin[a] = pn.origin[a];
    n.exp[a] = int8_t(pn.exp[a]);
  }
  n.count = uint8_t(pn.count);
  for (int r = 0; r < 6; ++r)
    for (int i = 0; i < N; ++i) n.q[r][i] = Q(pn.q[r][i]);  // a field of at most 16 bits
  return {};
}

template <int N, class Q>
struct QuantizedAabb {
  using Node = QNode<N, Q>;
  static constexpr NodeKindId kId = NodeKindId::kQuantizedAabb;
  static constexpr int kWidth = N;

  static int count(const Node& n) { return n.count; }
  static uint32_t child(const Node& n, int i) { return n.child[i]; }
  static void set_child(Node& n, int i, uint32_t ref) { n.child[i] = ref; }

  static void child_box(const Node& n, int i, int64_t lo[3], int64_t hi[3]) { offset_box(n, i, lo, hi); }

  // The children's grid boxes relative to their common low corner, at the smallest scale whose offsets fit
  // child_bits, lows rounded down and highs up (so each decoded box contains its grid box); empty slots hold
  // kEmptyChild.
  static void encode(Node& n, const GridBox* boxes, const uint32_t* refs, int count, const FixedFormat& f) {
    const int64_t qmax = (int64_t(1) << f.child_bits) - 1;
    std::memset(&n, 0, sizeof n);
    n.count = uint8_t(count);
    for (int a = 0; a < 3; ++a) {
      int64_t lo = INT64_MAX, hi = INT64_MIN;
      for (int i = 0; i < count; ++i) {
        lo = std::min(lo, boxes[i].lo[a]);
        hi = std::max(hi, boxes[i].hi[a]);
      }
      int e = 0;
      while (int64_t(round_shift(hi - lo, e, Round::kUp)) > qmax) ++e;
      n.origin[a] = int32_t(lo);
      n.exp[a] = int8_t(e);
      for (int i = 0; i < count; ++i) {
        n.q[2 * a][i] = Q(round_shift(boxes[i].lo[a] - lo, e, Round::kDown));
        n.q[2 * a + 1][i] = Q(round_shift(boxes[i].hi[a] - lo, e, Round::kUp));
      }
    }
    for (int i = 0; i < N; ++i) n.child[i] = i < count ? refs[i] : kEmptyChild;
  }

  // The fields the datapath's widths are proven for: count, scales, offsets below 2^k and decoded planes within
  // [-2^B, 2^(B+1)] grid units (minus any valid ray origin they stay below 2^(B+G+1), the translated range the box
  // unit's widths are derived for, G >= 1).
  static std::string check(const Node& n, const FixedFormat& f) {
    const int B = f.coord_bits;
    const int64_t qlim = int64_t(1) << f.child_bits;
    if (n.count < 1 || n.count > N) return "child count out of range";
    for (int a = 0; a < 3; ++a)
      if (n.exp[a] < 0 || n.exp[a] > B + 1) return "scale out of range";
    for (int r = 0; r < 6; ++r) {
      for (int i = 0; i < N; ++i) {
        const int64_t q = int64_t(n.q[r][i]);
        if (q >= qlim) return "child offset wider than child_bits";
        const int64_t plane = int64_t(n.origin[r / 2]) + (q << n.exp[r / 2]);
        if (plane < -(int64_t(1) << B) || plane > (int64_t(1) << (B + 1))) return "box outside the grid";
      }
    }
    return {};
  }

  // The packed layouts' fields of the node (the children's leaf bits, groups and bases are the caller's).
  static uint32_t image_flags(const FixedFormat&) { return 0; }
  // Each child's box: the grid boxes below it joined with its float box rounded outward.
  static void build(const NodeBuild& b, const WideBvh<N>& t, Node* nodes) {
    build_axis_aligned<QuantizedAabb>(b, t, nodes, t.root_ref);
  }

  static void to_packed(const Node& n, PackedNode& pn) { offset_fields_to_packed(n, pn); }
  static std::string from_packed(const PackedNode& pn, Node& n) { return offset_fields_from_packed(pn, n); }
};

}  // namespace rtu::hw
