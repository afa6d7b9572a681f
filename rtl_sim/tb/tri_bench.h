// The triangle unit's bench traits (bench.h) for rtl/tri_core.sv: its vectors (tri_vectors.h) and their check,
// every result bit for bit: hit and t with hw::triangle_test, e1, e2 and det with the general 128-bit edge
// functions, t with hw::div_shift(num, den) whenever den != 0 (hit or not), and u, v formed from the unit's
// integers as triangle_test forms them, with triangle_test's.
#pragma once

#include <cstdint>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "rtl_sim/cosim/rtl_tri_unit.h"
#include "rtl_sim/cosim/tri_ports.h"
#include "rtl_sim/params/tri_params.h"
#include "rtl_sim/tb/bench.h"
#include "rtl_sim/tb/tri_vectors.h"

namespace rtu::rtl {

inline TriInputs tri_inputs(const TriSet& s, const TriCase& c) {
  return tri_unit_inputs(s.rays[c.ray], c.v, c.tmin, c.tlim);
}

struct TriStats {
  uint64_t cases = 0, hits = 0, det_zero = 0, t_checked = 0, t_saturated = 0, uv_checked = 0, zero_dirs = 0,
           edge_zero = 0, reversed = 0;
};

// Empty when the unit's result for c agrees with the model bit for bit.
inline std::string compare_tri(const TriSet& s, const TriCase& c, const TriOut& o, TriStats& st) {
  const TriExpect e = expected(s, c);
  const hw::FixedRay& r = s.rays[c.ray];
  ++st.cases;
  st.hits += uint64_t(e.hit);
  st.det_zero += uint64_t(e.det == 0);
  st.zero_dirs += uint64_t(r.d[0] == 0 || r.d[1] == 0 || r.d[2] == 0);
  st.edge_zero += uint64_t(e.e0 == 0 || e.e1 == 0 || e.e2 == 0);
  st.reversed += uint64_t(c.tlim < c.tmin);
  std::ostringstream err;
  if (o.hit != e.hit) err << "hit " << o.hit << ", the model says " << e.hit << "; ";
  if (o.e1 != e.e1) err << "e1 " << to_string(o.e1) << ", the model says " << to_string(e.e1) << "; ";
  if (o.e2 != e.e2) err << "e2 " << to_string(o.e2) << ", the model says " << to_string(e.e2) << "; ";
  if (o.det != e.det) err << "det " << to_string(o.det) << ", the model says " << to_string(e.det) << "; ";
  if (e.den != 0) {
    ++st.t_checked;
    st.t_saturated += uint64_t(e.t_div == r.t_limit || e.t_div == -r.t_limit);
    if (o.t != e.t_div) err << "t " << o.t << ", div_shift says " << e.t_div << "; ";
  }
  if (e.hit) {
    if (o.t != e.t) err << "t " << o.t << ", triangle_test says " << e.t << "; ";
    // u, v as triangle_test forms them, from the unit's integers.
    float u, v;
    hw::triangle_barycentrics(o.e1, o.e2, o.det, u, v);
    ++st.uv_checked;
    if (u != e.u || v != e.v)
      err << "u, v " << u << ", " << v << ", triangle_test says " << e.u << ", " << e.v << "; ";
  }
  return err.str();
}

struct TriBench : TriPorts {
  using Set = TriSet;
  using Case = TriCase;
  using Stats = TriStats;
  static constexpr bool kDrawAtFullRate = false;

  static Inputs inputs(const Set& s, const Case& c) { return tri_inputs(s, c); }
  static std::string compare(const Params&, const Set& s, const Case& c, const Out& o, Stats& st) {
    return compare_tri(s, c, o, st);
  }
  static std::string describe(const Set& s, const Case& c) { return rtl::describe(s, c); }
  static std::string describe(const Params&, const Out& o) {
    return "unit: hit " + std::to_string(o.hit) + " t " + std::to_string(o.t) + " e1 " + to_string(o.e1) + " e2 " +
           to_string(o.e2) + " det " + to_string(o.det);
  }
  static uint64_t checked(const Stats& st) { return st.cases; }
  static Set random_cases(const hw::FixedFormat& f, uint64_t seed, size_t n) {
    return tri_random_cases(f, seed, n);
  }
  static const std::vector<RtlUnitInfo>& units() { return rtl_tri_units(); }
  static uint64_t issue(const hw::TimingConfig& c, const Inputs&) { return uint64_t(c.tri_rate); }
  static int latency(const hw::TimingConfig& c) { return c.tri_latency; }
  static bool one_per_clock(const hw::TimingConfig&, const Params&) { return true; }  // tri_rate is 1
  static void report(const std::string& what, const Stats& st, double secs) {
    std::printf(
        "rtl tri %-40s %8llu cases (%llu hits, %llu det 0, %llu t checked, %llu saturated, %llu u/v checked, %llu "
        "zero direction components, %llu zero edge functions, %llu reversed intervals) %.2f s\n",
        what.c_str(), (unsigned long long)st.cases, (unsigned long long)st.hits, (unsigned long long)st.det_zero,
        (unsigned long long)st.t_checked, (unsigned long long)st.t_saturated, (unsigned long long)st.uv_checked,
        (unsigned long long)st.zero_dirs, (unsigned long long)st.edge_zero, (unsigned long long)st.reversed, secs);
    std::fflush(stdout);
  }
};

}  // namespace rtu::rtl
