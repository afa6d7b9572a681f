// The datapath's half of a primitive kind (format/prim_kind.h): PrimTest<K>, specialized beside each kind's format
// header (prim_<kind>_test.h). A bounded kind gives
//   - leaf(g, p): the float copy of scene primitive p that a float leaf holds (LeafPrim, float_tracer.h);
//   - test_float(lp, rp, tmin, tmax, h): the float reference test (intersect_float.h: robust, rounded once);
//   - test_fixed(r, rec, tmin, tlim, h, short_edges, word): the bit-accurate test on its record, whose bit widths
//     FixedFormat::validate (curves: FixedFormat::curve_limits) proves (intersect_fixed.h), word its prim word.
// A plane gives test_float and test_fixed on its own records. The tracers dispatch by record (fixed) or by scene
// kind (float) with a switch on the enum, the kinds' functions inlined through it.
#pragma once

#include "hwmodel/datapath/prim_curve_test.h"
#include "hwmodel/datapath/prim_plane_test.h"
#include "hwmodel/datapath/prim_sphere_test.h"
#include "hwmodel/datapath/prim_triangle_test.h"
