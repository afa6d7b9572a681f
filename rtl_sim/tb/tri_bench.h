// The triangle unit's testbench driver, for any Verilated parameter set of rtl/tri_core.sv: packs vectors into
// ports, streams them through the valid/ready handshake (chosen or random valid and ready patterns), checks the
// protocol (results in order, each exactly once, outputs held while stalled, nothing after the last), and
// compares every result with the C++ model bit for bit: hit and t with hw::triangle_test, e1, e2 and det with
// the general 128-bit edge functions, t with hw::div_shift(num, den) whenever den != 0 (hit or not), and u, v
// formed from the unit's integers as triangle_test forms them, with triangle_test's.
#pragma once

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "hwmodel/numeric/rng.h"
#include "rtl_sim/cosim/sim.h"
#include "rtl_sim/cosim/tri_ports.h"
#include "rtl_sim/params/tri_params.h"
#include "rtl_sim/tb/tri_vectors.h"

namespace rtu::rtl {

inline TriInputs tri_inputs(const TriSet& s, const TriCase& c) {
  return tri_unit_inputs(s.rays[c.ray], c.v, c.tmin, c.tlim);
}

struct Flow {
  uint32_t valid_pct = 100, ready_pct = 100;
  uint64_t seed = 1;
};

struct TriStream {
  std::vector<TriOut> outs;
  std::vector<uint64_t> in_edge, out_edge;
  std::string error;
  uint64_t error_cycle = 0;
  bool in_ready_dropped = false;
};

// Streams `in` through the unit (already reset); tags count from tag0. Fails on a stall of `stall_limit`
// cycles, a result out of order, a stalled output that changes, or a result after the last one.
template <class Model>
TriStream run_stream(Sim<Model>& sim, const TriUnitParams& p, const std::vector<TriInputs>& in, const Flow& flow,
                     uint32_t tag0, uint64_t stall_limit = 1000) {
  Model& m = sim.dut();
  hw::Pcg32 rng(flow.seed);
  TriStream r;
  const uint32_t tag_mask = (1u << kTriTagBits) - 1;
  size_t next = 0;
  bool presenting = false, held = false;
  TriOut held_out;
  uint64_t idle = 0;
  while (r.outs.size() < in.size()) {
    if (!presenting && next < in.size() && (flow.valid_pct >= 100 || rng.next_u32() % 100 < flow.valid_pct)) {
      drive_inputs(m, p, in[next], uint32_t(tag0 + next) & tag_mask);
      presenting = true;
    }
    m.in_valid = presenting;
    m.out_ready = flow.ready_pct >= 100 || rng.next_u32() % 100 < flow.ready_pct;
    sim.eval();
    if (held && (!m.out_valid || !(read_outputs(m, p) == held_out))) {
      r.error =
          "a stalled result changed or vanished before it was taken (cycle " + std::to_string(sim.cycle()) + ")";
      break;
    }
    const bool in_fire = presenting && m.in_ready, out_fire = m.out_valid && m.out_ready;
    if (presenting && !m.in_ready) r.in_ready_dropped = true;
    if (out_fire) {
      const TriOut o = read_outputs(m, p);
      const uint32_t want = uint32_t(tag0 + r.outs.size()) & tag_mask;
      if (o.tag != want) {
        r.error = "result " + std::to_string(r.outs.size()) + " carries tag " + std::to_string(o.tag) +
                  ", expected " + std::to_string(want) + " (lost, duplicated or reordered)";
        break;
      }
      r.outs.push_back(o);
      r.out_edge.push_back(sim.cycle());
    }
    held = m.out_valid && !m.out_ready;
    if (held) held_out = read_outputs(m, p);
    if (in_fire) {
      r.in_edge.push_back(sim.cycle());
      ++next;
      presenting = false;
    }
    idle = (in_fire || out_fire) ? 0 : idle + 1;
    if (idle > stall_limit) {
      r.error = "timeout: no handshake for " + std::to_string(stall_limit) + " cycles with " +
                std::to_string(r.outs.size()) + " of " + std::to_string(in.size()) + " results out";
      break;
    }
    sim.tick();
  }
  if (!r.error.empty()) r.error_cycle = sim.cycle();
  m.in_valid = 0;
  if (r.error.empty()) {
    m.out_ready = 1;
    for (int k = 0; k < p.latency + 2; ++k) {
      sim.eval();
      if (m.out_valid) {
        r.error = "a result after the last one (cycle " + std::to_string(sim.cycle()) + ")";
        r.error_cycle = sim.cycle();
        break;
      }
      sim.tick();
    }
  }
  return r;
}

struct TriStats {
  uint64_t cases = 0, hits = 0, det_zero = 0, t_checked = 0, t_saturated = 0, uv_checked = 0, zero_dirs = 0,
           edge_zero = 0, reversed = 0;
  void add(const TriStats& o) {
    cases += o.cases;
    hits += o.hits;
    det_zero += o.det_zero;
    t_checked += o.t_checked;
    t_saturated += o.t_saturated;
    uv_checked += o.uv_checked;
    zero_dirs += o.zero_dirs;
    edge_zero += o.edge_zero;
    reversed += o.reversed;
  }
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

// Runs a case set through a fresh simulation in batches and compares every result. Returns the first problem
// (case, model answers, VCD of the failing batch re-run from reset), or "". Fills `outs` when given.
template <class Model>
std::string check_tri_cases(const std::string& model, const TriUnitParams& p, const TriSet& s, const Flow& flow,
                            TriStats& st, std::vector<TriOut>* outs = nullptr, size_t batch = 4096) {
  std::string name = "tri_unit_" + model + "_" + s.name;
  std::replace_if(
      name.begin(), name.end(), [](char ch) { return !std::isalnum(uint8_t(ch)) && ch != '_'; }, '_');
  Sim<Model> sim(requested_vcd(name), 0, requested_vcd_cycles());
  sim.dut().in_valid = 0;
  sim.dut().out_ready = 0;
  sim.reset();
  std::vector<TriInputs> in;
  for (size_t first = 0; first < s.cases.size(); first += batch) {
    const size_t n = std::min(batch, s.cases.size() - first);
    in.clear();
    for (size_t k = 0; k < n; ++k) {
      in.push_back(tri_inputs(s, s.cases[first + k]));
      const std::string bad = contract_error(p, in.back());
      if (!bad.empty()) return bad + "\n" + describe(s, s.cases[first + k]);
    }
    Flow f = flow;
    f.seed = flow.seed + first;
    const TriStream r = run_stream(sim, p, in, f, uint32_t(first));
    std::string problem;
    size_t bad = 0;
    if (!r.error.empty()) {
      problem = r.error;
      bad = r.outs.size();
    } else {
      for (size_t k = 0; k < n && problem.empty(); ++k) {
        problem = compare_tri(s, s.cases[first + k], r.outs[k], st);
        bad = k;
      }
      if (outs) outs->insert(outs->end(), r.outs.begin(), r.outs.end());
    }
    if (!problem.empty()) {
      auto rerun = [&](const std::string& vcd, uint64_t from, uint64_t to) {
        Sim<Model> again(vcd, from, to);
        again.dut().in_valid = 0;
        again.dut().out_ready = 0;
        again.reset();
        return run_stream(again, p, in, f, uint32_t(first));
      };
      const TriStream r2 = rerun("", 0, 0);
      const uint64_t at = !r2.error.empty() ? r2.error_cycle : (bad < r2.out_edge.size() ? r2.out_edge[bad] : 0);
      const uint64_t window = 64 + 4 * uint64_t(p.latency), from = at > window ? at - window : 0;
      const std::string vcd = vcd_path(name + "_fail");
      rerun(vcd, from, at + 16);
      std::ostringstream msg;
      msg << model << " " << s.name << ", case " << first + bad << " of " << s.cases.size() << ": " << problem
          << "\n"
          << describe(s, s.cases[first + std::min(bad, n - 1)]) << "VCD of cycles " << from << ".." << at + 15
          << " of the batch (cases " << first << ".." << first + n - 1 << " re-run from reset): " << vcd;
      return msg.str();
    }
  }
  return std::string();
}

}  // namespace rtu::rtl
