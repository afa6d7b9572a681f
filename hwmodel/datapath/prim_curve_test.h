// The curve segment kind's tests (format/prim_curve.h; prim_test.h says what a PrimTest gives): the linear swept
// sphere in float (intersect_float.h) and in fixed point on the record (intersect_fixed.h's swept_sphere_test,
// whose widths FixedFormat::curve_limits proves).
#pragma once

#include <cstring>

#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/prim_test_base.h"

namespace rtu::hw {

template <>
struct PrimTest<CurvePrim> {
  static LeafPrim leaf(const Geometry& g, uint32_t p) {
    const CurveSegment& cs = g.curve(p);
    LeafPrim lp{};
    lp.prim = p | (g.opaque(p) ? 0u : kLeafNonOpaque);
    lp.a = cs.p0;
    lp.b = cs.p1;
    lp.c = Vec3(cs.r0, cs.r1, 0.0f);
    lp.prim |= kLeafCurve | ((cs.flags & kCurveCapStart) ? kLeafCapStart : 0u);
    return lp;
  }
  static bool test_float(const LeafPrim& lp, const RayPrecomp& rp, float tmin, float tmax, PrimHit& h) {
    return intersect_swept_sphere(lp.a, lp.c.x, lp.b, lp.c.y, (lp.prim & kLeafCapStart) != 0, rp, tmin, tmax, h);
  }
  static bool test_fixed(const FixedRay& r, const uint8_t* rec, int64_t tmin, int64_t tlim, FixedPrimHit& h, bool,
                         uint32_t& word) {
    CurveRecord c;
    std::memcpy(&c, rec, sizeof c);
    word = c.prim;
    return swept_sphere_test(r, c, tmin, tlim, h);
  }
};

}  // namespace rtu::hw
