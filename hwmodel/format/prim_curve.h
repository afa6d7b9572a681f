// The curve segment primitive kind (prim_kind.h): a segment of a round linear curve (geometry.h's CurveSegment):
// its record, encoder, check, orientation points and shading normal. Its tests: datapath/prim_curve_test.h. A
// segment is a round record (kind field 1) with round word kRoundCurve; its bit widths are
// FixedFormat::curve_limits(), which an image of curves names in its flags (curve_bits).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "hwmodel/format/prim_kind.h"

namespace rtu::hw {

// End points on the grid like a triangle's vertices, radii in grid.F rounded up, so the record's segment contains
// the spheres of the float one's rounded end points.
struct CurveRecord {
  int32_t p0[3], p1[3];  // end points on the grid (integers in [0, 2^B - 1]), rounded to nearest
  uint32_t r0, r1;       // radii in grid.F, rounded up, as curve_radius_field stores them (0: a zero radius)
  uint32_t round;        // kRoundCurve, with kRoundCapStart when the sphere at p0 belongs to the segment
  uint32_t prim;         // kind and scene primitive index (prim_kind.h)
};
static_assert(sizeof(CurveRecord) == kRecordBytes && offsetof(CurveRecord, round) == kRoundWordOffset &&
              offsetof(CurveRecord, prim) == 36);

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

struct CurvePrim {
  using Record = CurveRecord;
  static constexpr PrimKind kId = PrimKind::kCurve;
  static constexpr RecordKind kRecord = RecordKind::kCurve;
  static constexpr const char* kName = "curve segment";
  static constexpr TestCost kCost = TestCost::kCurve;

  static void encode(const RecordEncoding& e, uint32_t p, uint8_t* out, GridBox& box) {
    const CurveSegment& cs = e.g.curve(p);
    CurveRecord rec{};
    const int F = e.f.frac_bits;
    const Vec3* ends[2] = {&cs.p0, &cs.p1};
    const float radii[2] = {cs.r0, cs.r1};
    uint32_t* stored[2] = {&rec.r0, &rec.r1};
    int32_t* points[2] = {rec.p0, rec.p1};
    for (int i = 0; i < 2; ++i) {
      // Radius in grid.F units, rounded up (exact in double, as a sphere's), then to the field's 27 significant
      // bits, up. The frame holds the segment's spheres, so a radius is below 2^(B+F).
      const double rs = std::ceil(std::ldexp(double(radii[i]), F - e.frame.step_exp));
      if (!(rs < std::ldexp(1.0, 58)))
        throw std::invalid_argument("curve segment " +
                                    std::to_string(p - e.g.triangles.size() - e.g.spheres.size()) +
                                    ": radius beyond the record's range");
      *stored[i] = curve_radius_field(int64_t(rs));
      const int64_t r = curve_radius(*stored[i]);
      for (int a = 0; a < 3; ++a) {
        const int64_t g = e.frame.to_grid((*ends[i])[a], a, Round::kNearestEven);
        points[i][a] = int32_t(g);  // in [0, 2^B - 1]: the end point lies inside the frame's bounds
        box.lo[a] = std::min(box.lo[a], floor_shift((g << F) - r, F));
        box.hi[a] = std::max(box.hi[a], ceil_shift((g << F) + r, F));
      }
    }
    rec.round = kRoundCurve | ((cs.flags & kCurveCapStart) ? kRoundCapStart : 0u);
    rec.prim = record_word(RecordKind::kCurve, p);
    std::memcpy(out, &rec, sizeof rec);
  }

  // Index in range, an image with curve_bits, end points on the grid, radii up to 2^(B+F+1), no unknown round
  // bits.
  static std::string check(const RecordCheck& c, const uint8_t* rec) {
    const std::string at = "record " + std::to_string(c.index);
    CurveRecord s;
    std::memcpy(&s, rec, sizeof s);
    const uint32_t p = s.prim & kRecordPrimMask;
    if (p < c.num_triangles || p >= c.num_bounded) return at + ": curve segment index out of range";
    if (!c.curve_bits) return at + ": a curve segment in an image without curve_bits";
    const int B = c.f.coord_bits, F = c.f.frac_bits;
    const int64_t grid_max = (int64_t(1) << B) - 1;
    for (int e = 0; e < 3; ++e)
      if (s.p0[e] < 0 || s.p0[e] > grid_max || s.p1[e] < 0 || s.p1[e] > grid_max)
        return at + ": curve end point outside the grid";
    if (curve_radius(s.r0) > (int64_t(1) << (B + F + 1)) || curve_radius(s.r1) > (int64_t(1) << (B + F + 1)))
      return at + ": curve radius out of range";
    if (s.round & ~(kRoundCurve | kRoundCapStart)) return at + ": unknown round-primitive bits";
    return "";
  }

  // Its end points, widened by its larger radius (rounded up to grid units): the union of its spheres lies
  // within.
  static void orient_points(const uint8_t* rec, const GridBox&, const FixedFormat& f, OrientPoints& pts) {
    CurveRecord cr;
    std::memcpy(&cr, rec, sizeof cr);
    for (int a = 0; a < 3; ++a) {
      pts.p[0][a] = cr.p0[a];
      pts.p[1][a] = cr.p1[a];
    }
    pts.n = 2;
    pts.pad = ceil_shift(std::max(curve_radius(cr.r0), curve_radius(cr.r1)), f.frac_bits);
  }

  // From the axis point of the sphere the hit lies on (u of a curve hit is its s) to the hit point.
  static Vec3 normal(const Geometry& g, uint32_t p, const Vec3& at, float u) {
    const CurveSegment& c = g.curve(p);
    return at - (c.p0 + u * (c.p1 - c.p0));
  }
};

}  // namespace rtu::hw
