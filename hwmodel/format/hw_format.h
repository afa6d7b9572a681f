// The fixed-point device's memory formats: BVH nodes with quantized child boxes, and primitive records on the
// grid of the quantization frame (quant_frame.h). All little-endian, naturally aligned, no implicit padding.
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

// The kind of a primitive record, in bits 30..31 of its `prim` word. Instance records are found only in a
// top-level image (kImageTopLevel, device_image.h): the unit hands the ray to the instance's bottom level
// (instanced_fixed.h).
// kTrianglePair: a triangle whose next record is a triangle sharing an edge with it (format tri_pairs): the unit
// fetches and tests the two in one request, as RDNA4's compressed primitive nodes and Xe's quad leaves do.
enum class RecordKind : uint32_t { kTriangle = 0, kSphere = 1, kInstance = 2, kTrianglePair = 3 };
// Bit 29 of a triangle's `prim` word: the triangle is not opaque, its candidate hits go to the any-hit stage
// (any_hit.h). Never set on a sphere.
inline constexpr uint32_t kRecordNonOpaque = 1u << 29;
inline constexpr uint32_t kRecordPrimMask = (1u << 29) - 1;

// A primitive record: 40 bytes, triangle or sphere, told apart by the kind bits of its last word.
struct TriangleRecord {
  int32_t v[3][3];  // vertices v0, v1, v2 on the grid (integers in [0, 2^B - 1]), rounded to nearest
  uint32_t prim;    // kind (bits 30..31), kRecordNonOpaque (bit 29), scene primitive index (bits 0..28)
};
// Kind kSphere holds the round primitives: the word at bytes 32..35 says which (kRoundSphere, kRoundCurve).
struct SphereRecord {
  int64_t center[3];  // grid coordinates with F fraction bits, rounded to nearest
  int64_t radius;     // grid units with F fraction bits, rounded up (> 0)
  uint32_t reserved;  // kRoundSphere (0)
  uint32_t prim;      // kind (bits 30..31) and scene primitive index (bits 0..28)
};
// A segment of a round linear curve (geometry.h's CurveSegment; the test is intersect_fixed.h's
// swept_sphere_test): end points on the grid like a triangle's vertices, radii in grid.F rounded up, so the
// record's segment contains the spheres of the float one's rounded end points.
struct CurveRecord {
  int32_t p0[3], p1[3];  // end points on the grid (integers in [0, 2^B - 1]), rounded to nearest
  uint32_t r0, r1;       // radii in grid.F, rounded up, as curve_radius_field stores them (0: a zero radius)
  uint32_t round;        // kRoundCurve, with kRoundCapStart when the sphere at p0 belongs to the segment
  uint32_t prim;         // kind kSphere (bits 30..31) and scene primitive index (bits 0..28)
};
inline constexpr uint32_t kRoundSphere = 0, kRoundCurve = 1;
// A curve radius field: a 27-bit mantissa m (bits 0..26) and a shift s (bits 27..31), the radius m * 2^s grid.F
// units. Radii below 2^27 are stored as they are (s = 0); larger ones keep 27 significant bits, rounded up, so
// the stored radius never shrinks (relative growth below 2^-26).
inline constexpr int kCurveRadiusMantissaBits = 27;
inline int64_t curve_radius(uint32_t field) {
  return int64_t(field & ((1u << kCurveRadiusMantissaBits) - 1)) << (field >> kCurveRadiusMantissaBits);
}
// The field of a radius r >= 0 (grid.F units, below 2^58), rounded up.
inline uint32_t curve_radius_field(int64_t r) {
  int s = 0;
  while ((r >> s) >= (int64_t(1) << kCurveRadiusMantissaBits)) ++s;
  int64_t m = (r + (int64_t(1) << s) - 1) >> s;  // rounded up
  if (m >> kCurveRadiusMantissaBits) {           // the rounding carried into a 28th bit
    ++s;
    m = (m + 1) >> 1;
  }
  return uint32_t(m) | (uint32_t(s) << kCurveRadiusMantissaBits);
}
inline constexpr uint32_t kRoundCapStart = 1u << 8;
inline constexpr size_t kRoundWordOffset = 32;
// An instance of a top-level image: its world bounds on the grid (rounded outward) and its index in the scene's
// instance list (bits 0..28). Its transform and bottom level are held beside the image (instanced_fixed.h).
struct InstanceRecord {
  int32_t lo[3], hi[3];  // grid bounds, in [0, 2^B - 1]
  uint32_t reserved[3];  // 0
  uint32_t prim;         // kind (bits 30..31) and instance index (bits 0..28)
};
static_assert(sizeof(TriangleRecord) == 40 && sizeof(SphereRecord) == 40 && sizeof(InstanceRecord) == 40 &&
              sizeof(CurveRecord) == 40);
static_assert(offsetof(SphereRecord, reserved) == kRoundWordOffset &&
              offsetof(CurveRecord, round) == kRoundWordOffset);
// The prim word is the last 4 bytes of every record, so its kind bits are in byte 39.
static_assert(offsetof(TriangleRecord, prim) == 36 && offsetof(SphereRecord, prim) == 36 &&
              offsetof(InstanceRecord, prim) == 36 && offsetof(CurveRecord, prim) == 36);
inline constexpr size_t kRecordBytes = 40;
inline RecordKind record_kind(const uint8_t* rec) {
  return RecordKind(rec[39] >> 6);
}
// True for a kSphere record that holds a curve segment.
inline bool is_curve_record(const uint8_t* rec) {
  return record_kind(rec) == RecordKind::kSphere && (rec[kRoundWordOffset] & 0xFF) == kRoundCurve;
}
inline bool is_triangle(RecordKind k) {
  return k == RecordKind::kTriangle || k == RecordKind::kTrianglePair;
}
// True when triangles a and b share an edge: two of a's grid vertices are two of b's.
inline bool share_edge(const TriangleRecord& a, const TriangleRecord& b) {
  int same = 0;
  for (const auto& va : a.v)
    for (const auto& vb : b.v) same += va[0] == vb[0] && va[1] == vb[1] && va[2] == vb[2];
  return same == 2;
}

// A plane {x : n . x = w} in grid space, tested per ray outside the BVH.
struct PlaneRecord {
  int32_t normal[3];  // normal scaled so the largest component is in [1/2, 1], D fraction bits, nearest
  uint32_t prim;      // scene primitive index
  int64_t offset;     // w in grid units (same scale as the normal), F fraction bits, nearest, saturated to
                      // the translated range (2^(B+G+1) grid units)
};
static_assert(sizeof(PlaneRecord) == 24 && offsetof(PlaneRecord, offset) == 16);

}  // namespace rtu::hw
