// The box-unit seam: where the fixed tracer hands one BVH node and one ray to a box unit other than its own C++
// box test (hwmodel/datapath/intersect_fixed.h, box_test_delta), e.g. the Verilated RTL unit of rtl_sim/
// (co-simulation,
// `--set box_unit=rtl`). hwmodel defines the seam and never sees an implementation (docs/architecture.md).
//
// A unit tests every occupied child box of a node in one request and answers, per child, whether the box is hit
// over [tmin, tlim] and the entry distance t_near (t raw; meaningful for hit children only), plus the clocks the
// request took: `issue` (clocks the unit's input was busy with this node) and `result` (clocks from the node
// being taken to its result leaving). The timing model uses these two figures for that node instead of the
// configuration's box_rate and box_latency, so cycles follow the unit that answered. A unit must give the C++
// box test's answers bit for bit; the fixed tracer does not check this (the RTL testbench and the co-simulation
// tests do).
#pragma once

#include <cstdint>

#include "hwmodel/datapath/intersect_fixed.h"

namespace rtu::hw {

inline constexpr int kBoxUnitMaxWidth = 8;

// One node as the box unit's input ports see it: the decoded node relative to the ray origin (the tracer's
// FixedPolicy::expand_impl computes the same): child plane = base[a] + (q << sh[a]) in grid.F.
struct BoxUnitNode {
  int64_t base[3];                  // (node origin << F) - ray origin, per axis
  int sh[3];                        // node exponent + F, per axis
  uint16_t q[6][kBoxUnitMaxWidth];  // rows lo_x, hi_x, lo_y, hi_y, lo_z, hi_z; column = child slot
  int count;                        // occupied child slots (they come first)
};

struct BoxUnitResult {
  uint32_t hit = 0;                       // bit i: child i hit (never set for i >= count)
  int64_t t_near[kBoxUnitMaxWidth] = {};  // entry distance of hit children, t raw
  uint32_t issue = 0;                     // clocks the unit's input was busy with the node (>= 1)
  uint32_t result = 0;                    // clocks from the node taken to its result leaving (>= issue)
};

class BoxUnit {
 public:
  virtual ~BoxUnit() = default;
  // A short name for statistics and messages ("rtl").
  virtual const char* name() const = 0;
  // Throws std::invalid_argument when the unit cannot test nodes of this format and width (a different set of
  // widths than the unit was built for).
  virtual void check_format(const FixedFormat& f, int width) const = 0;
  // Tests one node. Not thread-safe: a tracer with a unit traces on one thread.
  virtual void test(const FixedRay& r, const BoxUnitNode& node, int64_t tmin, int64_t tlim,
                    BoxUnitResult& out) = 0;
};

}  // namespace rtu::hw
