// The Catch2 checks every RTL unit's testbench runs, over its bench traits (bench.h): a case set bit-exact,
// the stall and reset behaviour of the handshake, and issue and latency per input against the timing
// configuration the unit was derived from.
#pragma once

#include <catch2/catch.hpp>

#include <chrono>
#include <string>
#include <vector>

#include "rtl_sim/tb/bench.h"

namespace rtu::rtl {

// Runs a case set on a unit's model and fails with the first disagreement (case, answers, VCD path); logs what
// it covered. Fills `outs` when given.
template <class Bench, class Model>
typename Bench::Stats check_set(const std::string& unit, const typename Bench::Set& s, const Flow& flow = {},
                                std::vector<typename Bench::Out>* outs = nullptr) {
  const typename Bench::Params p = Bench::params(config_of<Bench>(unit));
  typename Bench::Stats st;
  const auto t0 = std::chrono::steady_clock::now();
  const std::string problem = check_cases<Bench, Model>(unit, p, s, flow, st, outs);
  if (!problem.empty()) FAIL(problem);
  std::string what = unit + " " + s.name;
  if (s.traced_rays) what += " (" + std::to_string(s.traced_rays) + " rays)";
  if (flow.valid_pct < 100 || flow.ready_pct < 100)
    what += " valid " + std::to_string(flow.valid_pct) + "% ready " + std::to_string(flow.ready_pct) + "%";
  Bench::report(what, st, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  CHECK(Bench::checked(st) == s.cases.size());
  return st;
}

// Random input gaps and output stalls of several densities on one case set: run_stream checks order,
// uniqueness and that a stalled output holds; check_cases compares every result.
template <class Bench, class Model>
void check_back_pressure(const std::string& unit, const typename Bench::Set& s, uint64_t seed) {
  for (const Flow& f :
       {Flow{70, 30, seed}, Flow{100, 50, seed + 1}, Flow{30, 90, seed + 2}, Flow{100, 5, seed + 3}}) {
    CAPTURE(f.valid_pct, f.ready_pct);
    check_set<Bench, Model>(unit, s, f);
  }
}

// With the output stalled the unit takes exactly LATENCY inputs (one per stage), then drops in_ready; they all
// come out, in order and bit-exact, once the output is ready again. Then a reset empties the pipeline: nothing
// half-done comes out afterwards. `sim` is fresh; the set has at least 3 LATENCY cases.
template <class Bench, class Model>
void check_stall_and_reset(Sim<Model>& sim, const typename Bench::Params& p, const typename Bench::Set& s) {
  auto& m = sim.dut();
  idle_reset(sim);
  size_t taken = 0;
  for (int c = 0; c < 3 * p.latency; ++c) {
    drive_inputs(m, p, Bench::inputs(s, s.cases[taken]), uint32_t(taken));
    m.in_valid = 1;
    sim.eval();
    if (m.in_ready) ++taken;
    sim.tick();
  }
  CHECK(taken == size_t(p.latency));
  sim.eval();
  CHECK(m.out_valid == 1);
  CHECK(m.in_ready == 0);
  m.in_valid = 0;
  // Releasing the output: the held inputs leave one per clock, in order.
  for (size_t k = 0; k < taken; ++k) {
    m.out_ready = 1;
    sim.eval();
    REQUIRE(m.out_valid == 1);
    const typename Bench::Out o = read_outputs(m, p);
    CHECK(o.tag == k);
    typename Bench::Stats st;
    CHECK(Bench::compare(p, s, s.cases[k], o, st) == "");
    sim.tick();
  }
  sim.eval();
  CHECK(m.out_valid == 0);

  m.out_ready = 0;
  m.in_valid = 1;
  drive_inputs(m, p, Bench::inputs(s, s.cases[0]), 0);
  for (int c = 0; c < 3; ++c) sim.tick();
  m.in_valid = 0;
  sim.reset(1);
  m.out_ready = 1;
  for (int c = 0; c < p.latency + 2; ++c) {
    sim.eval();
    CHECK(m.out_valid == 0);
    sim.tick();
  }
}

// With valid and ready always high, inputs go in back to back: each keeps the input for Bench::issue clocks and
// leaves latency + issue - 1 clocks after it was taken, exactly the timing model's unit (timing_model_units.cpp,
// TimingModel::unit), with the latency (box_latency, tri_latency) and rate of the configuration the unit was
// derived from. One input per clock when Bench::one_per_clock; otherwise some take several.
template <class Bench, class Model>
void check_rate(const std::string& unit) {
  const hw::TimingConfig cfg = config_of<Bench>(unit);
  const typename Bench::Params p = Bench::params(cfg);
  const int latency = Bench::latency(cfg);
  const bool one_per_clock = Bench::one_per_clock(cfg, p);
  INFO(unit << ": latency " << latency << ", one input per clock " << one_per_clock);
  const typename Bench::Set s = Bench::random_cases(unit_format<Bench>(unit), 5, 1000);
  std::vector<typename Bench::Inputs> in;
  for (const typename Bench::Case& c : s.cases) in.push_back(Bench::inputs(s, c));
  Sim<Model> sim(requested_vcd(std::string(Bench::kVcd) + "_" + unit + "_throughput"), 0, requested_vcd_cycles());
  idle_reset(sim);
  const auto r = run_stream<Bench>(sim, p, in, Flow{100, 100, 1}, 0);
  REQUIRE(r.error == "");
  REQUIRE(r.outs.size() == in.size());
  const uint64_t m = in.size();
  uint64_t wrong_in = 0, wrong_latency = 0, issue_sum = 0, multi = 0;
  for (size_t k = 0; k < m; ++k) {
    const uint64_t issue = Bench::issue(cfg, in[k]);
    issue_sum += issue;
    multi += uint64_t(issue > 1);
    if (k + 1 < m) wrong_in += uint64_t(r.in_edge[k + 1] != r.in_edge[k] + issue);
    wrong_latency += uint64_t(r.out_edge[k] - r.in_edge[k] != uint64_t(latency) + issue - 1);
  }
  CHECK(wrong_in == 0);
  CHECK(wrong_latency == 0);
  CHECK(r.out_edge.back() - r.in_edge.front() == issue_sum + uint64_t(latency) - 1);
  if (one_per_clock) {
    CHECK(multi == 0);
    CHECK_FALSE(r.in_ready_dropped);
  } else {
    CHECK(multi > 0);  // the vectors include inputs that take several clocks
  }
}

}  // namespace rtu::rtl
