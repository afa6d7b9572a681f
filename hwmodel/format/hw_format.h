// The fixed-point device's memory formats: BVH nodes with quantized child boxes, and (through prim_kinds.h, a
// header per primitive kind) primitive records on the grid of the quantization frame (quant_frame.h). All
// little-endian, naturally aligned, no implicit padding.
//
// Child boxes (after Vaidyanathan et al., "Watertight Ray Traversal with Reduced Precision", HPG 2016, and
// Ylitie et al., "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs", HPG 2017): a node
// stores an origin on the grid and a power-of-two scale per axis; child i's box on axis a is
//   lo = origin[a] + (q[2a][i]   << exp[a]),   hi = origin[a] + (q[2a+1][i] << exp[a])
// with k-bit offsets q (k = FixedFormat::child_bits). The encoder rounds lows down and highs up, so a decoded
// box always contains the exact box; decoding is shifts and adds, exact on the grid.
//
// Child references are those of the float BVH (bvh.h): bit 31 leaf; a leaf holds primitive records
// [first, first + count) with count - 1 in bits 27..30 and first in bits 0..26; otherwise a node index.
#pragma once

#include <cstddef>
#include <cstdint>

#include "hwmodel/format/prim_kinds.h"  // the primitive records, one header per kind

namespace rtu::hw {

// Node of width N with child offsets stored in Q (uint8_t for k <= 8, uint16_t for k <= 16).
template <int N, class Q>
struct QNode {
  int32_t origin[3];  // grid coordinates of the children's common low corner
  int8_t exp[3];      // per-axis scale: one offset step = 2^exp grid steps (0 .. B+1)
  uint8_t count;      // occupied child slots (they come first); the rest hold kEmptyChild
  Q q[6][N];          // rows lo_x, hi_x, lo_y, hi_y, lo_z, hi_z; column = child slot; values < 2^k
  uint32_t child[N];  // child reference per slot (see above)
};
// Bytes of a QNode of `width` children with `q_bytes`-byte offsets, for code that knows the width at run time.
constexpr size_t qnode_bytes(int width, int q_bytes) {
  return 16 + size_t(width) * (6 * size_t(q_bytes) + 4);
}
static_assert(sizeof(QNode<2, uint8_t>) == qnode_bytes(2, 1) && sizeof(QNode<4, uint8_t>) == qnode_bytes(4, 1) &&
              sizeof(QNode<6, uint8_t>) == qnode_bytes(6, 1) && sizeof(QNode<8, uint8_t>) == qnode_bytes(8, 1) &&
              sizeof(QNode<2, uint16_t>) == qnode_bytes(2, 2) && sizeof(QNode<4, uint16_t>) == qnode_bytes(4, 2) &&
              sizeof(QNode<6, uint16_t>) == qnode_bytes(6, 2) && sizeof(QNode<8, uint16_t>) == qnode_bytes(8, 2));
static_assert(sizeof(QNode<2, uint8_t>) == 36 && sizeof(QNode<4, uint8_t>) == 56 &&
              sizeof(QNode<6, uint8_t>) == 76 && sizeof(QNode<8, uint8_t>) == 96);
static_assert(sizeof(QNode<2, uint16_t>) == 48 && sizeof(QNode<4, uint16_t>) == 80 &&
              sizeof(QNode<6, uint16_t>) == 112 && sizeof(QNode<8, uint16_t>) == 144);
using QNode4x8 = QNode<4, uint8_t>;
static_assert(offsetof(QNode4x8, q) == 16 && offsetof(QNode4x8, child) == 40);
// Width 6: the child references follow 36 (or 72) offset bytes, still 4-byte aligned, no padding.
using QNode6x8 = QNode<6, uint8_t>;
using QNode6x16 = QNode<6, uint16_t>;
static_assert(offsetof(QNode6x8, q) == 16 && offsetof(QNode6x8, child) == 52 && offsetof(QNode6x16, child) == 88);

// An instance of a top-level image (RecordKind::kInstance, instanced_fixed.h): its world bounds on the grid
// (rounded outward) and its index in the scene's instance list (bits 0..26). Its transform and bottom level are
// held beside the image; the unit hands the ray to the instance's bottom level.
struct InstanceRecord {
  int32_t lo[3], hi[3];  // grid bounds, in [0, 2^B - 1]
  uint32_t reserved[3];  // 0
  uint32_t prim;         // kind and instance index (prim_kind.h)
};
static_assert(sizeof(InstanceRecord) == kRecordBytes && offsetof(InstanceRecord, prim) == 36);

}  // namespace rtu::hw
