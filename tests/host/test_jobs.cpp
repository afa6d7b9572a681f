// The jobs behind rtusim's plan, demo and report called as host functions, without the command line, on small
// inputs; and the helpers the command line shares (ray specs, timing overrides, pipeline-trace windows).
#include <catch2/catch.hpp>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/devices/device_settings.h"
#include "host/io/error.h"
#include "host/io/image.h"
#include "host/io/json_io.h"
#include "host/io/pipeline_trace.h"
#include "host/jobs/compare.h"
#include "host/jobs/demo.h"
#include "host/jobs/image_diff.h"
#include "host/jobs/pareto.h"
#include "host/jobs/plan.h"
#include "host/jobs/report.h"
#include "host/jobs/sweep.h"
#include "host/scene/ray_spec.h"
#include "host/scene/scene.h"
#include "hwmodel/timing/timing_config.h"
#include "tests/common/test_util.h"
#include "tests/host/plan_checks.h"

namespace fs = std::filesystem;
using rtu::host::Json;

using rtu::test::TempDir;

namespace {

// A small scene of every primitive kind with a light and a 40x30 camera, so that a whole demo runs in seconds.
std::string small_scene(const fs::path& dir) {
  const fs::path p = dir / "small.json";
  std::ofstream(p) << R"({
  "camera": {"position": [0, 1.5, 5], "look_at": [0, 0.5, 0], "fov_y": 45, "width": 40, "height": 30},
  "materials": {"chrome": {"type": "mirror", "color": [0.9, 0.9, 0.9]}},
  "meshes": [{"generate": "icosphere", "subdiv": 2, "transform": {"translate": [-0.8, 0.6, 0]}}],
  "spheres": [{"center": [0.9, 0.5, 0], "radius": 0.5, "material": "chrome"}],
  "planes": [{"normal": [0, 1, 0], "offset": 0}],
  "lights": [{"type": "point", "position": [2, 4, 3], "intensity": [20, 20, 20]}]
})";
  return p.string();
}

Json read_json(const fs::path& p) {
  return rtu::host::read_json_file(p.string());  // depth-limited, as rtu reads JSON (host/io/json_io.h)
}

// A plan of `scene` within `max_error` over the given widths and bits, measured on `rays` rays on one thread, with
// no image.
rtu::host::PlanOptions plan_options(const std::string& scene, double max_error, std::vector<int> widths,
                                    std::vector<int> coord_bits, std::vector<int> child_bits, int rays) {
  rtu::host::PlanOptions o;
  o.scene = scene;
  o.max_error = max_error;
  o.widths = std::move(widths);
  o.coord_bits = std::move(coord_bits);
  o.child_bits = std::move(child_bits);
  o.sweep.rays = rays;
  o.sweep.image_width = 0;
  o.sweep.threads = 1;
  return o;
}

}  // namespace

TEST_CASE("plan: the chosen format meets its budget on the sample it measured, with the fewest coordinate bits",
          "[jobs][plan]") {
  rtu::host::PlanOptions o =
      plan_options("builtin:icosphere?subdiv=2", 0.02, {4}, {3, 6, 10, 14, 18, 24}, {4, 8}, 300);
  std::vector<rtu::host::SweepRow> candidates;
  std::vector<rtu::host::PlanStage> stages;
  const rtu::host::PlanResult r = rtu::host::plan_format(o, [&](const rtu::host::PlanStep& s) {
    stages.push_back(s.stage);
    if (s.stage == rtu::host::PlanStage::kCandidate) {
      REQUIRE(s.row != nullptr);
      CHECK(s.meets == rtu::host::plan_meets(*s.row, o));
      candidates.push_back(*s.row);
    }
  });
  REQUIRE(r.found);
  CHECK(r.scene == "builtin:icosphere?subdiv=2");
  CHECK(rtu::host::plan_meets(r.best, o));
  CHECK(rtu::host::plan_error(r.best, "hit") <= o.max_error);
  CHECK(r.best.box_false_negatives == 0);
  CHECK(r.best.rays == 2 * o.sweep.rays);
  CHECK(r.best.p.bvh_width == 4);
  CHECK(r.json["plan"]["coord_bits"] == r.format.coord_bits);
  // The fewest coordinate bits that meet the budget are the first of the list that do: every candidate before
  // them did not. Minimising cycles, the plan then takes more bits while they are faster.
  const int bits = r.json["widths"][0]["coord_bits"];
  CHECK(r.format.coord_bits == r.json["widths"][0]["chosen_coord_bits"]);
  CHECK(r.format.coord_bits >= bits);
  for (const rtu::host::SweepRow& c : candidates)
    if (rtu::host::plan_meets(c, o) && c.p.format.find("child_bits=8") != std::string::npos) {
      const int cb = rtu::hw::format_from_spec(c.p.format).coord_bits;
      // Every candidate walked up to the chosen bits met the budget and was slower than the chosen.
      if (cb > bits && cb < r.format.coord_bits) CHECK(c.cycles >= r.best.cycles);
    }
  bool seen = false;
  for (const rtu::host::SweepRow& c : candidates) {
    if (c.p.format.find("child_bits=8") == std::string::npos || c.p.format == "default") continue;
    if (c.p.format.find("coord_bits=" + std::to_string(bits) + ":") != std::string::npos) seen = true;
    if (!seen) CHECK_FALSE(rtu::host::plan_meets(c, o));
  }
  CHECK(seen);
  // The reference is the configuration's format (rdna2: default) at the plan's width, measured last.
  CHECK(r.reference.p.format == "default");
  CHECK(r.reference.p.bvh_width == r.best.p.bvh_width);
  REQUIRE(!stages.empty());
  CHECK(stages.front() == rtu::host::PlanStage::kCoordBits);
  CHECK(stages[stages.size() - 2] == rtu::host::PlanStage::kDefault);
  CHECK(stages.back() == rtu::host::PlanStage::kCandidate);
  CHECK(r.json["plan"]["format"] == r.best.p.format);
  CHECK(r.json["plan"]["cycles"] == r.best.cycles);
  CHECK(r.json["default"]["cycles"] == r.reference.cycles);
}

TEST_CASE("compare_hits: a ray starting on a surface has a large relative but a small distance error", "[jobs]") {
  // Ray 0 starts a millionth of a unit from the surface it hits; ray 1 hits at t = 10. |d| = 2, a grid step of
  // 1e-5 world units.
  std::vector<rtu::hw::Ray> rays(2);
  rays[0].dir = rays[1].dir = rtu::hw::Vec3(0.0f, 0.0f, 2.0f);
  std::vector<rtu::hw::Hit> ref(2), dev(2);
  ref[0].prim = dev[0].prim = ref[1].prim = dev[1].prim = 0;
  ref[0].t = 1e-6f;
  dev[0].t = 3e-6f;  // relative error 2; distance 4e-6 = 0.4 steps
  ref[1].t = 10.0f;
  dev[1].t = 10.0001f;  // relative error 1e-5; distance 2e-4 = 20 steps
  const rtu::host::HitComparison c = rtu::host::compare_hits(ref, dev, {true, true}, false, &rays, 1e-5);
  CHECK(c.t_rel_max == Approx(2.0).epsilon(1e-6));
  CHECK(c.t_rel_max_ray == 0);
  CHECK(c.t_abs_steps_max == Approx(double(10.0001f - 10.0f) * 2.0 / 1e-5).epsilon(1e-9));
  CHECK(c.t_abs_steps_max_ray == 1);
  CHECK(c.t_abs_steps_mean ==
        Approx((double(3e-6f) - double(1e-6f)) * 2.0 / 1e-5 / 2.0 + c.t_abs_steps_max / 2.0));
  // Without a grid step the distance is not computed.
  CHECK(rtu::host::compare_hits(ref, dev, {true, true}, false).t_abs_steps_max == 0.0);
}

TEST_CASE("plan: the confidence bounds hold their definitions", "[jobs][plan]") {
  using rtu::host::proportion_upper_bound;
  // Clopper-Pearson: P(X <= k | n, p_u) = 1 - confidence, checked by summing the binomial terms directly.
  for (const auto& [k, n] : {std::pair<uint64_t, uint64_t>{0, 10}, {1, 10}, {5, 20}, {17, 300}, {99, 1000}}) {
    const double pu = proportion_upper_bound(k, n, 0.95);
    CHECK(pu > double(k) / double(n));
    double cdf = 0.0, term = std::pow(1.0 - pu, double(n));  // P(X = 0)
    for (uint64_t i = 0; i <= k; ++i) {
      cdf += term;
      term *= double(n - i) / double(i + 1) * pu / (1.0 - pu);
    }
    CHECK(cdf == Approx(0.05).epsilon(1e-9));
  }
  CHECK(proportion_upper_bound(0, 1000, 0.95) == Approx(1.0 - std::pow(0.05, 1.0 / 1000.0)).epsilon(1e-12));
  // Many trials, few successes: the Poisson limit, chi2(0.95; 2(k + 1)) / 2n; chi2(0.95; 6) = 12.5916. The two
  // differ by O(k / n) relatively.
  CHECK(proportion_upper_bound(2, 40000, 0.95) == Approx(12.5916 / 80000.0).epsilon(1e-3));
  CHECK(proportion_upper_bound(3, 3, 0.95) == 1.0);
  CHECK(proportion_upper_bound(0, 0, 0.95) == 1.0);
  // Mean: z(0.95) = 1.644854.
  CHECK(rtu::host::mean_upper_bound(0.5, 2.0, 400, 0.95) == Approx(0.5 + 1.644854 * 2.0 / 20.0).epsilon(1e-6));
  CHECK(std::isinf(rtu::host::mean_upper_bound(0.5, 2.0, 1, 0.95)));
}

TEST_CASE("plan: a seed, a stated bound that meets the budget, and the configuration's own format",
          "[jobs][plan]") {
  rtu::host::PlanOptions o = plan_options("builtin:icosphere?subdiv=2", 0.05, {4}, {4, 8, 12, 16}, {4, 6}, 400);
  o.config = "embedded";  // its format is compact, not default
  o.sweep.seed = 7;
  const rtu::host::PlanResult a = rtu::host::plan_format(o);
  REQUIRE(a.found);
  const std::string base = rtu::hw::timing_preset("embedded").format;
  CHECK(a.best.p.format.rfind(base + ":", 0) == 0);
  CHECK(a.reference.p.format == base);
  CHECK(a.json["base_format"] == base);
  CHECK(a.json["seed"] == 7);
  CHECK(a.json["confidence"] == 0.95);
  // The stated bound is the error's: above the measured rate, within the budget, and what plan_meets compares.
  const double bound = a.json["plan"]["error_bound"].get<double>();
  CHECK(bound == rtu::host::plan_error_bound(a.best, o));
  CHECK(bound >= rtu::host::plan_error(a.best, "hit"));
  CHECK(bound <= o.max_error);
  CHECK(bound ==
        rtu::host::proportion_upper_bound(a.best.false_misses + a.best.false_hits, a.best.compared_rays, 0.95));
  // Same seed, same plan; the seed picks the incoherent rays.
  const rtu::host::PlanResult again = rtu::host::plan_format(o);
  CHECK(again.json.dump() == a.json.dump());
  o.sweep.seed = 8;
  const rtu::host::PlanResult other = rtu::host::plan_format(o);
  CHECK(other.json["seed"] == 8);
  CHECK(other.json["widths"].dump() != a.json["widths"].dump());
  // A budget that zero disagreements on these rays cannot show is refused, naming the rays needed.
  o.max_error = 1e-4;
  CHECK_THROWS_WITH(rtu::host::plan_format(o), Catch::Contains("use --rays"));
}

TEST_CASE("plan: a bad metric, budget, cost or --min-gain is refused before the scene is loaded", "[jobs][plan]") {
  rtu::host::PlanOptions o;
  o.scene = "no/such/scene.obj";
  o.metric = "psnr";
  CHECK_THROWS_WITH(rtu::host::plan_format(o), Catch::Contains("--metric"));
  o.metric = std::string("t");  // a move: GCC 12 -Wrestrict misfires on copying "t" over "psnr" here
  o.max_error = -1.0;
  CHECK_THROWS_WITH(rtu::host::plan_format(o), Catch::Contains("--max-error"));
  o.max_error = 0.1;
  o.min_psnr = 30.0;
  o.sweep.image_width = 0;
  CHECK_THROWS_WITH(rtu::host::plan_format(o), Catch::Contains("--min-psnr needs a render"));
  o.min_psnr = 0.0;
  o.minimise = "foo";
  CHECK_THROWS_WITH(rtu::host::plan_format(o),
                    Catch::Contains("--minimise: cycles, bytes, energy, area or perf-per-area, got 'foo'"));
  o.minimise = "cycles";
  for (const double bad : {-1.0, 100.5, std::nan(""), HUGE_VAL}) {
    o.min_gain_pct = bad;
    CHECK_THROWS_WITH(rtu::host::plan_format(o), Catch::Contains("--min-gain: a finite percentage in 0..100"));
  }
  o.min_gain_pct = rtu::host::kDefaultMinGainPct;
  o.config = "no-such-preset";
  CHECK_THROWS_AS(rtu::host::plan_format(o), rtu::host::Error);
}

TEST_CASE("plan: budgets below the smallest showable bound and NaN options are refused at once", "[jobs][plan]") {
  rtu::host::PlanOptions o;
  o.scene = "no/such/scene.obj";  // refused before the scene is loaded
  for (double m : {0.0, 1e-20, 4.9e-324, 1e-12, 2e-8}) {
    o.max_error = m;
    CHECK_THROWS_WITH(rtu::host::plan_format(o), Catch::Contains("below the smallest hit disagreement"));
  }
  // The smallest showable budget is the bound of zero disagreements on the most rays; just above it, the message
  // names rays that do show it, and they do.
  const double smallest = rtu::host::plan_smallest_hit_budget(rtu::host::kMaxPlanRays, o.confidence);
  CHECK(smallest > 2e-8);
  CHECK(smallest < 3e-8);
  o.max_error = 1e-5;
  o.sweep.rays = 1000;
  try {
    rtu::host::plan_format(o);
    FAIL("no error");
  } catch (const rtu::host::Error& e) {
    const std::string msg = e.what();
    INFO(msg);
    const size_t at = msg.find("use --rays ");
    REQUIRE(at != std::string::npos);
    const uint64_t need = std::stoull(msg.substr(at + 11));
    CHECK(rtu::host::plan_smallest_hit_budget(need, o.confidence) <= 1e-5);
    CHECK(rtu::host::plan_smallest_hit_budget(need - 1, o.confidence) > 1e-5);
  }
  // NaN in any one of these options, the others valid, is refused with the option named.
  o.max_error = 0.1;
  using Field = double rtu::host::PlanOptions::*;
  const std::pair<Field, const char*> nan_options[] = {{&rtu::host::PlanOptions::min_psnr, "--min-psnr"},
                                                       {&rtu::host::PlanOptions::confidence, "--confidence"},
                                                       {&rtu::host::PlanOptions::area_budget, "--area-budget"},
                                                       {&rtu::host::PlanOptions::max_error, "--max-error"}};
  for (const auto& [field, option] : nan_options) {
    rtu::host::PlanOptions bad = o;
    bad.*field = std::nan("");
    CHECK_THROWS_WITH(rtu::host::plan_format(bad), Catch::Contains(option));
  }
}

TEST_CASE(
    "plan: more coordinate bits pay only beyond --min-gain, and for less traversal work or beyond the placement "
    "noise",
    "[jobs][plan]") {
  rtu::host::PlanOptions o;
  rtu::host::SweepRow fewer, more;
  fewer.p.format = "packed:coord_bits=14:child_bits=8";
  more.p.format = "packed:coord_bits=16:child_bits=8";
  fewer.node_visit_overhead = more.node_visit_overhead = 0.05;
  fewer.prim_test_overhead = more.prim_test_overhead = 0.02;
  // The IFC house's case: node visits equal, DRAM bytes per ray lower at more bits by where nodes fall on cache
  // lines, cycles 5% lower: a tie, and the message says so, with the measured bytes.
  fewer.cycles = 1000000;
  more.cycles = 950000;
  fewer.dram_bytes_per_ray = 186.0;
  more.dram_bytes_per_ray = 164.0;
  CHECK(rtu::host::plan_cheaper(more, fewer, o));
  CHECK_FALSE(rtu::host::plan_more_bits_pay(more, fewer, o));
  std::string why = rtu::host::plan_more_bits_cause(more, fewer, o);
  INFO(why);
  CHECK(why.find("fewer DRAM bytes per ray (164 against 186)") != std::string::npos);
  CHECK(why.find("cache lines") != std::string::npos);
  CHECK(why.find("a tie") != std::string::npos);
  CHECK(why.find("node visits") == std::string::npos);
  // The same bytes and 10% fewer cycles: beyond the noise, taken, the cause still the bytes.
  more.cycles = 900000;
  CHECK(rtu::host::plan_more_bits_pay(more, fewer, o));
  why = rtu::host::plan_more_bits_cause(more, fewer, o);
  CHECK(why.find("a tie") == std::string::npos);
  CHECK(why.find("DRAM bytes") != std::string::npos);
  // Fewer node visits: taken at any saving beyond --min-gain, and named as the cause (not cache lines).
  more.cycles = 970000;
  more.node_visit_overhead = 0.01;
  more.dram_bytes_per_ray = 190.0;
  CHECK(rtu::host::plan_more_bits_pay(more, fewer, o));
  why = rtu::host::plan_more_bits_cause(more, fewer, o);
  CHECK(why.find("fewer node visits (+1% over the float reference's, against +5%)") != std::string::npos);
  CHECK(why.find("DRAM") == std::string::npos);
  // Fewer node visits but 1% fewer cycles: within --min-gain (2%), so the fewer bits are kept, saying why; with
  // --min-gain 0 any saving pays.
  more.cycles = 990000;
  CHECK_FALSE(rtu::host::plan_more_bits_pay(more, fewer, o));
  why = rtu::host::plan_more_bits_cause(more, fewer, o);
  CHECK(why.rfind("1% fewer cycles for +2 bits, below --min-gain 2% (fewer node visits", 0) == 0);
  CHECK(why.find("the fewer bits kept") != std::string::npos);
  o.min_gain_pct = 0.0;
  CHECK(rtu::host::plan_more_bits_pay(more, fewer, o));
  o.min_gain_pct = rtu::host::kDefaultMinGainPct;
  // Not cheaper: never taken.
  more.cycles = 1000001;
  CHECK_FALSE(rtu::host::plan_more_bits_pay(more, fewer, o));
  // Minimising bytes: exact figures, no noise margin.
  o.minimise = "bytes";
  fewer.bvh_bytes = 1000;
  more.bvh_bytes = 999;
  CHECK(rtu::host::plan_more_bits_pay(more, fewer, o));
}

TEST_CASE("plan: the objectives' order, and why a costlier candidate that saves too little is passed over",
          "[jobs][plan]") {
  rtu::host::PlanOptions o;
  rtu::host::SweepRow small, big;
  small.p.format = "default:coord_bits=12:child_bits=8";
  big.p.format = "default:coord_bits=16:child_bits=8";
  small.rays = big.rays = 1000;
  small.cycles = 100000;
  big.cycles = 99800;  // 0.2% fewer cycles
  small.area_mm2 = 1.0;
  big.area_mm2 = 1.12;  // for 12% more area
  small.pj_per_ray = 1000.0;
  big.pj_per_ray = 900.0;
  // Rays per clock per mm^2: rays / cycles / area.
  CHECK(rtu::host::plan_rays_per_clock(small) == Approx(0.01));
  CHECK(rtu::host::plan_perf_per_area(small) == Approx(0.01));
  CHECK(rtu::host::plan_perf_per_area(big) == Approx(1000.0 / 99800.0 / 1.12));
  CHECK(rtu::host::plan_perf_per_area(rtu::host::SweepRow{}) == 0.0);  // no cycles, no area: no figure
  // Minimising cycles (the default): big is cheaper, but its saving is below --min-gain 2%, so small is kept, and
  // the plan says why in the issue's words.
  CHECK(rtu::host::plan_cheaper(big, small, o));
  CHECK(rtu::host::plan_gain(big, small, o) == Approx(0.002));
  CHECK(rtu::host::plan_min_gain_applies(o));
  CHECK_FALSE(rtu::host::plan_pays(big, small, o));
  CHECK(rtu::host::plan_passed_over(big, small, o) == "0.2% fewer cycles for +12% area, below --min-gain 2%");
  CHECK(rtu::host::plan_passed_over(small, big, o).empty());  // not cheaper: nothing passed over
  // Smaller and cheaper needs no threshold; a saving beyond it pays.
  rtu::host::SweepRow smaller = small;
  smaller.cycles = 99700;
  CHECK(rtu::host::plan_pays(smaller, big, o));
  big.cycles = 97000;
  CHECK(rtu::host::plan_pays(big, small, o));
  CHECK(rtu::host::plan_passed_over(big, small, o).empty());
  big.cycles = 99800;
  o.min_gain_pct = 0.0;  // any saving pays
  CHECK(rtu::host::plan_pays(big, small, o));
  // Energy: 10% less per ray pays beyond 2%.
  o.min_gain_pct = rtu::host::kDefaultMinGainPct;
  o.minimise = "energy";
  CHECK(rtu::host::plan_pays(big, small, o));
  // Area: the smaller; no threshold (area is what it minimises).
  o.minimise = "area";
  CHECK_FALSE(rtu::host::plan_min_gain_applies(o));
  CHECK(rtu::host::plan_cheaper(small, big, o));
  CHECK_FALSE(rtu::host::plan_cheaper(big, small, o));
  // Rays per clock per mm^2: small (0.01) over big (0.00895), however few its cycles; with 20% fewer cycles than
  // small for 12% more area big has the better ratio and is taken, its gain the ratio's.
  o.minimise = "perf-per-area";
  CHECK_FALSE(rtu::host::plan_min_gain_applies(o));
  CHECK(rtu::host::plan_cheaper(small, big, o));
  big.cycles = 80000;
  CHECK(rtu::host::plan_pays(big, small, o));
  CHECK(rtu::host::plan_gain(big, small, o) == Approx(1.0 / 0.8 / 1.12 - 1.0));
}

TEST_CASE(
    "plan --min-gain: with a budget 12 and 16 coordinate bits both meet, 16 bits that save less are not taken, "
    "--minimise area takes 12",
    "[jobs][plan]") {
  rtu::host::PlanOptions o = plan_options("builtin:seed", 1e-2, {4}, {12, 16}, {8}, 5000);
  std::vector<rtu::host::SweepRow> rows;
  const auto collect = [&](const rtu::host::PlanStep& s) {
    if (s.stage == rtu::host::PlanStage::kCandidate && s.row->p.format != "default") rows.push_back(*s.row);
  };
  // Any saving (--min-gain 0, the rule before the threshold): 16 bits, faster by fewer node visits.
  o.min_gain_pct = 0.0;
  const rtu::host::PlanResult any = rtu::host::plan_format(o, collect);
  REQUIRE(any.found);
  REQUIRE(rows.size() == 2);
  const rtu::host::SweepRow &b12 = rows[0], &b16 = rows[1];
  REQUIRE(rtu::host::plan_meets(b12, o));
  REQUIRE(rtu::host::plan_meets(b16, o));
  REQUIRE(b16.area_mm2 > b12.area_mm2);
  const double gain = 1.0 - double(b16.cycles) / double(b12.cycles);
  REQUIRE(gain > 0.0);
  CHECK(any.format.coord_bits == 16);
  // The default threshold is above this saving (1.4%, for 11% more area): 12 bits, and the step says why.
  REQUIRE(100.0 * gain < rtu::host::kDefaultMinGainPct);
  o.min_gain_pct = rtu::host::kDefaultMinGainPct;
  const rtu::host::PlanResult def = rtu::host::plan_format(o);
  REQUIRE(def.found);
  CHECK(def.format.coord_bits == 12);
  CHECK(def.best.cycles == b12.cycles);
  CHECK(def.json["min_gain_pct"] == rtu::host::kDefaultMinGainPct);
  const Json& step = def.json["widths"][0]["more_coord_bits"].at(0);
  CHECK(step["taken"] == false);
  CHECK(step["to_coord_bits"] == 16);
  const std::string cause = step["cause"];
  INFO(cause);
  CHECK(cause.rfind(rtu::host::plan_passed_over(b16, b12, o), 0) == 0);
  CHECK(cause.find("% fewer cycles for +1") != std::string::npos);  // +11% area
  CHECK(cause.find("% area, below --min-gain 2%") != std::string::npos);
  // Every candidate is listed with its rays per clock per mm^2.
  const Json& listed = def.json["widths"][0]["candidates"];
  REQUIRE(listed.size() == 2);
  CHECK(listed[1]["perf_per_mm2"].get<double>() == rtu::host::plan_perf_per_area(b16));
  // A threshold just below the saving takes 16 bits; one just above keeps 12.
  o.min_gain_pct = 90.0 * gain;
  CHECK(rtu::host::plan_format(o).format.coord_bits == 16);
  o.min_gain_pct = 110.0 * gain;
  CHECK(rtu::host::plan_format(o).format.coord_bits == 12);
  // Minimising area, with any threshold: the fewest bits that meet the budget, and no walk up the bits.
  o.minimise = "area";
  o.min_gain_pct = 0.0;
  const rtu::host::PlanResult area = rtu::host::plan_format(o);
  CHECK(area.format.coord_bits == 12);
  CHECK(area.json["widths"][0]["more_coord_bits"].empty());
  CHECK(area.json["cost"].get<std::string>().rfind("area (area_mm2)", 0) == 0);
}

TEST_CASE("plan --minimise perf-per-area: the most rays per clock per mm^2 of the candidates within the budget",
          "[jobs][plan]") {
  rtu::host::PlanOptions o = plan_options("builtin:seed", 1e-2, {2, 4, 8}, {12, 16}, {4, 8}, 1000);
  o.minimise = "perf-per-area";
  const auto [res, candidates] = plan_with_candidates(o);
  REQUIRE(res.found);
  REQUIRE(candidates.size() >= 6);
  const double best = rtu::host::plan_perf_per_area(res.best);
  CHECK(best == Approx(double(res.best.rays) / double(res.best.cycles) / res.best.area_mm2));
  for (const rtu::host::SweepRow& r : candidates) {
    CAPTURE(r.p.format, r.p.bvh_width);
    CHECK(rtu::host::plan_perf_per_area(r) <= best);
  }
  CHECK(res.json["minimise"] == "perf-per-area");
  CHECK(res.json["min_gain_applies"] == false);
  CHECK(res.json["plan"]["perf_per_mm2"].get<double>() == best);
  CHECK(res.json["default"]["perf_per_mm2"].get<double>() == rtu::host::plan_perf_per_area(res.reference));
  // Its own choice: the smallest unit (--minimise area) is not the best ratio here, nor as large.
  o.minimise = "area";
  const rtu::host::PlanResult area = rtu::host::plan_format(o);
  REQUIRE(area.found);
  CHECK(area.best.area_mm2 < res.best.area_mm2);
  CHECK(rtu::host::plan_perf_per_area(area.best) < best);
  for (const rtu::host::SweepRow& r : candidates) CHECK(r.area_mm2 >= area.best.area_mm2);
}

TEST_CASE("plan and sweep: the poll hook is called between steps and stops the job when it throws",
          "[jobs][plan]") {
  rtu::host::PlanOptions o = plan_options("builtin:icosphere?subdiv=1", 0.05, {4}, {10, 16}, {8}, 64);
  int polls = 0;
  o.sweep.poll = [&] {
    if (++polls == 3) throw std::runtime_error("interrupted");
  };
  size_t candidates = 0;
  CHECK_THROWS_WITH(rtu::host::plan_format(o,
                                           [&](const rtu::host::PlanStep& s) {
                                             if (s.stage == rtu::host::PlanStage::kCandidate) ++candidates;
                                           }),
                    "interrupted");
  CHECK(polls == 3);
  CHECK(candidates == 0);  // stopped inside the first candidate, between its stages
  polls = 0;
  o.sweep.poll = [&] { ++polls; };
  const rtu::host::PlanResult r = rtu::host::plan_format(o);
  CHECK(r.found);
  CHECK(polls > 4);  // several stages per candidate
}

TEST_CASE("report plots: a hit disagreement of 0 is drawn apart from one wrong ray, with its own tick",
          "[jobs][report][pareto]") {
  using rtu::host::ParetoError;
  std::vector<rtu::host::SweepRow> rows(3);
  for (size_t i = 0; i < rows.size(); ++i) {
    rows[i].p =
        rtu::host::SweepPoint{"builtin:seed", "default:coord_bits=" + std::to_string(12 + 4 * i), 4, "rdna2"};
    rows[i].rays = 2000;
    rows[i].cycles = 1000 + 100 * i;
    rows[i].bvh_bytes = 5000 - 1000 * i;
  }
  rows[0].hit_agreement = 1.0 - 10.0 / 2000;
  rows[1].hit_agreement = 1.0 - 1.0 / 2000;  // one wrong ray
  rows[2].hit_agreement = 1.0;               // none
  const double one = rtu::host::pareto_error(rows[1], ParetoError::kHitDisagreement);
  const double zero = rtu::host::pareto_error(rows[2], ParetoError::kHitDisagreement);
  CHECK(one == Approx(1.0 / 2000));
  CHECK(zero == Approx(one / rtu::host::kHitZeroBelow));
  const std::string gnuplot = rtu::host::find_gnuplot();
  if (gnuplot.empty()) {
    WARN("gnuplot not installed: the plot's script is not checked");
    return;
  }
  TempDir dir("jobs_zero_plot");
  const auto plots = rtu::host::write_pareto_plots(rows, dir.path.string(), gnuplot);
  REQUIRE(plots.size() == 2);
  REQUIRE(plots[0].error == ParetoError::kHitDisagreement);
  const std::string stem = plots[0].png.substr(0, plots[0].png.size() - 4);
  std::ifstream in(dir.path / (stem + ".gp"));
  const std::string gp((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // The "0" tick at the zeros, decade ticks from above the break, and the dashed break between 0 and one ray.
  CHECK(gp.find("set ytics (\"0\" 5e-05, 0.001, 0.01)") != std::string::npos);
  CHECK(gp.find("set arrow 100000 from graph 0, first 0.000158") != std::string::npos);
  CHECK(gp.find("one wrong ray is 1/rays = 0.0005") != std::string::npos);
  CHECK(fs::exists(dir.path / plots[0].png));
  // The t error's plot has no zero on its axis: no break there.
  const std::string tstem = plots[1].png.substr(0, plots[1].png.size() - 4);
  std::ifstream tin(dir.path / (tstem + ".gp"));
  const std::string tgp((std::istreambuf_iterator<char>(tin)), std::istreambuf_iterator<char>());
  CHECK(tgp.find("set arrow 100000") == std::string::npos);
}

TEST_CASE("demo: writes every file it lists, and its figures agree with the files", "[jobs][demo]") {
  TempDir dir("jobs_demo");
  rtu::host::DemoOptions o;
  o.scene = small_scene(dir.path);
  o.out = (dir.path / "out").string();
  o.threads = 1;
  o.spp = 1;
  o.max_depth = 2;
  std::vector<rtu::host::DemoStage> stages;
  const rtu::host::DemoResult r =
      rtu::host::run_demo(o, [&](rtu::host::DemoStage s, const rtu::host::DemoResult&) { stages.push_back(s); });
  using S = rtu::host::DemoStage;
  CHECK(stages == std::vector<S>{S::kLoaded, S::kTraced, S::kTraced, S::kCompared, S::kRendered, S::kRendered,
                                 S::kHybrid, S::kRenderDiff});
  REQUIRE(!r.written.empty());
  for (const std::string& f : r.written) {
    CAPTURE(f);
    CHECK(fs::is_regular_file(f));
    CHECK(fs::file_size(f) > 0);
  }
  CHECK(r.written.back() == o.out + "/report.json");
  // One hit of 16 bytes per primary ray in each hit file.
  CHECK(fs::file_size(o.out + "/primary_float.hits") == 40u * 30u * 16u);
  CHECK(fs::file_size(o.out + "/primary_fixed.hits") == 40u * 30u * 16u);
  CHECK(r.fixed_vs_float.rays == 40u * 30u);
  REQUIRE(r.traces.size() == 2);
  CHECK(r.traces[0].device == rtu::hw::DeviceKind::kFloat);
  CHECK(r.traces[1].device == rtu::hw::DeviceKind::kFixed);
  REQUIRE(r.renders.size() == 3);
  CHECK_FALSE(r.renders[0].result.timed);
  CHECK(r.renders[1].options.device.kind == rtu::hw::DeviceKind::kTimed);
  CHECK(r.renders[1].result.timed);
  CHECK(r.renders[1].result.device_clock > 0);
  CHECK(r.renders[2].options.hybrid);
  const Json j = read_json(o.out + "/report.json");
  CHECK(j["width"] == 40);
  CHECK(j["devices"]["float"]["hits"] == r.traces[0].stats.hits);
  CHECK(j["devices"]["fixed"]["hits"] == r.traces[1].stats.hits);
  CHECK(j["renders"]["fixed"]["device"] == "timed");
  CHECK(j["renders"]["fixed"]["timing"]["cycles_per_frame"] == r.renders[1].result.device_clock);
  CHECK(j["hybrid_vs_raytrace"]["raytrace_cycles"] == r.renders[1].result.device_clock);
  CHECK(j["render_fixed_vs_float"]["pixels_differing"] == r.render_fixed_vs_float.pixels_differing);
}

TEST_CASE("report: the page, report.json, the sweep CSV and every image it embeds are written",
          "[jobs][report][scale]") {
  TempDir dir("jobs_report");
  rtu::host::ReportOptions o;
  o.out = (dir.path / "out").string();
  o.scenes = {"builtin:icosphere?subdiv=1"};
  o.quick = true;
  o.threads = 1;
  std::vector<rtu::host::ReportStage> stages;
  const rtu::host::ReportResult r =
      rtu::host::write_report(o, [&](const rtu::host::ReportStep& s) { stages.push_back(s.stage); });
  using S = rtu::host::ReportStage;
  CHECK(stages == std::vector<S>{S::kStart, S::kRender, S::kRender, S::kCycles, S::kSweep, S::kStress});
  for (const char* f :
       {"index.html", "report.json", "sweep.csv", "render_float.png", "render_fixed.png", "render_heatmap.png"}) {
    CAPTURE(f);
    CHECK(fs::file_size(o.out + "/" + f) > 0);
  }
  REQUIRE(!r.images.empty());
  std::ifstream page(o.out + "/index.html");
  const std::string html((std::istreambuf_iterator<char>(page)), std::istreambuf_iterator<char>());
  for (const std::string& img : r.images) {
    CAPTURE(img);
    CHECK(fs::is_regular_file(o.out + "/" + img));
    CHECK(html.find("src=\"" + img + "\"") != std::string::npos);
  }
  CHECK(r.stress_failures == 0);
  const Json j = read_json(o.out + "/report.json");
  CHECK(j["images"].size() == r.images.size());
  CHECK(j["cycles"].size() == rtu::hw::timing_preset_names().size());  // one scene: one row per preset
  CHECK(j["sweep"]["points"] == rtu::host::read_sweep_csv(o.out + "/sweep.csv").size());
  CHECK(j["stress"]["failures"] == 0);

  // The renders are shown at least 320 px wide (twice their size in the quick report, pixelated).
  for (const char* img : {"render_float.png", "render_fixed.png", "render_heatmap.png"}) {
    CAPTURE(img);
    const size_t at = html.find("src=\"" + std::string(img) + "\"");
    REQUIRE(at != std::string::npos);
    const size_t w = html.find("width=\"", at);
    REQUIRE(w != std::string::npos);
    CHECK(std::stoi(html.substr(w + 7)) >= 320);
    CHECK(std::stoi(html.substr(w + 7)) == 2 * j["renders"]["width"].get<int>());
  }
  // The heatmap: each pixel has the ramp's colour for its largest channel difference on the log scale whose full
  // scale report.json gives, and the page has the colour bar with its tick values.
  const rtu::host::Image fa = rtu::host::read_png(o.out + "/render_float.png");
  const rtu::host::Image fb = rtu::host::read_png(o.out + "/render_fixed.png");
  const rtu::host::Image heat = rtu::host::read_png(o.out + "/render_heatmap.png");
  const int full_scale = j["renders"]["heatmap_full_scale"].get<int>();
  CHECK(full_scale == rtu::host::diff_ramp_full_scale(j["renders"]["max_abs"].get<int>()));
  REQUIRE(heat.rgb.size() == fa.rgb.size());
  size_t wrong = 0;
  for (size_t p = 0; p < size_t(fa.width) * size_t(fa.height); ++p) {
    int d = 0;
    for (size_t k = 0; k < 3; ++k) d = std::max(d, std::abs(int(fa.rgb[3 * p + k]) - int(fb.rgb[3 * p + k])));
    const auto c = rtu::host::diff_ramp_color(rtu::host::diff_ramp_t(d, full_scale));
    wrong += c[0] != heat.rgb[3 * p] || c[1] != heat.rgb[3 * p + 1] || c[2] != heat.rgb[3 * p + 2];
  }
  CHECK(wrong == 0);
  CHECK(html.find("class=\"colorbar\"") != std::string::npos);
  CHECK(html.find("linear-gradient(to right, rgb(252,253,191) 0.00%") != std::string::npos);
  CHECK(html.find(">" + std::to_string(full_scale) + "</span>") != std::string::npos);
  CHECK(html.find(">0</span>") != std::string::npos);
  // RTL areas come from the table the project ships (no --area): the default format at rdna2 has one.
  CHECK(j["sweep"]["area_source"].get<std::string>().find("bench/data/rtl_area.csv") != std::string::npos);
  size_t with_area = 0;
  for (const rtu::host::SweepRow& row : rtu::host::read_sweep_csv(o.out + "/sweep.csv")) {
    with_area += row.rtl_cells > 0;
    if (row.p.format == "default" && row.p.config == "rdna2" && row.p.bvh_width == 4) CHECK(row.rtl_cells > 0);
  }
  CHECK(with_area > 0);
  for (const Json& p : j["sweep"]["plots"]) CHECK(p["area_panel"] == true);
}

TEST_CASE("report: the area table compiled in is the one the project ships", "[jobs][report]") {
  const rtu::host::AreaTable shipped = rtu::host::AreaTable::shipped();
  const rtu::host::AreaTable file =
      rtu::host::AreaTable::load(std::string(RTU_SOURCE_DIR) + "/" + rtu::host::kShippedAreaTable);
  CHECK(shipped.by_params.size() >= 9);
  REQUIRE(shipped.by_params.size() == file.by_params.size());
  for (const auto& [params, e] : file.by_params) {
    CAPTURE(params);
    REQUIRE(shipped.by_params.count(params) == 1);
    CHECK(shipped.by_params.at(params).cells == e.cells);
    CHECK(shipped.by_params.at(params).transistors == e.transistors);
  }
  CHECK_THROWS_WITH(rtu::host::AreaTable::parse("a,b\n", "t.csv"), Catch::Contains("t.csv:1"));
}

TEST_CASE("report: an output directory that cannot be created is refused before any work", "[jobs][report]") {
  TempDir dir("jobs_report_bad");
  std::ofstream(dir.path / "file") << "x";
  rtu::host::ReportOptions o;
  o.out = (dir.path / "file" / "out").string();
  bool started = false;
  CHECK_THROWS_AS(rtu::host::write_report(o, [&](const rtu::host::ReportStep&) { started = true; }),
                  rtu::host::Error);
  CHECK_FALSE(started);
}

TEST_CASE("ray specs, timing overrides and pipeline-trace windows as the command line passes them", "[jobs]") {
  const rtu::host::Scene s = rtu::host::load_scene("builtin:icosphere?subdiv=1");
  CHECK(rtu::host::rays_from_spec("primary:4x3", s, 1).size() == 12);
  CHECK(rtu::host::rays_from_spec("incoherent:7", s, 1).size() == 7);
  CHECK_THROWS_WITH(rtu::host::rays_from_spec("primary:0", s, 1), Catch::Contains("bad count '0'"));

  const rtu::hw::TimingConfig c = rtu::host::timing_config_from("intel", {"box_rate=3", "ray_slots=7"});
  CHECK(c.name == "intel");
  CHECK(c.box_rate == 3);
  CHECK(c.ray_slots == 7);
  CHECK_THROWS_WITH(rtu::host::timing_config_from("intel", {"box_rate"}), Catch::Contains("is not key=value"));
  CHECK_THROWS_AS(rtu::host::timing_config_from("no-such-preset", {}), rtu::host::Error);

  rtu::host::DeviceSettings d;
  d.config = "intel";
  d.format_fields["coord_bits"] = 16;
  const rtu::host::DeviceOptions timed = d.options(rtu::hw::DeviceKind::kTimed);
  CHECK(timed.kind == rtu::hw::DeviceKind::kTimed);
  CHECK(timed.format.coord_bits == 16);
  CHECK(timed.format.width == timed.timing.bvh_width);  // the preset's width, as --config gives it
  CHECK(d.options(rtu::hw::DeviceKind::kFloat).kind == rtu::hw::DeviceKind::kFloat);

  // One design point, one configuration: --format and --bvh-width on the timed device are the configuration's
  // keys, spelled either way.
  rtu::host::DeviceSettings by_option, by_set;
  by_option.format = "compact";
  by_option.bvh_width = 8;
  by_set.sets = {"format=compact", "bvh_width=8"};
  const rtu::host::DeviceOptions a = by_option.options(rtu::hw::DeviceKind::kTimed);
  const rtu::host::DeviceOptions b = by_set.options(rtu::hw::DeviceKind::kTimed);
  CHECK(a.timing.format == "compact");
  CHECK(a.timing.bvh_width == 8);
  const auto keys_a = rtu::hw::timing_keys(a.timing), keys_b = rtu::hw::timing_keys(b.timing);
  REQUIRE(keys_a.size() == keys_b.size());
  for (size_t i = 0; i < keys_a.size(); ++i) CHECK(keys_a[i].value == keys_b[i].value);
  CHECK(a.format.name == b.format.name);
  CHECK(a.format.coord_bits == rtu::hw::format_preset("compact").coord_bits);
  CHECK(a.format.width == 8);
  rtu::host::DeviceSettings clash = by_option;
  clash.sets = {"format=wide8"};
  CHECK_THROWS_WITH(clash.options(rtu::hw::DeviceKind::kTimed), Catch::Contains("--set format=wide8"));
  // Without --format the fixed device takes the default format and the timed device its configuration's.
  rtu::host::DeviceSettings plain;
  plain.config = "embedded";
  CHECK(plain.options(rtu::hw::DeviceKind::kFixed).format.name == "default");
  CHECK(plain.options(rtu::hw::DeviceKind::kTimed).format.coord_bits ==
        rtu::hw::format_preset(rtu::hw::timing_preset("embedded").format).coord_bits);

  const rtu::hw::PipelineTrace t = rtu::host::pipeline_trace_window("10:20");
  CHECK(t.from == 10);
  CHECK(t.to == 20);
  CHECK_THROWS_WITH(rtu::host::pipeline_trace_window("20:10"), Catch::Contains("--trace-window"));
  CHECK_THROWS_AS(rtu::host::pipeline_trace_window("10"), rtu::host::Error);
}
