// Test vectors for the RTL triangle unit (rtl/tri_core.sv) and the C++ model's answers for them. A vector is one
// triangle record's grid vertices against one fixed-point ray (hw::FixedRay) over an interval [tmin, tlim]:
// exactly what the fixed tracer hands to hw::triangle_test. Sources:
//   directed    corner cases by hand: degenerate triangles (repeated or collinear vertices), vertices at both
//               ends of the grid, rays with one or two zero direction components, origins at the edge of the
//               guard range, the largest direction, intervals at, one below and one above the hit distance
//   random      seeded triangles (anywhere, small, degenerate, at the grid's ends) and rays (aimed exactly at a
//               point, vertex or edge of the triangle, or random with zero components), intervals around t
//   watertight  grid rays exactly through vertices and edge points of a closed mesh (builtin:icosphere), each
//               against every triangle sharing that vertex or edge
//   traversal   every triangle a real traversal tests: a fixed device image of a real mesh, rays traced with
//               FixedTracer::trace_recorded, each primitive event replayed with the closest hit so far
// Nothing here knows the RTL; the testbench (tri_bench.h, test_tri_unit.cpp) turns vectors into port values.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/numeric/fixed.h"
#include "hwmodel/numeric/fixed_format.h"
#include "rtl_sim/tb/vectors.h"

namespace rtu::rtl {

struct TriCase {
  uint32_t ray = 0;   // index into TriSet::rays
  int32_t v[3][3]{};  // grid vertices
  int64_t tmin = 0, tlim = 0;
  uint32_t group = 0;  // watertight sets: the rays' shared-edge group (cases of one group share a ray and edge)
};

struct TriSet : VectorSet<TriCase> {
  uint32_t groups = 0;  // watertight sets: rays through a shared vertex or edge
};

// The C++ model's answer: hw::triangle_test (hit, t, u, v), and the integers the unit outputs, by the general
// 128-bit definition: e_i = d . (A_j x A_k), det, num = N . A0, den = N . d, and div_shift(num, den) (when den !=
// 0).
struct TriExpect {
  bool hit = false;
  int64_t t = 0;       // triangle_test's t (on a hit)
  float u = 0, v = 0;  // triangle_test's u, v (on a hit)
  hw::Wide e0 = 0, e1 = 0, e2 = 0, det = 0, num = 0, den = 0;
  int64_t t_div = 0;  // div_shift(num, den, t_shift, nearest even, t_limit) when den != 0
};
TriExpect expected(const TriSet& s, const TriCase& c);

TriSet tri_directed_cases(const hw::FixedFormat& f);
TriSet tri_random_cases(const hw::FixedFormat& f, uint64_t seed, size_t n);
TriSet tri_watertight_cases(const std::string& scene, const hw::FixedFormat& f, uint64_t seed, size_t n);
TriSet tri_traversal_cases(const std::string& scene, const hw::FixedFormat& f, size_t max_cases, uint64_t seed);

std::string describe(const TriSet& s, const TriCase& c);
std::string to_string(hw::Wide x);

}  // namespace rtu::rtl
