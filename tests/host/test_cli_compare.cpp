// rtusim end to end: compare (the fixed device against the float reference) and the stress suite.
#include <catch2/catch.hpp>

#include <fstream>

#include "host/io/ray_io.h"
#include "tests/host/cli_checks.h"

namespace fs = std::filesystem;
using namespace rtu::test;

TEST_CASE("compare: the JSON report's keys, conservative boxes, agreement on the seed scene", "[cli][fixed]") {
  const fs::path d = temp_dir("cli");
  const std::string json = (d / "c.json").string(), replay = (d / "dis.rays").string();
  REQUIRE_RTUSIM_OK(
      r, "compare --scene builtin:seed --rays incoherent:50000 --json " + json + " --disagreements " + replay);
  const nlohmann::json j = read_json(json);
  for (const char* key : {"rays", "hit_agreement", "prim_agreement", "false_misses", "false_hits", "invalid_rays",
                          "t_rel_error_max", "t_rel_error_mean", "box_false_negatives", "node_visit_overhead",
                          "prim_test_overhead", "disagreements", "format"})
    CHECK(j.contains(key));
  CHECK(j["rays"] == 50000);
  CHECK(j["box_checks"].get<uint64_t>() > 100000);
  CHECK(j["box_false_negatives"] == 0);
  CHECK(j["hit_agreement"].get<double>() >= 0.9999);
  // Quantized child boxes only grow, so the fixed device never visits fewer nodes than the float one on rays
  // whose hits agree; 8-bit child boxes keep the growth small on this scene.
  CHECK(j["node_visit_overhead"].get<double>() >= 0.0);
  CHECK(j["node_visit_overhead"].get<double>() <= 0.05);
  // Every listed disagreement names its ray; the replay file holds exactly the disagreeing rays.
  CHECK(rtu::host::read_rays(replay).size() == j["disagreements_total"].get<size_t>());
  for (const auto& e : j["disagreements"]) CHECK(e["ray"].get<uint64_t>() < 50000);
}

TEST_CASE("compare: what it did not check it does not report", "[cli][fixed]") {
  const fs::path d = temp_dir("cli");
  const std::string json = (d / "c2.json").string();
  // Any-hit: a hit is any hit, so primitives and t are not compared.
  Run r = run_rtusim("compare --scene builtin:cornell --rays primary:3000 --any-hit --json " + json);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("primitive agreement") == std::string::npos);
  CHECK(r.output.find("t error") == std::string::npos);
  nlohmann::json j = rtu::host::read_json_file(json);
  CHECK(j["prim_agreement"].is_null());
  CHECK(j["t_rel_error_max"].is_null());
  CHECK(j["box_checks"].get<uint64_t>() > 0);
  // The timed device does not repeat its box tests: no "false negatives 0" it did not count.
  r = run_rtusim("compare --scene builtin:cornell --rays primary:3000 --device timed --json " + json);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("false negatives") == std::string::npos);
  CHECK(r.output.find("not checked on the timed device") != std::string::npos);
  j = rtu::host::read_json_file(json);
  CHECK(j["box_false_negatives"].is_null());
  // Closest hit: the distance error in grid steps beside the relative one, from the device's frame.
  REQUIRE(j["grid_step"].is_number());
  CHECK(j["grid_step"].get<double>() > 0.0);
  CHECK(j["t_abs_error_steps_mean"].get<double>() <= j["t_abs_error_steps_max"].get<double>());
  CHECK(r.output.find("grid steps") != std::string::npos);
}

TEST_CASE("a camera beyond the fixed-point frame: render says so, compare fails naming the reason",
          "[cli][fixed]") {
  const fs::path d = temp_dir("cli");
  // A unit sphere seen from 2000 units: 1000 frame sizes away, beyond the default format's 2^6 guard range.
  std::ofstream(d / "far.json") << R"({"camera": {"position": [0, 0, 2000], "look_at": [0, 0, 0], "fov_y": 0.1,
    "width": 32, "height": 24}, "spheres": [{"center": [0, 0, 0], "radius": 1}],
    "lights": [{"type": "point", "position": [3, 6, 4], "intensity": [60, 60, 60]}]})";
  const std::string scene = (d / "far.json").string(), stats = (d / "far-stats.json").string();
  Run r = run_rtusim("render --scene " + scene + " --device fixed --out " + (d / "far.png").string() +
                     " --stats " + stats);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("768 of 768 traced rays (100%) were invalid") != std::string::npos);
  CHECK(r.output.find("most rays were invalid") != std::string::npos);
  CHECK(r.output.find("out_of_frame 768") != std::string::npos);
  const nlohmann::json j = rtu::host::read_json_file(stats);
  CHECK(j["unit"]["total"]["invalid_rays"] == 768);
  CHECK(j["warnings"].size() == 2);
  // The float device represents every ray: no warning.
  r = run_rtusim("render --scene " + scene + " --device float --out " + (d / "far-float.png").string());
  CHECK(r.status == 0);
  CHECK(r.output.find("warning") == std::string::npos);
  // Nothing valid on both devices: an error, not a row of zeros.
  r = run_rtusim("compare --scene " + scene + " --rays primary");
  CHECK(r.exited);
  CHECK(r.status != 0);
  CHECK(r.output.find("nothing compared") != std::string::npos);
  CHECK(r.output.find("out_of_frame 0 / 768") != std::string::npos);
  CHECK(r.output.find("t error") == std::string::npos);
}

TEST_CASE("stress: every category runs, no promise breaks at the default format", "[cli][fixed][stress][scale]") {
  const fs::path d = temp_dir("cli");
  const std::string json = (d / "stress.json").string();
  const Run r = run_rtusim("stress --count 3000 --json " + json);
  INFO(r.output);
  CHECK(r.status == 0);
  const nlohmann::json j = read_json(json);
  CHECK(j["failures"] == 0);
  CHECK(j["categories"].size() == 12);
  for (const auto& c : j["categories"]) {
    INFO(c["name"]);
    CHECK(c["cases"].get<uint64_t>() > 0);
    CHECK(c["failure_rule"].get<std::string>().size() > 10);
  }
  // The promises hold at every width, not only the default: the narrowest preset, the 128-bit box path,
  // binary, 6- and 8-wide nodes, and a 12-bit grid.
  for (const char* f : {"--format compact", "--format precise", "--format binary", "--format wide6",
                        "--format wide8", "--coord-bits 12 --child-bits 4"}) {
    const Run s = run_rtusim(std::string("stress --count 1500 ") + f);
    INFO(f << "\n" << s.output);
    CHECK(s.status == 0);
  }
}

TEST_CASE("compare --rays: incoherent without a count, and a spec that is neither a kind nor a file", "[cli]") {
  const fs::path d = temp_dir("cli");
  const std::string json = (d / "c_inc.json").string();
  REQUIRE_RTUSIM_OK(r, "compare --scene builtin:cornell --rays incoherent --json " + json);
  const Run p = run_rtusim("compare --scene builtin:cornell --rays primary --json " + json + "_p");
  REQUIRE(p.status == 0);
  // As many as the camera's image has.
  const nlohmann::json a = rtu::host::read_json_file(json), b = rtu::host::read_json_file(json + "_p");
  CHECK(a["rays"] == b["rays"]);
  CHECK(a["rays"].get<uint64_t>() > 0);
  const Run bad = run_rtusim("compare --scene builtin:cornell --rays incoherrent:100");
  INFO(bad.output);
  CHECK(bad.status == 2);
  CHECK(bad.output.find("no such ray file, and not a ray spec") != std::string::npos);
  CHECK(bad.output.find("incoherent:N") != std::string::npos);
  // --seed draws incoherent rays only.
  const Run seed = run_rtusim("compare --scene builtin:cornell --rays primary:100 --seed 3");
  CHECK(seed.status == 2);
  CHECK(seed.output.find("--seed applies to --rays incoherent") != std::string::npos);
}
