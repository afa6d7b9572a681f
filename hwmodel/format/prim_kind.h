// Primitive kinds: what one kind of primitive provides, as node_kind.h says for the BVH's nodes. A kind is one
// type (TrianglePrim, SpherePrim, CurvePrim, PlanePrim) in two halves:
//   - format/ (this room, prim_<kind>.h): the scene kind it serves (PrimKind, geometry.h), its name, its 40-byte
//     record (the stored struct, trivially copyable, sizeof = kRecordBytes; a plane's 24-byte PlaneRecord is kept
//     outside the BVH), the encoder from the float primitive onto the quantization frame's grid with its grid box,
//     the check of one record's fields against the format (an image from device memory), the points the oriented
//     node kind's fitting bounds it by (orient_points), and the shading normal at a hit;
//   - datapath/prim_<kind>_test.h: PrimTest<K>, its float test (the reference, on the leaf's float copy) and its
//     fixed test (bit-accurate, on the record), whose error bounds and bit widths FixedFormat::validate (or, for
//     curves, FixedFormat::curve_limits) proves.
// The table of kinds is prim_kinds.h: one row each, and the dispatch from a scene kind or a record to the type.
//
// A record names its kind in its last word (`prim`, bytes 36..39), read by record_kind():
//   bits 0..26   the scene primitive index (the instance index in a top level): the unit's primitive index holds
//                fewer than 2^27 (kMaxBvhPrims, and the host's check_scene_size), as a leaf's first record does
//   bits 27..28  the kind field's high bits (0 in every kind so far)
//   bit  29      kRecordNonOpaque: a triangle whose candidate hits go to the any-hit stage (any_hit.h)
//   bits 30..31  the kind field's low bits
// The kind field is 4 bits, its value one row of kRecordFields: 0 triangle, 1 round (the word at bytes 32..35
// says which: kRoundSphere, kRoundCurve), 2 instance, 3 triangle pair; 4..15 are free (motion-blurred primitives
// come next). Bits 27..28 were the primitive index's top two bits, always zero because the index never reaches
// 2^27, so every image keeps its bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <type_traits>

#include "hwmodel/format/node_kind.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

// A record's kind as the unit reads it (record_kind): the kind field, and for round records the round word. Its
// value is also the count of the record's kPrim trace event (fixed_tracer.h), by which the timing model prices the
// request (timing_model_units.cpp): kCurve is 4 there as it is here.
enum class RecordKind : uint8_t {
  kTriangle = 0,
  kSphere = 1,
  kInstance = 2,
  kTrianglePair = 3,  // a triangle whose next record is a triangle sharing an edge with it (format tri_pairs)
  kCurve = 4,         // a segment of a round linear curve: kind field 1, round word kRoundCurve
  kUnknown = 0xFF,    // a kind field no row has: the image check refuses it
};

// How the timing model prices one test of a kind (timing_model_units.cpp): the unit it occupies and its keys.
//   kTriangle      a triangle unit issue slot, tri_latency (or the clocks an attached RTL triangle unit reports)
//   kTrianglePair  two triangle unit issue slots at once, the result when both are done
//   kSphere        a triangle unit issue slot, sphere_latency
//   kPlane         a triangle unit issue slot, plane_latency
//   kCurve         a curve unit for one clock, or a triangle unit for curve_issue clocks; curve_latency
//   kTransform     the pipelined transform unit (an instance record of a top level), xform_latency
enum class TestCost : uint8_t { kTriangle, kTrianglePair, kSphere, kPlane, kCurve, kTransform };

inline constexpr uint32_t kRecordKindLowShift = 30, kRecordKindHighShift = 27;
inline constexpr uint32_t kRecordKindMask = (3u << kRecordKindLowShift) | (3u << kRecordKindHighShift);
inline constexpr uint32_t kRecordNonOpaque = 1u << 29;
inline constexpr uint32_t kRecordPrimBits = 27;
inline constexpr uint32_t kRecordPrimMask = (1u << kRecordPrimBits) - 1;
inline constexpr size_t kRecordBytes = 40;

// Round records (kind field 1): the word at bytes 32..35, its low byte the round primitive.
inline constexpr uint32_t kRoundSphere = 0, kRoundCurve = 1;
inline constexpr uint32_t kRoundCapStart = 1u << 8;  // a curve segment's: the sphere at p0 belongs to it
inline constexpr size_t kRoundWordOffset = 32;

// The kind field of each record kind, and for round kinds the round word's low byte.
struct RecordField {
  RecordKind kind;
  uint8_t field;
  int16_t round;  // -1: not a round kind
};
inline constexpr uint32_t kRoundField = 1;
inline constexpr RecordField kRecordFields[] = {
    {RecordKind::kTriangle, 0, -1},
    {RecordKind::kSphere, kRoundField, kRoundSphere},
    {RecordKind::kInstance, 2, -1},
    {RecordKind::kTrianglePair, 3, -1},
    {RecordKind::kCurve, kRoundField, kRoundCurve},
};

constexpr uint32_t record_field(RecordKind k) {
  for (const RecordField& r : kRecordFields)
    if (r.kind == k) return r.field;
  return 0;
}
// The prim word of a record of kind k for index `index` (below 2^27).
constexpr uint32_t record_word(RecordKind k, uint32_t index, bool non_opaque = false) {
  const uint32_t f = record_field(k);
  return ((f & 3u) << kRecordKindLowShift) | ((f >> 2) << kRecordKindHighShift) |
         (non_opaque ? kRecordNonOpaque : 0u) | index;
}
// The word with its kind field set to that of k (the rest kept).
constexpr uint32_t with_record_kind(uint32_t word, RecordKind k) {
  return (word & ~kRecordKindMask) | record_word(k, 0);
}

// The kind field of a record; the prim word's last byte holds it (bits 6..7 low, 3..4 high).
inline uint32_t record_field_of(const uint8_t* rec) {
  const uint32_t b = rec[39];
  return (b >> 6) | ((b >> 1) & 0xCu);
}
inline RecordKind record_kind(const uint8_t* rec) {
  const uint32_t field = record_field_of(rec);
  if (field == kRoundField) return rec[kRoundWordOffset] == kRoundCurve ? RecordKind::kCurve : RecordKind::kSphere;
  return field < 4 ? RecordKind(field) : RecordKind::kUnknown;
}
inline bool is_triangle(RecordKind k) {
  return k == RecordKind::kTriangle || k == RecordKind::kTrianglePair;
}
// True for a record that holds a curve segment.
inline bool is_curve_record(const uint8_t* rec) {
  return record_kind(rec) == RecordKind::kCurve;
}

// x / 2^s rounded down or up: a grid box around values with s fraction bits.
inline int64_t floor_shift(int64_t x, int s) {
  return int64_t(round_shift(x, s, Round::kDown));
}
inline int64_t ceil_shift(int64_t x, int s) {
  return int64_t(round_shift(x, s, Round::kUp));
}

// What a kind's encoder reads: the scene, the format and the quantization frame.
struct RecordEncoding {
  const Geometry& g;
  const FixedFormat& f;
  const QuantFrame& frame;
};

// What a kind's record check reads besides the record: the image's format, counts and flags, the record's index
// and the one after it (null at the end).
struct RecordCheck {
  const FixedFormat& f;
  uint32_t num_triangles;
  uint64_t num_bounded;
  bool curve_bits;  // the image carries curve_bits (flags bits 27..31)
  uint32_t index;
  const uint8_t* next;
};

// The points the oriented node kind bounds a record by (orient_points): up to 8 grid points and a pad (grid units,
// rounded up) by which each is widened along a rotated axis times the axis row's length.
struct OrientPoints {
  int64_t p[8][3];
  int n = 0;
  int64_t pad = 0;
  // The eight corners of a grid box.
  void corners(const GridBox& b) {
    for (n = 0; n < 8; ++n)
      for (int a = 0; a < 3; ++a) p[n][a] = (n >> a) & 1 ? b.hi[a] : b.lo[a];
  }
};

// What a bounded kind K provides in this room (a plane, kept out of the BVH, provides its own encode and check:
// prim_plane.h).
template <class K>
concept PrimitiveKind = requires(const RecordEncoding& e, const RecordCheck& c, const uint8_t* rec, uint8_t* out,
                                 GridBox& box, uint32_t p, OrientPoints& pts, const Geometry& g, const Vec3& at,
                                 float u) {
  requires std::is_trivially_copyable_v<typename K::Record> && sizeof(typename K::Record) == kRecordBytes;
  { K::kId } -> std::convertible_to<PrimKind>;
  { K::kRecord } -> std::convertible_to<RecordKind>;
  { K::kName } -> std::convertible_to<const char*>;
  { K::kCost } -> std::convertible_to<TestCost>;  // how the timing model prices its test
  K::encode(e, p, out, box);                      // the record of scene primitive p, and its grid box (extended)
  { K::check(c, rec) } -> std::same_as<std::string>;
  K::orient_points(rec, box, c.f, pts);
  { K::normal(g, p, at, u) } -> std::same_as<Vec3>;  // not normalized; u as the hit's
};

}  // namespace rtu::hw
