// The cost model of ray sorting in the firmware (hwmodel/timing/sort_timing.h), worked by hand, and its keys.
#include <catch2/catch.hpp>

#include <stdexcept>
#include <string>

#include "hwmodel/timing/sort_timing.h"
#include "hwmodel/timing/timing_config.h"

using rtu::hw::SortCycles;
using rtu::hw::SortWork;
using rtu::hw::TimingConfig;

TEST_CASE("ray sort cycles worked by hand", "[sort][timing]") {
  // Two sorts of 5 rays, 4 radix passes each (8 passes, 40 keys through them), 4-bit digits (16 bins).
  const SortWork w{2, 10, 8, 40};
  TimingConfig c;
  c.sort_key_cycles = 3;
  c.sort_keys_per_clock = 2;
  c.sort_radix_bits = 4;
  c.dram_latency = 100;
  // Phase latency: (3 x 2 sorts + 8 passes) x 100 = 1400 cycles.
  SECTION("bandwidth-bound: 4 bytes per clock") {
    c.dram_bytes_per_cycle = 4;
    const SortCycles r = rtu::hw::sort_cycles(w, c);
    // keys: max(10 x 3 = 30, 10 x 40 / 4 = 100); passes: max(40 / 2 + 8 x 16 = 148, 40 x 20 / 4 = 200);
    // permute: max(10 / 2 = 5, 10 x 68 / 4 = 170); return: max(5, 10 x 36 / 4 = 90). 100 + 200 + 170 + 90 = 560.
    CHECK(r.key_cycles == 100.0);
    CHECK(r.pass_cycles == 200.0);
    CHECK(r.permute_cycles == 170.0);
    CHECK(r.return_cycles == 90.0);
    CHECK(r.latency_cycles == 1400);
    CHECK(r.cycles == 1960);
    CHECK(r.dram_bytes == 400 + 800 + 680 + 360);
    CHECK(r.compute_cycles == 30.0 + 148.0 + 5.0 + 5.0);
    CHECK(r.dram_cycles == 560.0);
    CHECK(std::string(r.limit) == "dram");
  }
  SECTION("compute-bound: 1000 bytes per clock") {
    c.dram_bytes_per_cycle = 1000;
    const SortCycles r = rtu::hw::sort_cycles(w, c);
    CHECK(r.cycles == 1400 + 30 + 148 + 5 + 5);
    CHECK(std::string(r.limit) == "compute");
  }
  SECTION("the phases' sum rounds up once: 3 bytes per clock") {
    c.dram_bytes_per_cycle = 3;
    // 400 / 3 + 800 / 3 + 680 / 3 + 360 / 3 = 2240 / 3 = 746.67: 747.
    CHECK(rtu::hw::sort_cycles(w, c).cycles == 1400 + 747);
  }
  SECTION("a chip of 2 units: the compute shared, the prefix sums side by side, the bandwidth the chip's") {
    c.units = 2;
    c.dram_bytes_per_cycle = 1000;
    // keys 30 / 2 = 15; passes 40 / (2 x 2) + 8 x 16 = 138; permute and return 10 / 4 = 2.5 each: 158.
    CHECK(rtu::hw::sort_cycles(w, c).cycles == 1400 + 158);
  }
  SECTION("sort_gather index: keys and radix passes only, as Meister et al.'s tracer counts them") {
    c.dram_bytes_per_cycle = 4;
    rtu::hw::set_timing_key(c, "sort_gather", "index");
    const SortCycles r = rtu::hw::sort_cycles(w, c);
    // keys 100 and passes 200 as above; no permute, no return; latency (2 sorts + 8 passes) x 100 = 1000.
    CHECK(r.permute_cycles == 0.0);
    CHECK(r.return_cycles == 0.0);
    CHECK(r.latency_cycles == 1000);
    CHECK(r.cycles == 1000 + 100 + 200);
    CHECK(r.dram_bytes == 400 + 800);
    CHECK(r.compute_cycles == 30.0 + 148.0);
  }
  SECTION("no sort, no cycles") {
    const SortCycles r = rtu::hw::sort_cycles(SortWork{}, c);
    CHECK(r.cycles == 0);
    CHECK(r.dram_bytes == 0);
    CHECK(std::string(r.limit) == "none");
  }
}

TEST_CASE("ray sort keys: defaults, ranges and an unknown key refused", "[sort][config]") {
  TimingConfig c;
  CHECK(c.ray_sort == rtu::hw::RaySort::kNone);  // off by default: every preset's cycles stay what they were
  rtu::hw::set_timing_key(c, "ray_sort", "origin_direction");
  CHECK(std::string(rtu::hw::name_of(c.ray_sort)) == "origin_direction");
  CHECK_THROWS_WITH(rtu::hw::set_timing_key(c, "ray_sort", "hilbert"),
                    Catch::Contains("ray_sort = 'hilbert' must be none, origin, direction, origin_direction or "
                                    "termination"));
  CHECK(std::string(rtu::hw::name_of(c.ray_sort)) == "origin_direction");  // unchanged by the refusal
  CHECK_THROWS_WITH(rtu::hw::set_timing_key(c, "sort_radix_bits", "17"), Catch::Contains("sort_radix_bits = 17"));
  CHECK_THROWS_WITH(rtu::hw::set_timing_key(c, "sort_radix_bits", "0"), Catch::Contains("outside [1, 16]"));
  CHECK_THROWS_AS(rtu::hw::set_timing_key(c, "sort_keys_per_clock", "0"), std::invalid_argument);
  CHECK_THROWS_AS(rtu::hw::set_timing_key(c, "sort_key_cycles", "-1"), std::invalid_argument);
  rtu::hw::set_timing_key(c, "sort_key_cycles", "0");  // a key unit that hides behind the memory
  CHECK(c.sort_key_cycles == 0.0);
}
