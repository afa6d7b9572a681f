// The RTL box unit (rtl/box_unit.sv) under Verilator against the C++ model, for the box units of the timing
// presets rdna2 (default format, N = 4), intel (wide6 format, N = 6) and embedded (compact format, N = 4), and
// wide8_lanes3 (intel with 8-wide nodes over 3 lanes: N = 8, the sequencer with a partial last chunk): every
// result bit-exact with hw::box_test_delta<int64_t>, conservative against hw::box_test_exact, over directed,
// seeded random and traversal-captured vectors; the valid/ready protocol under back-pressure; latency and
// throughput against the presets' box_latency and box_rate. Tags: [rtl] plus [params] [directed] [random]
// [traversal] [handshake] [throughput] [harness].
#include <catch2/catch.hpp>

#include <string>

#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_models.h"
#include "rtl_sim/cosim/rtl_box_unit.h"
#include "rtl_sim/tb/box_bench.h"
#include "rtl_sim/tb/unit_checks.h"

namespace {

using namespace rtu;
using namespace rtu::rtl;

constexpr const char* kIfc = "/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc";

hw::TimingConfig config_of(const std::string& unit) {
  return rtl::config_of<BoxBench>(unit);
}
hw::FixedFormat preset_format(const std::string& unit) {
  return unit_format<BoxBench>(unit);
}
template <class Model>
CompareStats check(const std::string& unit, const CaseSet& s, const Flow& flow = {}) {
  return check_set<BoxBench, Model>(unit, s, flow);
}

}  // namespace

TEST_CASE("box unit: the Verilated models carry the widths and latency the C++ presets give", "[rtl][params]") {
  CHECK(std::string(RTU_RTL_BOX_ARGS_rdna2) == verilator_args(box_unit_params(hw::timing_preset("rdna2"))));
  CHECK(std::string(RTU_RTL_BOX_ARGS_intel) == verilator_args(box_unit_params(hw::timing_preset("intel"))));
  CHECK(std::string(RTU_RTL_BOX_ARGS_embedded) == verilator_args(box_unit_params(hw::timing_preset("embedded"))));
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
  check_back_pressure<BoxBench, Vbox_unit_rdna2>("rdna2", s, seed);
  check<Vbox_unit_intel>("intel", random_cases(preset_format("intel"), seed, 5000), Flow{60, 40, seed});
  check<Vbox_unit_embedded>("embedded", random_cases(preset_format("embedded"), seed, 5000), Flow{60, 40, seed});
  check<Vbox_unit_wide8_lanes3>("wide8_lanes3", random_cases(preset_format("wide8_lanes3"), seed, 5000),
                                Flow{60, 40, seed});

  // With the output stalled the unit takes exactly LATENCY nodes, which come out in order once the output is
  // ready again; a reset empties the pipeline.
  Sim<Vbox_unit_rdna2> sim(requested_vcd("box_unit_rdna2_stall_and_reset"), 0, requested_vcd_cycles());
  check_stall_and_reset<BoxBench>(sim, box_unit_params(hw::timing_preset("rdna2")), s);
}

TEST_CASE("box unit: issue and latency per node equal the timing preset's box_rate and box_latency",
          "[rtl][throughput]") {
  check_rate<BoxBench, Vbox_unit_rdna2>("rdna2");
  check_rate<BoxBench, Vbox_unit_intel>("intel");
  check_rate<BoxBench, Vbox_unit_embedded>("embedded");
  check_rate<BoxBench, Vbox_unit_wide8_lanes3>("wide8_lanes3");
}

TEST_CASE("testbench helpers: a wait that never ends fails after its cycle budget", "[rtl][harness]") {
  const BoxUnitParams p = box_unit_params(hw::timing_preset("rdna2"));
  const CaseSet s = random_cases(preset_format("rdna2"), 3, 64);
  std::vector<BoxInputs> in;
  for (const BoxCase& c : s.cases) in.push_back(unit_inputs(s, c));
  Sim<Vbox_unit_rdna2> sim(requested_vcd("box_unit_rdna2_timeout"), 0, requested_vcd_cycles());
  idle_reset(sim);
  // Output never ready: the stream stops making progress and fails by its stall limit instead of hanging.
  const auto r = run_stream<BoxBench>(sim, p, in, Flow{100, 0, 1}, 0, 200);
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
