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

#include <chrono>
#include <cstdio>
#include <string>

#include "Vtri_core_embedded.h"
#include "Vtri_core_rdna2.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_sim/tb/tri_bench.h"
#include "rtl_tri_models.h"

namespace {

using namespace rtu;
using namespace rtu::rtl;

constexpr const char* kIfc = "/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc";

hw::FixedFormat preset_format(const std::string& preset) {
  const hw::TimingConfig c = hw::timing_preset(preset);
  hw::FixedFormat f = hw::format_preset(c.format);
  f.width = c.bvh_width;
  return f;
}

void report(const std::string& what, const TriStats& st, double secs) {
  std::printf(
      "rtl tri %-40s %8llu cases (%llu hits, %llu det 0, %llu t checked, %llu saturated, %llu u/v checked, %llu "
      "zero direction components, %llu zero edge functions, %llu reversed intervals) %.2f s\n",
      what.c_str(), (unsigned long long)st.cases, (unsigned long long)st.hits, (unsigned long long)st.det_zero,
      (unsigned long long)st.t_checked, (unsigned long long)st.t_saturated, (unsigned long long)st.uv_checked,
      (unsigned long long)st.zero_dirs, (unsigned long long)st.edge_zero, (unsigned long long)st.reversed, secs);
  std::fflush(stdout);
}

template <class Model>
TriStats check(const std::string& preset, const TriSet& s, const Flow& flow = {},
               std::vector<TriOut>* outs = nullptr) {
  const TriUnitParams p = tri_unit_params(hw::timing_preset(preset));
  TriStats st;
  const auto t0 = std::chrono::steady_clock::now();
  const std::string problem = check_tri_cases<Model>(preset, p, s, flow, st, outs);
  if (!problem.empty()) FAIL(problem);
  std::string what = preset + " " + s.name;
  if (s.traced_rays) what += " (" + std::to_string(s.traced_rays) + " rays)";
  if (flow.valid_pct < 100 || flow.ready_pct < 100)
    what += " valid " + std::to_string(flow.valid_pct) + "% ready " + std::to_string(flow.ready_pct) + "%";
  report(what, st, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  CHECK(st.cases == s.cases.size());
  return st;
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
  for (const Flow& f :
       {Flow{70, 30, seed}, Flow{100, 50, seed + 1}, Flow{30, 90, seed + 2}, Flow{100, 5, seed + 3}}) {
    CAPTURE(f.valid_pct, f.ready_pct);
    check<Vtri_core_rdna2>("rdna2", s, f);
  }
  check<Vtri_core_embedded>("embedded", tri_random_cases(preset_format("embedded"), seed, 5000),
                            Flow{60, 40, seed});

  // With the output stalled the unit takes exactly LATENCY triangles, then drops in_ready; they come out in
  // order once the output is ready. A reset empties the pipeline.
  const TriUnitParams p = tri_unit_params(hw::timing_preset("rdna2"));
  Sim<Vtri_core_rdna2> sim(requested_vcd("tri_unit_rdna2_stall_and_reset"), 0, requested_vcd_cycles());
  auto& m = sim.dut();
  m.in_valid = 0;
  m.out_ready = 0;
  sim.reset();
  size_t taken = 0;
  for (int c = 0; c < 3 * p.latency; ++c) {
    drive_inputs(m, p, tri_inputs(s, s.cases[taken]), uint32_t(taken));
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
  for (size_t k = 0; k < taken; ++k) {
    m.out_ready = 1;
    sim.eval();
    REQUIRE(m.out_valid == 1);
    const TriOut o = read_outputs(m, p);
    CHECK(o.tag == k);
    TriStats st;
    CHECK(compare_tri(s, s.cases[k], o, st) == "");
    sim.tick();
  }
  sim.eval();
  CHECK(m.out_valid == 0);
  m.out_ready = 0;
  m.in_valid = 1;
  drive_inputs(m, p, tri_inputs(s, s.cases[0]), 0);
  for (int c = 0; c < 3; ++c) sim.tick();
  m.in_valid = 0;
  sim.reset(1);
  m.out_ready = 1;
  for (int c = 0; c < p.latency + 2; ++c) {
    sim.eval();
    CHECK(m.out_valid == 0);
    sim.tick();
  }
  // Output never ready: the stream fails by its stall limit instead of hanging.
  std::vector<TriInputs> in;
  for (size_t k = 0; k < 64; ++k) in.push_back(tri_inputs(s, s.cases[k]));
  const TriStream r = run_stream(sim, p, in, Flow{100, 0, 1}, 0, 200);
  CHECK(r.error.find("timeout") != std::string::npos);
  CHECK(r.in_edge.size() == size_t(p.latency));
}

namespace {

// With valid and ready always high: one triangle per clock (tri_rate 1), each leaving tri_latency clocks after
// it was taken.
template <class Model>
void check_rate(const std::string& preset) {
  const hw::TimingConfig cfg = hw::timing_preset(preset);
  const TriUnitParams p = tri_unit_params(cfg);
  const TriSet s = tri_random_cases(preset_format(preset), 5, 1000);
  std::vector<TriInputs> in;
  for (const TriCase& c : s.cases) in.push_back(tri_inputs(s, c));
  Sim<Model> sim(requested_vcd("tri_unit_" + preset + "_throughput"), 0, requested_vcd_cycles());
  sim.dut().in_valid = 0;
  sim.dut().out_ready = 0;
  sim.reset();
  const TriStream r = run_stream(sim, p, in, Flow{100, 100, 1}, 0);
  REQUIRE(r.error == "");
  REQUIRE(r.outs.size() == in.size());
  uint64_t wrong_in = 0, wrong_latency = 0;
  for (size_t k = 0; k < in.size(); ++k) {
    if (k + 1 < in.size()) wrong_in += uint64_t(r.in_edge[k + 1] != r.in_edge[k] + uint64_t(cfg.tri_rate));
    wrong_latency += uint64_t(r.out_edge[k] - r.in_edge[k] != uint64_t(cfg.tri_latency));
  }
  INFO(preset << ": tri_latency " << cfg.tri_latency << ", tri_rate " << cfg.tri_rate);
  CHECK(wrong_in == 0);
  CHECK(wrong_latency == 0);
  CHECK_FALSE(r.in_ready_dropped);
  CHECK(r.out_edge.back() - r.in_edge.front() == in.size() - 1 + uint64_t(cfg.tri_latency));
}

}  // namespace

TEST_CASE("tri unit: one test per clock and tri_latency clocks per test, as the timing presets say",
          "[rtl][tri][throughput]") {
  check_rate<Vtri_core_rdna2>("rdna2");
  check_rate<Vtri_core_embedded>("embedded");
}
