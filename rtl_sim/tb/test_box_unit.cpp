// The RTL box unit (rtl/box_unit.sv) under Verilator against the C++ model, for the box units of the timing
// presets rdna2 (default format, N = 4), intel (wide6 format, N = 6) and embedded (compact format, N = 4), and
// wide8_lanes3 (intel with 8-wide nodes over 3 lanes: N = 8, the sequencer with a partial last chunk): every
// result bit-exact with hw::box_test_delta<int64_t>, conservative against hw::box_test_exact, over directed,
// seeded random and traversal-captured vectors; the valid/ready protocol under back-pressure; latency and
// throughput against the presets' box_latency and box_rate. Tags: [rtl] plus [params] [directed] [random]
// [traversal] [handshake] [throughput] [harness].
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

#include "Vbox_unit_embedded.h"
#include "Vbox_unit_intel.h"
#include "Vbox_unit_rdna2.h"
#include "Vbox_unit_wide8_lanes3.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_models.h"
#include "rtl_sim/cosim/rtl_box_unit.h"
#include "rtl_sim/tb/box_bench.h"

namespace {

using namespace rtu;
using namespace rtu::rtl;

constexpr const char* kIfc = "/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc";

// The configuration of a Verilated unit (a preset, or wide8_lanes3: intel with 8-wide nodes and box_rate 3).
hw::TimingConfig config_of(const std::string& unit) {
  for (const RtlUnitInfo& u : rtl_units())
    if (u.name == unit) return unit_config(u.spec);
  throw std::invalid_argument("no Verilated unit " + unit);
}

// The format of a unit's datapath, at its BVH width (as the timed device uses it).
hw::FixedFormat preset_format(const std::string& preset) {
  const hw::TimingConfig c = config_of(preset);
  hw::FixedFormat f = hw::format_preset(c.format);
  f.width = c.bvh_width;
  return f;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void report(const std::string& what, const CompareStats& st, double secs) {
  std::printf(
      "rtl %-44s %7llu nodes %9llu child tests (%llu hits, %llu exact accepts, %llu false positives, %llu t_near "
      "checked, %llu saturated, %llu axes rcp_sh<0, %llu zero axes, %llu reversed intervals, %llu partial nodes) "
      "%.2f s\n",
      what.c_str(), (unsigned long long)st.nodes, (unsigned long long)st.child_tests, (unsigned long long)st.hits,
      (unsigned long long)st.exact_accepts, (unsigned long long)st.false_positives,
      (unsigned long long)st.tnear_checked, (unsigned long long)st.tnear_saturated,
      (unsigned long long)st.neg_rcp_sh, (unsigned long long)st.zero_axes,
      (unsigned long long)st.reversed_intervals, (unsigned long long)st.partial_nodes, secs);
  std::fflush(stdout);
}

// Runs a case set on the preset's model and fails with the first disagreement (case, model answers, VCD path).
template <class Model>
CompareStats check(const std::string& preset, const CaseSet& s, const Flow& flow = {}) {
  const BoxUnitParams p = box_unit_params(config_of(preset));
  CompareStats st;
  const auto t0 = std::chrono::steady_clock::now();
  const std::string problem = check_cases<Model>(preset, p, s, flow, st);
  if (!problem.empty()) FAIL(problem);
  std::string what = preset + " " + s.name;
  if (s.traced_rays) what += " (" + std::to_string(s.traced_rays) + " rays)";
  if (flow.valid_pct < 100 || flow.ready_pct < 100)
    what += " valid " + std::to_string(flow.valid_pct) + "% ready " + std::to_string(flow.ready_pct) + "%";
  report(what, st, seconds_since(t0));
  CHECK(st.nodes == s.cases.size());
  return st;
}

}  // namespace

TEST_CASE("box unit: the Verilated models carry the widths and latency the C++ presets give", "[rtl][params]") {
  CHECK(std::string(RTU_RTL_ARGS_rdna2) == verilator_args(box_unit_params(hw::timing_preset("rdna2"))));
  CHECK(std::string(RTU_RTL_ARGS_intel) == verilator_args(box_unit_params(hw::timing_preset("intel"))));
  CHECK(std::string(RTU_RTL_ARGS_embedded) == verilator_args(box_unit_params(hw::timing_preset("embedded"))));
  CHECK(rtl_units().size() == 4);
  for (const RtlUnitInfo& u : rtl_units()) {
    CAPTURE(u.name, u.spec);
    CHECK(u.args == verilator_args(box_unit_params(unit_config(u.spec))));
  }
  CHECK(box_unit_params(config_of("wide8_lanes3")).lanes == 3);
  CHECK(box_unit_params(config_of("wide8_lanes3")).n == 8);
  // The default format is the rdna2 unit's, with the 64-bit path.
  const BoxUnitParams p = box_unit_params(hw::timing_preset("rdna2"));
  CHECK(p.n == 4);
  CHECK(p.a == 39);
  CHECK(p.m == 21);
  CHECK(p.tb == 56);
  CHECK(p.latency == hw::timing_preset("rdna2").box_latency);
  CHECK(p.lanes == 4);
  CHECK(box_unit_params(hw::timing_preset("embedded")).lanes == hw::timing_preset("embedded").box_rate);
  CHECK(box_unit_params(hw::timing_preset("intel")).n == 6);      // Intel's 6-wide BVH
  CHECK(box_unit_params(hw::timing_preset("intel")).lanes == 6);  // box_rate 6 = N: one node per clock per unit
  // A wide format has no 64-bit path: refused, not silently mis-built.
  CHECK_THROWS_AS(box_unit_params(hw::format_preset("precise"), 4, 4, 6), std::invalid_argument);
}

TEST_CASE("box unit: directed corner cases are bit-exact and conservative", "[rtl][directed]") {
  const CaseSet rd = directed_cases(preset_format("rdna2"));
  const CompareStats st = check<Vbox_unit_rdna2>("rdna2", rd);
  // The corner cases are really there.
  CHECK(st.zero_axes > 1000);
  CHECK(st.neg_rcp_sh > 100);
  CHECK(st.reversed_intervals > 100);
  CHECK(st.partial_nodes > 10);
  CHECK(st.tnear_saturated > 10);
  CHECK(st.hits > 1000);
  CHECK(st.child_tests - st.hits > 1000);
  CHECK(st.false_positives > 0);  // the fixed test is conservative, not exact: some boxes only it accepts
  check<Vbox_unit_intel>("intel", directed_cases(preset_format("intel")));
  check<Vbox_unit_embedded>("embedded", directed_cases(preset_format("embedded")));
  check<Vbox_unit_wide8_lanes3>("wide8_lanes3", directed_cases(preset_format("wide8_lanes3")));
}

TEST_CASE("box unit: seeded random vectors are bit-exact and conservative", "[rtl][random]") {
  const uint64_t seed = test_seed(20240615);
  CAPTURE(seed);
  INFO("rerun with RTU_RTL_SEED=" << seed);
  const CompareStats st = check<Vbox_unit_rdna2>("rdna2", random_cases(preset_format("rdna2"), seed, 500000));
  CHECK(st.child_tests >= 1500000);
  CHECK(st.neg_rcp_sh > 1000);
  CHECK(st.hits > 50000);
  check<Vbox_unit_intel>("intel", random_cases(preset_format("intel"), seed + 1, 20000));
  check<Vbox_unit_embedded>("embedded", random_cases(preset_format("embedded"), seed + 2, 30000));
  check<Vbox_unit_wide8_lanes3>("wide8_lanes3", random_cases(preset_format("wide8_lanes3"), seed + 3, 20000));
}

TEST_CASE("box unit: vectors captured from traversals of real meshes are bit-exact and conservative",
          "[rtl][traversal]") {
  const uint64_t seed = test_seed(7);
  CAPTURE(seed);
  {
    const CaseSet s = traversal_cases(kIfc, preset_format("rdna2"), 400000, seed);
    INFO(s.traced_rays << " rays traced");
    CHECK(s.replay_mismatches == 0);  // the replayed closest hit (the box tests' limit) is the tracer's
    const CompareStats st = check<Vbox_unit_rdna2>("rdna2", s);
    CHECK(st.child_tests >= 1200000);
    CHECK(st.hits > 200000);
  }
  {
    const CaseSet s = traversal_cases("builtin:seed", preset_format("rdna2"), 30000, seed);
    CHECK(s.replay_mismatches == 0);
    check<Vbox_unit_rdna2>("rdna2", s);
  }
  {
    const CaseSet s = traversal_cases(kIfc, preset_format("intel"), 15000, seed);
    CHECK(s.replay_mismatches == 0);
    check<Vbox_unit_intel>("intel", s);
  }
  {
    const CaseSet s = traversal_cases(kIfc, preset_format("embedded"), 20000, seed);
    CHECK(s.replay_mismatches == 0);
    check<Vbox_unit_embedded>("embedded", s);
  }
}

TEST_CASE("box unit: back-pressure holds every result, none lost, duplicated or reordered", "[rtl][handshake]") {
  const uint64_t seed = test_seed(99);
  CAPTURE(seed);
  const CaseSet s = random_cases(preset_format("rdna2"), seed, 20000);
  // Random input gaps and output stalls of several densities; run_stream checks order, uniqueness and that a
  // stalled output holds; check_cases compares every result.
  for (const Flow& f :
       {Flow{70, 30, seed}, Flow{100, 50, seed + 1}, Flow{30, 90, seed + 2}, Flow{100, 5, seed + 3}}) {
    CAPTURE(f.valid_pct, f.ready_pct);
    check<Vbox_unit_rdna2>("rdna2", s, f);
  }
  check<Vbox_unit_intel>("intel", random_cases(preset_format("intel"), seed, 5000), Flow{60, 40, seed});
  check<Vbox_unit_embedded>("embedded", random_cases(preset_format("embedded"), seed, 5000), Flow{60, 40, seed});
  check<Vbox_unit_wide8_lanes3>("wide8_lanes3", random_cases(preset_format("wide8_lanes3"), seed, 5000),
                                Flow{60, 40, seed});

  // With the output stalled the unit takes exactly LATENCY nodes (one per stage), then drops in_ready; they all
  // come out, in order, once the output is ready again.
  const BoxUnitParams p = box_unit_params(hw::timing_preset("rdna2"));
  Sim<Vbox_unit_rdna2> sim(requested_vcd("box_unit_rdna2_stall_and_reset"), 0, requested_vcd_cycles());
  auto& m = sim.dut();
  m.in_valid = 0;
  m.out_ready = 0;
  sim.reset();
  std::vector<BoxInputs> in;
  for (size_t k = 0; k < 40; ++k) in.push_back(unit_inputs(s, s.cases[k]));
  size_t taken = 0;
  for (int c = 0; c < 3 * p.latency; ++c) {
    drive_inputs(m, p, in[taken], uint32_t(taken));
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
  // Releasing the output: the held nodes leave one per clock, in order.
  for (size_t k = 0; k < taken; ++k) {
    m.out_ready = 1;
    sim.eval();
    REQUIRE(m.out_valid == 1);
    const BoxOut o = read_outputs(m, p);
    CHECK(o.tag == k);
    CompareStats st;
    CHECK(compare_node(p, s, s.cases[k], o, st) == "");
    sim.tick();
  }
  sim.eval();
  CHECK(m.out_valid == 0);

  // A reset empties the pipeline: nothing half-done comes out afterwards.
  m.out_ready = 0;
  m.in_valid = 1;
  drive_inputs(m, p, in[0], 0);
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

namespace {

// With valid and ready always high, nodes go in back to back: a node of `count` children keeps the input for
// issue = max(1, ceil(count / box_rate)) clocks and leaves box_latency + issue - 1 clocks after it was taken,
// exactly the timing model's box unit (timed_engine.cpp, TimingModel::unit). One node per clock when
// box_rate >= N.
template <class Model>
void check_rate(const std::string& preset) {
  const hw::TimingConfig cfg = config_of(preset);
  const BoxUnitParams p = box_unit_params(cfg);
  INFO(preset << ": box_latency " << cfg.box_latency << ", box_rate " << cfg.box_rate << ", N " << p.n
              << ", LANES " << p.lanes);
  const CaseSet s = random_cases(preset_format(preset), 5, 1000);
  std::vector<BoxInputs> in;
  for (const BoxCase& c : s.cases) in.push_back(unit_inputs(s, c));
  Sim<Model> sim(requested_vcd("box_unit_" + preset + "_throughput"), 0, requested_vcd_cycles());
  sim.dut().in_valid = 0;
  sim.dut().out_ready = 0;
  sim.reset();
  const StreamResult r = run_stream(sim, p, in, Flow{100, 100, 1}, 0);
  REQUIRE(r.error == "");
  REQUIRE(r.outs.size() == in.size());
  const uint64_t m = in.size();
  uint64_t wrong_in = 0, wrong_latency = 0, issue_sum = 0, multi = 0;
  for (size_t k = 0; k < m; ++k) {
    const uint64_t count = uint64_t(in[k].count), rate = uint64_t(cfg.box_rate);
    const uint64_t issue = std::max<uint64_t>(1, (count + rate - 1) / rate);
    issue_sum += issue;
    multi += uint64_t(issue > 1);
    if (k + 1 < m) wrong_in += uint64_t(r.in_edge[k + 1] != r.in_edge[k] + issue);
    wrong_latency += uint64_t(r.out_edge[k] - r.in_edge[k] != uint64_t(cfg.box_latency) + issue - 1);
  }
  CHECK(wrong_in == 0);
  CHECK(wrong_latency == 0);
  CHECK(r.out_edge.back() - r.in_edge.front() == issue_sum + uint64_t(cfg.box_latency) - 1);
  if (cfg.box_rate >= p.n) {
    CHECK(multi == 0);  // one node per clock
    CHECK_FALSE(r.in_ready_dropped);
  } else {
    CHECK(multi > 0);  // the vectors include nodes that take several clocks
  }
}

}  // namespace

TEST_CASE("box unit: issue and latency per node equal the timing preset's box_rate and box_latency",
          "[rtl][throughput]") {
  check_rate<Vbox_unit_rdna2>("rdna2");
  check_rate<Vbox_unit_intel>("intel");
  check_rate<Vbox_unit_embedded>("embedded");
  check_rate<Vbox_unit_wide8_lanes3>("wide8_lanes3");
}

TEST_CASE("testbench helpers: a wait that never ends fails after its cycle budget", "[rtl][harness]") {
  const BoxUnitParams p = box_unit_params(hw::timing_preset("rdna2"));
  const CaseSet s = random_cases(preset_format("rdna2"), 3, 64);
  std::vector<BoxInputs> in;
  for (const BoxCase& c : s.cases) in.push_back(unit_inputs(s, c));
  Sim<Vbox_unit_rdna2> sim(requested_vcd("box_unit_rdna2_timeout"), 0, requested_vcd_cycles());
  sim.dut().in_valid = 0;
  sim.dut().out_ready = 0;
  sim.reset();
  // Output never ready: the stream stops making progress and fails by its stall limit instead of hanging.
  const StreamResult r = run_stream(sim, p, in, Flow{100, 0, 1}, 0, 200);
  CHECK(r.error.find("timeout") != std::string::npos);
  CHECK(r.in_edge.size() == size_t(p.latency));
  // run_until gives up after exactly its budget.
  const uint64_t c0 = sim.cycle();
  sim.dut().in_valid = 1;
  CHECK_FALSE(sim.run_until([&] { return sim.dut().in_ready != 0; }, 100));
  CHECK(sim.cycle() - c0 == 100);
  // ... and returns as soon as the condition holds.
  sim.dut().out_ready = 1;
  CHECK(sim.run_until([&] { return sim.dut().in_ready != 0; }, 100));
  CHECK(sim.cycle() - c0 == 100);
  // Packing round trip of a wide port.
  VlWide<4> w{};
  put_bits(w, 37, 40, uint64_t(-12345));
  put_bits(w, 3, 30, 0x2abcdef1);
  CHECK(sign_extend(get_bits(w, 37, 40), 40) == -12345);
  CHECK(get_bits(w, 3, 30) == 0x2abcdef1u);
}
