// rtusim trace --against-*: an A/B of two timed design points on one ray set. Each side's figures must be those
// of the same design point traced alone, and the ratios the ratios of those figures.
#include <catch2/catch.hpp>

#include <string>

#include "host/io/ray_io.h"
#include "tests/host/cli_checks.h"

namespace fs = std::filesystem;
using namespace rtu::test;

namespace {

const std::string kScene = "trace --scene builtin:seed --rays primary:48x32 --device timed ";

nlohmann::json trace_stats(const fs::path& d, const std::string& name, const std::string& args) {
  const std::string stats = (d / (name + ".json")).string();
  REQUIRE_RTUSIM_OK(r, kScene + args + " --stats " + stats + " --out " + (d / (name + ".hits")).string());
  return read_json(stats);
}

}  // namespace

TEST_CASE("A/B: each side is its design point traced alone, the ratios are theirs", "[cli][timed]") {
  const fs::path d = temp_dir("cli_ab");
  const nlohmann::json a = trace_stats(d, "a", "--config rdna4");
  const nlohmann::json b = trace_stats(d, "b", "--config rdna4 --set box_units=2");
  const nlohmann::json j = trace_stats(d, "ab", "--config rdna4 --against-set box_units=2");
  const nlohmann::json& ab = j["ab"];
  // The model is deterministic: the same design point gives the same cycles, bit for bit.
  CHECK(ab["a"]["cycles"] == a["timing"]["cycles"]);
  CHECK(ab["b"]["cycles"] == b["timing"]["cycles"]);
  CHECK(j["against"]["timing"]["cycles"] == b["timing"]["cycles"]);
  CHECK(ab["b"]["label"] == "rdna4 + box_units=2");
  CHECK(ab["speedup"].get<double>() == a["timing"]["cycles"].get<double>() / b["timing"]["cycles"].get<double>());
  CHECK(ab["area_ratio"].get<double>() == b["timing"]["energy"]["area"]["total_mm2"].get<double>() /
                                              a["timing"]["energy"]["area"]["total_mm2"].get<double>());
  // A second box unit is area: B is larger, and per mm^2 the ratio follows.
  CHECK(ab["area_ratio"].get<double>() > 1.0);
  CHECK(ab["perf_per_area_ratio"].get<double>() ==
        Approx(ab["speedup"].get<double>() / ab["area_ratio"].get<double>()).epsilon(1e-12));
  // Timing never changes a hit: one format, the same hits on every ray.
  CHECK(ab["hits_compared"] == 48 * 32);
  CHECK(ab["hits_differ"] == 0);
  CHECK(ab["verdict"].get<std::string>().find("limited by") != std::string::npos);
}

TEST_CASE("A/B: another preset drops A's overrides, another format counts the hits that moved", "[cli][timed]") {
  const fs::path d = temp_dir("cli_ab");
  const nlohmann::json plain = trace_stats(d, "plain", "--config rdna4");
  const nlohmann::json j = trace_stats(d, "ab", "--config rdna2 --set box_units=2 --against-config rdna4");
  CHECK(j["ab"]["b"]["label"] == "rdna4");
  CHECK(j["ab"]["b"]["cycles"] == plain["timing"]["cycles"]);

  // compact rounds 16-bit coordinates: the seed's rays hit at other t, some elsewhere. The A/B counts exactly the
  // rays whose hit files differ in primitive, and apart from those the hits at another t.
  const nlohmann::json c = trace_stats(d, "compact", "--config rdna2 --format compact");
  const nlohmann::json f = trace_stats(d, "f", "--config rdna2 --against-format compact");
  const auto ha = rtu::host::read_hits((d / "f.hits").string()),
             hb = rtu::host::read_hits((d / "compact.hits").string());
  REQUIRE(ha.size() == hb.size());
  size_t differ = 0, t_differ = 0;
  for (size_t i = 0; i < ha.size(); ++i) {
    differ += ha[i].prim != hb[i].prim;
    t_differ += ha[i].prim == hb[i].prim && ha[i].hit() && ha[i].t != hb[i].t;
  }
  CHECK(f["ab"]["hits_differ"] == differ);
  CHECK(f["ab"]["t_differ"] == t_differ);
  CHECK(differ + t_differ > 0);  // 16-bit coordinates move t on the seed's rays: the count is not vacuous
  CHECK(f["ab"]["b"]["cycles"] == c["timing"]["cycles"]);
  CHECK(f["ab"]["b"]["format"] == c["format"]["name"]);
}

TEST_CASE("A/B: --against-format takes a format spec, priced for B's own format", "[cli][timed]") {
  // rdna4 without its oriented nodes: B is the same point as --format rdna4:node_kind=0 alone, and its area
  // drops by the rotation stage.
  const fs::path d = temp_dir("cli_ab");
  const nlohmann::json alone = trace_stats(d, "alone", "--config rdna4 --format rdna4:node_kind=0");
  const nlohmann::json j = trace_stats(d, "ab", "--config rdna4 --against-format rdna4:node_kind=0");
  CHECK(j["ab"]["b"]["cycles"] == alone["timing"]["cycles"]);
  CHECK(j["ab"]["b"]["area_mm2"] == alone["timing"]["energy"]["area"]["total_mm2"]);
  CHECK(j["ab"]["area_ratio"].get<double>() < 1.0);
}

TEST_CASE("A/B: cycles only (--sample, no --out) compares no hits", "[cli][timed]") {
  const fs::path d = temp_dir("cli_ab");
  const std::string stats = (d / "s.json").string();
  REQUIRE_RTUSIM_OK(
      r, kScene + "--config rdna4 --sample 0.5 --sample-unit 64 --against-set box_units=2 --stats " + stats);
  const nlohmann::json j = read_json(stats);
  CHECK(j["ab"]["hits_compared"] == 0);
  CHECK(j["ab"]["hits_differ"] == 0);
  CHECK(r.output.find("hits: not compared") != std::string::npos);
}

TEST_CASE("A/B: refused off the timed device and for bad keys, with the reason", "[cli][timed]") {
  Run r = run_rtusim("trace --scene builtin:seed --rays primary:8x8 --device fixed --against-set box_units=2");
  CHECK(r.status != 0);
  CHECK(r.output.find("timed device") != std::string::npos);
  r = run_rtusim(kScene + "--config rdna4 --against-set no_such_key=1");
  CHECK(r.status != 0);
  CHECK(r.output.find("no_such_key") != std::string::npos);
  r = run_rtusim(kScene + "--config rdna4 --against-config no_such_preset");
  CHECK(r.status != 0);
  CHECK(r.output.find("no_such_preset") != std::string::npos);
}
