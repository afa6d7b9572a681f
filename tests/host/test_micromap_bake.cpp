// Opacity micromaps baked from builtin:forest's leaf texture (host/scene/micromap_bake.h): every known
// micro-triangle state is the any-hit stage's answer wherever it is asked in it; with the maps the fixed and timed
// devices give the same hits while the unit resolves candidates without the stage.
#include <catch2/catch.hpp>

#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

#include "host/cost/cost_model.h"
#include "host/devices/direct_device.h"
#include "host/io/image.h"
#include "host/jobs/trace_job.h"
#include "host/scene/micromap_bake.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "host/scene/shading.h"
#include "hwmodel/timing/timing_config.h"
#include "tests/host/cli_checks.h"

using namespace rtu;

namespace {

// The forest: 64 trees of 72 alpha-masked leaf cards.
const host::Scene& forest() {
  static const host::Scene s = host::load_scene("builtin:forest");
  return s;
}

}  // namespace

TEST_CASE("micromaps: a known micro-triangle state is the any-hit stage's answer everywhere in it",
          "[micromap][alpha]") {
  const host::Scene& s = forest();
  const host::SceneAnyHit alpha(s);
  REQUIRE(alpha.stage() != nullptr);
  const std::vector<uint8_t>& non_opaque = s.geometry.non_opaque;
  REQUIRE(!non_opaque.empty());
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> d(0.0f, 1.0f);
  double previous_unknown = 2.0;  // above any share
  for (int level = 0; level <= 5; ++level) {
    CAPTURE(level);
    host::MicromapStats st;
    const hw::MicromapSet maps = host::bake_micromaps(*alpha.tables(), non_opaque, level, &st);
    REQUIRE(maps.check().empty());
    CHECK(st.triangles > 0);
    uint64_t asked = 0, known = 0, wrong = 0;
    for (uint32_t prim = 0; prim < non_opaque.size(); prim += 37) {  // every 37th triangle: a few hundred
      if (!non_opaque[prim]) continue;
      for (int k = 0; k < 200; ++k) {
        // Random points, and points on the grid's lines and corners (the edges the lookup splits).
        float u = d(rng), v = d(rng);
        if (k % 4 == 1) u = float(int(u * 64.0f)) / 64.0f;
        if (k % 4 == 2) u = float(int(u * 64.0f)) / 64.0f, v = float(int(v * 64.0f)) / 64.0f;
        if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
        const hw::MicroState m = maps.lookup(prim, u, v);
        ++asked;
        if (!hw::known(m)) continue;
        ++known;
        const bool stage = alpha.stage()->accept(prim, u, v);
        if (stage != (m == hw::MicroState::kOpaque)) {
          ++wrong;
          UNSCOPED_INFO("triangle " << prim << " at (" << u << ", " << v << "): map says "
                                    << (m == hw::MicroState::kOpaque ? "opaque" : "transparent"));
        }
      }
    }
    const uint64_t unknown = st.micro_triangles - st.opaque - st.transparent;
    std::printf(
        "micromaps level %d: %llu maps (%llu 2-state), %llu micro-triangles, %.1f%% known; %llu of %llu "
        "points known, %llu wrong\n",
        level, (unsigned long long)st.triangles, (unsigned long long)st.two_state,
        (unsigned long long)st.micro_triangles,
        100.0 * double(st.opaque + st.transparent) / double(st.micro_triangles), (unsigned long long)known,
        (unsigned long long)asked, (unsigned long long)wrong);
    CHECK(wrong == 0);
    if (level >= 4) CHECK(known > asked / 2);  // finer maps resolve most of the leaf (57% at 4, 74% at 5)
    // The unknown area shrinks as the micro-triangles do (the unknown ones straddle the mask's edges); at levels
    // 0 and 1 every micro-triangle holds both kinds of texel.
    const double unknown_share = double(unknown) / double(st.micro_triangles);
    if (level > 1) CHECK(unknown_share < previous_unknown);
    previous_unknown = unknown_share;
  }
}

TEST_CASE("micromaps: the same hits, fewer any-hit requests, on the fixed and timed devices",
          "[micromap][alpha][timed]") {
  const host::Scene& s = forest();
  const host::SceneAnyHit alpha(s);
  const hw::MicromapSet maps = host::bake_micromaps(*alpha.tables(), s.geometry.non_opaque, 5);
  const std::vector<hw::Ray> rays = host::primary_rays(s.camera, 96, 72);
  for (const char* kind : {"fixed", "timed"}) {
    CAPTURE(kind);
    host::DeviceOptions o;
    o.kind = hw::parse_device_kind(kind);
    o.timing = hw::timing_preset("rdna2");
    o.any_hit = alpha.stage();
    hw::TraversalStats plain, mapped;
    std::vector<hw::Hit> a(rays.size()), b(rays.size());
    const auto without = host::make_device(s.geometry, o);
    without->trace_batch(rays.data(), a.data(), rays.size(), false, 2, plain);
    o.micromaps = &maps;
    const auto with = host::make_device(s.geometry, o);
    with->trace_batch(rays.data(), b.data(), rays.size(), false, 2, mapped);
    CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(hw::Hit)) == 0);
    // Each candidate is resolved once, by the map or by the stage; the stage's ignored ones and the map's
    // transparent ones are the same candidates' answers.
    CHECK(mapped.any_hit_calls + mapped.omm_opaque + mapped.omm_transparent == plain.any_hit_calls);
    CHECK(mapped.any_hit_ignored + mapped.omm_transparent == plain.any_hit_ignored);
    CHECK(mapped.omm_opaque > 0);
    CHECK(mapped.omm_transparent > 0);
    std::printf(
        "micromaps level 5, %s: %llu any-hit calls without, %llu with (%llu opaque, %llu transparent by "
        "the map)\n",
        kind, (unsigned long long)plain.any_hit_calls, (unsigned long long)mapped.any_hit_calls,
        (unsigned long long)mapped.omm_opaque, (unsigned long long)mapped.omm_transparent);
    CHECK(mapped.any_hit_calls < plain.any_hit_calls / 2);
    if (with->timed()) {
      // The unit asks the stage only for the unknown ones: its requests are the calls, and the frame is faster.
      CHECK(with->timed()->timing().any_hit_requests == mapped.any_hit_calls);
      // Every non-opaque triangle of the forest has a map: each candidate was looked up (omm_latency each), the
      // unknown ones then asked.
      CHECK(with->timed()->timing().omm_lookups ==
            mapped.omm_opaque + mapped.omm_transparent + mapped.any_hit_calls);
      CHECK(without->timed()->timing().omm_lookups == 0);
      // Each lookup reads its state's line through the node cache: the accesses are the plain run's and one a
      // lookup, the node and record fetches the same.
      const hw::TimingStats &tw = with->timed()->timing(), &tp = without->timed()->timing();
      CHECK(tw.cache_hits + tw.cache_misses == tp.cache_hits + tp.cache_misses + tw.omm_lookups);
      CHECK(tw.node_fetches == tp.node_fetches);
      CHECK(tw.prim_fetches == tp.prim_fetches);
      CHECK(with->timed()->timing().cycles < without->timed()->timing().cycles);  // level 5: 0.93x on the frame
    }
  }
}

TEST_CASE("micromaps: trace --omm-level bakes them for the fixed device, not the float reference",
          "[micromap][alpha]") {
  const host::Scene& s = forest();
  const std::vector<hw::Ray> rays = host::primary_rays(s.camera, 64, 48);
  for (const hw::DeviceKind kind : {hw::DeviceKind::kFixed, hw::DeviceKind::kFloat}) {
    host::TraceRequest req;
    req.scene = &s;
    req.rays = rays;
    req.kind = kind;
    req.threads = 2;
    const host::TraceRun plain = host::run_trace(req);
    req.omm_level = 4;
    const host::TraceRun mapped = host::run_trace(req);
    CHECK(std::memcmp(plain.hits.data(), mapped.hits.data(), rays.size() * sizeof(hw::Hit)) == 0);
    CHECK(plain.stats.omm_opaque + plain.stats.omm_transparent == 0);
    if (kind == hw::DeviceKind::kFixed) {
      CHECK(mapped.micromaps != nullptr);
      CHECK(mapped.stats.omm_opaque + mapped.stats.omm_transparent > 0);
      CHECK(mapped.stats.any_hit_calls < plain.stats.any_hit_calls);
    } else {
      CHECK(mapped.micromaps == nullptr);  // the reference always asks the stage
      CHECK(mapped.stats.any_hit_calls == plain.stats.any_hit_calls);
    }
  }
}

TEST_CASE("micromaps: the render's stats price the lookup: its logic by level, its energy by the lookups made",
          "[micromap][alpha][energy]") {
  const test::TempDir d("omm_cost");
  double area[2] = {0.0, 0.0};
  for (int k = 0; k < 2; ++k) {
    const std::string stats = (d.path / ("s" + std::to_string(k) + ".json")).string();
    const test::Run r =
        test::run_rtusim("render --scene builtin:forest --device timed --config rdna2 --omm-level " +
                         std::to_string(k == 0 ? 2 : 6) + " --width 32 --height 24 --max-depth 1 --out " +
                         (d.path / "f.png").string() + " --stats " + stats);
    INFO(r.output);
    REQUIRE(r.status == 0);
    const nlohmann::json l = test::read_json(stats)["micromaps"]["lookup"];
    area[k] = l["area_mm2"].get<double>();
    CHECK(area[k] > 0.0);
    CHECK(l["lookups"].get<uint64_t>() > 0);
    CHECK(l["pj"].get<double>() == Approx(l["lookups"].get<double>() * l["pj_each"].get<double>()));
  }
  // A finer map's index has wider products and sums.
  CHECK(area[1] > area[0]);
  CHECK(host::omm_lookup_cost(6).toggles_per_test > host::omm_lookup_cost(2).toggles_per_test);
}

TEST_CASE(
    "micromaps: a micromap cache of their own keeps the image and takes the states' lines off the node cache",
    "[micromap][alpha][timing]") {
  const test::TempDir d("omm_cache");
  nlohmann::json t[2];
  uint64_t lookups = 0;
  std::string png[2];
  for (int k = 0; k < 2; ++k) {
    const std::string stats = (d.path / ("s" + std::to_string(k) + ".json")).string();
    png[k] = (d.path / ("f" + std::to_string(k) + ".png")).string();
    const test::Run r = test::run_rtusim(
        "render --scene builtin:forest --device timed --config rdna2 --omm-level 4 --width 48 --height 36 "
        "--max-depth 1 --threads 1 --set omm_cache_kib=" +
        std::string(k ? "8" : "0") + " --out " + png[k] + " --stats " + stats);
    INFO(r.output);
    REQUIRE(r.status == 0);
    const nlohmann::json j = test::read_json(stats);
    t[k] = j["timing"];
    lookups = j["micromaps"]["lookup"]["lookups"].get<uint64_t>();
  }
  CHECK(host::read_png(png[0]).rgb == host::read_png(png[1]).rgb);  // timing never changes a hit
  // Off (the default): no micromap cache counts. On: every state line access is the micromap cache's, one a
  // lookup at most (a state is a byte of one line), and the node cache sees only nodes and records.
  CHECK(t[0]["omm_cache"]["hits"] == 0);
  CHECK(t[0]["omm_cache"]["misses"] == 0);
  const uint64_t omm_lines =
      t[1]["omm_cache"]["hits"].get<uint64_t>() + t[1]["omm_cache"]["misses"].get<uint64_t>();
  CHECK(lookups > 0);
  CHECK(omm_lines == lookups);
  CHECK(t[1]["cache"]["line_accesses"].get<uint64_t>() + omm_lines ==
        t[0]["cache"]["line_accesses"].get<uint64_t>());
  test::check_refused(
      {{"trace --scene builtin:forest --rays primary:64 --device timed --set cache_ways=64 --set omm_cache_kib=2",
        "omm_cache_kib = 2 KiB is not a whole number of sets"},
       {"trace --scene builtin:forest --rays primary:64 --device timed --omm-level 2 --set omm_cache_kib=8 "
        "--sample 0.1",
        "does not model the micromap cache"}});
}
