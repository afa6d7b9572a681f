// The triangle kind's tests (format/prim_triangle.h; prim_test.h says what a PrimTest gives): Woop's watertight
// test in float (intersect_float.h) and the integer watertight test on grid vertices (intersect_fixed.h's
// triangle_test, exact edge functions, t rounded once).
#pragma once

#include <cstring>

#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/prim_test_base.h"

namespace rtu::hw {

template <>
struct PrimTest<TrianglePrim> {
  static LeafPrim leaf(const Geometry& g, uint32_t p) {
    const Triangle& t = g.triangles[p];
    LeafPrim lp{};
    lp.prim = p | (g.opaque(p) ? 0u : kLeafNonOpaque);
    lp.a = t.v0;
    lp.b = t.v1;
    lp.c = t.v2;
    return lp;
  }
  static bool test_float(const LeafPrim& lp, const RayPrecomp& rp, float tmin, float tmax, PrimHit& h) {
    return intersect_triangle(lp.a, lp.b, lp.c, rp, tmin, tmax, h);
  }
  static bool test_fixed(const FixedRay& r, const uint8_t* rec, int64_t tmin, int64_t tlim, FixedPrimHit& h,
                         bool short_edges, uint32_t& word) {
    TriangleRecord t;
    std::memcpy(&t, rec, sizeof t);
    word = t.prim;
    return triangle_test(r, t.v, tmin, tlim, h, short_edges);
  }
};

}  // namespace rtu::hw
