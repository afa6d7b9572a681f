// The RTL traversal unit (trav/trav_unit.sv) against the C++ model: its hits equal the fixed device's bit for bit
// (t, primitive, u, v) on random triangle soups, closest and any hit, widths 4 and 8; its cycles beside the
// timing model's for the same configuration and rays.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

#include "rtl_models.h"
#include "rtl_sim/params/rtl_params.h"
#include "rtl_sim/trav/trav_driver.h"
#include "tests/hwmodel/timing_checks.h"

using namespace rtu;
using namespace rtu::rtl;

namespace {

struct Case {
  std::vector<uint8_t> bytes;
  std::vector<hw::Ray> rays;
};

// A soup of `tris` triangles in [-10, 10]^3 and its rays: `kind` 0 a camera's (a 12 x 8 grid from z = -30 toward
// the soup), 1 incoherent (random origins and directions in the soup's box), 2 shadow rays (from points on the
// camera rays' way through the soup toward a light above it, t up to the light).
Case soup(uint64_t seed, const char* format, int tris, int kind) {
  hw::Geometry g = hw::fixed_checks::random_scene(seed, tris, 0);
  g.planes.clear();  // triangles only: the unit has no plane test
  const hw::DeviceImage img = hw::image_checks::encode(g, hw::format_preset(format));
  Case cs{std::vector<uint8_t>(img.data(), img.data() + img.size()), {}};
  if (kind == 1) {
    cs.rays = random_box_rays(seed + 1, 96);
    return cs;
  }
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 12; ++x) {
      hw::Ray r;
      r.origin = hw::Vec3(0.0f, 0.0f, -30.0f);
      r.dir = hw::Vec3(-0.3f + 0.6f * float(x) / 11.0f, -0.2f + 0.4f * float(y) / 7.0f, 1.0f);
      r.tmin = 0.0f;
      r.tmax = 1e30f;
      if (kind == 2) {  // from 30 units along the camera ray toward the light at (0, 40, 0)
        const hw::Vec3 p = r.origin + 30.0f * r.dir, l(0.0f, 40.0f, 0.0f);
        r.origin = p;
        r.dir = l - p;
        r.tmin = 1e-3f;
        r.tmax = 1.0f;
      }
      cs.rays.push_back(r);
    }
  return cs;
}

// Runs the packet on the Verilated unit `Model` of spec and on the fixed device; requires equal hits; returns the
// unit's run and, in model_cycles, the timing model's cycles for the same packet.
template <class Model>
TravRun run_both(const char* spec, const Case& cs, bool any_hit, uint64_t& model_cycles) {
  const hw::TimingConfig c = unit_config(spec);
  const hw::DeviceImage img = hw::DeviceImage::from_bytes(cs.bytes.data(), cs.bytes.size());
  TravDriver<Model> drv(trav_params(c), c, img);
  std::vector<hw::Hit> got(cs.rays.size()), want(cs.rays.size());
  hw::TimingStats s;
  const TravRun run = drv.trace(cs.rays.data(), got.data(), cs.rays.size(), any_hit, s);
  hw::TraversalStats fs;
  hw::FixedTracer(img).trace_batch(cs.rays.data(), want.data(), cs.rays.size(), any_hit, 1, fs);
  size_t hits = 0;
  for (size_t i = 0; i < cs.rays.size(); ++i) {
    INFO("ray " << i);
    REQUIRE(got[i].prim == want[i].prim);
    if (!want[i].hit()) continue;
    ++hits;
    REQUIRE(got[i].t == want[i].t);
    if (!any_hit) {  // an any-hit answer's u, v are those of whichever hit ended it: the same record here
      REQUIRE(got[i].u == want[i].u);
      REQUIRE(got[i].v == want[i].v);
    }
  }
  CHECK(hits > 0);
  std::vector<hw::Hit> timed;
  hw::TimingConfig mc = c;
  mc.fetch_port_rate = 1;  // the unit's port: one request and one answer a clock
  hw::TimedEngine engine(hw::EngineOptions{}, mc);
  engine.bind(cs.bytes.data(), cs.bytes.size());
  timed.assign(cs.rays.size(), hw::Hit{});
  hw::TraversalStats ts;
  model_cycles = engine.trace_cycles(cs.rays.data(), timed.data(), cs.rays.size(), any_hit, ts, 0, 0);
  std::printf(
      "%s %s: rtl %llu cycles, model %llu (%+.2f%%); reads %llu nodes %llu records, %llu spills, %llu "
      "late responses\n",
      spec, any_hit ? "any-hit" : "closest", (unsigned long long)run.cycles, (unsigned long long)model_cycles,
      100.0 * (double(model_cycles) / double(run.cycles) - 1.0), (unsigned long long)run.node_reads,
      (unsigned long long)run.record_reads, (unsigned long long)run.spills,
      (unsigned long long)run.response_delays);
  // The bound bench/results/rtl-correlation.md measures (largest packet error 2%, at 32 slots behind a 16 KiB
  // cache): the model claims a read's answer clock in request order, the unit's memory in order of readiness.
  CHECK(std::abs(double(model_cycles) - double(run.cycles)) <= 0.02 * double(run.cycles));
  return run;
}

}  // namespace

TEST_CASE("trav unit: hits equal the fixed device's, width 4", "[trav]") {
  for (int kind : {0, 1, 2}) {
    const Case cs = soup(11, "default", 3000, kind);
    for (bool any_hit : {false, true}) {
      uint64_t model = 0;
      run_both<Vtrav_unit_rdna2_s4>("rdna2:ray_slots=4", cs, any_hit || kind == 2, model);
    }
  }
}

TEST_CASE("trav unit: hits equal the fixed device's, width 8", "[trav]") {
  for (int kind : {0, 1, 2}) {
    const Case cs = soup(12, "wide8", 3000, kind);
    uint64_t model = 0;
    run_both<Vtrav_unit_wide8_s4>("rdna2:format=wide8:bvh_width=8:ray_slots=4", cs, kind == 2, model);
  }
}

TEST_CASE("trav unit: a short stack spills and refills through the memory port", "[trav]") {
  const Case cs = soup(13, "default", 3000, 1);
  uint64_t model = 0;
  const TravRun run = run_both<Vtrav_unit_rdna2_s16_st2>("rdna2:ray_slots=16:stack_entries=2", cs, false, model);
  CHECK(run.spills > 0);
  CHECK(run.refills > 0);
}

// One triangle (the BVH's root is its leaf) and one ray that hits it, worked by hand for rdna2 with 4 slots: the
// packet is decoded at cycle 0 (after packet_latency P); the ray leaves the ray fetch at ray_fetch_latency (10)
// and enters slot 0; setup_latency (8) later the slot asks for the record; the cold cache looks (cache_latency 4)
// and misses to DRAM, which moves the 64-byte line in ceil(64 / 64) = 1 clock and then waits dram_latency (200);
// the triangle unit answers tri_latency (12) after taking the data; traversal_latency (2) later the slot finds its
// stack empty and hands the hit to the write-back, which ends writeback_latency (4) after. So
//   cycles = P + 10 + 8 + (4 + 1 + 200) + 12 + 2 + 4 = 20 + 241 = 261,
// on the unit and in the timing model alike.
TEST_CASE("trav unit: a one-ray packet's cycles worked by hand", "[trav]") {
  hw::Geometry g;
  g.triangles.push_back({hw::Vec3(-1, -1, 0), hw::Vec3(1, -1, 0), hw::Vec3(0, 1, 0)});
  const hw::DeviceImage img = hw::image_checks::encode(g, hw::format_preset("default"));
  REQUIRE(hw::is_leaf(img.header().root_ref));
  // The record straddles two 64-byte lines (two DRAM transfers).
  REQUIRE(img.header().record_offset / 64 + 1 == (img.header().record_offset + 39) / 64);
  Case cs{std::vector<uint8_t>(img.data(), img.data() + img.size()), {}};
  hw::Ray r;
  r.origin = hw::Vec3(0.0f, 0.0f, -5.0f);
  r.dir = hw::Vec3(0.0f, 0.0f, 1.0f);
  r.tmin = 0.0f;
  r.tmax = 1e30f;
  cs.rays.push_back(r);
  const hw::TimingConfig c = unit_config("rdna2:ray_slots=4");
  const uint64_t hand = uint64_t(c.packet_latency) + uint64_t(c.ray_fetch_latency) + uint64_t(c.setup_latency) +
                        uint64_t(c.cache_latency) + 2 + uint64_t(c.dram_latency) + uint64_t(c.tri_latency) +
                        uint64_t(c.traversal_latency) + uint64_t(c.writeback_latency);
  REQUIRE(hand == 262);
  uint64_t model = 0;
  const TravRun run = run_both<Vtrav_unit_rdna2_s4>("rdna2:ray_slots=4", cs, false, model);
  CHECK(run.cycles == hand);
  CHECK(model == hand);
}
