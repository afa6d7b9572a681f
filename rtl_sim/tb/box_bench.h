// The box unit's testbench driver, for any Verilated parameter set of rtl/box_unit.sv: packs vectors into ports,
// streams them through the valid/ready handshake (with chosen or random valid and ready patterns), checks the
// protocol (results in order, each exactly once, outputs held while stalled), and compares every slot's result
// with the C++ model (bit-exact with hw::box_test_delta<int64_t>, conservative against hw::box_test_exact).
#pragma once

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "hwmodel/numeric/rng.h"
#include "rtl_sim/cosim/box_ports.h"
#include "rtl_sim/cosim/sim.h"
#include "rtl_sim/params/rtl_params.h"
#include "rtl_sim/tb/box_vectors.h"

namespace rtu::rtl {

// Input valid and output ready: each cycle high with these percentages (100: always). A presented input stays
// presented until taken (valid does not drop before the handshake).
struct Flow {
  uint32_t valid_pct = 100, ready_pct = 100;
  uint64_t seed = 1;
};

struct StreamResult {
  std::vector<BoxOut> outs;
  std::vector<uint64_t> in_edge, out_edge;  // rising edge (Sim::cycle) of each handshake
  std::string error;                        // protocol violation or timeout; empty when none
  uint64_t error_cycle = 0;                 // the cycle it was seen
  bool in_ready_dropped = false;            // in_ready was low while an input was presented
};

// Streams `in` through the unit (already reset). Tags count from tag0. Fails (error set) when no handshake
// happens for `stall_limit` cycles, when a result arrives out of order, when a stalled output changes, or when
// a result appears after the last one (a duplicate).
template <class Model>
StreamResult run_stream(Sim<Model>& sim, const BoxUnitParams& p, const std::vector<BoxInputs>& in,
                        const Flow& flow, uint32_t tag0, uint64_t stall_limit = 1000) {
  Model& m = sim.dut();
  hw::Pcg32 rng(flow.seed);
  StreamResult r;
  const uint32_t tag_mask = (1u << kTagBits) - 1;
  size_t next = 0;
  bool presenting = false, held = false;
  BoxOut held_out;
  uint64_t idle = 0;
  while (r.outs.size() < in.size()) {
    if (!presenting && next < in.size() && rng.next_u32() % 100 < flow.valid_pct) {
      drive_inputs(m, p, in[next], uint32_t(tag0 + next) & tag_mask);
      presenting = true;
    }
    m.in_valid = presenting;
    m.out_ready = rng.next_u32() % 100 < flow.ready_pct;
    sim.eval();
    if (held) {
      if (!m.out_valid || !read_outputs(m, p).same(held_out, p.n)) {
        r.error =
            "a stalled result changed or vanished before it was taken (cycle " + std::to_string(sim.cycle()) + ")";
        break;
      }
    }
    const bool in_fire = presenting && m.in_ready, out_fire = m.out_valid && m.out_ready;
    if (presenting && !m.in_ready) r.in_ready_dropped = true;
    if (out_fire) {
      const BoxOut o = read_outputs(m, p);
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
    if (!r.error.empty()) break;
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
    // Nothing more may come out: no result twice.
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

// Counts of what a comparison covered.
struct CompareStats {
  uint64_t nodes = 0, child_tests = 0, hits = 0, exact_accepts = 0, false_positives = 0, tnear_checked = 0,
           tnear_saturated = 0, neg_rcp_sh = 0, zero_axes = 0, reversed_intervals = 0, partial_nodes = 0;
  void add(const CompareStats& o) {
    nodes += o.nodes;
    child_tests += o.child_tests;
    hits += o.hits;
    exact_accepts += o.exact_accepts;
    false_positives += o.false_positives;
    tnear_checked += o.tnear_checked;
    tnear_saturated += o.tnear_saturated;
    neg_rcp_sh += o.neg_rcp_sh;
    zero_axes += o.zero_axes;
    reversed_intervals += o.reversed_intervals;
    partial_nodes += o.partial_nodes;
  }
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

// Runs a case set through a fresh simulation of Model in batches and compares every result. Returns the first
// problem (with the case, the model's answers and the VCD of the failing batch, re-run with tracing), or an
// empty string. With RTU_RTL_TRACE=1 the whole run is dumped too.
template <class Model>
std::string check_cases(const std::string& model, const BoxUnitParams& p, const CaseSet& s, const Flow& flow,
                        CompareStats& st, size_t batch = 4096) {
  std::string tag_name = "box_unit_" + model + "_" + s.name;
  std::replace_if(
      tag_name.begin(), tag_name.end(), [](char ch) { return !std::isalnum(uint8_t(ch)) && ch != '_'; }, '_');
  Sim<Model> sim(requested_vcd(tag_name), 0, requested_vcd_cycles());
  sim.dut().in_valid = 0;
  sim.dut().out_ready = 0;
  sim.reset();
  std::vector<BoxInputs> in;
  for (size_t first = 0; first < s.cases.size(); first += batch) {
    const size_t n = std::min(batch, s.cases.size() - first);
    in.clear();
    for (size_t k = 0; k < n; ++k) {
      in.push_back(unit_inputs(s, s.cases[first + k]));
      const std::string bad = contract_error(p, in.back());
      if (!bad.empty()) return bad + "\n" + describe(s, s.cases[first + k]);
    }
    Flow f = flow;
    f.seed = flow.seed + first;
    const StreamResult r = run_stream(sim, p, in, f, uint32_t(first));
    std::string problem, detail;
    size_t bad_index = 0;
    if (!r.error.empty()) {
      problem = r.error;
      bad_index = r.outs.size();
    } else {
      for (size_t k = 0; k < n && problem.empty(); ++k) {
        problem = compare_node(p, s, s.cases[first + k], r.outs[k], st);
        bad_index = k;
      }
      if (!problem.empty()) {
        const BoxOut& o = r.outs[bad_index];
        std::ostringstream d;
        d << "unit: hit mask 0x" << std::hex << o.hit << std::dec << " t_near";
        for (int i = 0; i < p.n; ++i) d << " " << o.tnear[i];
        detail = d.str() + "\n" + describe(s, s.cases[first + bad_index]);
      }
    }
    if (!problem.empty()) {
      // Re-run the batch from reset (the same stimulus: the flow is seeded by the batch) to find the cycle of
      // the failure, then once more with a VCD of the cycles around it.
      auto rerun = [&](const std::string& vcd, uint64_t from, uint64_t to) {
        Sim<Model> again(vcd, from, to);
        again.dut().in_valid = 0;
        again.dut().out_ready = 0;
        again.reset();
        return run_stream(again, p, in, f, uint32_t(first));
      };
      const StreamResult r2 = rerun("", 0, 0);
      const uint64_t at =
          !r2.error.empty() ? r2.error_cycle : (bad_index < r2.out_edge.size() ? r2.out_edge[bad_index] : 0);
      const uint64_t window = 64 + 4 * uint64_t(p.latency), from = at > window ? at - window : 0;
      const std::string vcd = vcd_path(tag_name + "_fail");
      rerun(vcd, from, at + 16);
      std::ostringstream msg;
      msg << model << " " << s.name << ", case " << first + bad_index << " of " << s.cases.size() << ": "
          << problem << "\n"
          << detail << "VCD of cycles " << from << ".." << at + 15 << " of the batch (cases " << first << ".."
          << first + n - 1 << " re-run from reset; the failure at cycle " << at << "): " << vcd;
      return msg.str();
    }
  }
  return std::string();
}

}  // namespace rtu::rtl
