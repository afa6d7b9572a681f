// The oriented node kind (node_kind.h): a node names one rotation of the format's table (rotation_table.h) and
// stores its children's boxes in that rotated frame, quantized as the axis-aligned kind quantizes them (k-bit
// offsets from a common origin at a power-of-two scale per axis). A child's region is
// { p : lo <= (M p) / 2^rot_bits <= hi } for the node's integer matrix M, so the encoder bounds a subtree by
// exact integer products of its points, and the unit's test (datapath/oriented_aabb_test.h) rotates the ray with
// the same integers. The kind's build picks each node's rotation (node_build.h: the least summed surface area of
// the children, after DOBB-BVH, Kern et al., HPG 2025). Rotation 0 is the identity: such a node is the
// axis-aligned node's boxes with 4 more bytes.
#pragma once

#include <cstddef>
#include <cstring>
#include <stdexcept>
#include <string>

#include "hwmodel/format/hw_format.h"
#include "hwmodel/format/node_build.h"
#include "hwmodel/format/node_kind.h"
#include "hwmodel/format/quantized_aabb.h"
#include "hwmodel/format/rotation_table.h"

namespace rtu::hw {

template <int N, class Q>
struct ONode {
  int32_t origin[3];  // rotated-frame grid coordinates of the children's common low corner
  int8_t exp[3];      // per-axis scale of the offsets (0 .. B+3)
  uint8_t count;      // occupied child slots (they come first); the rest hold kEmptyChild
  uint16_t rot;       // index into the format's rotation table (< rotations)
  uint16_t reserved;  // 0
  Q q[6][N];          // rows lo_x, hi_x, lo_y, hi_y, lo_z, hi_z of the rotated frame; values < 2^k
  uint32_t child[N];  // child reference per slot
};
constexpr size_t onode_bytes(int width, int q_bytes) {
  return 20 + size_t(width) * (6 * size_t(q_bytes) + 4);
}
static_assert(sizeof(ONode<2, uint8_t>) == onode_bytes(2, 1) && sizeof(ONode<4, uint8_t>) == onode_bytes(4, 1) &&
              sizeof(ONode<6, uint8_t>) == onode_bytes(6, 1) && sizeof(ONode<8, uint8_t>) == onode_bytes(8, 1) &&
              sizeof(ONode<2, uint16_t>) == onode_bytes(2, 2) && sizeof(ONode<4, uint16_t>) == onode_bytes(4, 2) &&
              sizeof(ONode<6, uint16_t>) == onode_bytes(6, 2) && sizeof(ONode<8, uint16_t>) == onode_bytes(8, 2));

// The image header's flag bits of the kind: the rotation table's size and its entries' bits (node_kind.h), and the
// format fields they give back to a bound image (DeviceImage::format, through kNodeKinds).
inline constexpr uint32_t kOrientedImageFlags = kImageRotationsMask | kImageRotBitsMask;
inline void oriented_from_image_flags(uint32_t flags, FixedFormat& f) {
  f.rotations = int((flags & kImageRotationsMask) >> kImageRotationsShift) + 1;
  f.rot_bits = int((flags & kImageRotBitsMask) >> kImageRotBitsShift);
}

template <int N, class Q>
struct OrientedAabb {
  using Node = ONode<N, Q>;
  static constexpr NodeKindId kId = NodeKindId::kOrientedAabb;
  static constexpr int kWidth = N;

  static int count(const Node& n) { return n.count; }
  static uint32_t child(const Node& n, int i) { return n.child[i]; }
  static void set_child(Node& n, int i, uint32_t ref) { n.child[i] = ref; }

  // Child i's box in the node's rotated frame, grid units.
  static void child_box(const Node& n, int i, int64_t lo[3], int64_t hi[3]) { offset_box(n, i, lo, hi); }

  // The children's boxes given in the frame of rotation `rot` (grid units), quantized outward as the
  // axis-aligned kind does.
  static void encode_rotated(Node& n, int rot, const GridBox* boxes, const uint32_t* refs, int count,
                             const FixedFormat& f) {
    QNode<N, Q> a;
    QuantizedAabb<N, Q>::encode(a, boxes, refs, count, f);
    std::memset(&n, 0, sizeof n);
    for (int i = 0; i < 3; ++i) {
      n.origin[i] = a.origin[i];
      n.exp[i] = a.exp[i];
    }
    n.count = a.count;
    n.rot = uint16_t(rot);
    std::memcpy(n.q, a.q, sizeof n.q);
    std::memcpy(n.child, a.child, sizeof n.child);
  }
  // The concept's encoder: boxes in the world's axes, rotation 0 (the identity).
  static void encode(Node& n, const GridBox* boxes, const uint32_t* refs, int count, const FixedFormat& f) {
    encode_rotated(n, 0, boxes, refs, count, f);
  }

  // The fields the rotated test's widths are proven for (FixedFormat::rotated_translated_bits): count, rotation
  // index, scales, offsets below 2^k, decoded planes within [-2^(B+2), 2^(B+2)] grid units (a point of the grid
  // rotated stays below sqrt(3) 2^B (1 + 2^-rot_bits sqrt(3)) in magnitude, and the quantization adds less than
  // one quantum of the node's span, itself below 2^(B+2)).
  static std::string check(const Node& n, const FixedFormat& f) {
    const int B = f.coord_bits;
    const int64_t qlim = int64_t(1) << f.child_bits, plim = int64_t(1) << (B + 2);
    if (n.count < 1 || n.count > N) return "child count out of range";
    if (n.rot >= f.rotations)
      return "rotation index " + std::to_string(n.rot) + " beyond the table's " + std::to_string(f.rotations) +
             " rotations";
    if (n.reserved != 0) return "reserved field not zero";
    for (int a = 0; a < 3; ++a)
      if (n.exp[a] < 0 || n.exp[a] > B + 3) return "scale out of range";
    for (int r = 0; r < 6; ++r)
      for (int i = 0; i < N; ++i) {
        const int64_t q = int64_t(n.q[r][i]);
        if (q >= qlim) return "child offset wider than child_bits";
        const int64_t plane = int64_t(n.origin[r / 2]) + (q << n.exp[r / 2]);
        if (plane < -plim || plane > plim) return "box outside the rotated grid";
      }
    return {};
  }

  // The packed layouts' fields of the node (packed_layout.h: the rotation index after the count).
  // The rotation table's size and entries' bits (node_kind.h: kImageRotationsShift, kImageRotBitsShift).
  static uint32_t image_flags(const FixedFormat& f) {
    return (uint32_t(f.rotations - 1) << kImageRotationsShift) | (uint32_t(f.rot_bits) << kImageRotBitsShift);
  }
  // Each node in the rotation of the format's table whose children's boxes have the least summed surface area.
  static void build(const NodeBuild& b, const WideBvh<N>& t, Node* nodes) {
    build_oriented<OrientedAabb>(b, rotation_table(b.f.rotations, b.f.rot_bits), t, nodes, t.root_ref);
  }

  static void to_packed(const Node& n, PackedNode& pn) {
    offset_fields_to_packed(n, pn);
    pn.rot = n.rot;
  }
  static std::string from_packed(const PackedNode& pn, Node& n) {
    std::string why = offset_fields_from_packed(pn, n);
    if (why.empty() && pn.rot > 0xFFFF) why = "rotation index out of range";
    n.rot = uint16_t(pn.rot);
    return why;
  }
};

}  // namespace rtu::hw
