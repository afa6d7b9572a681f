// Node kinds: how one BVH node is stored, built, checked and decoded, tested and priced. A kind is one type per
// (width, offset bytes) that bundles:
//   - format/ (this room): the stored struct `Node` (trivially copyable, no padding, sizeof = its bytes), its
//     child count and references, the encoder that quantizes the children's grid boxes into it, the check of one
//     node's fields against the format (an image from device memory), and its fields in the packed layouts
//     (packed_layout.h: to_packed, from_packed), its image flags, and `build`, which encodes a BVH's nodes in the
//     kind's fitting (node_build.h: axis-aligned, or oriented by the rotation of least surface area);
//   - datapath/node_test.h: the fixed test of one node's children (a fast kernel, the reference path, the input of
//     an attached box unit) and the exact oracle that checks it;
//   - a cost class (NodeCostClass), which the timing model prices (TimingModel::Layout::node_cost).
// The image names its kind in header flags bits 8..11 (device_image.h); every dispatch goes through
// with_node_kind (node_kinds.h), as the BVH width's does. The tree around the nodes (references, leaves, order,
// depth) is the same for every kind and stays in the image's encoder (device_image_encode.cpp, packed_tree.h), its
// check (device_image.cpp) and traverse.h.
// A new kind: its format header beside quantized_aabb.h, its test beside datapath/quantized_aabb_test.h, one
// row in node_kinds.h and one include in datapath/node_test.h.
#pragma once

#include <algorithm>
#include <concepts>
#include <cstdint>
#include <string>

#include "hwmodel/format/packed_layout.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

// Which of the timing model's box-test costs prices a node of the kind (node_cost.h): slab tests (box_rate,
// box_latency), or slab tests after the ray's rotation into the node's frame (and obb_rotate_latency).
enum class NodeCostClass : uint8_t { kAxisAligned = 0, kOriented = 1 };

// Image header flags bits 8..11: the node kind. 0 is the quantized AABB, so images written before kinds existed
// read as that kind, byte for byte.
inline constexpr uint32_t kImageNodeKindShift = 8;
inline constexpr uint32_t kImageNodeKindMask = 0xFu << kImageNodeKindShift;
// Image header flags of an oriented kind: bits 12..21 the rotation table's size - 1, bits 22..26 its entries'
// fraction bits (rotation_table.h); zero in other kinds.
inline constexpr uint32_t kImageRotationsShift = 12, kImageRotBitsShift = 22;
inline constexpr uint32_t kImageRotationsMask = 0x3FFu << kImageRotationsShift;
inline constexpr uint32_t kImageRotBitsMask = 0x1Fu << kImageRotBitsShift;

// A box on the grid, exact integers: the encoder's input for one child (contains everything below it).
struct GridBox {
  int64_t lo[3] = {INT64_MAX, INT64_MAX, INT64_MAX};
  int64_t hi[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
  void extend(const GridBox& b) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], b.lo[a]);
      hi[a] = std::max(hi[a], b.hi[a]);
    }
  }
};

// What the encoder hands a kind's build hook (node_build.h): the format, the quantization frame, the records in
// leaf order and their grid boxes.
struct NodeBuild {
  const FixedFormat& f;
  const QuantFrame& frame;
  const uint8_t* records;
  const GridBox* record_boxes;
  // A float box on the grid, rounded outward.
  GridBox outward(const Aabb& b) const {
    GridBox g;
    for (int a = 0; a < 3; ++a) {
      g.lo[a] = frame.to_grid(b.lo[a], a, Round::kDown);
      g.hi[a] = frame.to_grid(b.hi[a], a, Round::kUp);
    }
    return g;
  }
};

// What a kind K provides in this room. Checks return an empty string or the problem (the image check prefixes
// the node's index).
template <class K>
concept NodeKind = requires(typename K::Node& n, const typename K::Node& cn, const GridBox* boxes,
                            const uint32_t* refs, const FixedFormat& f, PackedNode& pn, const PackedNode& cpn,
                            int i, uint32_t ref, int64_t* lo, int64_t* hi) {
  requires std::is_trivially_copyable_v<typename K::Node>;
  { K::kId } -> std::convertible_to<NodeKindId>;
  { K::kWidth } -> std::convertible_to<int>;
  { K::count(cn) } -> std::same_as<int>;
  { K::child(cn, i) } -> std::same_as<uint32_t>;
  K::set_child(n, i, ref);
  K::child_box(cn, i, lo, hi);  // child i's decoded box on the grid, exact: what the encoder checks
  K::encode(n, boxes, refs, i, f);
  { K::check(cn, f) } -> std::same_as<std::string>;
  K::to_packed(cn, pn);
  { K::from_packed(cpn, n) } -> std::same_as<std::string>;
  // The image's flags for the kind's own fields (0 if none; DeviceImage::format reads them back).
  { K::image_flags(f) } -> std::same_as<uint32_t>;
  // Encodes every node of a BVH whose root is a node (the kind's fitting: node_build.h).
  requires requires(const NodeBuild& b, const WideBvh<K::kWidth>& t, typename K::Node* out) {
    K::build(b, t, out);
  };
};

}  // namespace rtu::hw
