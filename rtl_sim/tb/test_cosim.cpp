// Co-simulation: the timed device with its box tests answered by the Verilated RTL unit (`--set box_unit=rtl`,
// rtl_sim/cosim/) against the same device with the C++ box test, and likewise with its triangle tests answered by
// the Verilated triangle unit (`--set tri_unit=rtl`), and with both. On a real mesh and the built-in scenes the
// hits are identical bit for bit and so are the cycles and every timing statistic: the RTL's clocks per node and
// per triangle (issue and result, measured on its valid/ready ports) equal the presets' box_rate and box_latency,
// one triangle per clock and tri_latency. A unit one clock slower changes the cycles, so the equality is a
// measurement, not a tautology. Tags: [rtl][cosim].
#include <catch2/catch.hpp>

#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "host/devices/direct_device.h"
#include "host/devices/trav_units.h"
#include "host/io/error.h"
#include "host/jobs/render.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_sim/cosim/rtl_box_unit.h"
#include "rtl_sim/cosim/rtl_tri_unit.h"
#include "rtl_sim/params/rtl_params.h"

namespace {

using rtu::host::DeviceOptions;
using rtu::hw::Hit;
using rtu::hw::Ray;

constexpr const char* kIfc = "/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc";

// A unit's configuration: a preset name, or a spec as rtl_params.h's unit_config() reads it.
DeviceOptions options(const std::string& spec, const std::string& box_unit, const std::string& tri_unit = "cpp") {
  DeviceOptions o;
  o.kind = rtu::hw::DeviceKind::kTimed;
  o.timing = rtu::rtl::unit_config(spec);
  rtu::hw::set_timing_key(o.timing, "box_unit", box_unit);
  rtu::hw::set_timing_key(o.timing, "tri_unit", tri_unit);
  o.format = rtu::hw::format_preset(o.timing.format);
  o.format.width = o.timing.bvh_width;
  o.tracer.bvh.width = o.format.width;
  return o;
}

std::vector<Ray> rays_for(const rtu::host::Scene& s, size_t primary, size_t incoherent) {
  std::vector<Ray> rays = rtu::host::primary_rays(s.camera, primary);
  const std::vector<Ray> inc = rtu::host::incoherent_rays(s.geometry.bounds(), incoherent, 11);
  rays.insert(rays.end(), inc.begin(), inc.end());
  return rays;
}

// Every field of the timing statistics.
void check_same_timing(const rtu::hw::TimingStats& a, const rtu::hw::TimingStats& b) {
  CHECK(a.cycles == b.cycles);
  CHECK(a.rays == b.rays);
  CHECK(a.box_tests == b.box_tests);
  CHECK(a.box_issue_cycles == b.box_issue_cycles);
  CHECK(a.tri_tests == b.tri_tests);
  CHECK(a.tri_issue_cycles == b.tri_issue_cycles);
  CHECK(a.sphere_tests == b.sphere_tests);
  CHECK(a.plane_tests == b.plane_tests);
  CHECK(a.node_fetches == b.node_fetches);
  CHECK(a.cache_hits == b.cache_hits);
  CHECK(a.cache_misses == b.cache_misses);
  CHECK(a.dram_bytes == b.dram_bytes);
  CHECK(a.stack_spills == b.stack_spills);
  CHECK(a.queue_stall_cycles == b.queue_stall_cycles);
  CHECK(a.slot_busy_cycles == b.slot_busy_cycles);
}

// Traces the rays on both devices, closest and any hit: the hits identical bit for bit, and so are the nodes
// visited, the box and primitive tests and the hit count, which exceeds min_hits.
void check_same_hits(rtu::host::DirectDevice& cpp, rtu::host::DirectDevice& rtl, const std::vector<Ray>& rays,
                     uint64_t min_hits) {
  for (bool any_hit : {false, true}) {
    CAPTURE(any_hit);
    std::vector<Hit> hc(rays.size()), hr(rays.size());
    rtu::hw::TraversalStats sc, sr;
    cpp.trace_batch(rays.data(), hc.data(), rays.size(), any_hit, 2, sc);
    rtl.trace_batch(rays.data(), hr.data(), rays.size(), any_hit, 2, sr);
    CHECK(std::memcmp(hc.data(), hr.data(), hc.size() * sizeof(Hit)) == 0);
    CHECK(sr.nodes_visited == sc.nodes_visited);
    CHECK(sr.box_tests == sc.box_tests);
    CHECK(sr.prim_tests == sc.prim_tests);
    CHECK(sr.hits == sc.hits);
    CHECK(sr.hits > min_hits);
  }
}

// A firmware render of the scene on the rdna2 device with C++ units and on `rtl` (its RTL units): the same image
// and device clock, and every timing statistic the same. Returns the render with the RTL units.
rtu::host::RenderResult check_same_render(const std::string& scene, int width, int height, int max_depth,
                                          const DeviceOptions& rtl) {
  const rtu::host::Scene s = rtu::host::load_scene(scene);
  rtu::host::RenderOptions o;
  o.width = width;
  o.height = height;
  o.max_depth = max_depth;
  o.device = options("rdna2", "cpp");
  const rtu::host::RenderResult c = rtu::host::render(s, o);
  o.device = rtl;
  const rtu::host::RenderResult r = rtu::host::render(s, o);
  REQUIRE(c.rgb.size() == r.rgb.size());
  CHECK(std::memcmp(c.rgb.data(), r.rgb.data(), c.rgb.size() * sizeof(float)) == 0);
  CHECK(r.device_clock == c.device_clock);
  check_same_timing(c.timing, r.timing);
  return r;
}

// A unit that answers as the RTL does but reports one clock more per node: the cycles must follow it.
class SlowerUnit final : public rtu::hw::BoxUnit {
 public:
  explicit SlowerUnit(std::unique_ptr<rtu::hw::BoxUnit> inner) : m_inner(std::move(inner)) {}
  const char* name() const override { return "rtl+1"; }
  void check_format(const rtu::hw::FixedFormat& f, int width) const override { m_inner->check_format(f, width); }
  void test(const rtu::hw::FixedRay& r, const rtu::hw::BoxUnitNode& n, int64_t tmin, int64_t tlim,
            rtu::hw::BoxUnitResult& out) override {
    m_inner->test(r, n, tmin, tlim, out);
    ++out.result;
  }

 private:
  std::unique_ptr<rtu::hw::BoxUnit> m_inner;
};

// A triangle unit that answers as the RTL does and keeps the clocks it reported; `extra` clocks are added to each
// result (a slower unit).
class ClockedTriUnit final : public rtu::hw::TriUnit {
 public:
  ClockedTriUnit(std::unique_ptr<rtu::hw::TriUnit> inner, uint32_t extra)
      : m_inner(std::move(inner)), m_extra(extra) {}
  const char* name() const override { return "rtl (clocked)"; }
  void check_format(const rtu::hw::FixedFormat& f) const override { m_inner->check_format(f); }
  void test(const rtu::hw::FixedRay& r, const int32_t v[3][3], int64_t tmin, int64_t tlim,
            rtu::hw::TriUnitResult& out) override {
    m_inner->test(r, v, tmin, tlim, out);
    ++tests;
    hits += out.hit ? 1 : 0;
    issue.insert(out.issue);
    result.insert(out.result);
    out.result += m_extra;
  }
  uint64_t tests = 0, hits = 0;
  std::set<uint32_t> issue, result;  // every value reported

 private:
  std::unique_ptr<rtu::hw::TriUnit> m_inner;
  uint32_t m_extra;
};

}  // namespace

TEST_CASE("co-simulation: the RTL box unit gives the C++ unit's hits and cycles on a real mesh", "[rtl][cosim]") {
  const rtu::host::Scene s = rtu::host::load_scene(kIfc);
  const std::vector<Ray> rays = rays_for(s, 12000, 4000);
  for (const rtu::rtl::RtlUnitInfo& u : rtu::rtl::rtl_units()) {
    const std::string& preset = u.name;
    CAPTURE(preset, u.spec);
    const auto cpp = rtu::host::make_device(s.geometry, options(u.spec, "cpp"));
    const auto rtl = rtu::host::make_device(s.geometry, options(u.spec, "rtl"));
    check_same_hits(*cpp, *rtl, rays, 0);
    check_same_timing(cpp->timed()->timing(), rtl->timed()->timing());
    INFO(preset << ": " << rtl->timed()->timing().cycles << " cycles, " << rtl->timed()->timing().box_tests
                << " box tests");
    CHECK(rtl->timed()->timing().box_tests > 100000);
  }
}

TEST_CASE("co-simulation: a render through the firmware is the same image in the same cycles", "[rtl][cosim]") {
  const rtu::host::RenderResult r = check_same_render("builtin:seed", 48, 36, 3, options("rdna2", "rtl"));
  CHECK(r.timing.box_tests > 0);
}

TEST_CASE("co-simulation: the cycles follow the unit's clocks", "[rtl][cosim]") {
  const rtu::host::Scene s = rtu::host::load_scene("builtin:cornell");
  const std::vector<Ray> rays = rays_for(s, 3000, 1000);
  DeviceOptions fixed = options("rdna2", "cpp");
  fixed.kind = rtu::hw::DeviceKind::kFixed;
  const auto image_device = rtu::host::make_device(s.geometry, fixed);  // the image the timed device binds
  const rtu::hw::DeviceImage& img = *image_device->image();
  auto run = [&](std::unique_ptr<rtu::hw::BoxUnit> unit, const std::string& box_unit) {
    rtu::hw::TimedEngine e(rtu::hw::EngineOptions{}, options("rdna2", box_unit).timing, std::move(unit));
    e.bind(img.data(), img.size());
    std::vector<Hit> h(rays.size());
    rtu::hw::TraversalStats st;
    e.trace_cycles(rays.data(), h.data(), rays.size(), false, st, 0, 0);
    return std::make_pair(e.timing(), h);
  };
  const auto [base, hb] = run(nullptr, "cpp");
  const auto [same, hs] = run(rtu::rtl::make_rtl_box_unit(options("rdna2", "rtl").timing), "rtl");
  const auto [slow, hl] =
      run(std::make_unique<SlowerUnit>(rtu::rtl::make_rtl_box_unit(options("rdna2", "rtl").timing)), "rtl");
  CHECK(same.cycles == base.cycles);
  CHECK(slow.cycles > base.cycles);
  CHECK(std::memcmp(hb.data(), hl.data(), hb.size() * sizeof(Hit)) == 0);  // timing never changes a hit
}

TEST_CASE("co-simulation: a configuration without a Verilated unit is a clear error", "[rtl][cosim]") {
  const rtu::host::Scene s = rtu::host::load_scene("builtin:seed");
  DeviceOptions o = options("rdna2", "rtl");
  rtu::hw::set_timing_key(o.timing, "box_latency", "9");  // no unit was verilated with 9 stages
  CHECK_THROWS_WITH(rtu::host::make_device(s.geometry, o), Catch::Contains("no Verilated box unit") &&
                                                               Catch::Contains("LATENCY=9") &&
                                                               Catch::Contains("rdna2 (rdna2): "));
  // An image the unit cannot take: the configuration (bvh_width 4 picks the rdna2 unit) and the image (width 6)
  // disagree; the unit refuses it at bind instead of testing part of each node.
  DeviceOptions w = options("intel", "rtl");
  rtu::hw::set_timing_key(w.timing, "bvh_width", "4");
  CHECK(w.format.width == 6);
  CHECK_THROWS_WITH(rtu::host::make_device(s.geometry, w),
                    Catch::Contains("cannot test nodes") && Catch::Contains("width 6"));
  // Without box_unit = rtl the engine refuses a unit, and with it requires one.
  CHECK_THROWS_WITH(rtu::hw::TimedEngine(rtu::hw::EngineOptions{}, options("rdna2", "rtl").timing, nullptr),
                    Catch::Contains("no RTL box unit is attached"));
  CHECK_THROWS_WITH(rtu::hw::TimedEngine(rtu::hw::EngineOptions{}, options("rdna2", "cpp").timing,
                                         rtu::rtl::make_rtl_box_unit(options("rdna2", "rtl").timing)),
                    Catch::Contains("box_unit = cpp"));
}

// The presets whose triangle unit is verilated (rtl_tri_units(): rdna2, embedded), on the IFC house: the timed
// device with tri_unit = rtl against tri_unit = cpp, primary and incoherent rays, closest and any hit; then both
// units RTL at once against both C++.
TEST_CASE("co-simulation: the RTL triangle unit gives the C++ unit's hits and cycles on a real mesh",
          "[rtl][cosim][tri]") {
  const rtu::host::Scene s = rtu::host::load_scene(kIfc);
  const std::vector<Ray> rays = rays_for(s, 3000, 1000);
  REQUIRE(rtu::rtl::rtl_tri_units().size() == 2);
  for (const rtu::rtl::RtlUnitInfo& u : rtu::rtl::rtl_tri_units()) {
    for (const char* box : {"cpp", "rtl"}) {
      CAPTURE(u.name, u.args, box);
      const auto cpp = rtu::host::make_device(s.geometry, options(u.name, "cpp", "cpp"));
      const auto rtl = rtu::host::make_device(s.geometry, options(u.name, box, "rtl"));
      check_same_hits(*cpp, *rtl, rays, rays.size() / 4);
      check_same_timing(cpp->timed()->timing(), rtl->timed()->timing());
      INFO(u.name << ": " << rtl->timed()->timing().cycles << " cycles, " << rtl->timed()->timing().tri_tests
                  << " triangle tests");
      CHECK(rtl->timed()->timing().tri_tests > 20000);
    }
  }
}

TEST_CASE("co-simulation: a render with the RTL triangle unit is the same image in the same cycles",
          "[rtl][cosim][tri]") {
  const rtu::host::RenderResult r =
      check_same_render("builtin:cornell", 32, 24, 2, options("rdna2", "rtl", "rtl"));
  CHECK(r.timing.tri_tests > 0);
}

// The unit's latency and throughput as measured on its ports, triangle by triangle over a traversal: every
// triangle keeps the input exactly one clock (one test per clock: tri_rate 1) and leaves tri_latency clocks after
// it was taken, the configuration's figures (not the RTL's parameters). A unit reporting one clock more changes
// the cycles and no hit.
TEST_CASE("co-simulation: the triangle unit's measured latency and throughput are the configuration's",
          "[rtl][cosim][tri]") {
  const rtu::host::Scene s = rtu::host::load_scene(kIfc);
  const std::vector<Ray> rays = rays_for(s, 1000, 500);
  for (const rtu::rtl::RtlUnitInfo& u : rtu::rtl::rtl_tri_units()) {
    CAPTURE(u.name);
    DeviceOptions fixed = options(u.name, "cpp");
    fixed.kind = rtu::hw::DeviceKind::kFixed;
    const auto image_device = rtu::host::make_device(s.geometry, fixed);  // the image the timed device binds
    const rtu::hw::DeviceImage& img = *image_device->image();
    const rtu::hw::TimingConfig cfg = options(u.name, "cpp", "rtl").timing;
    auto run = [&](uint32_t extra, ClockedTriUnit** seen) {
      auto unit = std::make_unique<ClockedTriUnit>(rtu::rtl::make_rtl_tri_unit(cfg), extra);
      *seen = unit.get();
      auto e = std::make_unique<rtu::hw::TimedEngine>(rtu::hw::EngineOptions{}, cfg, nullptr, std::move(unit));
      e->bind(img.data(), img.size());
      std::vector<Hit> h(rays.size());
      rtu::hw::TraversalStats st;
      e->trace_cycles(rays.data(), h.data(), rays.size(), false, st, 0, 0);
      return std::make_pair(std::move(e), h);
    };
    ClockedTriUnit* same = nullptr;
    ClockedTriUnit* slow = nullptr;
    const auto [es, hs] = run(0, &same);
    CHECK(same->tests > 5000);
    CHECK(same->hits > 0);
    CHECK(same->issue == std::set<uint32_t>{uint32_t(cfg.tri_rate)});      // one triangle per clock
    CHECK(same->result == std::set<uint32_t>{uint32_t(cfg.tri_latency)});  // tri_latency from taken to result
    CHECK(es->timing().tri_tests == same->tests);
    CHECK(es->timing().tri_issue_cycles == same->tests);
    const auto [el, hl] = run(1, &slow);
    // Not necessarily more: on a memory-bound unit (embedded) a clock's shift reorders DRAM requests, and the
    // row-buffer hits it gains or loses can outweigh the clock (seen: 27 fewer of 45900 on the IFC house).
    CHECK(el->timing().cycles != es->timing().cycles);
    CHECK(std::memcmp(hs.data(), hl.data(), hs.size() * sizeof(Hit)) == 0);  // timing never changes a hit
  }
}

TEST_CASE("co-simulation: a configuration without a Verilated triangle unit is a clear error",
          "[rtl][cosim][tri]") {
  const rtu::host::Scene s = rtu::host::load_scene("builtin:cornell");
  // The precise format's widths have no Verilated triangle unit; the message names the ones built.
  DeviceOptions o = options("rdna2:format=precise", "cpp", "rtl");
  CHECK_THROWS_WITH(rtu::host::make_device(s.geometry, o),
                    Catch::Contains("no Verilated triangle unit for format precise") &&
                        Catch::Contains("rdna2 (format default, tri_latency 12): -GB=24") &&
                        Catch::Contains("embedded (format compact, tri_latency 10): -GB=16"));
  // A unit is chosen by its parameters, not by the preset's name: intel (format xe6, the default format's widths
  // bit-packed, tri_latency 12) takes the rdna2 unit; embedded's format with intel's tri_latency has none.
  CHECK_NOTHROW(rtu::host::make_device(s.geometry, options("intel", "cpp", "rtl")));
  o = options("embedded", "cpp", "rtl");
  rtu::hw::set_timing_key(o.timing, "tri_latency", "12");
  CHECK_THROWS_WITH(rtu::host::make_device(s.geometry, o),
                    Catch::Contains("format compact") && Catch::Contains("LATENCY=12"));
  o = options("rdna2", "cpp", "rtl");
  rtu::hw::set_timing_key(o.timing, "tri_latency", "9");
  CHECK_THROWS_WITH(rtu::host::make_device(s.geometry, o),
                    Catch::Contains("no Verilated triangle unit") && Catch::Contains("LATENCY=9"));
  o = options("rdna2", "cpp", "rtl");
  rtu::hw::set_timing_key(o.timing, "tri_rate", "2");
  CHECK_THROWS_WITH(rtu::host::make_device(s.geometry, o), Catch::Contains("tri_rate 2"));
  // An image the unit cannot take: the configuration picks the rdna2 unit (default format), the image is compact.
  o = options("rdna2", "cpp", "rtl");
  o.format = rtu::hw::format_preset("compact");
  o.format.width = o.timing.bvh_width;
  CHECK_THROWS_WITH(rtu::host::make_device(s.geometry, o),
                    Catch::Contains("cannot test triangles of format") && Catch::Contains("-GB=16"));
  // Without tri_unit = rtl the engine refuses a unit, and with it requires one.
  CHECK_THROWS_WITH(rtu::hw::TimedEngine(rtu::hw::EngineOptions{}, options("rdna2", "cpp", "rtl").timing),
                    Catch::Contains("no RTL triangle unit is attached"));
  CHECK_THROWS_WITH(rtu::hw::TimedEngine(rtu::hw::EngineOptions{}, options("rdna2", "cpp").timing, nullptr,
                                         rtu::rtl::make_rtl_tri_unit(options("rdna2", "cpp", "rtl").timing)),
                    Catch::Contains("tri_unit = cpp"));
}

// `rtusim trace --rtl-unit` through the runner rtusim registers (host/devices/trav_units.h): the configuration's
// Verilated traversal unit runs the packet with the timed device's hits; a configuration no unit was verilated for
// is refused with its parameters and the build option that adds one.
TEST_CASE(
    "trace --rtl-unit: a verilated configuration runs with the device's hits, another is refused with the fix",
    "[rtl][cosim]") {
  REQUIRE(rtu::host::have_rtl_trav_unit());
  const rtu::host::Scene s = rtu::host::load_scene(kIfc);
  const std::vector<Ray> rays = rtu::host::incoherent_rays(s.geometry.bounds(), 300, 5);
  const DeviceOptions o = options("rdna2:ray_slots=4", "cpp");
  const auto timed = rtu::host::make_device(s.geometry, o);
  std::vector<Hit> h(rays.size());
  rtu::hw::TraversalStats st;
  timed->trace_batch(rays.data(), h.data(), rays.size(), false, 1, st);
  const rtu::host::RtlTravRun r =
      rtu::host::run_rtl_trav_unit(o.timing, *timed->image(), rays.data(), rays.size(), false);
  CHECK(r.unit == "rdna2_s4");
  REQUIRE(r.hits.size() == h.size());
  CHECK(std::memcmp(r.hits.data(), h.data(), h.size() * sizeof(Hit)) == 0);
  CHECK(r.cycles > 0);
  // The rdna2 preset as it is (32 slots) is not among the units verilated by default.
  CHECK_THROWS_WITH(rtu::host::run_rtl_trav_unit(options("rdna2", "cpp").timing, *timed->image(), rays.data(),
                                                 rays.size(), false),
                    Catch::Contains("no verilated traversal unit") && Catch::Contains("-GSLOTS=32") &&
                        Catch::Contains("-DRTU_RTL_TRAV_EXTRA_UNITS="));
  // Orders the unit does not take visit other nodes: refused by name, not compared (they differed by 30-39%).
  for (const auto& [key, value] :
       {std::pair<std::string, std::string>{"traversal", "treelet_first"}, {"child_order", "slot"}}) {
    rtu::hw::TimingConfig other = o.timing;
    rtu::hw::set_timing_key(other, "treelet_bytes", "512");
    rtu::hw::set_timing_key(other, key, value);
    CHECK_THROWS_WITH(rtu::host::run_rtl_trav_unit(other, *timed->image(), rays.data(), rays.size(), false),
                      Catch::Contains("the RTL traversal unit needs") &&
                          Catch::Contains(key == "traversal" ? "traversal depth_first" : "child_order nearest"));
  }
}
