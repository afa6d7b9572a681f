// Ray sorting in the firmware renderer on the timed device (firmware/ray_sort.h, hwmodel/timing/sort_timing.h):
// the image and the hits are those without sorting, whatever the key; the sort's cycles are its cost model's
// over the firmware's counts, and the frame adds them; cycles do not depend on the host's threads.
#include <catch2/catch.hpp>

#include <cstring>
#include <string>
#include <vector>

#include "host/jobs/render.h"
#include "host/scene/scene.h"
#include "hwmodel/timing/sort_timing.h"
#include "hwmodel/timing/timing_config.h"
#include "tests/hwmodel/timing_checks.h"

using rtu::host::RenderOptions;
using rtu::host::RenderResult;

namespace {

// A path-traced render of builtin:seed (every ray type but occlusion: mirror, glass, diffuse, shadow) at 2 spp,
// so that two paths add to each pixel and a change of shading order would show in the bits.
RenderOptions seed_options(const std::string& device, const std::string& key) {
  RenderOptions o;
  o.device.kind = rtu::hw::parse_device_kind(device);
  o.device.timing = rtu::hw::timing_preset("rdna2");
  rtu::hw::set_timing_key(o.device.timing, "ray_sort", key);
  o.device.format = rtu::hw::format_preset(o.device.timing.format);
  o.device.format.width = o.device.timing.bvh_width;
  o.device.tracer.bvh.width = o.device.format.width;
  o.width = 48;
  o.height = 36;
  o.spp = 2;
  o.max_depth = 3;
  o.threads = 2;
  o.keep_primary = true;
  return o;
}

bool same_bits(const RenderResult& a, const RenderResult& b) {
  return a.rgb.size() == b.rgb.size() && a.primary.size() == b.primary.size() &&
         std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(float)) == 0 &&
         std::memcmp(a.primary.data(), b.primary.data(), a.primary.size() * sizeof(rtu::hw::Hit)) == 0;
}

}  // namespace

TEST_CASE("ray sorting keeps the image and the hits bit for bit, with every key", "[sort][timed][render]") {
  const rtu::host::Scene s = rtu::host::load_scene("builtin:seed");
  const RenderResult fixed = rtu::host::render(s, seed_options("fixed", "none"));
  const RenderResult none = rtu::host::render(s, seed_options("timed", "none"));
  REQUIRE(same_bits(fixed, none));
  CHECK_FALSE(none.fw.sorted);
  CHECK(none.sort_cycles.cycles == 0);
  CHECK(none.frame_cycles == none.device_clock);
  for (const rtu::hw::RaySortKeyInfo& k : rtu::hw::kRaySortKeys) {
    if (std::string(k.name) == "none") continue;
    INFO(k.name);
    const RenderOptions o = seed_options("timed", k.name);
    const RenderResult r = rtu::host::render(s, o);
    // Hits equal the fixed device's (unsorted) and the image is the same, to the bit.
    CHECK(same_bits(fixed, r));
    // The same rays reached the unit, in another order: the same traversal work, per ray type.
    for (int t = 0; t < rtu::hw::cmd::kRayTypeCount; ++t) {
      CHECK(r.fw.rays[t] == none.fw.rays[t]);
      CHECK(r.device.stats_by_type[t].box_tests == none.device.stats_by_type[t].box_tests);
      CHECK(r.device.stats_by_type[t].prim_tests == none.device.stats_by_type[t].prim_tests);
    }
    CHECK(r.fw.traces == none.fw.traces);
    // Every TRACE of this render has at least 2 rays, so every ray was sorted; 30- or 29-bit keys in 8-bit
    // digits are 4 passes a sort.
    REQUIRE(r.fw.sorted);
    uint64_t rays = 0, by_type = 0;
    for (int t = 0; t < rtu::hw::cmd::kRayTypeCount; ++t) {
      rays += r.fw.rays[t];
      by_type += r.fw.sort.by_type[t];
      CHECK(r.fw.sort.by_type[t] == r.fw.rays[t]);
    }
    CHECK(r.fw.sort.rays == rays);
    CHECK(by_type == rays);
    CHECK(r.fw.sort.sorts == r.fw.traces);
    CHECK(r.fw.sort.passes == 4 * r.fw.sort.sorts);
    CHECK(r.fw.sort.pass_rays == 4 * rays);
    // The frame: the sort's cycles, its cost model's over the firmware's counts, before the unit's.
    const rtu::hw::SortCycles c = rtu::hw::sort_cycles(rtu::host::sort_work(r.fw.sort), o.device.timing);
    CHECK(r.sort_cycles.cycles == c.cycles);
    CHECK(r.sort_cycles.cycles > 0);
    CHECK(r.frame_cycles == r.raster_cycles.cycles + r.sort_cycles.cycles + r.device_clock);
  }
}

TEST_CASE("ray sorting keeps occlusion rays' hits and hybrid mode's image", "[sort][timed][render]") {
  const rtu::host::Scene s = rtu::host::load_scene("builtin:cornell");
  for (const bool hybrid : {false, true}) {
    INFO("hybrid " << hybrid);
    RenderOptions o = seed_options("timed", "none");
    o.ao = true;
    o.hybrid = hybrid;
    const RenderResult a = rtu::host::render(s, o);
    rtu::hw::set_timing_key(o.device.timing, "ray_sort", "origin_direction");
    const RenderResult b = rtu::host::render(s, o);
    CHECK(same_bits(a, b));
    CHECK(b.fw.sort.by_type[int(rtu::hw::cmd::RayType::kOcclusion)] > 0);
    CHECK(b.fw.sort.by_type[int(rtu::hw::cmd::RayType::kPrimary)] == (hybrid ? 0 : b.fw.paths));
    CHECK(b.frame_cycles == b.raster_cycles.cycles + b.sort_cycles.cycles + b.device_clock);
  }
}

TEST_CASE("ray sorting's cycles do not depend on the host's threads", "[sort][timed]") {
  const rtu::host::Scene s = rtu::host::load_scene("builtin:seed");
  RenderOptions o = seed_options("timed", "termination");
  o.threads = 1;
  const RenderResult one = rtu::host::render(s, o);
  o.threads = 2;
  const RenderResult two = rtu::host::render(s, o);
  CHECK(same_bits(one, two));
  CHECK(one.device_clock == two.device_clock);
  CHECK(one.sort_cycles.cycles == two.sort_cycles.cycles);
  CHECK(one.frame_cycles == two.frame_cycles);
  check_same_timing(one.timing, two.timing);
}
