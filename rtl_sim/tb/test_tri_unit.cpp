// The RTL triangle unit (rtl/tri_core.sv) under Verilator against the C++ model, for the triangle units of the
// timing presets rdna2 (default format, tri_latency 12) and embedded (compact format, tri_latency 10): every
// result bit for bit equal to hw::triangle_test (hit, t, u and v formed from the unit's e1, e2 and det), to the
// general 128-bit edge functions (e1, e2, det) and to hw::div_shift (t whenever den != 0), over directed,
// seeded random, watertight (rays through the shared edges and vertices of a closed mesh) and
// traversal-captured vectors; the valid/ready protocol under back-pressure; latency and throughput against the
// presets' tri_latency and tri_rate. Tags: [rtl] [tri] plus [params] [directed] [random] [watertight]
// [traversal] [handshake] [throughput]. RTU_RTL_TRI_VECTORS=N scales the random set (default 1,000,000 on rdna2,
// half on embedded).
#include <catch2/catch.hpp>

#include <string>

#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_models.h"
#include "rtl_sim/tb/tri_bench.h"
#include "rtl_sim/tb/unit_checks.h"

namespace {

using namespace rtu;
using namespace rtu::rtl;

constexpr const char* kIfc = "/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc";

hw::FixedFormat preset_format(const std::string& unit) {
  return unit_format<TriBench>(unit);
}
template <class Model>
TriStats check(const std::string& unit, const TriSet& s, const Flow& flow = {},
               std::vector<TriOut>* outs = nullptr) {
  return check_set<TriBench, Model>(unit, s, flow, outs);
}

}  // namespace

TEST_CASE("tri unit: the Verilated models carry the widths and latency the C++ presets give",
          "[rtl][tri][params]") {
  CHECK(std::string(RTU_RTL_TRI_ARGS_rdna2) == verilator_args(tri_unit_params(hw::timing_preset("rdna2"))));
  CHECK(std::string(RTU_RTL_TRI_ARGS_embedded) == verilator_args(tri_unit_params(hw::timing_preset("embedded"))));
  const TriUnitParams p = tri_unit_params(hw::timing_preset("rdna2"));
  CHECK(p.latency == hw::timing_preset("rdna2").tri_latency);
  CHECK(p.a == 39);
  CHECK(p.ew() == 106);  // FixedFormat::edge_function_bits() + sign
  CHECK(p.ew() == hw::format_preset("default").edge_function_bits() + 1);
  CHECK(p.qw() == 57);
  CHECK(p.div_stages() == 7);
  CHECK(p.bits_per_stage() == 9);
  const TriUnitParams e = tri_unit_params(hw::timing_preset("embedded"));
  CHECK(e.latency == hw::timing_preset("embedded").tri_latency);
  CHECK(e.qw() == 33);
  CHECK(e.bits_per_stage() == 7);
  CHECK_THROWS_AS(tri_unit_params(hw::format_preset("default"), 5), std::invalid_argument);
}

TEST_CASE("tri unit: directed corner cases are bit-exact", "[rtl][tri][directed]") {
  const TriStats st = check<Vtri_core_rdna2>("rdna2", tri_directed_cases(preset_format("rdna2")));
  CHECK(st.hits > 1000);
  CHECK(st.det_zero > 1000);
  CHECK(st.zero_dirs > 1000);
  CHECK(st.edge_zero > 1000);
  CHECK(st.t_saturated > 10);
  CHECK(st.reversed > 100);
  check<Vtri_core_embedded>("embedded", tri_directed_cases(preset_format("embedded")));
}

TEST_CASE("tri unit: seeded random vectors are bit-exact", "[rtl][tri][random]") {
  const uint64_t seed = test_seed(20240616);
  CAPTURE(seed);
  INFO("rerun with RTU_RTL_SEED=" << seed);
  const size_t n = size_t(env_u64("RTU_RTL_TRI_VECTORS", 1000000));
  const TriStats st = check<Vtri_core_rdna2>("rdna2", tri_random_cases(preset_format("rdna2"), seed, n));
  CHECK(st.hits > n / 20);
  CHECK(st.det_zero > n / 50);
  CHECK(st.zero_dirs > n / 20);
  check<Vtri_core_embedded>("embedded", tri_random_cases(preset_format("embedded"), seed + 1, n / 2));
}

namespace {

// Rays through a shared vertex or edge of the closed mesh: every case bit-exact, and at least one triangle of
// each group hit (the ray cannot pass between them).
template <class Model>
void check_watertight(const std::string& preset, size_t n, uint64_t seed) {
  const TriSet s = tri_watertight_cases("builtin:icosphere", preset_format(preset), seed, n);
  std::vector<TriOut> outs;
  const TriStats st = check<Model>(preset, s, Flow{}, &outs);
  REQUIRE(outs.size() == s.cases.size());
  std::vector<uint8_t> hit(s.groups, 0);
  for (size_t k = 0; k < outs.size(); ++k) hit[s.cases[k].group] |= uint8_t(outs[k].hit);
  uint64_t leaks = 0;
  for (uint8_t h : hit) leaks += uint64_t(h == 0);
  INFO(preset << ": " << s.groups << " rays through shared vertices and edges");
  CHECK(leaks == 0);
  CHECK(st.edge_zero > s.cases.size() / 4);  // the rays really pass through edges (an edge function is 0)
}

}  // namespace

TEST_CASE("tri unit: rays through shared edges and vertices of a closed mesh are bit-exact and never leak",
          "[rtl][tri][watertight]") {
  const uint64_t seed = test_seed(11);
  CAPTURE(seed);
  check_watertight<Vtri_core_rdna2>("rdna2", 100000, seed);
  check_watertight<Vtri_core_embedded>("embedded", 50000, seed + 1);
}

TEST_CASE("tri unit: vectors captured from traversals of a real mesh are bit-exact", "[rtl][tri][traversal]") {
  const uint64_t seed = test_seed(7);
  CAPTURE(seed);
  {
    const TriSet s = tri_traversal_cases(kIfc, preset_format("rdna2"), 200000, seed);
    CHECK(s.replay_mismatches == 0);
    const TriStats st = check<Vtri_core_rdna2>("rdna2", s);
    CHECK(st.hits > 10000);
  }
  {
    const TriSet s = tri_traversal_cases(kIfc, preset_format("embedded"), 100000, seed);
    CHECK(s.replay_mismatches == 0);
    check<Vtri_core_embedded>("embedded", s);
  }
}

TEST_CASE("tri unit: back-pressure holds every result, none lost, duplicated or reordered",
          "[rtl][tri][handshake]") {
  const uint64_t seed = test_seed(99);
  CAPTURE(seed);
  const TriSet s = tri_random_cases(preset_format("rdna2"), seed, 10000);
  check_back_pressure<TriBench, Vtri_core_rdna2>("rdna2", s, seed);
  check<Vtri_core_embedded>("embedded", tri_random_cases(preset_format("embedded"), seed, 5000),
                            Flow{60, 40, seed});

  // With the output stalled the unit takes exactly LATENCY triangles, which come out in order once the output
  // is ready again; a reset empties the pipeline.
  const TriUnitParams p = tri_unit_params(hw::timing_preset("rdna2"));
  Sim<Vtri_core_rdna2> sim(requested_vcd("tri_unit_rdna2_stall_and_reset"), 0, requested_vcd_cycles());
  check_stall_and_reset<TriBench>(sim, p, s);
  // Output never ready: the stream fails by its stall limit instead of hanging.
  std::vector<TriInputs> in;
  for (size_t k = 0; k < 64; ++k) in.push_back(tri_inputs(s, s.cases[k]));
  const auto r = run_stream<TriBench>(sim, p, in, Flow{100, 0, 1}, 0, 200);
  CHECK(r.error.find("timeout") != std::string::npos);
  CHECK(r.in_edge.size() == size_t(p.latency));
}

TEST_CASE("tri unit: one test per clock and tri_latency clocks per test, as the timing presets say",
          "[rtl][tri][throughput]") {
  check_rate<TriBench, Vtri_core_rdna2>("rdna2");
  check_rate<TriBench, Vtri_core_embedded>("embedded");
}
