// The triangle-unit seam: where the fixed tracer hands one triangle record and one ray to a triangle unit other
// than its own C++ triangle test (hwmodel/datapath/intersect_fixed.h, triangle_test), e.g. the Verilated RTL unit
// of rtl_sim/ (co-simulation, `--set tri_unit=rtl`). As box_unit.h: hwmodel defines the seam and never sees an
// implementation (docs/architecture.md). Spheres and planes stay with the C++ tests.
//
// A unit tests one triangle (the record's three grid vertices) over [tmin, tlim] and answers whether it is hit,
// its t (t raw; meaningful for a hit only) and the integers the barycentrics come from: the edge functions e1, e2
// and their sum det (u = e1 / det, v = e2 / det, formed in double by the tracer exactly as triangle_test forms
// them), plus the clocks the request took: `issue` (clocks the unit's input was busy with this triangle) and
// `result` (clocks from the triangle being taken to its result leaving). The timing model uses these two figures
// for that triangle instead of the configuration's one issue clock and tri_latency, so cycles follow the unit
// that answered. A unit must give triangle_test's answers bit for bit; the fixed tracer does not check this (the
// RTL testbench and the co-simulation tests do).
#pragma once

#include <cstdint>

#include "hwmodel/datapath/intersect_fixed.h"

namespace rtu::hw {

struct TriUnitResult {
  bool hit = false;
  int64_t t = 0;                 // t raw (meaningful when hit)
  Wide e1 = 0, e2 = 0, det = 0;  // edge functions of v1 and v2 and their sum (meaningful when hit)
  uint32_t issue = 0;            // clocks the unit's input was busy with the triangle (>= 1)
  uint32_t result = 0;           // clocks from the triangle taken to its result leaving (>= issue)
};

class TriUnit {
 public:
  virtual ~TriUnit() = default;
  // A short name for statistics and messages ("rtl").
  virtual const char* name() const = 0;
  // Throws std::invalid_argument when the unit cannot test triangles of this format (other widths than the unit
  // was built for).
  virtual void check_format(const FixedFormat& f) const = 0;
  // Tests one triangle of grid vertices v. Not thread-safe: a tracer with a unit traces on one thread.
  virtual void test(const FixedRay& r, const int32_t v[3][3], int64_t tmin, int64_t tlim, TriUnitResult& out) = 0;
};

}  // namespace rtu::hw
