// The toggle counting of rtu_rtl_activity (activity/toggle_count.h, activity.h) on the toggle-coverage models:
// a unit held idle with constant inputs shows no transition; the adder and the multiplier of rtl/ref_ops.sv with
// operands that flip a known bit pattern give exactly the expected count on every bit of their ports and result
// register; the nets are merged as intended. With RTU_BUILD_ACTIVITY also the box and triangle units: idle, and
// fed one constant input every clock, they show no transition once the pipeline is full. Tags: [rtl] [activity].
#include <catch2/catch.hpp>

#include <bit>
#include <cstdint>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "Vref_add32_cov.h"
#include "Vref_mul32_cov.h"
#include "rtl_sim/activity/activity.h"
#include "rtl_sim/activity/toggle_count.h"

#ifdef RTU_ACTIVITY_UNITS
#include "Vbox_unit_cov_embedded.h"
#include "Vbox_unit_cov_rdna2.h"
#include "Vtri_core_cov_embedded.h"
#include "Vtri_core_cov_rdna2.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_sim/cosim/box_ports.h"
#include "rtl_sim/cosim/tri_ports.h"
#include "rtl_sim/params/rtl_params.h"
#include "rtl_sim/params/tri_params.h"
#endif

namespace {

using namespace rtu::rtl;

// Where a meter writes its coverage file.
std::string dat(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("test_rtl_activity_" + name + ".dat")).string();
}

uint64_t sum(const std::vector<uint64_t>& v) {
  uint64_t s = 0;
  for (uint64_t x : v) s += x;
  return s;
}

// Counts per signal name (the part before '[') in one scope, and per bit of one signal.
std::map<std::string, uint64_t> by_signal(const ToggleMeter& m, const std::vector<uint64_t>& counts) {
  std::map<std::string, uint64_t> out;
  for (size_t i = 0; i < counts.size(); ++i) {
    const std::string& n = m.names()[i];
    const std::string sig = n.substr(n.find(' ') + 1);
    out[sig.substr(0, sig.find('['))] += counts[i];
  }
  return out;
}
uint64_t bit_count(const ToggleMeter& m, const std::vector<uint64_t>& counts, const std::string& signal, int bit) {
  const std::string suffix = " " + signal + "[" + std::to_string(bit) + "]";
  for (size_t i = 0; i < counts.size(); ++i) {
    const std::string& n = m.names()[i];
    if (n.size() >= suffix.size() && n.compare(n.size() - suffix.size(), suffix.size(), suffix) == 0)
      return counts[i];
  }
  FAIL("no coverage point " << signal << "[" << bit << "]");
  return 0;
}

}  // namespace

TEST_CASE("activity: a coverage file's toggle points are parsed, clock and reset excluded", "[rtl][activity]") {
  std::istringstream in(
      "# SystemC::Coverage-3\n"
      "C '\001t\002toggle\001page\002v_toggle/m\001o\002a[3]\001h\002top.m' 17\n"
      "C '\001t\002line\001page\002v_line/m\001o\002block\001h\002top.m' 4\n"
      "C '\001t\002toggle\001page\002v_toggle/m\001o\002clk\001h\002top.m.u' 99\n");
  const std::vector<TogglePoint> p = parse_toggle_points(in);
  REQUIRE(p.size() == 2);
  CHECK(p[0].scope == "top.m");
  CHECK(p[0].signal == "a[3]");
  CHECK(p[0].count == 17);
  CHECK(excluded_signal(p[1].signal));
  CHECK(excluded_signal("rst"));
  CHECK_FALSE(excluded_signal("rst_n"));
  CHECK_FALSE(excluded_signal("a[3]"));
}

TEST_CASE("activity: nets are points with equal counts at every checkpoint", "[rtl][activity]") {
  // Points 0 and 1 alias, 2 differs from them at one checkpoint only, 3 never toggles.
  const std::vector<std::vector<std::vector<uint64_t>>> runs = {{{1, 1, 1, 0}, {4, 4, 5, 0}}, {{2, 2, 2, 0}}};
  const NetClasses c = classify_nets(runs, 4);
  CHECK(c.nets == 2);
  CHECK(c.constant_points == 1);
  CHECK(c.net[0] == c.net[1]);
  CHECK(c.net[0] != c.net[2]);
  CHECK(c.net[3] == -1);
  const ToggleTotals t = net_totals(c, {2, 2, 2, 0});
  CHECK(t.points == 4);
  CHECK(t.toggles_raw == 6);
  CHECK(t.toggles == 4);
}

TEST_CASE("activity: an idle adder shows no transition and a known operand pattern gives the known count",
          "[rtl][activity]") {
  Sim<Vref_add32_cov> sim;
  sim.reset();
  ToggleMeter meter(sim.context(), dat("add"));
  sim.dut().in_a = 0x1234;
  sim.dut().in_b = 0x10;
  sim.tick();
  CHECK(idle_toggles(sim, meter, 50) == 0);
  REQUIRE(meter.names().size() == 32 * 4);  // in_a, in_b, y, out_y (clk, rst excluded)

  // a alternates between 0 and 0x0000ffff, b stays 0x10000: y and the result register flip bits 0..15 at every
  // operation, bit 16 never. 100 operations from a = 0: a changes 99 times after the first; the result register
  // held 0x1234 + 0x10 = 0x1244 before and takes 0x10000 first (bits 2, 6, 9, 12 and 16 change), then 99 flips.
  const uint32_t pattern = 0x0000ffffu;
  sim.dut().in_b = 0x10000;
  auto drive = [&](Vref_add32_cov& m, size_t k) { m.in_a = (k % 2) ? pattern : 0; };
  const ActivityRun r = run_activity(sim, meter, 100, drive, 100, 4, 1);
  CHECK(r.inputs == 100);
  CHECK(r.cycles == 100);
  const std::vector<uint64_t>& c = r.total();
  for (int b = 0; b < 16; ++b) {
    CHECK(bit_count(meter, c, "in_a", b) == 99);
    CHECK(bit_count(meter, c, "out_y", b) == 99 + ((0x1244u >> b) & 1u));
  }
  for (int b = 16; b < 32; ++b) {
    CHECK(bit_count(meter, c, "in_a", b) == 0);
    CHECK(bit_count(meter, c, "out_y", b) == (b == 16 ? 1u : 0u));
  }
  const auto s = by_signal(meter, c);
  CHECK(s.at("in_a") == 16 * 99);
  CHECK(s.at("in_b") == 0);             // set before the counters were zeroed
  CHECK(s.at("y") == 16 * 99);          // the adder's result: a + 0x10000
  CHECK(s.at("out_y") == 16 * 99 + 5);  // the register: the first result, then every flip
  CHECK(sum(c) == 16 * 99 * 3 + 5);
  // Held still again: nothing.
  CHECK(idle_toggles(sim, meter, 20) == 0);
}

TEST_CASE("activity: the multiplier's full product register counts every flip of the product", "[rtl][activity]") {
  Sim<Vref_mul32_cov> sim;
  sim.dut().in_a = 0;
  sim.dut().in_b = 0;
  sim.reset();
  ToggleMeter meter(sim.context(), dat("mul"));
  CHECK(idle_toggles(sim, meter, 50) == 0);
  REQUIRE(meter.names().size() == 32 * 2 + 64 * 2);
  // a = 2^32 - 1 fixed, b alternates 0 and 1: the product alternates 0 and 2^32 - 1 (bits 0..31 flip, 32..63
  // stay 0): 9 flips after the first operation (0).
  sim.dut().in_a = 0xffffffffu;
  sim.tick();  // the register takes 0 * a = 0: no change
  auto drive = [&](Vref_mul32_cov& m, size_t k) { m.in_b = k % 2; };
  const ActivityRun r = run_activity(sim, meter, 10, drive, 10, 2, 1);
  const std::vector<uint64_t>& c = r.total();
  for (int b = 0; b < 64; ++b) CHECK(bit_count(meter, c, "out_y", b) == (b < 32 ? 9u : 0u));
  CHECK(by_signal(meter, c).at("in_b") == 9);
  CHECK(by_signal(meter, c).at("in_a") == 0);
}

TEST_CASE("activity: random operands give the adder's nets once each", "[rtl][activity]") {
  Sim<Vref_add32_cov> sim;
  sim.reset();
  ToggleMeter meter(sim.context(), dat("add_rnd"));
  rtu::hw::Pcg32 rng(3);
  auto drive = [&](Vref_add32_cov& m, size_t) {
    m.in_a = rng.next_u32();
    m.in_b = rng.next_u32();
  };
  const ActivityRun a = run_activity(sim, meter, 2000, drive, 2000, 32, 5);
  const ActivityRun b = run_activity(sim, meter, 2000, drive, 2000, 32, 6);
  const NetClasses c = classify_nets({a.at, b.at}, meter.names().size());
  // in_a, in_b, y and out_y are 128 distinct nets (out_y is y one clock later: they differ at checkpoints).
  CHECK(c.nets == 128);
  CHECK(c.constant_points == 0);
  // Uniform random operands: about half the bits of each of the four signals change per operation.
  const double per_op = double(net_totals(c, b.total()).toggles) / 2000.0;
  CHECK(per_op > 55.0);
  CHECK(per_op < 72.0);
}

#ifdef RTU_ACTIVITY_UNITS
namespace {

// Idle with constant inputs: no transition; then one constant input every clock (valid high, the same tag): no
// transition once the first input has gone through the pipeline.
template <class Model, class Params, class Inputs>
void check_constant(const Params& p, const Inputs& in, int latency, const std::string& name) {
  INFO(name);
  Sim<Model> sim;
  sim.dut().in_valid = 0;
  sim.dut().out_ready = 1;
  drive_inputs(sim.dut(), p, in, 5);
  sim.reset();
  ToggleMeter meter(sim.context(), dat(name));
  CHECK(idle_toggles(sim, meter, 100) == 0);
  sim.dut().in_valid = 1;
  for (int i = 0; i < latency + 4; ++i) sim.tick();
  meter.zero();
  for (int i = 0; i < 100; ++i) sim.tick();
  CHECK(sum(meter.read()) == 0);
  // And the filling did toggle something (the counters count at all).
  sim.dut().in_valid = 0;
  meter.zero();
  for (int i = 0; i < latency + 4; ++i) sim.tick();
  CHECK(sum(meter.read()) > 0);
}

}  // namespace

TEST_CASE("activity: box and triangle units idle or fed one constant input show no transition",
          "[rtl][activity]") {
  for (const char* preset : {"rdna2", "embedded"}) {
    const BoxUnitParams p = box_unit_params(rtu::hw::timing_preset(preset));
    BoxInputs in{};
    for (int a = 0; a < 3; ++a) {
      in.base[a] = -100;
      in.sh[a] = 2;
      in.rcpm_dn[a] = in.rcpm_up[a] = 1 << (p.m - 1);
      in.rcp_sh[a] = 3;
    }
    for (int r = 0; r < 6; ++r)
      for (int i = 0; i < p.n; ++i) in.q[r][i] = uint32_t(r % 2 ? 3 + i : i) & ((1u << p.k) - 1);
    in.count = p.lanes;  // one clock per node: a full node on a two-lane unit would alternate its chunks
    in.tmin = 0;
    in.tlim = 1000;
    REQUIRE(contract_error(p, in).empty());
    if (std::string(preset) == "rdna2")
      check_constant<Vbox_unit_cov_rdna2>(p, in, p.latency, "box_rdna2");
    else
      check_constant<Vbox_unit_cov_embedded>(p, in, p.latency, "box_embedded");

    const TriUnitParams t = tri_unit_params(rtu::hw::timing_preset(preset));
    TriInputs ti{};
    const int64_t v[3][3] = {{10, 10, 10}, {200, 10, 10}, {10, 200, 10}};
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 3; ++a) ti.v[i][a] = v[i][a];
    ti.o[0] = ti.o[1] = 50 << t.f;
    ti.o[2] = 500 << t.f;
    ti.d[2] = -(int64_t(1) << t.d);
    ti.tmin = 0;
    ti.tlim = (int64_t(1) << t.tb) - 1;
    REQUIRE(contract_error(t, ti).empty());
    if (std::string(preset) == "rdna2")
      check_constant<Vtri_core_cov_rdna2>(t, ti, t.latency, "tri_rdna2");
    else
      check_constant<Vtri_core_cov_embedded>(t, ti, t.latency, "tri_embedded");
  }
}
#endif
