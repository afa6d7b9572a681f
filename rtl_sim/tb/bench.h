// The testbench driver of every RTL unit, for any Verilated parameter set: streams vectors through the
// valid/ready handshake (with chosen or random valid and ready patterns), checks the protocol (results in order,
// each exactly once, outputs held while stalled, nothing after the last) and compares every result with the C++
// model. A unit's bench traits (box_bench.h: BoxBench, tri_bench.h: TriBench) extend its port traits
// (cosim/rtl_unit.h) with its vectors and their checks:
//   Set, Case, Stats          a set of vectors (name, rays, cases, traced_rays: vectors.h), one vector, the counts
//                             of what a comparison covered (Stats::add)
//   kDrawAtFullRate           whether a 100% valid or ready still draws from the random pattern each cycle
//   inputs(s, c)              a vector as the unit's inputs
//   compare(p, s, c, o, st)   "" when the unit's output o for c agrees with the model, else what differs
//   describe(s, c)            the vector and the model's answers; describe(p, o) the unit's output
//   checked(st)               how many vectors a comparison covered
//   random_cases(f, seed, n)  seeded random vectors of a format
//   units()                   the models this build verilated (rtl_units(), rtl_tri_units())
//   issue(cfg, in)            the clocks an input keeps the unit's input busy in configuration cfg
//   latency(cfg)              the configuration's latency of the unit (box_latency, tri_latency)
//   one_per_clock(cfg, p)     whether every input is taken in one clock
//   report(what, st, secs)    one line of the test log
#pragma once

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_sim/cosim/sim.h"
#include "rtl_sim/params/rtl_params.h"

namespace rtu::rtl {

// Input valid and output ready: each cycle high with these percentages (100: always). A presented input stays
// presented until taken (valid does not drop before the handshake).
struct Flow {
  uint32_t valid_pct = 100, ready_pct = 100;
  uint64_t seed = 1;
};

template <class Out>
struct Stream {
  std::vector<Out> outs;
  std::vector<uint64_t> in_edge, out_edge;  // rising edge (Sim::cycle) of each handshake
  std::string error;                        // protocol violation or timeout; empty when none
  uint64_t error_cycle = 0;                 // the cycle it was seen
  bool in_ready_dropped = false;            // in_ready was low while an input was presented
};

// Streams `in` through the unit (already reset). Tags count from tag0. Fails (error set) when no handshake
// happens for `stall_limit` cycles, when a result arrives out of order, when a stalled output changes, or when
// a result appears after the last one (a duplicate).
template <class Bench, class Model>
Stream<typename Bench::Out> run_stream(Sim<Model>& sim, const typename Bench::Params& p,
                                       const std::vector<typename Bench::Inputs>& in, const Flow& flow,
                                       uint32_t tag0, uint64_t stall_limit = 1000) {
  using Out = typename Bench::Out;
  Model& m = sim.dut();
  hw::Pcg32 rng(flow.seed);
  auto draw = [&](uint32_t pct) { return (!Bench::kDrawAtFullRate && pct >= 100) || rng.next_u32() % 100 < pct; };
  Stream<Out> r;
  const uint32_t tag_mask = (1u << Bench::kTagBits) - 1;
  size_t next = 0;
  bool presenting = false, held = false;
  Out held_out;
  uint64_t idle = 0;
  while (r.outs.size() < in.size()) {
    if (!presenting && next < in.size() && draw(flow.valid_pct)) {
      drive_inputs(m, p, in[next], uint32_t(tag0 + next) & tag_mask);
      presenting = true;
    }
    m.in_valid = presenting;
    m.out_ready = draw(flow.ready_pct);
    sim.eval();
    if (held && (!m.out_valid || !Bench::same(p, read_outputs(m, p), held_out))) {
      r.error =
          "a stalled result changed or vanished before it was taken (cycle " + std::to_string(sim.cycle()) + ")";
      break;
    }
    const bool in_fire = presenting && m.in_ready, out_fire = m.out_valid && m.out_ready;
    if (presenting && !m.in_ready) r.in_ready_dropped = true;
    if (out_fire) {
      const Out o = read_outputs(m, p);
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

// Valid and ready low, then a reset: the state every run starts from.
template <class Model>
void idle_reset(Sim<Model>& sim) {
  sim.dut().in_valid = 0;
  sim.dut().out_ready = 0;
  sim.reset();
}

// Runs a case set through a fresh simulation of Model in batches and compares every result. Returns the first
// problem (with the case, the unit's and the model's answers and the VCD of the failing batch, re-run with
// tracing), or an empty string. With RTU_RTL_TRACE=1 the whole run is dumped too. Fills `outs` when given.
template <class Bench, class Model>
std::string check_cases(const std::string& model, const typename Bench::Params& p, const typename Bench::Set& s,
                        const Flow& flow, typename Bench::Stats& st,
                        std::vector<typename Bench::Out>* outs = nullptr, size_t batch = 4096) {
  std::string tag_name = std::string(Bench::kVcd) + "_" + model + "_" + s.name;
  std::replace_if(
      tag_name.begin(), tag_name.end(), [](char ch) { return !std::isalnum(uint8_t(ch)) && ch != '_'; }, '_');
  Sim<Model> sim(requested_vcd(tag_name), 0, requested_vcd_cycles());
  idle_reset(sim);
  std::vector<typename Bench::Inputs> in;
  for (size_t first = 0; first < s.cases.size(); first += batch) {
    const size_t n = std::min(batch, s.cases.size() - first);
    in.clear();
    for (size_t k = 0; k < n; ++k) {
      in.push_back(Bench::inputs(s, s.cases[first + k]));
      const std::string bad = contract_error(p, in.back());
      if (!bad.empty()) return bad + "\n" + Bench::describe(s, s.cases[first + k]);
    }
    Flow f = flow;
    f.seed = flow.seed + first;
    const auto r = run_stream<Bench>(sim, p, in, f, uint32_t(first));
    std::string problem, detail;
    size_t bad_index = 0;
    if (!r.error.empty()) {
      problem = r.error;
      bad_index = r.outs.size();
      detail = Bench::describe(s, s.cases[first + std::min(bad_index, n - 1)]);
    } else {
      for (size_t k = 0; k < n && problem.empty(); ++k) {
        problem = Bench::compare(p, s, s.cases[first + k], r.outs[k], st);
        bad_index = k;
      }
      if (!problem.empty())
        detail = Bench::describe(p, r.outs[bad_index]) + "\n" + Bench::describe(s, s.cases[first + bad_index]);
      if (outs) outs->insert(outs->end(), r.outs.begin(), r.outs.end());
    }
    if (!problem.empty()) {
      // Re-run the batch from reset (the same stimulus: the flow is seeded by the batch) to find the cycle of
      // the failure, then once more with a VCD of the cycles around it.
      auto rerun = [&](const std::string& vcd, uint64_t from, uint64_t to) {
        Sim<Model> again(vcd, from, to);
        idle_reset(again);
        return run_stream<Bench>(again, p, in, f, uint32_t(first));
      };
      const auto r2 = rerun("", 0, 0);
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

// The configuration of a Verilated unit of the bench's kind, by its name.
template <class Bench>
hw::TimingConfig config_of(const std::string& unit) {
  for (const RtlUnitInfo& u : Bench::units())
    if (u.name == unit) return unit_config(u.spec);
  throw std::invalid_argument("no Verilated " + std::string(Bench::kKey) + " " + unit);
}

// The format of a unit's datapath, at its BVH width (as the timed device uses it).
template <class Bench>
hw::FixedFormat unit_format(const std::string& unit) {
  const hw::TimingConfig c = config_of<Bench>(unit);
  hw::FixedFormat f = hw::format_from_spec(c.format);
  f.width = c.bvh_width;
  return f;
}

}  // namespace rtu::rtl
