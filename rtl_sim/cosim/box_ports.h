// The ports of rtl/box_unit.sv as integers, and their packing into a Verilated model of any parameter set: the
// one place that knows the port layout, shared by the testbench (tb/) and the co-simulation adapter
// (cosim/rtl_box_unit.cpp). BoxPorts are the unit's traits for the shared harness (cosim/rtl_unit.h).
#pragma once

#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "hwmodel/datapath/box_unit.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "rtl_sim/cosim/rtl_unit.h"
#include "rtl_sim/cosim/sim.h"
#include "rtl_sim/params/rtl_params.h"

namespace rtu::rtl {

inline constexpr int kMaxWidth = hw::kBoxUnitMaxWidth;
inline constexpr int kTagBits = 16;  // box_unit's TAGW default

// The unit's inputs for one node and ray, before packing.
struct BoxInputs {
  int64_t base[3];  // (origin << F) - ray origin
  int sh[3];        // exp + F
  uint32_t q[6][kMaxWidth];
  int count;
  int64_t rcpm_dn[3], rcpm_up[3];
  int rcp_sh[3];
  bool zero[3], neg[3];
  int64_t tmin, tlim;
};

// What the fixed tracer hands its box test (hw::BoxUnitNode) with the ray's reciprocals, as port values.
inline BoxInputs unit_inputs(const hw::FixedRay& r, const hw::BoxUnitNode& n, int64_t tmin, int64_t tlim) {
  BoxInputs in{};
  for (int a = 0; a < 3; ++a) {
    in.base[a] = n.base[a];
    in.sh[a] = n.sh[a];
    in.rcpm_dn[a] = r.rcpm_dn[a];
    in.rcpm_up[a] = r.rcpm_up[a];
    in.rcp_sh[a] = r.rcp_sh[a];
    in.zero[a] = r.zero[a];
    in.neg[a] = r.d[a] < 0;
  }
  for (int row = 0; row < 6; ++row)
    for (int i = 0; i < kMaxWidth; ++i) in.q[row][i] = n.q[row][i];
  in.count = n.count;
  in.tmin = tmin;
  in.tlim = tlim;
  return in;
}

struct BoxOut {
  uint32_t hit = 0;  // bit i: slot i
  int64_t tnear[kMaxWidth] = {};
  uint32_t tag = 0;
  bool same(const BoxOut& o, int n) const {
    if (hit != o.hit || tag != o.tag) return false;
    for (int i = 0; i < n; ++i)
      if (tnear[i] != o.tnear[i]) return false;
    return true;
  }
};

// Empty when the inputs are inside the unit's contract (every value fits its port; the unit's header).
inline std::string contract_error(const BoxUnitParams& p, const BoxInputs& in) {
  std::ostringstream e;
  const int64_t tmax = (int64_t(1) << p.tb) - 1;
  for (int a = 0; a < 3; ++a) {
    if (in.base[a] <= -(int64_t(1) << p.a) || in.base[a] >= (int64_t(1) << p.a)) e << "base[" << a << "] ";
    if (in.sh[a] < 0 || in.sh[a] >= (1 << p.shw)) e << "sh[" << a << "] ";
    if (!in.zero[a]) {
      if (std::abs(in.rcpm_dn[a]) > (int64_t(1) << p.m) || std::abs(in.rcpm_up[a]) > (int64_t(1) << p.m))
        e << "rcpm[" << a << "] ";
      if (in.rcp_sh[a] < -p.lsh || in.rcp_sh[a] > p.rsh) e << "rcp_sh[" << a << "] ";
    }
    for (int i = 0; i < p.n; ++i)
      for (int r = 2 * a; r < 2 * a + 2; ++r) {
        if (in.q[r][i] >= (1u << p.k)) e << "q[" << r << "][" << i << "] ";
        // The decoded planes must stay below 2^A (always so for an encoded node and a ray in its frame).
        const int64_t plane = in.base[a] + (int64_t(in.q[r][i]) << in.sh[a]);
        if (plane <= -(int64_t(1) << p.a) || plane >= (int64_t(1) << p.a)) e << "plane[" << r << "][" << i << "] ";
      }
  }
  if (in.count < 0 || in.count > p.n) e << "count ";
  if (std::abs(in.tmin) > tmax || std::abs(in.tlim) > tmax) e << "interval ";
  const std::string s = e.str();
  return s.empty() ? s : "inputs outside the unit's contract: " + s;
}

template <class Model>
void drive_inputs(Model& m, const BoxUnitParams& p, const BoxInputs& in, uint32_t tag) {
  for (int a = 0; a < 3; ++a) {
    put_bits(m.in_base, a * (p.a + 1), p.a + 1, uint64_t(in.base[a]));
    put_bits(m.in_sh, a * p.shw, p.shw, uint64_t(in.sh[a]));
    put_bits(m.in_rcpm_dn, a * (p.m + 2), p.m + 2, uint64_t(in.rcpm_dn[a]));
    put_bits(m.in_rcpm_up, a * (p.m + 2), p.m + 2, uint64_t(in.rcpm_up[a]));
    put_bits(m.in_rcp_sh, a * p.rsw(), p.rsw(), uint64_t(int64_t(in.rcp_sh[a])));
    put_bits(m.in_zero, a, 1, in.zero[a] ? 1 : 0);
    put_bits(m.in_neg, a, 1, in.neg[a] ? 1 : 0);
  }
  for (int r = 0; r < 6; ++r)
    for (int i = 0; i < p.n; ++i) put_bits(m.in_q, (r * p.n + i) * p.k, p.k, in.q[r][i]);
  put_bits(m.in_count, 0, p.cw(), uint64_t(in.count));
  put_bits(m.in_tmin, 0, p.tb + 1, uint64_t(in.tmin));
  put_bits(m.in_tlim, 0, p.tb + 1, uint64_t(in.tlim));
  put_bits(m.in_tag, 0, kTagBits, tag);
}

template <class Model>
BoxOut read_outputs(const Model& m, const BoxUnitParams& p) {
  BoxOut o;
  o.hit = uint32_t(get_bits(m.out_hit, 0, p.n));
  for (int i = 0; i < p.n; ++i)
    o.tnear[i] = sign_extend(get_bits(m.out_tnear, i * (p.tb + 2), p.tb + 2), p.tb + 2);
  o.tag = uint32_t(get_bits(m.out_tag, 0, kTagBits));
  return o;
}

struct BoxPorts {
  using Params = BoxUnitParams;
  using Inputs = BoxInputs;
  using Out = BoxOut;
  static constexpr const char* kKey = "box_unit";
  static constexpr const char* kItem = "node";
  static constexpr const char* kVcd = "box_unit";
  static constexpr int kTagBits = rtl::kTagBits;
  static Params params(const hw::TimingConfig& c) { return box_unit_params(c); }
  static bool same(const Params& p, const Out& a, const Out& b) { return a.same(b, p.n); }
  static std::string describe(const RtlUnitInfo& u) { return u.name + " (" + u.spec + "): " + u.args; }
};

}  // namespace rtu::rtl
