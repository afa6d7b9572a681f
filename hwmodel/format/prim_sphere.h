// The sphere primitive kind (prim_kind.h): its record, encoder, check, orientation points and shading normal. Its
// tests: datapath/prim_sphere_test.h. A sphere is a round record (kind field 1) with round word kRoundSphere.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "hwmodel/format/prim_kind.h"

namespace rtu::hw {

struct SphereRecord {
  int64_t center[3];  // grid coordinates with F fraction bits, rounded to nearest
  int64_t radius;     // grid units with F fraction bits, rounded up (> 0)
  uint32_t reserved;  // the round word: kRoundSphere (0)
  uint32_t prim;      // kind and scene primitive index (prim_kind.h)
};
static_assert(sizeof(SphereRecord) == kRecordBytes && offsetof(SphereRecord, reserved) == kRoundWordOffset &&
              offsetof(SphereRecord, prim) == 36);

struct SpherePrim {
  using Record = SphereRecord;
  static constexpr PrimKind kId = PrimKind::kSphere;
  static constexpr RecordKind kRecord = RecordKind::kSphere;
  static constexpr const char* kName = "sphere";
  static constexpr TestCost kCost = TestCost::kSphere;

  static void encode(const RecordEncoding& e, uint32_t p, uint8_t* out, GridBox& box) {
    const Sphere& s = e.g.spheres[p - e.g.triangles.size()];
    SphereRecord rec{};
    const int F = e.f.frac_bits;
    // Radius in grid.F units, rounded up: r * 2^(F - step_exp) is exact in double (a float times a power of
    // two), and at least one unit so a sphere never vanishes.
    const double rs = std::ldexp(double(s.radius), F - e.frame.step_exp);
    rec.radius = std::max<int64_t>(1, int64_t(std::ceil(rs)));
    for (int a = 0; a < 3; ++a) {
      rec.center[a] = e.frame.to_grid(s.center[a], a, Round::kNearestEven, F);
      box.lo[a] = std::min(box.lo[a], floor_shift(rec.center[a] - rec.radius, F));
      box.hi[a] = std::max(box.hi[a], ceil_shift(rec.center[a] + rec.radius, F));
    }
    rec.prim = record_word(RecordKind::kSphere, p);
    std::memcpy(out, &rec, sizeof rec);
  }

  // Index in range, the center like a ray origin (within the guard range), 0 < radius <= 2^(B+F+1), round word 0.
  static std::string check(const RecordCheck& c, const uint8_t* rec) {
    const std::string at = "record " + std::to_string(c.index);
    SphereRecord s;
    std::memcpy(&s, rec, sizeof s);
    const uint32_t p = s.prim & kRecordPrimMask;
    if (p < c.num_triangles || p >= c.num_bounded) return at + ": sphere index out of range";
    const int B = c.f.coord_bits, F = c.f.frac_bits;
    const int64_t center_lim = int64_t(1) << (B + c.f.guard_bits + F);
    for (int64_t x : s.center)
      if (x <= -center_lim || x >= center_lim) return at + ": center out of range";
    if (s.radius <= 0 || s.radius > (int64_t(1) << (B + F + 1)) || s.reserved != 0)
      return at + ": radius out of range";
    return "";
  }

  // The corners of its grid box.
  static void orient_points(const uint8_t*, const GridBox& box, const FixedFormat&, OrientPoints& pts) {
    pts.corners(box);
  }

  // From the center to the hit point.
  static Vec3 normal(const Geometry& g, uint32_t p, const Vec3& at, float) {
    return at - g.spheres[p - g.triangles.size()].center;
  }
};

}  // namespace rtu::hw
