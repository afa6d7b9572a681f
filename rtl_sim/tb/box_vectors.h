// Test vectors for the RTL box unit and the C++ model's answers for them. A vector is one BVH node (origin,
// scale, child offsets, count) against one fixed-point ray (hw::FixedRay) over an interval [tmin, tlim]: exactly
// what the fixed tracer hands to its box test (hwmodel/datapath/fixed_tracer.cpp, FixedPolicy::expand_impl).
// Sources:
//   directed   corner cases built by hand (signed zero direction components, rays exactly through faces, edges
//              and corners, flat/point/inverted boxes, tiny direction components (rcp_sh < 0), the largest
//              magnitudes of every input, empty and reversed intervals, count < N)
//   random     seeded: aimed rays (exactly through a box corner), random directions with zero and tiny
//              components, intervals ending exactly at a plane distance
//   traversal  every node a real traversal visits: a fixed device image of a real mesh, rays traced with
//              FixedTracer::trace_recorded, each node event replayed with the ray and the closest hit so far
// Nothing here knows the RTL; the testbench (test_box_unit.cpp) turns vectors into port values.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/numeric/fixed_format.h"
#include "rtl_sim/cosim/box_ports.h"
#include "rtl_sim/tb/vectors.h"

namespace rtu::rtl {

struct BoxCase {
  uint32_t ray = 0;               // index into CaseSet::rays
  int32_t origin[3] = {0, 0, 0};  // node origin, grid
  int8_t exp[3] = {0, 0, 0};      // node scale per axis
  uint8_t count = 0;              // occupied slots (0..N)
  uint16_t q[6][kMaxWidth] = {};  // rows lo_x, hi_x, lo_y, hi_y, lo_z, hi_z; column = slot
  int64_t tmin = 0, tlim = 0;     // the interval, t raw
};

// Box vectors of one format (format.width = N).

struct CaseSet : VectorSet<BoxCase> {
  uint64_t child_tests() const;  // occupied slots over all cases
};

// The unit's inputs for a case (box_ports.h).
BoxInputs unit_inputs(const CaseSet& s, const BoxCase& c);

// The C++ model's answer for one slot: hw::box_test_delta<int64_t> on the planes decoded as the fixed tracer
// decodes them, and hw::box_test_exact on the grid box.
struct ChildExpect {
  bool hit = false;        // box_test_delta's result (before the occupancy mask)
  bool t_written = false;  // box_test_delta wrote t_near (it does not when a zero-direction slab test fails)
  int64_t t_near = 0;
  bool exact = false;  // the exact test accepts the box
};
struct BoxExpect {
  ChildExpect c[kMaxWidth];
};
BoxExpect expected(const CaseSet& s, const BoxCase& c);

// The grid box of slot i: lo = origin + (q_lo << exp), hi = origin + (q_hi << exp).
void child_box(const BoxCase& c, int i, int64_t lo[3], int64_t hi[3]);

CaseSet directed_cases(const hw::FixedFormat& f);
CaseSet random_cases(const hw::FixedFormat& f, uint64_t seed, size_t nodes);
// Loads `scene` (host::load_scene spec), builds a BVH of the format's width and the fixed device image, traces
// primary rays of the scene camera and seeded incoherent rays, and keeps every visited node until `max_nodes`.
CaseSet traversal_cases(const std::string& scene, const hw::FixedFormat& f, size_t max_nodes, uint64_t seed);

// Ray, node, interval and the model's answers, for failure messages.
std::string describe(const CaseSet& s, const BoxCase& c);

}  // namespace rtu::rtl
