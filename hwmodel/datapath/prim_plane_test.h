// The plane kind's tests (format/prim_plane.h; prim_test.h says what a PrimTest gives): t = (c - o.n) / (d.n) in
// float (intersect_float.h) and in fixed point on the record (intersect_fixed.h's plane_test). Planes are tested
// per ray, before the BVH.
#pragma once

#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/datapath/intersect_float.h"
#include "hwmodel/datapath/prim_test_base.h"

namespace rtu::hw {

template <>
struct PrimTest<PlanePrim> {
  static bool test_float(const Plane& p, const RayPrecomp& rp, float tmin, float tmax, PrimHit& h) {
    return intersect_plane(p, rp, tmin, tmax, h);
  }
  static bool test_fixed(const FixedRay& r, const PlaneRecord& p, int64_t tmin, int64_t tlim, FixedPrimHit& h) {
    return plane_test(r, p, tmin, tlim, h);
  }
};

}  // namespace rtu::hw
