// The plane primitive kind (prim_kind.h): unbounded, kept out of the BVH and tested per ray, so its record is the
// 24-byte PlaneRecord of the image's plane section rather than a 40-byte record. Its encoder, check and shading
// normal; its tests: datapath/prim_plane_test.h.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "hwmodel/format/prim_kind.h"

namespace rtu::hw {

// A plane {x : n . x = w} in grid space.
struct PlaneRecord {
  int32_t normal[3];  // normal scaled so the largest component is in [1/2, 1], D fraction bits, nearest
  uint32_t prim;      // scene primitive index
  int64_t offset;     // w in grid units (same scale as the normal), F fraction bits, nearest, saturated to
                      // the translated range (2^(B+G+1) grid units)
};
static_assert(sizeof(PlaneRecord) == 24 && offsetof(PlaneRecord, offset) == 16);

struct PlanePrim {
  using Record = PlaneRecord;
  static constexpr PrimKind kId = PrimKind::kPlane;
  static constexpr const char* kName = "plane";
  static constexpr TestCost kCost = TestCost::kPlane;

  // The record of the scene's plane i.
  static PlaneRecord encode(const RecordEncoding& e, uint32_t i) {
    const Plane& pl = e.g.planes[i];
    PlaneRecord rec{};
    rec.prim = e.g.plane_prim(i);
    // n . x_world = c with x_world = O + step * x_grid:  n . x_grid = (c - n . O) / step. Scale by 2^-(E+1)
    // so the largest normal component is in [1/2, 1); D fraction bits for n, F for the offset, nearest.
    const float m = std::max({std::abs(pl.normal.x), std::abs(pl.normal.y), std::abs(pl.normal.z)});
    if (!(m > 0.0f) || !std::isfinite(m) || !std::isfinite(pl.offset))
      throw std::invalid_argument("plane " + std::to_string(i) + ": zero or non-finite normal or offset");
    const int E = std::ilogb(m);
    double no = 0.0;
    for (int a = 0; a < 3; ++a) {
      rec.normal[a] = int32_t(std::nearbyint(std::ldexp(double(pl.normal[a]), e.f.dir_bits - E - 1)));
      no += double(pl.normal[a]) * std::ldexp(double(e.frame.origin[a]), e.frame.step_exp);
    }
    const double w = std::ldexp(double(pl.offset) - no, e.f.frac_bits - e.frame.step_exp - E - 1);
    const double wmax = std::ldexp(1.0, e.f.translated_bits());
    if (std::abs(w) >= wmax) {
      ++saturation_counter();  // a plane beyond the guard range: moved to its edge
      rec.offset = w > 0 ? int64_t(wmax) - 1 : 1 - int64_t(wmax);
    } else {
      rec.offset = int64_t(std::nearbyint(w));
    }
    return rec;
  }

  // Plane i of an image whose bounded primitives number num_bounded: a non-zero normal within 2^D, an offset in
  // the translated range, its index in primitive order after the bounded ones. Empty, or the problem.
  static std::string check(const PlaneRecord& pl, const FixedFormat& f, uint64_t num_bounded, uint32_t i) {
    const int64_t wmax = int64_t(1) << f.translated_bits();
    bool zero = true;
    for (int32_t c : pl.normal) {
      if (c < -(int64_t(1) << f.dir_bits) || c > (int64_t(1) << f.dir_bits)) return "plane normal out of range";
      zero = zero && c == 0;
    }
    if (zero || pl.offset <= -wmax || pl.offset >= wmax) return "plane " + std::to_string(i) + " invalid";
    if (pl.prim != num_bounded + i) return "plane " + std::to_string(i) + ": index out of order";
    return "";
  }

  // The plane's normal, the same on both sides.
  static Vec3 normal(const Geometry& g, uint32_t p, const Vec3&, float) {
    return g.planes[p - g.num_bounded()].normal;
  }
};

}  // namespace rtu::hw
