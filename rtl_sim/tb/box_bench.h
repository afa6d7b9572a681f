// The box unit's bench traits (bench.h) for rtl/box_unit.sv: its vectors (box_vectors.h) and their check, every
// slot's result bit-exact with hw::box_test_delta<int64_t> and conservative against hw::box_test_exact.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "rtl_sim/cosim/box_ports.h"
#include "rtl_sim/cosim/rtl_box_unit.h"
#include "rtl_sim/params/rtl_params.h"
#include "rtl_sim/tb/bench.h"
#include "rtl_sim/tb/box_vectors.h"

namespace rtu::rtl {

// Counts of what a comparison covered.
struct CompareStats {
  uint64_t nodes = 0, child_tests = 0, hits = 0, exact_accepts = 0, false_positives = 0, tnear_checked = 0,
           tnear_saturated = 0, neg_rcp_sh = 0, zero_axes = 0, reversed_intervals = 0, partial_nodes = 0;
};

// Empty when the unit's result for case c agrees with the model: the hit mask bit for bit (slots >= count never
// hit), t_near equal to the model's t0 saturated to +-2^TB wherever the model writes it (and unsaturated on every
// hit), and no box rejected that the exact test accepts.
inline std::string compare_node(const BoxUnitParams& p, const CaseSet& s, const BoxCase& c, const BoxOut& o,
                                CompareStats& st) {
  const BoxExpect e = expected(s, c);
  const hw::FixedRay& r = s.rays[c.ray];
  const int64_t sat = int64_t(1) << p.tb;
  ++st.nodes;
  st.partial_nodes += uint64_t(c.count < p.n);
  st.reversed_intervals += uint64_t(c.tlim < c.tmin);
  for (int a = 0; a < 3; ++a) {
    st.neg_rcp_sh += uint64_t(!r.zero[a] && r.rcp_sh[a] < 0);
    st.zero_axes += uint64_t(r.zero[a]);
  }
  std::ostringstream err;
  for (int i = 0; i < p.n; ++i) {
    const bool occupied = i < c.count, got = (o.hit >> i) & 1u;
    const ChildExpect& x = e.c[i];
    const bool want = occupied && x.hit;
    if (got != want) {
      err << "slot " << i << ": hit " << got << ", the model says " << want << (occupied ? "" : " (unoccupied)")
          << "; ";
      continue;
    }
    if (!occupied) continue;
    ++st.child_tests;
    st.hits += uint64_t(got);
    st.exact_accepts += uint64_t(x.exact);
    st.false_positives += uint64_t(got && !x.exact);
    if (x.exact && !got) err << "slot " << i << ": rejected, but the exact test accepts it; ";
    if (x.t_written) {
      const int64_t want_t = std::clamp(x.t_near, -sat, sat);
      ++st.tnear_checked;
      st.tnear_saturated += uint64_t(want_t != x.t_near);
      if (o.tnear[i] != want_t)
        err << "slot " << i << ": t_near " << o.tnear[i] << ", the model says " << want_t << " (t0 " << x.t_near
            << "); ";
      if (x.hit && want_t != x.t_near) err << "slot " << i << ": a hit's t_near is outside the t register; ";
    }
  }
  return err.str();
}

struct BoxBench : BoxPorts {
  using Set = CaseSet;
  using Case = BoxCase;
  using Stats = CompareStats;
  static constexpr bool kDrawAtFullRate = true;

  static Inputs inputs(const Set& s, const Case& c) { return unit_inputs(s, c); }
  static std::string compare(const Params& p, const Set& s, const Case& c, const Out& o, Stats& st) {
    return compare_node(p, s, c, o, st);
  }
  static std::string describe(const Set& s, const Case& c) { return rtl::describe(s, c); }
  static std::string describe(const Params& p, const Out& o) {
    std::ostringstream d;
    d << "unit: hit mask 0x" << std::hex << o.hit << std::dec << " t_near";
    for (int i = 0; i < p.n; ++i) d << " " << o.tnear[i];
    return d.str();
  }
  static uint64_t checked(const Stats& st) { return st.nodes; }
  static Set random_cases(const hw::FixedFormat& f, uint64_t seed, size_t n) {
    return rtl::random_cases(f, seed, n);
  }
  static const std::vector<RtlUnitInfo>& units() { return rtl_units(); }
  // A node of `count` children keeps the input for max(1, ceil(count / box_rate)) clocks (timing_model_units.cpp,
  // TimingModel::unit).
  static uint64_t issue(const hw::TimingConfig& c, const Inputs& in) {
    const uint64_t count = uint64_t(in.count), rate = uint64_t(c.box_rate);
    return std::max<uint64_t>(1, (count + rate - 1) / rate);
  }
  static int latency(const hw::TimingConfig& c) { return c.box_latency; }
  static bool one_per_clock(const hw::TimingConfig& c, const Params& p) { return c.box_rate >= p.n; }
  static void report(const std::string& what, const Stats& st, double secs) {
    std::printf(
        "rtl %-44s %7llu nodes %9llu child tests (%llu hits, %llu exact accepts, %llu false positives, %llu "
        "t_near checked, %llu saturated, %llu axes rcp_sh<0, %llu zero axes, %llu reversed intervals, %llu "
        "partial "
        "nodes) %.2f s\n",
        what.c_str(), (unsigned long long)st.nodes, (unsigned long long)st.child_tests,
        (unsigned long long)st.hits, (unsigned long long)st.exact_accepts, (unsigned long long)st.false_positives,
        (unsigned long long)st.tnear_checked, (unsigned long long)st.tnear_saturated,
        (unsigned long long)st.neg_rcp_sh, (unsigned long long)st.zero_axes,
        (unsigned long long)st.reversed_intervals, (unsigned long long)st.partial_nodes, secs);
    std::fflush(stdout);
  }
};

}  // namespace rtu::rtl
