// The timing configuration: presets validate and differ where the hardware they resemble differs, every key
// prints and parses back, and bad keys and values are refused with the key named.
#include <catch2/catch.hpp>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

using namespace rtu::hw;

namespace {

// The message of the std::invalid_argument `f` throws ("" when it throws nothing).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// Preset `name` has every key of preset `base` but those of `may_differ` at base's value; returns how many keys
// differ.
int check_keys_kept(const std::string& name, const std::string& base, const std::vector<std::string>& may_differ) {
  INFO(name << " against " << base);
  const auto a = timing_keys(timing_preset(name)), b = timing_keys(timing_preset(base));
  REQUIRE(a.size() == b.size());
  int differing = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    INFO(a[i].key);
    if (std::find(may_differ.begin(), may_differ.end(), a[i].key) == may_differ.end())
      CHECK(a[i].value == b[i].value);
    differing += a[i].value != b[i].value;
  }
  return differing;
}

std::string value_of(const TimingConfig& c, const std::string& key) {
  for (const TimingKey& k : timing_keys(c))
    if (k.key == key) return k.value;
  FAIL("no key " << key);
  return "";
}

}  // namespace

TEST_CASE("every timing preset validates and lists every key", "[timing][config]") {
  REQUIRE(timing_preset_names() ==
          std::vector<std::string>{"rdna2", "intel", "embedded", "rdna2-mem", "intel-mem", "rdna2-chip",
                                   "intel-chip", "embedded-chip", "rdna4", "xe2", "rdna4-mem", "xe2-mem",
                                   "rdna4-chip", "xe2-chip", "rdna4-lss", "vksim-mobile", "vksim-mobile-chip",
                                   "vksim-rtx2060", "vksim-rtx2060-chip"});
  for (const std::string& name : timing_preset_names()) {
    INFO(name);
    const TimingConfig c = timing_preset(name);
    CHECK(c.name == name);
    CHECK_NOTHROW(c.validate());
    CHECK_FALSE(timing_preset_description(name).empty());
    const auto keys = timing_keys(c);
    CHECK(keys.size() == 84);  // every field of TimingConfig but `name`
    for (const TimingKey& k : keys) {
      CHECK_FALSE(k.key.empty());
      CHECK_FALSE(k.value.empty());
      CHECK_FALSE(k.description.empty());
    }
    CHECK(keys.front().key == "format");
    CHECK(keys.back().key == "watchdog_cycles");
  }
  // The default-constructed configuration is the rdna2 preset.
  const auto a = timing_keys(TimingConfig{}), b = timing_keys(timing_preset("rdna2"));
  REQUIRE(a.size() == b.size());
  for (size_t i = 0; i < a.size(); ++i) CHECK(a[i].value == b[i].value);
  CHECK(TimingConfig{}.name == "rdna2");
}

TEST_CASE("timing presets differ where the hardware does", "[timing][config]") {
  const TimingConfig rdna2 = timing_preset("rdna2"), intel = timing_preset("intel"),
                     embedded = timing_preset("embedded");
  CHECK(rdna2.bvh_width == 4);
  CHECK(rdna2.box_rate == 4);
  CHECK(rdna2.tri_rate == 1);
  // Intel's hardware BVH is 6-wide; the preset took width 8 while the model supported only 2, 4 and 8.
  CHECK(intel.bvh_width == 6);
  CHECK(intel.format == "xe6");  // 6-wide nodes of 64 bytes, as Intel's
  CHECK(format_preset(intel.format).width == intel.bvh_width);
  CHECK(intel.box_units * intel.box_rate == 12);  // Intel's 12 box tests per clock
  CHECK(intel.box_rate == intel.bvh_width);       // each unit a 6-wide node per clock
  CHECK(intel.tri_rate == 1);
  CHECK(embedded.format == "compact");
  CHECK(embedded.bvh_width == 4);
  CHECK(embedded.box_units == 1);
  CHECK(embedded.box_rate <= 2);
  CHECK(embedded.cache_kib == 16);
  CHECK(embedded.ray_slots < rdna2.ray_slots);
  // Every preset's format exists, as wide as the preset's BVH.
  for (const std::string& name : timing_preset_names()) {
    INFO(name);
    CHECK_NOTHROW(format_preset(timing_preset(name).format));
    CHECK(format_preset(timing_preset(name).format).width == timing_preset(name).bvh_width);
  }
}

TEST_CASE("the 2025 presets take the vendors' rates, widths and caches", "[timing][config]") {
  const TimingConfig rdna2 = timing_preset("rdna2"), rdna4 = timing_preset("rdna4"),
                     intel = timing_preset("intel"), xe2 = timing_preset("xe2");
  // RDNA4: two intersection engines, 8 box tests (one 8-wide node a clock) or 2 triangle tests per clock.
  CHECK(rdna4.bvh_width == 8);
  CHECK(rdna4.box_units * rdna4.box_rate == 8);
  CHECK(rdna4.box_rate == rdna4.bvh_width);  // a BVH8 node a clock on both engines
  CHECK(rdna4.tri_units * rdna4.tri_rate == 2);
  CHECK(rdna4.box_units * rdna4.box_rate == 2 * rdna2.box_units * rdna2.box_rate);
  // 128-byte nodes with 12-bit child boxes.
  CHECK(format_preset(rdna4.format).child_bits == 12);
  CHECK(format_preset(rdna4.format).node_align == 128);
  // Xe2: three traversal pipelines of 6 box tests (one box unit each), 2 triangle tests, BVH6 as Xe-HPG.
  CHECK(xe2.format == intel.format);
  CHECK(xe2.bvh_width == 6);
  CHECK(xe2.box_units == 3);
  CHECK(xe2.box_rate == xe2.bvh_width);
  CHECK(xe2.box_units * xe2.box_rate == 18);
  CHECK(xe2.tri_units * xe2.tri_rate == 2);
  CHECK(xe2.ray_slots * intel.box_units == intel.ray_slots * xe2.box_units);  // the slots of a pipeline as intel's
  // The memory: one unit's share of the chip's bandwidth at its clock, the first-level cache, 300 ns to VRAM.
  const TimingConfig rm = timing_preset("rdna4-mem"), xm = timing_preset("xe2-mem");
  CHECK(rm.dram_bytes_per_cycle == Approx(644.6 / (64 * 2.4)).epsilon(0.002));   // RX 9070 XT: 64 RAs
  CHECK(xm.dram_bytes_per_cycle == Approx(456.0 / (20 * 2.67)).epsilon(0.002));  // B580: 20 Xe2 cores
  CHECK(rm.cache_kib == 32);                                                     // the CU's L0
  CHECK(xm.cache_kib == 2 * timing_preset("intel-mem").cache_kib);               // Xe2's 16 KB BVH cache
  CHECK(rm.dram_latency == Approx(300 * rm.clock_ghz).margin(1));
  CHECK(xm.dram_latency == Approx(300 * xm.clock_ghz).margin(1));
  const TimingConfig rc = timing_preset("rdna4-chip"), xc = timing_preset("xe2-chip");
  CHECK(rc.units == 64);
  CHECK(xc.units == 20);
  CHECK(rc.l2_kib == 8192);   // Navi 48: 8 MB
  CHECK(xc.l2_kib == 18432);  // BMG-G21: 18 MB
  CHECK(rc.dram_bytes_per_cycle * rc.clock_ghz == Approx(644.6).epsilon(0.0001));
  CHECK(xc.dram_bytes_per_cycle * xc.clock_ghz == Approx(456.0).epsilon(0.0001));
}

TEST_CASE("memory-bound presets keep their base's datapath and take one unit's share of a real GPU's memory",
          "[timing][config]") {
  // The keys a memory-bound preset may change: the cache and what is behind it. Every other key is its base's, so
  // that a difference in cycles between the two is the memory's alone.
  const std::vector<std::string> memory = {"cache_kib",     "cache_ways",   "line_bytes",          "layout_align",
                                           "cache_latency", "dram_latency", "dram_bytes_per_cycle"};
  const std::pair<std::string, std::string> mem_presets[] = {
      {"rdna2-mem", "rdna2"}, {"intel-mem", "intel"}, {"rdna4-mem", "rdna4"}, {"xe2-mem", "xe2"}};
  for (const auto& [mem, base] : mem_presets) {
    INFO(mem << " against " << base);
    CHECK(check_keys_kept(mem, base, memory) >= 3);  // cache size, latency and bandwidth at least
  }
  // The figures follow from the chips' published ones (timing_config.cpp): bandwidth / (units x clock), a small
  // first-level cache, 300 ns to VRAM at the unit's clock.
  const TimingConfig r = timing_preset("rdna2-mem"), i = timing_preset("intel-mem");
  CHECK(r.dram_bytes_per_cycle == Approx(512.0 / (80 * 2.0)));  // RX 6900 XT: 512 GB/s, 80 CUs, 2.0 GHz
  CHECK(i.dram_bytes_per_cycle == Approx(560.0 / (32 * 2.1)).epsilon(0.001));  // A770: 560 GB/s, 32 Xe cores
  CHECK(r.cache_kib == 16);                                                    // RDNA's L0 per CU
  CHECK(i.cache_kib == 8);                                                     // Alchemist's BVH cache
  CHECK(r.dram_latency == Approx(300 * r.clock_ghz));
  CHECK(i.dram_latency == Approx(300 * i.clock_ghz));
  // Memory-bound against their bases: a smaller cache, slower and narrower memory behind it.
  for (const auto& [mem, base] : mem_presets) {
    const TimingConfig m = timing_preset(mem), g = timing_preset(base);
    CHECK(m.cache_kib < g.cache_kib);
    CHECK(m.dram_latency > g.dram_latency);
    CHECK(m.dram_bytes_per_cycle < g.dram_bytes_per_cycle / 4);
  }
}

TEST_CASE("chip presets keep their unit's preset and take the chip's published memory", "[timing][config][chip]") {
  // What a chip preset may change from its unit's: the chip keys and the DRAM latency behind the L2.
  const std::vector<std::string> chip = {"units",
                                         "ray_policy",
                                         "l2_kib",
                                         "l2_slices",
                                         "l2_ways",
                                         "l2_latency",
                                         "l2_bytes_per_cycle",
                                         "dram_channels",
                                         "dram_banks",
                                         "dram_row_bytes",
                                         "dram_activate_cycles",
                                         "dram_precharge_cycles",
                                         "dram_bytes_per_cycle",
                                         "dram_latency"};
  for (const auto& [name, unit] : {std::pair<std::string, std::string>{"rdna2-chip", "rdna2-mem"},
                                   {"intel-chip", "intel-mem"},
                                   {"embedded-chip", "embedded"},
                                   {"rdna4-chip", "rdna4-mem"},
                                   {"xe2-chip", "xe2-mem"},
                                   {"vksim-mobile-chip", "vksim-mobile"},
                                   {"vksim-rtx2060-chip", "vksim-rtx2060"}}) {
    check_keys_kept(name, unit, chip);
  }
  const TimingConfig r = timing_preset("rdna2-chip"), i = timing_preset("intel-chip"),
                     e = timing_preset("embedded-chip");
  CHECK(r.units == 80);  // Navi 21: 80 CUs, one Ray Accelerator each
  CHECK(i.units == 32);  // ACM-G10: 32 Xe cores, one RTU each
  CHECK(r.l2_kib == 4096);
  CHECK(i.l2_kib == 16384);
  CHECK(r.dram_bytes_per_cycle * r.clock_ghz == Approx(512.0));                  // GB/s
  CHECK(i.dram_bytes_per_cycle * i.clock_ghz == Approx(560.0).epsilon(0.0001));  // 266.67 x 2.1
  CHECK(e.dram_bytes_per_cycle * e.clock_ghz == Approx(51.2));                   // LPDDR5-6400 x64
  // A miss through the L2 that opens a row costs about the -mem presets' 300 ns (the unit alone).
  const TimingConfig r4 = timing_preset("rdna4-chip"), x2 = timing_preset("xe2-chip");
  for (const TimingConfig* c : {&r, &i, &r4, &x2}) {
    INFO(c->name);
    const double ns = (c->l2_latency + c->dram_activate_cycles + c->dram_latency) / c->clock_ghz;
    CHECK(ns == Approx(300.0).epsilon(0.02));
  }
  // The shared DRAM over the units is the -mem preset's share (rdna2-mem: 3.2 bytes per clock per unit).
  CHECK(r.dram_bytes_per_cycle / r.units == Approx(timing_preset("rdna2-mem").dram_bytes_per_cycle));
}

TEST_CASE("the papers' baseline presets take Vulkan-Sim's configuration files' figures",
          "[timing][config][chip]") {
  // Vulkan-Sim 2.0's gpgpusim.config options (timing_config.cpp names the files): the mobile SoC of treelet
  // prefetching's code and the RTX 2060.
  const TimingConfig m = timing_preset("vksim-mobile-chip"), r = timing_preset("vksim-rtx2060-chip");
  for (const TimingConfig* c : {&m, &r}) {
    INFO(c->name);
    CHECK(c->clock_ghz == 1.365);  // -gpgpu_clock_domains 1365:...
    CHECK(c->format == "xe6");     // Mesa's BVH6 of 64-byte nodes
    CHECK(c->bvh_width == 6);
    CHECK(c->cache_kib == 64);                                // -gpgpu_cache:dl1 S:1:128:512: 512 x 128 B
    CHECK(c->cache_latency == 20);                            // -gpgpu_l1_latency 20
    CHECK(c->l2_latency == 160);                              // -gpgpu_l2_rop_latency 160
    CHECK(c->dram_latency == 100 + 8);                        // -dram_latency 100, tCL 20 at 3.5 GHz
    CHECK(c->dram_activate_cycles == 8);                      // tRCD 20 at 3.5 GHz: 5.7 ns at 1.365 GHz
    CHECK(c->dram_banks == 16);                               // nbk=16
    CHECK(c->l2_kib / c->l2_slices == 64 * 16 * 128 / 1024);  // S:64:128:16 per sub-partition
  }
  CHECK(m.units == 8);            // -gpgpu_n_clusters 8
  CHECK(m.ray_slots == 16 * 32);  // -gpgpu_rt_max_warps 16
  CHECK(m.l2_kib == 512);         // 4 channels of one sub-partition
  CHECK(m.dram_channels == 4);
  CHECK(m.dram_bytes_per_cycle * m.clock_ghz == Approx(56.0).epsilon(0.001));  // 4 x 14 GB/s
  CHECK(m.box_latency == 4);  // -gpgpu_rt_intersection_latency 2,4,4,2,4,4,4
  CHECK(m.tri_latency == 4);
  CHECK(r.units == 30);
  CHECK(r.ray_slots == 4 * 32);  // -gpgpu_rt_max_warps 4
  CHECK(r.l2_kib == 3072);       // 12 channels x 2 sub-partitions
  CHECK(r.dram_channels == 12);
  CHECK(r.dram_bytes_per_cycle * r.clock_ghz == Approx(336.0).epsilon(0.001));  // 12 x 28 GB/s
  CHECK(r.box_latency == 8);                                                    // 4,8,8,4,8,8,8
  CHECK(r.tri_latency == 8);
  // The unit presets: one unit's share of the DRAM, and an L2 miss opening a row for every miss.
  for (const auto& [chip, unit] :
       {std::pair{m, timing_preset("vksim-mobile")}, {r, timing_preset("vksim-rtx2060")}}) {
    INFO(unit.name);
    CHECK(unit.dram_bytes_per_cycle == Approx(chip.dram_bytes_per_cycle / chip.units).margin(0.01));
    CHECK(unit.dram_bytes_per_cycle <= chip.dram_bytes_per_cycle / chip.units);
    CHECK(unit.dram_latency == chip.l2_latency + chip.dram_activate_cycles + chip.dram_latency);
  }
}

TEST_CASE("timing keys round-trip through their printed values", "[timing][config]") {
  for (const std::string& from : timing_preset_names()) {
    for (const std::string& onto : timing_preset_names()) {
      if (from == onto) continue;
      INFO(from << " onto " << onto);
      const TimingConfig src = timing_preset(from);
      TimingConfig dst = timing_preset(onto);
      // In key order, each step validated. The RTX 2060's L2 of 24 slices divides no other chip's power-of-two
      // L2 into whole sets, so a key refused for what the other keys still hold is set again after them; only
      // the L2's size and slices may need that.
      std::vector<TimingKey> later;
      for (const TimingKey& k : timing_keys(src)) {
        try {
          set_timing_key(dst, k.key, k.value);
        } catch (const std::invalid_argument&) {
          later.push_back(k);
        }
      }
      for (const TimingKey& k : later) {
        CHECK((k.key == "l2_kib" || k.key == "l2_slices"));
        REQUIRE_NOTHROW(set_timing_key(dst, k.key, k.value));
      }
      const auto a = timing_keys(src), b = timing_keys(dst);
      REQUIRE(a.size() == b.size());
      for (size_t i = 0; i < a.size(); ++i) {
        CHECK(a[i].key == b[i].key);
        CHECK(a[i].value == b[i].value);
      }
      CHECK(dst.clock_ghz == src.clock_ghz);  // bit for bit, not only as text
      CHECK(dst.dram_bytes_per_cycle == src.dram_bytes_per_cycle);
      CHECK(dst.name == onto);  // set_timing_key leaves the name alone
    }
  }
  // Doubles that need all 17 digits come back exactly.
  TimingConfig c;
  c.clock_ghz = 0.1 + 0.2;
  c.dram_bytes_per_cycle = 1.0 / 3.0;
  TimingConfig d;
  set_timing_key(d, "clock_ghz", value_of(c, "clock_ghz"));
  set_timing_key(d, "dram_bytes_per_cycle", value_of(c, "dram_bytes_per_cycle"));
  CHECK(d.clock_ghz == c.clock_ghz);
  CHECK(d.dram_bytes_per_cycle == c.dram_bytes_per_cycle);
}

TEST_CASE("set_timing_key sets what it parses and refuses the rest, naming the key", "[timing][config]") {
  TimingConfig c = timing_preset("rdna2");
  set_timing_key(c, "ray_slots", "64");
  CHECK(c.ray_slots == 64);
  // The cluster engine: off in every preset, 1..64 triangles per clock when set.
  for (const std::string& name : timing_preset_names()) CHECK(timing_preset(name).cluster_tri_rate == 0);
  set_timing_key(c, "cluster_tri_rate", "8");
  CHECK(c.cluster_tri_rate == 8);
  CHECK(value_of(c, "cluster_tri_rate") == "8");
  CHECK_THROWS_WITH(set_timing_key(c, "cluster_tri_rate", "65"), Catch::Contains("cluster_tri_rate"));
  set_timing_key(c, "cluster_tri_rate", "0");
  set_timing_key(c, "dram_bytes_per_cycle", "12.5");
  CHECK(c.dram_bytes_per_cycle == 12.5);
  set_timing_key(c, "format", "compact");
  CHECK(c.format == "compact");
  set_timing_key(c, "line_bytes", "32");
  CHECK(c.line_bytes == 32);
  set_timing_key(c, "cache_kib", "0");  // no cache
  CHECK(c.cache_kib == 0);
  for (int w : {2, 4, 6, 8}) {
    set_timing_key(c, "bvh_width", std::to_string(w));
    CHECK(c.bvh_width == w);
  }

  struct Case {
    const char* key;
    const char* value;
    const char* words;  // besides the key
  };
  const Case cases[] = {
      {"ray_slots", "12x", "integer"},
      {"ray_slots", "", "integer"},
      {"ray_slots", "1e99", "integer"},
      {"ray_slots", "99999999999", "integer"},
      {"ray_slots", " 5", "integer"},
      {"ray_slots", "5.0", "integer"},
      {"ray_slots", "0", "[1, 4096]"},
      {"ray_slots", "4097", "[1, 4096]"},
      {"stack_entries", "65", "[1, 64]"},
      {"box_latency", "0", "[1, 100000]"},
      {"tri_latency", "0", "[1, 100000]"},
      {"dram_latency", "100001", "[0, 100000]"},
      {"box_rate", "0", "[1, 64]"},
      {"tri_units", "65", "[1, 64]"},
      {"queue_depth", "-1", "[1, 4096]"},
      {"cache_ways", "0", "[1, 64]"},
      {"cache_kib", "65537", "[0, 65536]"},
      {"cache_ways", "3", "whole number of sets"},  // 64 KiB of 3 x 64-byte sets
      {"line_bytes", "48", "power of two"},
      {"line_bytes", "8", "[16, 4096]"},
      {"bvh_width", "3", "2, 4, 6 or 8"},
      {"bvh_width", "5", "2, 4, 6 or 8"},
      {"bvh_width", "16", "2, 4, 6 or 8"},
      {"format", "nosuch", "nosuch"},
      {"format", "", "format preset"},
      {"box_unit", "verilog", "cpp or rtl"},
      {"box_unit", "", "cpp or rtl"},
      {"tri_unit", "verilog", "cpp or rtl"},
      {"tri_unit", "RTL", "cpp or rtl"},
      {"clock_ghz", "0", "clock_ghz"},
      {"clock_ghz", "-1", "clock_ghz"},
      {"clock_ghz", "inf", "finite"},
      {"clock_ghz", "nan", "finite"},
      {"clock_ghz", "2GHz", "number"},
      {"dram_bytes_per_cycle", "1e999", "finite"},
      {"dram_bytes_per_cycle", "", "number"},
  };
  for (const Case& k : cases) {
    INFO(k.key << " = '" << k.value << "'");
    TimingConfig t = timing_preset("rdna2");
    const std::string e = error_of([&] { set_timing_key(t, k.key, k.value); });
    INFO(e);
    CHECK(e.find(k.key) != std::string::npos);
    CHECK(e.find(k.words) != std::string::npos);
    // A refused value leaves the configuration as it was.
    const auto a = timing_keys(t), b = timing_keys(timing_preset("rdna2"));
    for (size_t i = 0; i < a.size(); ++i) CHECK(a[i].value == b[i].value);
  }

  const std::string unknown = error_of([&] { set_timing_key(c, "ray_slot", "4"); });
  CHECK(unknown.find("ray_slot'") != std::string::npos);
  CHECK(unknown.find("ray_slots") != std::string::npos);  // the known keys are listed
  CHECK(unknown.find("dram_bytes_per_cycle") != std::string::npos);
  CHECK(error_of([&] { set_timing_key(c, "name", "x"); }).find("unknown") != std::string::npos);
}

TEST_CASE("validate names the first bad key, unknown presets list the known ones", "[timing][config]") {
  TimingConfig c;
  c.queue_depth = 0;
  c.cache_ways = 0;
  CHECK(error_of([&] { c.validate(); }).find("queue_depth") != std::string::npos);
  c = TimingConfig{};
  c.dram_bytes_per_cycle = 0.0;
  CHECK(error_of([&] { c.validate(); }).find("dram_bytes_per_cycle") != std::string::npos);
  c = TimingConfig{};
  c.cache_kib = 48;  // 48 KiB of 4-way 64-byte lines: 192 sets, fine
  CHECK_NOTHROW(c.validate());
  c.cache_ways = 5;  // 48 KiB / (5 * 64) is not whole
  CHECK(error_of([&] { c.validate(); }).find("cache_kib") != std::string::npos);

  const std::string e = error_of([] { timing_preset("amd"); });
  CHECK(e.find("'amd'") != std::string::npos);
  for (const std::string& n : timing_preset_names()) CHECK(e.find(n) != std::string::npos);
  CHECK_THROWS_AS(timing_preset_description("amd"), std::invalid_argument);
}
