// The timed device's memory systems and chips: memory behind the cache (banks, an L2), several units sharing an
// L2 and banked DRAM under each ray policy, against the single unit and the fixed device (hits bit for bit, cycles
// that repeat across thread counts), and sampled chips within their stated intervals.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "host/devices/direct_device.h"
#include "host/jobs/render.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"
#include "tests/host/timed_checks.h"
#include "tests/hwmodel/timing_checks.h"

using rtu::host::DeviceOptions;
using rtu::hw::Hit;
using rtu::hw::Ray;

namespace {

// The timing of incoherent and camera rays of a scene on preset `preset` with `sets` applied (key, value).
rtu::hw::TimingStats timed_stats(const rtu::host::Scene& s, const std::string& preset,
                                 const std::vector<std::pair<std::string, std::string>>& sets, size_t n) {
  DeviceOptions o = preset_options("timed", preset);
  for (const auto& [k, v] : sets) rtu::hw::set_timing_key(o.timing, k, v);
  std::vector<Ray> rays = camera_and_incoherent_rays(s, n, 5);
  const auto dev = rtu::host::make_device(s.geometry, o);
  std::vector<Hit> h(rays.size());
  rtu::hw::TraversalStats ts;
  dev->trace_batch(rays.data(), h.data(), rays.size(), false, 2, ts);
  return dev->timed()->timing();
}

}  // namespace

TEST_CASE("memory behind the cache: banks without row costs are the single channel, an L2 only helps",
          "[timed][memory]") {
  const rtu::host::Scene s = rtu::host::load_scene("/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc");
  for (const std::string preset : {"rdna2-mem", "embedded"}) {
    CAPTURE(preset);
    // A small stack, so that spills and refills (by address, on the banks) take part.
    const std::vector<std::pair<std::string, std::string>> base = {{"stack_entries", "2"}};
    const rtu::hw::TimingStats plain = timed_stats(s, preset, base, 3000);
    REQUIRE(plain.stack_spills > 0);
    // One channel of 8 banks with no activate or precharge cost: every transfer as on the single channel.
    auto banks = base;
    banks.insert(banks.end(), {{"dram_banks", "8"}, {"dram_row_bytes", "1024"}});
    const rtu::hw::TimingStats b = timed_stats(s, preset, banks, 3000);
    CHECK(b.cycles == plain.cycles);
    CHECK(b.dram_bytes == plain.dram_bytes);
    CHECK(b.dram_row_hits + b.dram_row_misses == plain.cache_misses + plain.stack_spills + plain.stack_refills);
    // With row costs every row miss waits 30-60 cycles more. The slots then interleave differently, which moves
    // the cache's hits by a fraction of a percent, but thousands of misses waiting longer cost cycles.
    auto costly = banks;
    costly.insert(costly.end(), {{"dram_activate_cycles", "30"}, {"dram_precharge_cycles", "30"}});
    const rtu::hw::TimingStats c = timed_stats(s, preset, costly, 3000);
    CHECK(c.dram_row_hits + c.dram_row_misses == c.cache_misses + c.stack_spills + c.stack_refills);
    CHECK(c.cycles > plain.cycles);
    CHECK(c.dram_row_hits > 0);
    // An L2 of no latency and unlimited bandwidth in front of the same DRAM: what it holds costs nothing.
    auto l2 = base;
    l2.insert(l2.end(), {{"l2_kib", "1024"}, {"l2_latency", "0"}, {"l2_bytes_per_cycle", "0"}});
    const rtu::hw::TimingStats z = timed_stats(s, preset, l2, 3000);
    CHECK(z.l2_hits + z.l2_misses == z.cache_misses);  // every node cache fill goes through the L2
    CHECK(z.l2_hits > 0);
    CHECK(z.dram_bytes < plain.dram_bytes);
    CHECK(z.cycles < plain.cycles);
  }
}

TEST_CASE("chip: one unit through the chip's code path runs the single unit's cycles, counter for counter",
          "[timed][chip]") {
  const rtu::host::Scene s = rtu::host::load_scene("/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc");
  std::vector<Ray> rays = camera_and_incoherent_rays(s, 2000, 9);
  for (const std::string preset : {"rdna2", "embedded", "intel-mem"}) {
    CAPTURE(preset);
    DeviceOptions o = preset_options("timed", preset);
    rtu::hw::set_timing_key(o.timing, "stack_entries", "2");  // spills too
    const auto single = rtu::host::make_device(s.geometry, o);
    const auto chip = rtu::host::make_device(s.geometry, o);
    chip->timed()->set_force_chip(true);
    std::vector<Hit> h1(rays.size()), h2(rays.size());
    rtu::hw::TraversalStats t1, t2;
    // Two packets: the second starts where the first ended and finds the cache as the first left it.
    for (int packet = 0; packet < 2; ++packet) {
      single->trace_batch(rays.data(), h1.data(), rays.size(), packet == 1, 2, t1);
      chip->trace_batch(rays.data(), h2.data(), rays.size(), packet == 1, 2, t2);
      CHECK(std::memcmp(h1.data(), h2.data(), h1.size() * sizeof(Hit)) == 0);
    }
    check_same_timing(single->timed()->timing(), chip->timed()->timing());
  }
}

TEST_CASE("chip: several units give the fixed device's hits, and the same cycles on any number of threads",
          "[timed][chip]") {
  const rtu::host::Scene s = rtu::host::load_scene("/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc");
  std::vector<Ray> rays = camera_and_incoherent_rays(s, 3000, 4);
  const auto fixed = rtu::host::make_device(s.geometry, preset_options("fixed", "rdna2"));
  std::vector<Hit> hf(rays.size());
  rtu::hw::TraversalStats sf;
  fixed->trace_batch(rays.data(), hf.data(), rays.size(), false, 2, sf);
  for (const std::string policy : {"round_robin", "blocks", "waves"}) {
    CAPTURE(policy);
    DeviceOptions o = preset_options("timed", "rdna2");
    rtu::hw::set_timing_key(o.timing, "units", "4");
    rtu::hw::set_timing_key(o.timing, "ray_policy", policy);
    rtu::hw::set_timing_key(o.timing, "l2_kib", "256");
    rtu::hw::set_timing_key(o.timing, "dram_banks", "8");
    rtu::hw::set_timing_key(o.timing, "dram_channels", "2");
    rtu::hw::set_timing_key(o.timing, "dram_activate_cycles", "20");
    rtu::hw::set_timing_key(o.timing, "dram_precharge_cycles", "20");
    std::vector<rtu::hw::TimingStats> runs;
    // 1 thread; 2: the units on one, rays recorded on the other; 3 and 7: the units on 2 and 4 threads
    // (run_units_in_step's windows), rays recorded on 1 and 3.
    for (int threads : {1, 2, 3, 7}) {
      CAPTURE(threads);
      const auto chip = rtu::host::make_device(s.geometry, o);
      std::vector<Hit> h(rays.size());
      rtu::hw::TraversalStats st;
      chip->trace_batch(rays.data(), h.data(), rays.size(), false, threads, st);
      CHECK(std::memcmp(h.data(), hf.data(), h.size() * sizeof(Hit)) == 0);
      CHECK(st.box_tests == sf.box_tests);
      runs.push_back(chip->timed()->timing());
      const auto& per_unit = chip->timed()->timing_by_unit();
      REQUIRE(per_unit.size() == 4);
      uint64_t unit_rays = 0;
      for (const auto& u : per_unit) {
        // round_robin and blocks split 6000 rays evenly; waves of 32 (rdna2's slots) give 188 waves, 47
        // each, the last of 16 rays.
        CHECK(u.rays == (policy == "waves" ? (&u - per_unit.data() < 3 ? 47 * 32 : 47 * 32 - 16) : 1500));
        CHECK(u.cycles == runs.back().cycles);
        unit_rays += u.rays;
      }
      CHECK(unit_rays == rays.size());
    }
    for (size_t r = 1; r < runs.size(); ++r) check_same_timing(runs[0], runs[r]);
    CHECK(runs[0].l2_hits > 0);
    CHECK(runs[0].dram_row_hits > 0);
  }
}

TEST_CASE("chip: units running ahead to their next memory access give the cycles of units strictly in step",
          "[timed][chip]") {
  // Running ahead reorders only what stays inside a unit; the shared memory must see the same requests in the same
  // order. Short stacks (spills and refills reach memory too), a small L2 and banks with row costs, so that every
  // kind of shared access is there; two packets, the second finding the memory as the first left it. With a
  // prefetcher, its fills reach the shared memory too (fetch_observer.h: run-ahead stops before every fetch).
  const rtu::host::Scene s = rtu::host::load_scene("/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc");
  std::vector<Ray> rays = camera_and_incoherent_rays(s, 3000, 5);
  for (const auto& [preset, prefetcher] : {std::pair{"embedded-chip", "none"}, std::pair{"intel-chip", "none"},
                                           std::pair{"embedded-chip", "next_line"}}) {
    CAPTURE(preset, prefetcher);
    DeviceOptions o = preset_options("timed", preset);
    rtu::hw::set_timing_key(o.timing, "prefetcher", prefetcher);
    rtu::hw::set_timing_key(o.timing, "units", "6");
    rtu::hw::set_timing_key(o.timing, "stack_entries", "2");
    rtu::hw::set_timing_key(o.timing, "l2_kib", "256");
    std::vector<rtu::hw::TimingStats> runs;
    // Ahead and in step on one unit thread; then the units on 3 threads (5 host threads), in windows of the
    // shared memory's lookahead with their requests held (no run-ahead there; without a prefetcher only).
    for (int threads : {2, 2, 5}) {
      const bool ahead = runs.empty();
      const auto chip = rtu::host::make_device(s.geometry, o);
      chip->timed()->set_run_ahead(ahead);
      std::vector<Hit> h(rays.size());
      rtu::hw::TraversalStats st;
      for (int packet = 0; packet < 2; ++packet)
        chip->trace_batch(rays.data(), h.data(), rays.size(), packet == 1, threads, st);
      runs.push_back(chip->timed()->timing());
      REQUIRE(chip->timed()->timing_by_unit().size() == 6);
    }
    check_same_timing(runs[0], runs[1]);
    check_same_timing(runs[0], runs[2]);
    CHECK(runs[0].stack_refills > 0);
    CHECK(runs[0].stack_spills > 0);
    CHECK(runs[0].l2_misses > 0);
    CHECK(runs[0].dram_row_misses > 0);
    CHECK((runs[0].prefetch_fills > 0) == (std::string(prefetcher) != "none"));
  }
}

namespace {

// A small chip: `units` units of rdna2 sharing an L2 and banked DRAM, waves handed to whichever unit asks first.
DeviceOptions dynamic_chip(int units, double fraction, uint64_t seed = 1) {
  DeviceOptions o = preset_options("timed", "rdna2");
  rtu::hw::set_timing_key(o.timing, "units", std::to_string(units));
  rtu::hw::set_timing_key(o.timing, "ray_policy", "dynamic");
  rtu::hw::set_timing_key(o.timing, "l2_kib", "256");
  rtu::hw::set_timing_key(o.timing, "dram_banks", "8");
  rtu::hw::set_timing_key(o.timing, "dram_channels", "2");
  o.sample.fraction = fraction;
  o.sample.seed = seed;
  return o;
}

}  // namespace

TEST_CASE("chip, dynamic dispatch: the fixed device's hits, the same cycles on any number of threads, sampled too",
          "[timed][chip][sample]") {
  const rtu::host::Scene s = rtu::host::load_scene("/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc");
  std::vector<Ray> rays = camera_and_incoherent_rays(s, 12000, 4);
  const size_t n = rays.size();
  const auto fixed = rtu::host::make_device(s.geometry, preset_options("fixed", "rdna2"));
  std::vector<Hit> hf(n);
  rtu::hw::TraversalStats sf;
  fixed->trace_batch(rays.data(), hf.data(), n, false, 2, sf);
  for (double fraction : {0.0, 0.1}) {
    CAPTURE(fraction);
    std::vector<rtu::hw::TimingStats> runs;
    for (int threads : {1, 2, 4}) {  // 4: the units on 2 threads unless sampled (warming touches other units)
      const auto chip = rtu::host::make_device(s.geometry, dynamic_chip(4, fraction));
      std::vector<Hit> h(n);
      rtu::hw::TraversalStats st;
      chip->trace_batch(rays.data(), h.data(), n, false, threads, st);
      // Sampled or not, every ray is traced: the hits and the datapath's counts are the fixed device's.
      CHECK(std::memcmp(h.data(), hf.data(), n * sizeof(Hit)) == 0);
      CHECK(st.box_tests == sf.box_tests);
      CHECK(st.prim_tests == sf.prim_tests);
      runs.push_back(chip->timed()->timing());
      const rtu::hw::SampleStats& ss = chip->timed()->sampling();
      if (fraction == 0.0) {
        // Each unit took whole waves of 32 (the last of 0 rays here: 24000 = 750 x 32), all of them together.
        uint64_t unit_rays = 0;
        for (const auto& u : chip->timed()->timing_by_unit()) {
          CHECK(u.rays % 32 == 0);
          CHECK(u.rays > 0);
          unit_rays += u.rays;
        }
        CHECK(unit_rays == n);
        CHECK(ss.packets_sampled == 0);
      } else {
        // 750 waves: a lead and a trail of 16 waves, 44 bursts of 16 between, 4 or 5 of them measured, each with
        // 12 waves more simulated around it.
        CHECK(ss.packets_sampled == 1);
        CHECK(ss.units_measured >= 4);
        CHECK(ss.units_measured <= 5);
        CHECK(ss.rays_simulated <= (32 + ss.units_measured * 28) * 32);
        CHECK(ss.rays_simulated + ss.rays_warmed == n);
        CHECK(runs.back().rays == n);
      }
    }
    for (size_t r = 1; r < runs.size(); ++r) check_same_timing(runs[0], runs[r]);
  }
}

TEST_CASE("chip sampling: a packet too short to thin is simulated in full, and the stats say why",
          "[timed][chip][sample]") {
  // 3000 rays on 4 units of 32 slots: 94 waves, 62 between the fill and the drain: 3 bursts of 4 turns (16 waves),
  // at 1 in 10 none measured. The packet runs in full: its cycles are the unsampled run's, and the statistics and
  // the notes name the packet and why.
  const rtu::host::Scene s = rtu::host::load_scene("/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc");
  const std::vector<Ray> rays = rtu::host::incoherent_rays(s.geometry.bounds(), 3000, 6);
  std::vector<Hit> h(rays.size());
  rtu::hw::TraversalStats st;
  const auto full = rtu::host::make_device(s.geometry, dynamic_chip(4, 0.0));
  full->trace_batch(rays.data(), h.data(), rays.size(), false, 1, st);
  const auto chip = rtu::host::make_device(s.geometry, dynamic_chip(4, 0.1));
  chip->trace_batch(rays.data(), h.data(), rays.size(), false, 1, st);
  const rtu::hw::SampleStats& ss = chip->timed()->sampling();
  CHECK(ss.packets_sampled == 0);
  CHECK(ss.packets_unthinned == 1);
  CHECK(ss.rays_simulated == rays.size());
  CHECK(ss.unthinned_why.find("94 waves on 4 units") != std::string::npos);
  CHECK(ss.unthinned_why.find("fewer than the 4") != std::string::npos);
  CHECK(chip->timed()->timing().cycles == full->timed()->timing().cycles);
  CHECK(full->timed()->sampling().packets_unthinned == 0);  // nothing asked, nothing to say
}

TEST_CASE("chip sampling: the full simulation's cycles lie in the stated interval, seed after seed",
          "[timed][chip][sample][scale]") {
  // A packet of incoherent rays and one of camera rays on a small chip, sampled at 1 in 10 with five seeds against
  // the full simulation; a fixed seed list makes this deterministic. Incoherent rays cost alike everywhere: the
  // interval is narrow and holds the truth. Camera rays cross from sky to house once; each measured burst meets
  // such a change as it follows waves from elsewhere, and the camera rays' interval is wide (bench/results/
  // sampled-timing.md gives the error on renders).
  const rtu::host::Scene s = rtu::host::load_scene("/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc");
  const std::vector<Ray> primary = rtu::host::primary_rays(s.camera, 40000);
  const std::vector<Ray> incoherent = rtu::host::incoherent_rays(s.geometry.bounds(), 40000, 6);
  for (const std::vector<Ray>* rays : {&incoherent, &primary}) {
    CAPTURE(rays == &primary ? "primary" : "incoherent");
    const size_t n = rays->size();
    std::vector<Hit> h(n);
    rtu::hw::TraversalStats st;
    const auto full = rtu::host::make_device(s.geometry, dynamic_chip(4, 0.0));
    full->trace_batch(rays->data(), h.data(), n, false, 2, st);
    const double exact = double(full->timed()->timing().cycles);
    int inside = 0;
    for (uint64_t seed : {1, 2, 3, 6, 7}) {
      const auto chip = rtu::host::make_device(s.geometry, dynamic_chip(4, 0.1, seed));
      chip->trace_batch(rays->data(), h.data(), n, false, 2, st);
      const double est = double(chip->timed()->timing().cycles), ci = chip->timed()->sampling().ci95();
      INFO("seed " << seed << ": full " << exact << ", sampled " << est << " +- " << ci);
      REQUIRE(chip->timed()->sampling().packets_sampled == 1);
      CHECK(ci > 0.0);
      CHECK(ci < (rays == &primary ? 0.6 : 0.06) * exact);
      CHECK(std::abs(est - exact) <= 2.0 * ci);
      inside += std::abs(est - exact) <= ci;
    }
    CHECK(inside >= 4);
  }
}

TEST_CASE("chip sampling: a chip whose units' rays are fixed refuses it, naming the policy that samples",
          "[timed][chip][sample]") {
  const rtu::host::Scene s = rtu::host::load_scene("builtin:seed");
  DeviceOptions o = dynamic_chip(4, 0.1);
  rtu::hw::set_timing_key(o.timing, "ray_policy", "waves");
  const auto chip = rtu::host::make_device(s.geometry, o);
  const std::vector<Ray> rays = rtu::host::primary_rays(s.camera, 40000);
  std::vector<Hit> h(rays.size());
  rtu::hw::TraversalStats st;
  REQUIRE_THROWS_WITH(chip->trace_batch(rays.data(), h.data(), rays.size(), false, 2, st),
                      Catch::Contains("ray_policy = dynamic") && Catch::Contains("slowest unit"));
}

TEST_CASE("chip sampling: a render's image is the unsampled render's, its cycles the same on 1 and 2 threads",
          "[timed][chip][sample]") {
  const rtu::host::Scene s = rtu::host::load_scene("builtin:seed");
  rtu::host::RenderOptions o = render_options(80, 60, 2, 3);
  // Two units of 8 slots: 9600 camera rays are 1200 waves, enough for every bounce's packet to be thinned.
  o.device = dynamic_chip(2, 0.0);
  rtu::hw::set_timing_key(o.device.timing, "ray_slots", "8");
  const rtu::host::RenderResult full = rtu::host::render(s, o);
  o.device.sample.fraction = 0.2;
  const rtu::host::RenderResult sampled = rtu::host::render(s, o);
  o.threads = 1;
  const rtu::host::RenderResult sampled1 = rtu::host::render(s, o);
  REQUIRE(full.rgb.size() == sampled.rgb.size());
  CHECK(std::memcmp(full.rgb.data(), sampled.rgb.data(), full.rgb.size() * sizeof(float)) == 0);
  CHECK(std::memcmp(full.rgb.data(), sampled1.rgb.data(), full.rgb.size() * sizeof(float)) == 0);
  CHECK(sampled.sampling.packets_sampled >= 3);  // camera rays and the larger bounces' packets
  CHECK(sampled.timing.cycles == sampled1.timing.cycles);
  CHECK(sampled.device_clock == sampled1.device_clock);
  const double exact = double(full.timing.cycles), est = double(sampled.timing.cycles);
  INFO("full " << exact << ", sampled " << est << " +- " << sampled.sampling.ci95());
  CHECK(std::abs(est - exact) <= 2.0 * sampled.sampling.ci95());
}
