// The ports of rtl/tri_core.sv as integers, and their packing into a Verilated model of any parameter set: the
// one place that knows the port layout, shared by the testbench (tb/tri_bench.h) and the co-simulation adapter
// (cosim/rtl_tri_unit.cpp). TriPorts are the unit's traits for the shared harness (cosim/rtl_unit.h).
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <string>

#include "hwmodel/datapath/intersect_fixed.h"
#include "rtl_sim/cosim/rtl_unit.h"
#include "rtl_sim/cosim/sim.h"
#include "rtl_sim/params/rtl_params.h"
#include "rtl_sim/params/tri_params.h"

namespace rtu::rtl {

inline constexpr int kTriTagBits = 16;  // tri_core's TAGW default

struct TriInputs {
  int64_t v[3][3];
  int64_t o[3], d[3];
  int64_t tmin, tlim;
};

// What the fixed tracer hands its triangle test (a record's grid vertices, the ray, the interval), as port values.
inline TriInputs tri_unit_inputs(const hw::FixedRay& r, const int32_t v[3][3], int64_t tmin, int64_t tlim) {
  TriInputs in{};
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a) in.v[i][a] = v[i][a];
  for (int a = 0; a < 3; ++a) {
    in.o[a] = r.o[a];
    in.d[a] = r.d[a];
  }
  in.tmin = tmin;
  in.tlim = tlim;
  return in;
}

// Empty when the inputs are inside the unit's contract (tri_core.sv's header).
inline std::string contract_error(const TriUnitParams& p, const TriInputs& in) {
  std::ostringstream e;
  const int64_t tmax = (int64_t(1) << p.tb) - 1, olim = int64_t(1) << (p.a - 1), dlim = int64_t(1) << p.d;
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a)
      if (in.v[i][a] < 0 || in.v[i][a] >= (int64_t(1) << p.b)) e << "v[" << i << "][" << a << "] ";
  for (int a = 0; a < 3; ++a) {
    if (in.o[a] <= -olim || in.o[a] >= olim) e << "o[" << a << "] ";
    if (in.d[a] < -dlim || in.d[a] > dlim) e << "d[" << a << "] ";
  }
  if (std::abs(in.tmin) > tmax || std::abs(in.tlim) > tmax) e << "interval ";
  const std::string s = e.str();
  return s.empty() ? s : "inputs outside the unit's contract: " + s;
}

struct TriOut {
  bool hit = false;
  int64_t t = 0;
  hw::Wide e1 = 0, e2 = 0, det = 0;
  uint32_t tag = 0;
  bool operator==(const TriOut&) const = default;
};

template <class Model>
void drive_inputs(Model& m, const TriUnitParams& p, const TriInputs& in, uint32_t tag) {
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a) put_bits(m.in_v, (3 * i + a) * p.b, p.b, uint64_t(in.v[i][a]));
  for (int a = 0; a < 3; ++a) {
    put_bits(m.in_o, a * p.a, p.a, uint64_t(in.o[a]));
    put_bits(m.in_d, a * p.dw(), p.dw(), uint64_t(in.d[a]));
  }
  put_bits(m.in_tmin, 0, p.tb + 1, uint64_t(in.tmin));
  put_bits(m.in_tlim, 0, p.tb + 1, uint64_t(in.tlim));
  put_bits(m.in_tag, 0, kTriTagBits, tag);
}

// A signed port of `width` <= 128 bits.
template <class Port>
hw::Wide get_wide(const Port& port, int width) {
  const int lo = std::min(width, 64), hi = width - lo;
  unsigned __int128 u = get_bits(port, 0, lo);
  if (hi > 0) u |= (unsigned __int128)get_bits(port, 64, hi) << 64;
  const int sh = 128 - width;
  return hw::Wide(u << sh) >> sh;
}

template <class Model>
TriOut read_outputs(const Model& m, const TriUnitParams& p) {
  TriOut o;
  o.hit = m.out_hit != 0;
  o.t = sign_extend(get_bits(m.out_t, 0, p.tb + 1), p.tb + 1);
  o.e1 = get_wide(m.out_e1, p.ew());
  o.e2 = get_wide(m.out_e2, p.ew());
  o.det = get_wide(m.out_det, p.ew());
  o.tag = uint32_t(get_bits(m.out_tag, 0, kTriTagBits));
  return o;
}

struct TriPorts {
  using Params = TriUnitParams;
  using Inputs = TriInputs;
  using Out = TriOut;
  static constexpr const char* kKey = "tri_unit";
  static constexpr const char* kItem = "triangle";
  static constexpr const char* kVcd = "tri_unit";
  static constexpr int kTagBits = kTriTagBits;
  static Params params(const hw::TimingConfig& c) { return tri_unit_params(c); }
  static bool same(const Params&, const Out& a, const Out& b) { return a == b; }
  // With the format and tri_latency of the configuration the model was derived from.
  static std::string describe(const RtlUnitInfo& u) {
    const hw::TimingConfig c = unit_config(u.spec);
    return u.name + " (format " + c.format + ", tri_latency " + std::to_string(c.tri_latency) + "): " + u.args;
  }
};

}  // namespace rtu::rtl
