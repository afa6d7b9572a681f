// The sphere kind's tests (format/prim_sphere.h; prim_test.h says what a PrimTest gives): the stable quadratic in
// float (intersect_float.h) and its fixed-point form on the record (intersect_fixed.h's sphere_test).
#pragma once

#include <cstring>

#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/prim_test_base.h"

namespace rtu::hw {

template <>
struct PrimTest<SpherePrim> {
  static LeafPrim leaf(const Geometry& g, uint32_t p) {
    const Sphere& s = g.spheres[p - g.triangles.size()];
    LeafPrim lp{};
    lp.prim = p | (g.opaque(p) ? 0u : kLeafNonOpaque);
    lp.a = s.center;
    lp.b = Vec3(s.radius, 0.0f, 0.0f);
    return lp;
  }
  static bool test_float(const LeafPrim& lp, const RayPrecomp& rp, float tmin, float tmax, PrimHit& h) {
    return intersect_sphere(lp.a, lp.b.x, rp, tmin, tmax, h);
  }
  static bool test_fixed(const FixedRay& r, const uint8_t* rec, int64_t tmin, int64_t tlim, FixedPrimHit& h, bool,
                         uint32_t& word) {
    SphereRecord s;
    std::memcpy(&s, rec, sizeof s);
    word = s.prim;
    return sphere_test(r, s, tmin, tlim, h);
  }
};

}  // namespace rtu::hw
