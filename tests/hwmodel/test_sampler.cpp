// Sampled timing's estimator (hwmodel/timing/sampler.h) as pure functions: steps, probes, strata, the ratio
// estimate and its jackknife variance, the detailed warm-up's length; and the statistics table
// (hwmodel/timing/timing_stats.h).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <set>
#include <string>
#include <vector>

#include "hwmodel/timing/sampler.h"
#include "hwmodel/timing/timing_stats.h"

using namespace rtu::hw;

TEST_CASE("sampler: the step of a fraction and of a short packet", "[sample]") {
  CHECK(sample_step(0.0) == 1);
  CHECK(sample_step(0.01) == 100);
  CHECK(sample_step(0.3) == 3);
  CHECK(sample_step(1.0) == 1);
  // 10 measured units at every k-th need more than 10 k units between the first and the last.
  const size_t U = 256, per_unit = 256 + 256 + 64;
  CHECK(packet_step(10000 * U, U, 100, per_unit) == 100);
  CHECK(packet_step(1001 * U + 1, U, 100, per_unit) == 100);  // (n - 1) / U = 1001 >= 1000
  CHECK(packet_step(1000 * U, U, 100, per_unit) == 99);       // 999 units: every 99th gives 10
  // Every 3rd would give 10 but the measured units with warm-up and tail would be over half the rays: in full.
  CHECK(packet_step(31 * U, U, 100, 2 * U) == 1);
  CHECK(packet_step(U, U, 100, per_unit) == 1);  // one unit
  CHECK(packet_step(5, U, 1, per_unit) == 1);    // not sampled at all
}

TEST_CASE("sampler: one probed ray per block, inside it, drawn from the seed", "[sample]") {
  const size_t n = 1000, stride = 32;
  const std::vector<size_t> a = probe_rays(n, stride, packet_draw(1, 0));
  REQUIRE(a.size() == (n + stride - 1) / stride);
  for (size_t q = 0; q < a.size(); ++q) {
    CHECK(a[q] >= q * stride);
    CHECK(a[q] < std::min(n, (q + 1) * stride));
  }
  CHECK(probe_rays(n, stride, packet_draw(1, 0)) == a);  // deterministic
  CHECK(probe_rays(n, stride, packet_draw(2, 0)) != a);  // another seed, other rays
  CHECK(probe_rays(n, stride, packet_draw(1, 1)) != a);  // another packet, other rays
  // Not always the block's first ray (a fixed place would probe the same image columns in every row).
  size_t at_first = 0;
  for (size_t q = 0; q < a.size(); ++q) at_first += a[q] == q * stride;
  CHECK(at_first < a.size() / 4);
  const std::vector<size_t> every = probe_rays(7, 1, 123);
  CHECK(every == std::vector<size_t>{0, 1, 2, 3, 4, 5, 6});
}

TEST_CASE("sampler: strata and the units measured in them", "[sample]") {
  SECTION("one stratum: every k-th unit from a seeded offset in [1, k]") {
    std::vector<double> aux(102, 1.0);
    std::vector<uint8_t> prims(102, 1);  // every unit tests primitives: no second stratum
    std::set<size_t> offsets;
    for (uint64_t draw = 0; draw < 64; ++draw) {
      const std::vector<Stratum> s = choose_strata(aux, prims, 10, draw << 32 | draw);
      REQUIRE(s.size() == 1);
      CHECK(s[0].units.size() == 100);  // units 1 .. 100; 0 and 101 are simulated in full
      CHECK(s[0].units.front() == 1);
      CHECK(s[0].units.back() == 100);
      REQUIRE(!s[0].picked.empty());
      offsets.insert(s[0].picked[0]);
      CHECK(s[0].picked[0] >= 1);
      CHECK(s[0].picked[0] <= 10);
      for (size_t i = 1; i < s[0].picked.size(); ++i) CHECK(s[0].picked[i] - s[0].picked[i - 1] == 10);
    }
    CHECK(offsets.size() > 5);  // the offset is drawn, not fixed
  }
  SECTION("two strata: shared by sqrt(units x work), at least 2 each, spread over each stratum") {
    // 200 units: every fifth tests primitives and costs ten times the others (camera rays: geometry and sky).
    const size_t units = 202, k = 10;
    std::vector<double> aux(units, 256.0);
    std::vector<uint8_t> prims(units, 0);
    for (size_t j = 1; j + 1 < units; j += 5) {
      prims[j] = 1;
      aux[j] = 2560.0;
    }
    const std::vector<Stratum> s = choose_strata(aux, prims, k, 77);
    REQUIRE(s.size() == 2);
    CHECK(s[0].units.size() == 160);
    CHECK(s[1].units.size() == 40);
    // 20 measured, shared as sqrt(160 x 40960) = 2560 to sqrt(40 x 102400) = 2024: 11 and 9.
    CHECK(s[0].picked.size() == 11);
    CHECK(s[1].picked.size() == 9);
    for (const Stratum& st : s) {
      for (size_t j : st.picked) CHECK(std::find(st.units.begin(), st.units.end(), j) != st.units.end());
      CHECK(std::is_sorted(st.picked.begin(), st.picked.end()));
      CHECK(std::adjacent_find(st.picked.begin(), st.picked.end()) == st.picked.end());  // distinct
    }
    for (size_t j : s[1].picked) CHECK(prims[j] == 1);
    for (size_t j : s[0].picked) CHECK(prims[j] == 0);
  }
}

TEST_CASE("sampler: the ratio estimate and its jackknife variance", "[sample]") {
  // Units 1 .. 8 in one stratum with work x; units 2, 4, 6 measured.
  std::vector<double> aux = {0, 100, 200, 300, 400, 500, 600, 700, 800, 0};
  Stratum st;
  st.units = {1, 2, 3, 4, 5, 6, 7, 8};
  st.picked = {2, 4, 6};
  SECTION("cycles proportional to the work: the estimate is exact and its variance 0") {
    st.measured_c = {3 * 200.0, 3 * 400.0, 3 * 600.0};
    const CycleEstimate e = estimate_cycles({st}, aux, 1000.0);
    CHECK(e.cycles == 1000.0 + 3 * 3600.0);
    CHECK(e.variance == 0.0);
  }
  SECTION("a worked example") {
    st.measured_c = {500.0, 1300.0, 1700.0};
    const CycleEstimate e = estimate_cycles({st}, aux, 0.0);
    // ratio 3500 / 1200; leave-one-out ratios 3000/1000, 2200/800, 1800/600 = 3, 2.75, 3.
    const double ratio = 3500.0 / 1200.0, total = 3600.0;
    CHECK(e.cycles == Approx(ratio * total).epsilon(1e-15));
    const double r[3] = {3.0, 2.75, 3.0}, mean = (r[0] + r[1] + r[2]) / 3;
    double spread = 0.0;
    for (double x : r) spread += (x - mean) * (x - mean);
    const double expected = 2.0 / 3.0 * spread * total * total * (1.0 - 3.0 / 8.0);
    CHECK(e.variance == Approx(expected).epsilon(1e-12));
    // The probe's error adds ratio^2 (M - m) x its mean square over the measured units.
    st.probe_error2 = 3 * 25.0;
    const CycleEstimate p = estimate_cycles({st}, aux, 0.0);
    CHECK(p.variance == Approx(expected + ratio * ratio * 5 * 25.0).epsilon(1e-12));
  }
  SECTION("every unit measured: no sampling variance") {
    st.picked = st.units;
    st.measured_c = {100, 250, 300, 390, 520, 640, 650, 800};
    CHECK(estimate_cycles({st}, aux, 0.0).variance == 0.0);
    CHECK(estimate_cycles({st}, aux, 0.0).cycles == Approx(3650.0).epsilon(1e-15));
  }
}

TEST_CASE("sampler: a chip's thinned packet, its estimate and its t interval", "[sample]") {
  using rtu::hw::chip_thinning;
  // 1000 waves on 4 units at 1 in 10: a lead and a trail of 16 waves, 60 bursts of 16 between, 6 measured, each
  // with 12 waves of warm-up and tail: 200 waves simulated, under half.
  const rtu::hw::ChipThinning t = chip_thinning(1000, 4, 10);
  CHECK(t.sampled);
  CHECK(t.lead == 16);
  CHECK(t.trail == 16);
  CHECK(t.burst == rtu::hw::kChipBurstTurns);
  // Too few bursts (10 between, 1 measured), no sampling asked, or what would be simulated over half: not sampled.
  CHECK_FALSE(chip_thinning(200, 4, 10).sampled);
  CHECK_FALSE(chip_thinning(1000, 4, 1).sampled);
  CHECK_FALSE(chip_thinning(1000, 4, 2).sampled);  // 30 measured bursts of 28 waves: 872 of 1000
  CHECK(chip_thinning(200, 4, 10).why_not.find("fewer than the 4") != std::string::npos);
  CHECK(chip_thinning(1000, 4, 2).why_not.find("over half") != std::string::npos);
  CHECK(chip_thinning(20, 4, 10).why_not.find("fill and drain") != std::string::npos);
  CHECK(chip_thinning(1000, 4, 1).why_not.empty());  // none asked
  // A chip's 262,144-ray packet (8192 waves of 32 on 80 units) at 1 in 10: 23 bursts of 4 turns between the fill
  // and the drain, 2 measured: simulated in full, and said why; at 1 in 5 it is thinned.
  CHECK_FALSE(chip_thinning(8192, 80, 10).sampled);
  CHECK(chip_thinning(8192, 80, 10).why_not.find("holds 23 bursts of 4 turns") != std::string::npos);
  CHECK(chip_thinning(8192, 80, 5).sampled);
  // Bursts with no room for their warm-up and tail thin nothing.
  CHECK(chip_thinning(100000, 4, 10, 2).why_not.find("no room") != std::string::npos);
  // Student's t: 12.706 for 1 degree of freedom, 2.042 for 30, 1.96 beyond.
  CHECK(rtu::hw::student_t975(1) == 12.706);
  CHECK(rtu::hw::student_t975(30) == 2.042);
  CHECK(rtu::hw::student_t975(31) == 1.96);
  // Two bursts costing 50 and 70 cycles for 100 work each, 800 more work between skipped: the ratio 0.6 times the
  // 1000 work between, plus the lead's 100 cycles and the trail's 30.
  rtu::hw::ChipSample c;
  c.lead_done = 1100;
  c.measured_c = {50.0, 70.0};
  c.measured_a = {100.0, 100.0};
  c.skipped_work = 800.0;
  c.mid_done = 1800;
  c.end = 1830;
  c.population = 20.0;
  c.sampled = 2.0;
  const rtu::hw::CycleEstimate e = rtu::hw::estimate_chip_cycles(c, 1000);
  CHECK(e.cycles == Approx(100.0 + 0.6 * 1000.0 + 30.0));
  // The jackknife: ratios 0.7 and 0.5 with one burst left out, (m - 1) / m x their squared spread, x the work
  // between squared, x (1 - 2 / 20), x (t for 1 degree of freedom / 1.96)^2.
  const double t1 = 12.706 / 1.96;
  CHECK(e.variance == Approx(0.5 * 0.02 * 1000.0 * 1000.0 * 0.9 * t1 * t1));
}

TEST_CASE("sampler: the detailed warm-up follows how long the stream's rays hold their slots", "[sample]") {
  const size_t slots = 32, U = 256;
  SlotTimeAccount a;
  CHECK(warmup_rays(a, slots, 0) == 16 * slots);  // nothing seen yet
  CHECK(warmup_rays(a, slots, 300) == 300);       // a fixed warm-up
  // A segment of w warm-up rays, U measured and 64 tail rays; ray i enters at 2i and leaves `life` later.
  auto segment = [&](size_t w, const std::vector<uint64_t>& life) {
    std::vector<uint64_t> entered, written;
    for (size_t i = 0; i < life.size(); ++i) {
      entered.push_back(2 * i);
      written.push_back(2 * i + life[i]);
    }
    std::vector<uint64_t> done = written;
    std::sort(done.begin(), done.end());
    account_slot_time(a, done, written, entered, w, U, slots);
  };
  const size_t w = 256;
  std::vector<uint64_t> short_lives(w + U + 64, 40);  // every ray leaves long before w rays have passed
  for (int i = 0; i < 2; ++i) segment(w, short_lives);
  CHECK(a.rays == 2 * U);
  CHECK(a.held == 2.0 * U * 40);
  CHECK(warmup_rays(a, slots, 0) == 8 * slots);  // the shortest of the grid
  // A few rays that stay for most of the time 2000 rays take: a longer warm-up.
  std::vector<uint64_t> long_tail = short_lives;
  for (size_t i = w; i < w + U; i += 16) long_tail[i] = 3000;
  SlotTimeAccount b;
  std::swap(a, b);
  for (int i = 0; i < 2; ++i) segment(w, long_tail);
  // The unit's rate: 2.125 cycles per ray (its 512th hit at 1094, its warm-up's last at 550). At w = 40 x 32
  // rays, a long ray's time beyond (w + 128) x 2.125 = 2992 cycles is 8, 32 x 8 = 256 in all, under 0.5% of the
  // 115,200 cycles held; at 32 x 32 it is 552 each.
  CHECK(warmup_rays(a, slots, 0) == 40 * slots);
}

TEST_CASE("timing statistics: one table for every counter, which add, scaling and the report read", "[timing]") {
  std::set<std::string> names;
  TimingStats a, b;
  uint64_t v = 1;
  for (const TimingCounter& c : timing_counters()) {
    CHECK(names.insert(c.name).second);
    CHECK(std::string(c.unit).size() > 0);
    CHECK(std::string(c.description).size() > 10);
    a.*c.member = v;
    b.*c.member = 1000 * v;
    ++v;
  }
  CHECK(names.size() * sizeof(uint64_t) == sizeof(TimingStats));
  TimingStats sum = a;
  sum.add(b);
  v = 1;
  for (const TimingCounter& c : timing_counters()) {
    CAPTURE(c.name);
    CHECK(sum.*c.member == 1001 * v++);
  }
  // Sampled timing scales the per-ray counters and leaves the packet's to the sampler.
  TimingStats s = a;
  scale_sampled(s, 2.5);
  for (const TimingCounter& c : timing_counters()) {
    CAPTURE(c.name);
    const uint64_t expect =
        c.scale == SampleScale::kPerRay ? uint64_t(std::llround(double(a.*c.member) * 2.5)) : a.*c.member;
    CHECK(s.*c.member == expect);
  }
  CHECK(s.cycles == a.cycles);
  CHECK(s.dram_bytes != a.dram_bytes);
  // The report: unique keys, every entry described, values from the counters.
  const TimingConfig cfg;
  std::set<std::string> keys;
  for (const TimingStatValue& r : timing_report(a, cfg)) {
    CHECK(keys.insert(r.key).second);
    CHECK(std::string(r.description).size() > 3);
  }
  CHECK(keys.size() == timing_report_keys().size());
  CHECK(keys.count("cache.hit_rate") == 1);
  CHECK(keys.count("lower_bound.limited_by") == 1);
}

TEST_CASE("timing statistics: the lower bound is the busiest resource", "[timing]") {
  TimingConfig c;
  c.box_units = 2;
  c.tri_units = 1;
  c.tri_rate = 1;
  c.dram_bytes_per_cycle = 64.0;
  TimingStats s;
  s.cycles = 1000;
  s.box_issue_cycles = 1000;  // 500 cycles over two units
  s.tri_tests = 300;
  s.sphere_tests = 100;
  s.plane_tests = 50;           // 450 test slots
  s.dram_bytes = 64 * 600 + 1;  // 600.02 cycles
  LowerBound b = lower_bound(s, c);
  CHECK(b.box == 500.0);
  CHECK(b.triangle == 450.0);
  CHECK(b.dram == Approx(600.015625));
  CHECK(std::string(b.limited_by) == "dram");
  CHECK(b.cycles_over_bound == Approx(1000.0 / 600.015625));
  s.dram_bytes = 0;
  b = lower_bound(s, c);
  CHECK(std::string(b.limited_by) == "box");
  CHECK(b.cycles == 500.0);
  // One ray per clock through fetch and setup: 700 rays need 700 clocks whatever the units do.
  s.rays = 700;
  b = lower_bound(s, c);
  CHECK(b.fetch == 700.0);
  CHECK(std::string(b.limited_by) == "fetch");
  CHECK(b.cycles == 700.0);
  CHECK(lower_bound(TimingStats{}, c).cycles_over_bound == 0.0);
}
