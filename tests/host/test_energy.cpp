// Area and energy (hwmodel/cost/energy_model.h, host/cost/cost_model.h): the accounting adds up on real timed
// runs, each event counts what the timing model counted, the tables' sources are where the code says they are, and
// the estimates respond to the keys that should move them and to nothing else.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/cost/cost_model.h"
#include "host/cost/timing_json.h"
#include "host/devices/direct_device.h"
#include "host/io/stats_json.h"
#include "host/jobs/plan.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/cost/energy_model.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_sim/trav/trav_params.h"
#include "tests/host/plan_checks.h"
#include "tests/host/timed_checks.h"

namespace {

using rtu::hw::TimingConfig;
using rtu::hw::TimingStats;

// A timed run of camera and incoherent rays on a scene (2 threads; cycles do not depend on them).
TimingStats timed_run(const std::string& scene, const TimingConfig& c, size_t n = 2000) {
  const rtu::host::Scene s = rtu::host::load_scene(scene);
  rtu::host::DeviceOptions o;
  o.kind = rtu::hw::DeviceKind::kTimed;
  o.timing = c;
  o.format = rtu::hw::format_preset(c.format);
  o.format.width = c.bvh_width;
  o.tracer.bvh.width = c.bvh_width;
  std::vector<rtu::hw::Ray> rays = camera_and_incoherent_rays(s, n, 3);
  std::vector<rtu::hw::Hit> hits(rays.size());
  const auto dev = rtu::host::make_device(s.geometry, o);
  rtu::hw::TraversalStats ts;
  dev->trace_batch(rays.data(), hits.data(), rays.size(), false, 2, ts);
  return dev->timed()->timing();
}

// Sums in double of up to ~10 terms of magnitude <= 1e12 pJ: relative rounding below 1e-15 per term; 1e-12
// leaves room and still fails on any term left out or counted twice.
constexpr double kSumTolerance = 1e-12;

}  // namespace

TEST_CASE("energy: the events times their energies are the total, and each counts the run's counter", "[energy]") {
  for (const std::string preset : {"rdna2", "embedded", "intel-mem"}) {
    CAPTURE(preset);
    const TimingConfig c = rtu::hw::timing_preset(preset);
    const TimingStats s = timed_run("builtin:cornell", c);
    REQUIRE(s.rays > 0);
    REQUIRE(s.cycles > 0);
    const rtu::hw::CostInputs in = rtu::host::cost_inputs(c);
    const rtu::hw::EnergyReport e = rtu::hw::energy_report(s, c, in);
    double sum = 0;
    for (const auto& ev : e.events) {
      CAPTURE(ev.key);
      CHECK(ev.pj_each >= 0);
      CHECK(std::isfinite(ev.pj_each));
      sum += double(ev.count) * ev.pj_each;
    }
    CHECK(std::abs(sum - e.total_pj) <= kSumTolerance * e.total_pj);
    CHECK(std::abs(e.pj_per_ray * double(s.rays) - e.total_pj) <= kSumTolerance * e.total_pj);
    const double seconds = double(s.cycles) / (c.clock_ghz * 1e9);
    CHECK(std::abs(e.watts * seconds - e.total_pj * 1e-12) <= kSumTolerance * e.total_pj * 1e-12);
    CHECK(std::abs(e.rays_per_joule * e.total_pj * 1e-12 - double(s.rays)) <= kSumTolerance * double(s.rays));

    auto event = [&](const std::string& key) -> const rtu::hw::EnergyEvent& {
      for (const auto& ev : e.events)
        if (ev.key == key) return ev;
      FAIL("no event " << key);
      return e.events.front();
    };
    CHECK(event("box_test").count == s.box_tests);
    CHECK(event("tri_test").count == s.tri_issue_cycles);
    CHECK(event("cache_read").count == s.cache_hits + s.cache_misses);
    CHECK(event("cache_fill").count == s.cache_misses);
    CHECK(event("stack").count == s.node_fetches);
    CHECK(event("dram").count == s.dram_bytes);
    CHECK(event("stream").count == s.stream_bytes);
    CHECK(event("leakage").count == s.cycles);
    CHECK(event("transform").count == s.instance_transforms);
    CHECK(event("transform").pj_each == Approx(18 * 3.7 + 15 * 0.9));  // Horowitz's float32 operators
    const double dram_pj_per_byte = 8.0 * rtu::hw::memory_type(c.memory_type).pj_per_bit;
    CHECK(event("dram").pj_each == dram_pj_per_byte);

    // The stats JSON carries the same figures: its events add up to its total.
    const rtu::host::Json j = rtu::host::timing_stats_json(s, c, rtu::hw::format_preset(c.format))["energy"];
    double jsum = 0;
    for (const auto& [key, ev] : j["events"].items()) {
      CAPTURE(key);
      CHECK(ev["pj"].get<double>() == Approx(double(ev["count"].get<uint64_t>()) * ev["pj_each"].get<double>()));
      jsum += ev["pj"].get<double>();
    }
    CHECK(std::abs(jsum - j["total_pj"].get<double>()) <= kSumTolerance * jsum);
    CHECK(j["total_pj"].get<double>() == e.total_pj);
    CHECK(j["area"]["total_mm2"].get<double>() == e.area.total_mm2);
  }
}

TEST_CASE("energy: the memory type moves the DRAM and stream events by its energy per bit, nothing else",
          "[energy]") {
  TimingConfig g = rtu::hw::timing_preset("rdna2");
  const TimingStats s = timed_run("builtin:cornell", g, 500);
  TimingConfig h = g;
  rtu::hw::set_timing_key(h, "memory_type", "hbm2");
  const rtu::hw::CostInputs in = rtu::host::cost_inputs(g);
  const auto eg = rtu::hw::energy_report(s, g, in), eh = rtu::hw::energy_report(s, h, in);
  REQUIRE(eg.events.size() == eh.events.size());
  for (size_t i = 0; i < eg.events.size(); ++i) {
    const std::string key = eg.events[i].key;
    CAPTURE(key);
    if (key == "dram" || key == "stream")
      CHECK(eh.events[i].pj_each == Approx(eg.events[i].pj_each * 3.9 / 7.5).epsilon(1e-12));
    else
      CHECK(eh.events[i].pj_each == eg.events[i].pj_each);
  }
  CHECK_THROWS_WITH(rtu::hw::set_timing_key(h, "memory_type", "ddr9"), Catch::Contains("memory_type"));
  CHECK_THROWS_AS(rtu::hw::memory_type("ddr9"), std::invalid_argument);
}

TEST_CASE("energy: SRAM energies pass through Horowitz's points and grow with capacity", "[energy]") {
  CHECK(rtu::hw::sram_read64_pj(8 * 1024.0) == Approx(10.0).epsilon(1e-12));
  CHECK(rtu::hw::sram_read64_pj(32 * 1024.0) == Approx(20.0).epsilon(1e-12));
  CHECK(rtu::hw::sram_read64_pj(1024 * 1024.0) == Approx(100.0).epsilon(1e-12));
  double last = 0;
  for (double kib = 0.25; kib <= 4096; kib *= 2) {
    const double e = rtu::hw::sram_read64_pj(kib * 1024);
    CHECK(e > last);
    last = e;
  }
  // A 64-byte line is eight 64-bit reads.
  CHECK(rtu::hw::sram_access_pj(65536, 64) == Approx(8 * rtu::hw::sram_read64_pj(65536)).epsilon(1e-12));
}

TEST_CASE(
    "area: units add their synthesized size and a format no synthesis ran for is a fit between its neighbours",
    "[energy]") {
  TimingConfig c = rtu::hw::timing_preset("rdna2");
  const rtu::hw::CostInputs in = rtu::host::cost_inputs(c);
  const rtu::host::AreaTable table = rtu::host::AreaTable::shipped();
  // The rdna2 box unit is in the shipped table: 4 transistors per NAND2 equivalent.
  CHECK(in.box.source.rfind("size synthesized", 0) == 0);
  CHECK(in.box.nand2_eq == Approx(1399866 / 4.0));
  const auto a1 = rtu::hw::area_report(c, in);
  rtu::hw::set_timing_key(c, "box_units", "3");
  const auto a3 = rtu::hw::area_report(c, in);
  CHECK(a3.total_mm2 - a1.total_mm2 == Approx(2 * a1.box_mm2).epsilon(1e-12));
  CHECK(a3.box_mm2 == Approx(3 * a1.box_mm2).epsilon(1e-12));
  CHECK(a1.box_mm2 == Approx(in.box.nand2_eq * 0.798e-6 / 0.7).epsilon(1e-12));

  // 14 coordinate bits: synthesized at 12 and 16, not 14.
  auto box_ge = [&](int bits) {
    rtu::hw::FixedFormat f = rtu::hw::format_from_spec("default:coord_bits=" + std::to_string(bits));
    f.width = 4;
    return rtu::host::cost_inputs(f, rtu::hw::timing_preset("rdna2"), table, rtu::host::ActivityTable{}).box;
  };
  const auto b12 = box_ge(12), b14 = box_ge(14), b16 = box_ge(16);
  CHECK(b12.source.rfind("size synthesized", 0) == 0);
  CHECK(b14.source.rfind("size fit", 0) == 0);
  CHECK(b14.nand2_eq > b12.nand2_eq);
  CHECK(b14.nand2_eq < b16.nand2_eq);
  // Without activity figures no switching energy is claimed.
  CHECK(b14.toggles_per_test == 0);
  CHECK(b14.source.find("activity none") != std::string::npos);
}

TEST_CASE("energy: the model's reference operators against Horowitz: the adder calibrates, the multiplier checks",
          "[energy]") {
  const auto ops = rtu::host::reference_ops(rtu::host::AreaTable::shipped(), rtu::host::ActivityTable::shipped());
  REQUIRE(ops.size() == 2);
  for (const auto& op : ops) {
    CAPTURE(op.key);
    REQUIRE(op.measured);
    // The adder sets the switched capacitance (Technology::cap_per_ge_ff, 1.23 fF given to 3 digits: 0.4%).
    if (op.key == "ref:add32") CHECK(op.pj == Approx(op.horowitz_pj).epsilon(0.005));
    // The multiplier is the independent check. Horowitz gives 3.1 pJ to two digits (+-1.6%) for a multiplier he
    // does not specify further (ours: 32 x 32 -> 64 bits, one register): 5% is the agreement claimed.
    if (op.key == "ref:mul32") CHECK(op.pj == Approx(op.horowitz_pj).epsilon(0.05));
    // Areas: yosys's generic cells, so the same order as his, not his figure (bench/results/area-energy.md).
    CHECK(op.area_um2 > 0.3 * op.horowitz_um2);
    CHECK(op.area_um2 < 3.0 * op.horowitz_um2);
  }
}

TEST_CASE("energy: malformed activity tables are refused naming the line", "[energy]") {
  using rtu::host::ActivityTable;
  CHECK_THROWS_WITH(ActivityTable::parse("params,cells\n", "t.csv"), Catch::Contains("t.csv:1"));
  CHECK_THROWS_WITH(ActivityTable::parse("params,unit,tests,signal_bits,toggles_per_test\nk,u,1,0,3\n", "t.csv"),
                    Catch::Contains("t.csv:2"));
  CHECK_THROWS_WITH(ActivityTable::parse("params,unit,tests,signal_bits,toggles_per_test\nk,u,1,2\n", "t.csv"),
                    Catch::Contains("t.csv:2"));
  const auto t = ActivityTable::parse(
      "params,unit,tests,signal_bits,toggles_per_test\n\"-GN=4 -GA=1\",x,10,100,25\n", "t.csv");
  REQUIRE(t.by_params.count("-GN=4 -GA=1") == 1);
  CHECK(t.by_params.at("-GN=4 -GA=1").toggles_per_test == 25);
}

namespace {

rtu::host::PlanOptions small_plan(double area_budget, const std::string& minimise) {
  rtu::host::PlanOptions o;
  o.scene = "/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc";
  o.max_error = 0.01;
  o.widths = {4};
  o.coord_bits = {10, 12, 16};
  o.child_bits = {8};
  o.sweep.rays = 1500;
  o.sweep.image_width = 0;
  o.area_budget = area_budget;
  o.minimise = minimise;
  return o;
}

}  // namespace

TEST_CASE(
    "plan --area-budget: the chosen units fit, running the chosen configuration gives the plan's figures, "
    "and one more unit of either kind would not fit or not be faster",
    "[energy][plan][scale]") {
  const double budget = 2.5;  // mm^2: the rdna2 unit with one box and one triangle unit is 1.6
  const rtu::host::PlanOptions o = small_plan(budget, "cycles");
  std::vector<rtu::host::SweepRow> candidates;
  const rtu::host::PlanResult res = rtu::host::plan_format(o, [&](const rtu::host::PlanStep& s) {
    if (s.stage == rtu::host::PlanStage::kCandidate) candidates.push_back(*s.row);
  });
  REQUIRE(res.found);
  const rtu::host::SweepRow& best = res.best;
  CHECK(best.area_mm2 <= budget);
  CHECK(res.reference.area_mm2 <= budget);  // the base format is costed in the same area
  for (const auto& r : candidates) CHECK(r.area_mm2 <= budget);

  // Run the chosen configuration as a sweep point of its own: the same cycles, area and energy.
  const rtu::host::Scene scene = rtu::host::load_scene(o.scene);
  const rtu::host::AreaTable area = rtu::host::AreaTable::shipped();
  auto cache = rtu::host::make_sweep_cache();
  const rtu::host::SweepRow again = rtu::host::run_sweep_point(
      scene, rtu::host::SweepPoint{o.scene, best.p.format, best.p.bvh_width, best.p.config}, o.sweep, area,
      *cache);
  CHECK(again.cycles == best.cycles);
  CHECK(again.area_mm2 == best.area_mm2);
  CHECK(again.pj_per_ray == best.pj_per_ray);
  CHECK(again.hit_agreement == best.hit_agreement);

  // One more box or triangle unit: over the budget, or not fewer cycles.
  const TimingConfig c = rtu::host::sweep_config(best.p.config);
  for (const auto& [nb, nt] : {std::pair{c.box_units + 1, c.tri_units}, std::pair{c.box_units, c.tri_units + 1}}) {
    const std::string more = "rdna2:box_units=" + std::to_string(nb) + ":tri_units=" + std::to_string(nt);
    CAPTURE(more);
    const rtu::host::SweepRow r = rtu::host::retime_sweep_point(scene, again, more, o.sweep, area, *cache);
    CHECK((r.area_mm2 > budget || r.cycles >= best.cycles));
  }
}

TEST_CASE(
    "plan --minimise energy: no candidate that meets the budget uses less energy per ray than the plan, but by "
    "at most --min-gain for more area",
    "[energy][plan][scale]") {
  rtu::host::PlanOptions o = small_plan(0.0, "energy");
  for (const double min_gain : {o.min_gain_pct, 0.0}) {
    o.min_gain_pct = min_gain;
    CAPTURE(min_gain);
    const auto [res, candidates] = plan_with_candidates(o);
    REQUIRE(res.found);
    REQUIRE(!candidates.empty());
    CHECK(res.json["min_gain_applies"] == true);
    for (const auto& r : candidates) {
      CAPTURE(r.p.format);
      if (r.pj_per_ray >= res.best.pj_per_ray) continue;
      // One width and child-offset width: the candidates are the walk up the coordinate bits, each weighed
      // against the plan's bits once they were kept.
      CHECK(r.area_mm2 > res.best.area_mm2);
      CHECK(100.0 * (1.0 - r.pj_per_ray / res.best.pj_per_ray) <= min_gain);
    }
    CHECK(res.best.pj_per_ray > 0);
    CHECK(res.json["plan"]["pj_per_ray"].get<double>() == res.best.pj_per_ray);
  }
}

TEST_CASE("energy: oriented nodes pay a rotation per node test and the stage's area", "[energy][obb][scale]") {
  TimingConfig c = rtu::hw::timing_preset("rdna2");
  c.bvh_width = 8;
  rtu::hw::FixedFormat aabb = rtu::hw::format_preset("wide8");
  rtu::hw::FixedFormat obb = aabb;
  obb.node_kind = 1;
  const rtu::host::AreaTable area = rtu::host::AreaTable::shipped();
  const rtu::host::ActivityTable activity = rtu::host::ActivityTable::shipped();
  const rtu::hw::CostInputs ai = rtu::host::cost_inputs(aabb, c, area, activity);
  const rtu::hw::CostInputs oi = rtu::host::cost_inputs(obb, c, area, activity);
  CHECK(ai.rotate.nand2_eq == 0);
  CHECK(ai.rotate.toggles_per_test == 0);
  // 24 multiplies and 12 adds of the reference operators: at least Horowitz's order (3.1 pJ and 0.1 pJ each,
  // 75.6 pJ) within the calibration's spread (the model's multiplier is 3.03 pJ).
  const double pj = oi.rotate.toggles_per_test * rtu::hw::nangate45().pj_per_transition();
  CHECK(pj > 0.8 * 75.6);
  CHECK(pj < 1.2 * 75.6);
  CHECK(oi.box.nand2_eq == ai.box.nand2_eq);  // the slab tests are the same unit
  // The stage's size: the synthesized products (bench/rtl_rotate_area.sh's row for the default widths) and the
  // reciprocals' six multiplies.
  const auto row = area.by_params.find("-GOB=39 -GDB=26 -GMB=14");
  REQUIRE(row != area.by_params.end());
  CHECK(oi.rotate.nand2_eq > double(row->second.transistors) / 4.0);
  CHECK(oi.rotate.nand2_eq < double(row->second.transistors) / 4.0 + 6.0 * 49290.0 / 4.0 + 1.0);
  CHECK(oi.rotate.source.find("size synthesized") == 0);
  const rtu::hw::AreaReport aa = rtu::hw::area_report(c, ai), oa = rtu::hw::area_report(c, oi);
  CHECK(oa.box_mm2 == Approx(rtu::hw::logic_area_mm2(c.box_units * (ai.box.nand2_eq + oi.rotate.nand2_eq))));
  CHECK(oa.tri_mm2 == aa.tri_mm2);
  // A timed run of an oriented image counts one rotation per node test (each node fetched is tested once
  // without restarts); an axis-aligned one none.
  for (int kind : {0, 1}) {
    const rtu::host::Scene scene = rtu::host::load_scene("builtin:hairball");
    rtu::host::DeviceOptions o;
    o.kind = rtu::hw::DeviceKind::kTimed;
    o.timing = c;
    o.format = kind ? obb : aabb;
    o.tracer.bvh.width = 8;
    const std::vector<rtu::hw::Ray> rays = rtu::host::incoherent_rays(scene.geometry.bounds(), 2000, 5);
    std::vector<rtu::hw::Hit> hits(rays.size());
    const auto dev = rtu::host::make_device(scene.geometry, o);
    rtu::hw::TraversalStats ts;
    dev->trace_batch(rays.data(), hits.data(), rays.size(), false, 2, ts);
    const TimingStats s = dev->timed()->timing();
    CHECK(s.obb_rotations == (kind ? s.node_fetches : 0));
    CHECK(s.node_fetches > 0);
    const rtu::hw::EnergyReport e = rtu::hw::energy_report(s, c, kind ? oi : ai);
    for (const auto& ev : e.events)
      if (std::string(ev.key) == "rotate") CHECK(ev.pj() == Approx(double(s.obb_rotations) * (kind ? pj : 0.0)));
  }
}

TEST_CASE("energy: a ray slot's storage is the RTL traversal unit's registers, as yosys synthesized them",
          "[energy]") {
  // bench/data/rtl_trav_area.csv (bench/rtl_trav_area.sh): per synthesized design its Verilator parameters and the
  // flip-flops of the slots' state, node/record buffers and stacks. trav_slot_bits sizes them from trav_unit.sv's
  // declarations; the cost model prices them (cost_inputs below).
  std::ifstream in(std::string(RTU_SOURCE_DIR) + "/bench/data/rtl_trav_area.csv");
  REQUIRE(in);
  std::string line;
  std::getline(in, line);
  REQUIRE(line == "params,control_cells,control_transistors,state_bits,buffer_bits,stack_bits");
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    INFO(line);
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    REQUIRE(f.size() == 6);
    auto g = [&](const std::string& name) {
      const size_t at = f[0].find("-G" + name + "=");
      REQUIRE(at != std::string::npos);
      return std::stoi(f[0].substr(at + name.size() + 3));
    };
    rtu::rtl::BoxUnitParams b;
    b.n = g("N");
    b.a = g("A");
    b.m = g("M");
    b.tb = g("TB");
    b.rsh = g("RSH");
    b.lsh = g("LSH");
    rtu::rtl::TriUnitParams t;
    t.a = b.a;
    t.d = g("D");
    t.tb = b.tb;
    const rtu::rtl::TravSlotBits sb = rtu::rtl::trav_slot_bits(b, t);
    const long slots = g("SLOTS"), stack = g("STACK");
    // Buffers and stacks are plain registers: every declared bit is a flip-flop.
    CHECK(std::stol(f[4]) == slots * sb.buffer);
    CHECK(std::stol(f[5]) == slots * (stack + sb.spill) * sb.entry);
    // The state: each slot's registers and the unit's 32-bit clock counter; yosys trims a register bit it proves
    // constant (at these parameters one of sp_from's, a slot), never adds one.
    const long state = std::stol(f[3]) - 32;
    CHECK(state <= slots * sb.state);
    CHECK(state >= slots * (sb.state - 1));
    // The cost model's slot: the registers, the buffer and the pending spills beside the stack.
    TimingConfig c = rtu::hw::timing_preset("rdna2");
    if (b.n == 8) {
      c.format = "wide8";
      c.bvh_width = 8;
    }
    const rtu::hw::CostInputs ci = rtu::host::cost_inputs(c);
    if (b.a == 39 && b.tb == 56) {  // the rows of the default format's widths
      CHECK(ci.slot_state_bits == double(sb.state + sb.buffer + sb.spill * sb.entry));
      CHECK(ci.stack_entry_bits == double(sb.entry));
    }
    ++rows;
  }
  CHECK(rows >= 2);
}
