// rtusim end to end: the subcommands on the built-in scenes, and bad input giving a clear error and a non-zero
// exit, never a crash.
#include <catch2/catch.hpp>

#include <unistd.h>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "host/io/image.h"
#include "host/io/json_io.h"
#include "host/io/ray_io.h"
#include "host/jobs/sweep.h"
#include "hwmodel/timing/timing_config.h"
#include "tests/common/test_util.h"
#include "tests/host/run_process.h"

namespace fs = std::filesystem;
using rtu::test::Run;
using rtu::test::run_rtusim;

using rtu::test::temp_dir;

namespace {

// rtusim's JSON read back through the depth-limited parser rtu reads JSON with (host/io/json_io.h): so every file
// these tests read also shows that rtusim writes nothing deeper than host::kMaxJsonDepth.
nlohmann::json read_json(const fs::path& p) {
  return rtu::host::read_json_file(p.string());
}

}  // namespace

TEST_CASE("every subcommand has --help", "[cli]") {
  for (const char* sub : {"info", "rays", "trace", "compare", "stress", "demo", "diff", "config", "sweep", "plan",
                          "report", "pareto"}) {
    const Run r = run_rtusim(std::string(sub) + " --help");
    INFO(r.output);
    CHECK(r.status == 0);
    CHECK(r.output.find("--") != std::string::npos);
  }
  CHECK(run_rtusim("frobnicate").status != 0);
  CHECK(run_rtusim("").status != 0);
}

TEST_CASE("rays -> trace round trip on a built-in scene, CSV and binary give the same hits", "[cli]") {
  const fs::path d = temp_dir("cli");
  const std::string rays = (d / "p.rays").string(), rays_csv = (d / "p.csv").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind primary --count 20000 --out " + rays).status == 0);
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind primary --count 20000 --out " + rays_csv).status == 0);
  const std::string stats = (d / "s.json").string();
  const Run t = run_rtusim("trace --scene builtin:seed --rays " + rays + " --out " + (d / "h.bin").string() +
                           " --stats " + stats + " --bvh-width 8");
  INFO(t.output);
  REQUIRE(t.status == 0);
  REQUIRE(
      run_rtusim("trace --scene builtin:seed --rays " + rays_csv + " --out " + (d / "h.csv").string()).status ==
      0);
  const auto a = rtu::host::read_hits((d / "h.bin").string()), b = rtu::host::read_hits((d / "h.csv").string());
  REQUIRE(a.size() == 20000);
  REQUIRE(std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0);

  const nlohmann::json j = read_json(stats);
  for (const char* key : {"rays", "hits", "trace_seconds", "rays_per_second", "nodes_visited", "box_tests",
                          "prim_tests", "invalid_rays"})
    CHECK(j.contains(key));
  CHECK(j["rays"] == 20000);
  CHECK(j["hits"].get<uint64_t>() > 10000);
  CHECK(j["hits"].get<uint64_t>() <= 20000);
  CHECK(j["bvh"]["width"] == 8);
}

TEST_CASE("trace with NaN rays warns, counts them and writes misses", "[cli]") {
  const fs::path d = temp_dir("cli");
  std::ofstream(d / "nan.csv") << "ox,oy,oz,tmin,dx,dy,dz,tmax\n0,1,8,0,0,0,-1,inf\nnan,0,0,0,1,0,0,inf\n"
                                  "0,0,0,0,0,-0,0,inf\n";
  const Run r = run_rtusim("trace --scene builtin:seed --rays " + (d / "nan.csv").string() + " --out " +
                           (d / "h.csv").string() + " --stats " + (d / "s.json").string());
  INFO(r.output);
  CHECK(r.status == 0);
  CHECK(r.output.find("2 invalid rays") != std::string::npos);
  CHECK(r.output.find("ray 1 (nan_origin)") != std::string::npos);
  const nlohmann::json j = read_json(d / "s.json");
  CHECK(j["invalid_rays"] == 2);
  CHECK(j["invalid_by_reason"]["zero_direction"] == 1);
  const auto hits = rtu::host::read_hits((d / "h.csv").string());
  REQUIRE(hits.size() == 3);
  CHECK_FALSE(hits[1].hit());
  CHECK_FALSE(hits[2].hit());
}

TEST_CASE("bad input: clear error, non-zero exit, no crash", "[cli]") {
  const fs::path d = temp_dir("cli");
  std::ofstream(d / "odd.rays", std::ios::binary) << std::string(45, 'x');
  std::ofstream(d / "broken.json") << "{ \"spheres\": [ {\"center\": [0,0,0], \"radius\": 1 ";
  std::ofstream(d / "unknown.json") << R"({"spheres": [{"center": [0,0,0], "radius": 1, "colour": 3}]})";
  const std::string out = (d / "h.bin").string();
  struct Case {
    std::string args, words;
  };
  const Case cases[] = {
      {"trace --scene builtin:seed --rays " + (d / "odd.rays").string() + " --out " + out, "multiple of 32"},
      {"trace --scene builtin:nosuch --rays " + (d / "odd.rays").string() + " --out " + out, "nosuch"},
      {"info --scene " + (d / "missing.obj").string(), "missing.obj"},
      {"info --scene " + (d / "broken.json").string(), "broken.json"},
      {"info --scene " + (d / "unknown.json").string(), "colour"},
      {"trace --scene builtin:seed --rays " + (d / "none.rays").string() + " --out " + out, "none.rays"},
      {"rays --scene builtin:seed --kind sideways --count 5 --out " + out, "sideways"},
      {"rays --scene builtin:seed --kind incoherent --out " + out, "--count"},
      {"info --scene builtin:seed --bvh-width 3", "bvh-width"},
      {"info --scene builtin:seed --format nosuch", "nosuch"},
      {"info --scene builtin:seed --coord-bits 31", "coord_bits"},
      {"info --scene builtin:seed --coord-bits 30 --guard-bits 8 --frac-bits 20 --t-bits 60", "edge function"},
      {"info --scene builtin:seed --dir-bits 30 --rcp-bits 40", "rcp"},
      {"compare --scene builtin:seed --rays primary:0", "count"},
      {"compare --scene builtin:seed --rays incoherent:x", "count"},
      {"stress --count 10 --category nosuch", "nosuch"},
  };
  for (const Case& c : cases) {
    const Run r = run_rtusim(c.args);
    INFO(c.args << "\n" << r.output);
    CHECK(r.status != 0);
    CHECK(r.status < 128);  // not killed by a signal
    CHECK(r.output.find(c.words) != std::string::npos);
  }
}

TEST_CASE("demo writes an image, hits and a report", "[cli]") {
  const fs::path d = temp_dir("cli") / "demo";
  const Run r = run_rtusim("demo --out " + d.string());
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(fs::file_size(d / "primary_float.png") > 1000);
  const nlohmann::json j = read_json(d / "report.json");
  CHECK(j["devices"]["float"]["hits"].get<uint64_t>() > 0);
  // The fixed device renders the same image up to quantization: the default format keeps hit agreement above
  // 99.99% on the seed scene (edges move by at most half a grid step of 2^-24 of the scene).
  CHECK(fs::file_size(d / "primary_fixed.png") > 1000);
  CHECK(j["devices"]["fixed"]["hits"].get<uint64_t>() > 0);
  CHECK(j["fixed_vs_float"]["hit_agreement"].get<double>() >= 0.9999);
}

TEST_CASE("compare: the JSON report's keys, conservative boxes, agreement on the seed scene", "[cli][fixed]") {
  const fs::path d = temp_dir("cli");
  const std::string json = (d / "c.json").string(), replay = (d / "dis.rays").string();
  const Run r = run_rtusim("compare --scene builtin:seed --rays incoherent:50000 --json " + json +
                           " --disagreements " + replay);
  INFO(r.output);
  REQUIRE(r.status == 0);
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

TEST_CASE("trace on the fixed device: formats, out-of-frame origins rejected with their reason", "[cli][fixed]") {
  const fs::path d = temp_dir("cli");
  std::ofstream(d / "far.csv") << "ox,oy,oz,tmin,dx,dy,dz,tmax\n0,1,8,0,0,-0.3,-1,inf\n1e12,0,0,0,-1,0,0,inf\n";
  const std::string stats = (d / "s.json").string();
  const Run r = run_rtusim("trace --device fixed --format compact --scene builtin:seed --rays " +
                           (d / "far.csv").string() + " --out " + (d / "h.csv").string() + " --stats " + stats);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("ray 1 (out_of_frame)") != std::string::npos);
  const nlohmann::json j = read_json(stats);
  CHECK(j["invalid_by_reason"]["out_of_frame"] == 1);
  CHECK(j["format"]["coord_bits"] == 16);
  const auto hits = rtu::host::read_hits((d / "h.csv").string());
  REQUIRE(hits.size() == 2);
  CHECK(hits[0].hit());
  CHECK_FALSE(hits[1].hit());
}

TEST_CASE("info reports the fixed image: bytes per node and footprint per format", "[cli][fixed]") {
  const fs::path d = temp_dir("cli");
  const Run list = run_rtusim("info --formats");
  REQUIRE(list.status == 0);
  for (const char* p : {"default", "wide6", "wide8", "binary", "compact", "precise", "cwbvh", "packed", "xe6"})
    CHECK(list.output.find(p) != std::string::npos);
  for (const auto& [format, node_bytes] :
       {std::pair{"default", 56}, std::pair{"wide6", 76}, std::pair{"wide8", 96}, std::pair{"binary", 36},
        std::pair{"precise", 80}, std::pair{"cwbvh", 80}, std::pair{"xe6", 64}}) {
    const std::string json = (d / (std::string(format) + ".json")).string();
    const Run r = run_rtusim(std::string("info --scene builtin:seed --format ") + format + " --json " + json);
    INFO(r.output);
    REQUIRE(r.status == 0);
    const nlohmann::json j = read_json(json);
    CHECK(j["bvh"]["image"]["bytes_per_node"] == node_bytes);
    CHECK(j["bvh"]["image"]["total_bytes"].get<uint64_t>() > j["bvh"]["image"]["node_bytes"].get<uint64_t>());
  }
}

TEST_CASE("stress: every category runs, no promise breaks at the default format", "[cli][fixed][stress]") {
  const fs::path d = temp_dir("cli");
  const std::string json = (d / "stress.json").string();
  const Run r = run_rtusim("stress --count 3000 --json " + json);
  INFO(r.output);
  CHECK(r.status == 0);
  const nlohmann::json j = read_json(json);
  CHECK(j["failures"] == 0);
  CHECK(j["categories"].size() == 11);
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

TEST_CASE("diff: identical and differing PNGs, JSON keys, heatmap", "[cli][image]") {
  const fs::path d = temp_dir("cli");
  rtu::host::Image a{8, 4, std::vector<uint8_t>(8 * 4 * 3, 120)};
  rtu::host::Image b = a;
  b.rgb[3 * 9 + 2] = 130;  // one channel of one pixel off by 10
  const std::string pa = (d / "a.png").string(), pa2 = (d / "a2.png").string(), pb = (d / "b.png").string();
  rtu::host::write_png(pa, a);
  rtu::host::write_png(pa2, a);
  rtu::host::write_png(pb, b);

  const std::string same_json = (d / "same.json").string();
  const Run same = run_rtusim("diff " + pa + " " + pa2 + " --json " + same_json);
  INFO(same.output);
  REQUIRE(same.status == 0);
  CHECK(same.output.find("8x4") != std::string::npos);
  CHECK(same.output.find("identical") != std::string::npos);
  const nlohmann::json js = read_json(same_json);
  CHECK(js["identical"] == true);
  CHECK(js["psnr_db"].is_null());
  CHECK(js["pixels_differing"] == 0);

  const std::string json = (d / "diff.json").string(), heat = (d / "heat.png").string();
  const Run r = run_rtusim("diff " + pa + " " + pb + " --heatmap " + heat + " --scale 20 --json " + json);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("1 of 32 pixels differ") != std::string::npos);
  const nlohmann::json j = read_json(json);
  for (const char* key : {"a", "b", "width", "height", "identical", "mse", "psnr_db", "max_abs", "mean_abs",
                          "pixels_differing", "frac_pixels_differing", "heatmap", "heatmap_scale"})
    CHECK(j.contains(key));
  CHECK(j["width"] == 8);
  CHECK(j["height"] == 4);
  CHECK(j["identical"] == false);
  CHECK(j["max_abs"] == 10);
  CHECK(j["pixels_differing"] == 1);
  CHECK(j["mse"].get<double>() == Approx(100.0 / 96.0));
  CHECK(j["psnr_db"].get<double>() == Approx(10.0 * std::log10(255.0 * 255.0 * 96.0 / 100.0)));
  CHECK(j["heatmap_scale"].get<double>() == 20.0);
  const rtu::host::Image h = rtu::host::read_png(heat);
  REQUIRE(h.width == 8);
  REQUIRE(h.height == 4);
  for (size_t p = 0; p < 32; ++p) {
    const bool black = h.rgb[3 * p] == 0 && h.rgb[3 * p + 1] == 0 && h.rgb[3 * p + 2] == 0;
    CHECK(black == (p != 9));
  }
}

TEST_CASE("diff: missing, corrupt and mismatched files give a clear error and a non-zero exit", "[cli][image]") {
  const fs::path d = temp_dir("cli");
  const std::string a = (d / "d4x4.png").string(), b = (d / "d4x3.png").string(), junk = (d / "junk.png").string();
  rtu::host::write_png(a, rtu::host::Image{4, 4, std::vector<uint8_t>(4 * 4 * 3, 7)});
  rtu::host::write_png(b, rtu::host::Image{4, 3, std::vector<uint8_t>(4 * 3 * 3, 7)});
  std::ofstream(junk, std::ios::binary) << "not a png";
  struct Case {
    std::string args, words;
  };
  const Case cases[] = {
      {"diff " + a + " " + (d / "nosuch.png").string(), "nosuch.png"},
      {"diff " + (d / "nosuch.png").string() + " " + a, "nosuch.png"},
      {"diff " + a + " " + junk, "junk.png"},
      {"diff " + a + " " + b, "sizes differ"},
      {"diff " + a + " " + b, "4x3"},
      {"diff " + a + " " + a + " --scale 0", "--scale"},
      {"diff " + a, "required"},
  };
  for (const Case& c : cases) {
    const Run r = run_rtusim(c.args);
    INFO(c.args << "\n" << r.output);
    CHECK(r.status != 0);
    CHECK(r.status < 128);
    CHECK(r.output.find(c.words) != std::string::npos);
  }
}

TEST_CASE("config: a preset's every key, --set overrides, JSON keys, --list", "[cli][timing][config]") {
  const Run r = run_rtusim("config --config rdna2");
  INFO(r.output);
  REQUIRE(r.status == 0);
  const std::vector<rtu::hw::TimingKey> keys = rtu::hw::timing_keys(rtu::hw::timing_preset("rdna2"));
  for (const rtu::hw::TimingKey& k : keys) {
    // A line "key<spaces> = value<spaces>   # description".
    const size_t at = r.output.find("\n" + k.key + " ");
    REQUIRE(at != std::string::npos);
    const std::string line = r.output.substr(at + 1, r.output.find('\n', at + 1) - at - 1);
    INFO(line);
    CHECK(line.find("= " + k.value + " ") != std::string::npos);
    CHECK(line.find("# " + k.description) != std::string::npos);
  }

  const Run s = run_rtusim("config --config intel --set ray_slots=64 --set box_latency=9");
  INFO(s.output);
  REQUIRE(s.status == 0);
  CHECK(s.output.find("ray_slots") != std::string::npos);
  CHECK(s.output.find("= 64 ") != std::string::npos);
  CHECK(s.output.find("= 9 ") != std::string::npos);
  CHECK(s.output.find("box_units                  = 2 ") != std::string::npos);  // intel's two box units

  const fs::path d = temp_dir("cli");
  const std::string json = (d / "timing.json").string();
  REQUIRE(run_rtusim("config --config embedded --set clock_ghz=0.8 --json " + json).status == 0);
  const nlohmann::ordered_json j = rtu::host::read_json_file(json);
  CHECK(j["preset"] == "embedded");
  std::vector<std::string> json_keys;
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.key() != "preset") json_keys.push_back(it.key());
  std::vector<std::string> want;
  for (const rtu::hw::TimingKey& k : keys) want.push_back(k.key);
  CHECK(json_keys == want);
  CHECK(j["format"] == "compact");
  CHECK(j["bvh_width"].is_number_integer());
  CHECK(j["bvh_width"] == 4);
  CHECK(j["clock_ghz"].is_number());
  CHECK(j["clock_ghz"].get<double>() == 0.8);
  CHECK(j["dram_bytes_per_cycle"].is_number());

  const Run l = run_rtusim("config --list");
  INFO(l.output);
  REQUIRE(l.status == 0);
  for (const std::string& n : rtu::hw::timing_preset_names()) CHECK(l.output.find(n + " ") != std::string::npos);
  CHECK(l.output.find("RDNA2") != std::string::npos);
}

TEST_CASE("config: unknown preset or key, bad values, malformed --set: exit 2 naming the problem",
          "[cli][timing][config]") {
  struct Case {
    std::string args, words;
  };
  const Case cases[] = {
      {"config --config amd", "amd"},
      {"config --config rdna2 --set ray_slot=4", "ray_slot"},
      {"config --config rdna2 --set ray_slots=12x", "ray_slots"},
      {"config --config rdna2 --set ray_slots=0", "ray_slots"},
      {"config --config rdna2 --set ray_slots=", "ray_slots"},
      {"config --config rdna2 --set bvh_width=5", "bvh_width"},
      {"config --config rdna2 --set clock_ghz=fast", "clock_ghz"},
      {"config --config rdna2 --set format=nosuch", "nosuch"},
      {"config --config rdna2 --set ray_slots", "key=value"},
  };
  for (const Case& c : cases) {
    const Run r = run_rtusim(c.args);
    INFO(c.args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(c.words) != std::string::npos);
  }
}

TEST_CASE("sweep: rows per point, resume, shards that merge into the whole, bad input", "[cli][sweep]") {
  const fs::path d = temp_dir("cli");
  const std::string whole = (d / "sweep_whole.csv").string(), a = (d / "sweep_a.csv").string(),
                    b = (d / "sweep_b.csv").string(), merged = (d / "sweep_merged.csv").string();
  for (const std::string& f : {whole, a, b, merged}) fs::remove(f);
  const std::string grid =
      "sweep --scene builtin:seed --formats default,compact,default:coord_bits=12 --bvh-width 4,8 --rays 3000 "
      "--image-width 48 ";
  Run r = run_rtusim(grid + "--out " + whole);
  INFO(r.output);
  REQUIRE(r.status == 0);
  auto read_lines = [](const std::string& path) {
    std::ifstream in(path);
    std::vector<std::string> lines;
    for (std::string l; std::getline(in, l);) lines.push_back(l);
    return lines;
  };
  // Everything but the last column (the point's wall time) is deterministic.
  auto strip_time = [](std::string l) { return l.substr(0, l.rfind(',')); };
  const std::vector<std::string> w = read_lines(whole);
  REQUIRE(w.size() == 7);  // header + 3 formats x 2 widths
  CHECK(w[0].rfind("scene,format,bvh_width,config,rays,seed,image_width,flatten,hit_agreement", 0) == 0);
  // The default format agrees with float on every ray of the seed scene (3000 + 3000 rays, seed 1, 48 wide).
  CHECK(w[1].find("builtin:seed,default,4,rdna2,6000,1,48,0,1,") == 0);
  // At every width the fixed device traverses the float reference's tree of the same width: quantized boxes
  // only grow, so it visits a few percent more nodes, never far fewer (a reference of another width would).
  for (size_t i = 1; i < w.size(); ++i) {
    std::vector<std::string> f;
    std::stringstream ss(w[i]);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    REQUIRE(f.size() == 29);
    const double node_overhead = std::stod(f[14]);
    INFO(w[i]);
    CHECK(node_overhead >= -0.01);
    CHECK(node_overhead <= 0.25);
  }
  // Resume: nothing left to run, the file unchanged.
  r = run_rtusim(grid + "--out " + whole);
  CHECK(r.status == 0);
  CHECK(r.output.find("0 run, 6 already") != std::string::npos);
  CHECK(read_lines(whole) == w);
  // An interrupted row (no newline at the end) is dropped and run again.
  {
    std::ofstream f(whole, std::ios::app);
    f << "builtin:seed,default,4";
  }
  r = run_rtusim(grid + "--out " + whole);
  CHECK(r.status == 0);
  CHECK(r.output.find("unfinished row") != std::string::npos);
  CHECK(read_lines(whole).size() == 7);
  // Two shards merge into the same rows.
  REQUIRE(run_rtusim(grid + "--shard 1/2 --out " + a).status == 0);
  REQUIRE(run_rtusim(grid + "--shard 2/2 --out " + b).status == 0);
  CHECK(read_lines(a).size() == 4);
  CHECK(read_lines(b).size() == 4);
  REQUIRE(run_rtusim("sweep --merge " + a + " " + b + " --out " + merged).status == 0);
  std::vector<std::string> m = read_lines(merged), ws = w;
  REQUIRE(m.size() == ws.size());
  for (auto* v : {&m, &ws}) {
    for (std::string& l : *v) l = strip_time(l);
    std::sort(v->begin() + 1, v->end());
  }
  CHECK(m == ws);
  // Bad input: a clear error naming it, exit 2, nothing crashes.
  for (const auto& [args, words] :
       std::vector<std::pair<std::string, std::string>>{{"--formats nosuch", "unknown format preset"},
                                                        {"--formats default:coord_bits=99", "coord_bits"},
                                                        {"--formats default:bits=3", "format key"},
                                                        {"--shard 3/2", "--shard"},
                                                        {"--shard x", "--shard"},
                                                        {"--bvh-width 3", "2, 4, 6 or 8"},
                                                        {"--config nosuch", "nosuch"}}) {
    const Run e =
        run_rtusim("sweep --scene builtin:seed " + args + " --rays 10 --out " + (d / "bad.csv").string());
    INFO(args << ": " << e.output);
    CHECK(e.status == 2);
    CHECK(e.output.find(words) != std::string::npos);
  }
  {
    std::ofstream f(d / "foreign.csv");
    f << "a,b,c\n1,2,3\n";
  }
  const Run e = run_rtusim("sweep --scene builtin:seed --rays 10 --out " + (d / "foreign.csv").string());
  CHECK(e.status == 2);
  CHECK(e.output.find("not a sweep file") != std::string::npos);
}

TEST_CASE(
    "plan: the fewest coordinate bits within the budget and the chosen, the reason, an impossible budget fails",
    "[cli][sweep]") {
  const fs::path d = temp_dir("cli");
  const std::string json = (d / "plan.json").string();
  const Run r = run_rtusim(
      "plan --scene builtin:cornell --max-error 2e-3 --bvh-width 4 --coord-bits 6,8,10,12,16 "
      "--child-bits 6,8 --rays 3000 --image-width 0 --json " +
      json);
  INFO(r.output);
  REQUIRE(r.status == 0);
  const nlohmann::json j = read_json(json);
  const auto& w = j["widths"][0];
  REQUIRE(w["feasible"] == true);
  const int b = w["coord_bits"];
  // The chosen width's error bound meets the budget; the next fewer tried does not (or it was the fewest tried).
  CHECK(w["error_bound_at_coord_bits"].get<double>() <= 2e-3);
  CHECK(w["error_at_coord_bits"].get<double>() <= w["error_bound_at_coord_bits"].get<double>());
  if (w.contains("fewer_coord_bits")) {
    CHECK(w["fewer_coord_bits"].get<int>() < b);
    CHECK(w["error_bound_at_fewer_coord_bits"].get<double>() > 2e-3);
    CHECK(r.output.find("why " + std::to_string(b) + " coordinate bits at least") != std::string::npos);
  }
  // Minimising cycles, the plan may take more bits than the fewest within the budget, never fewer.
  CHECK(w["chosen_coord_bits"].get<int>() >= b);
  // Every step up it weighed is printed with its measured cause; the steps taken lead to the chosen bits, and
  // only the last may be a tie that was not taken.
  int reached = b;
  for (size_t i = 0; i < w["more_coord_bits"].size(); ++i) {
    const auto& m = w["more_coord_bits"][i];
    CHECK(m["from_coord_bits"] == reached);
    CHECK(r.output.find(m["cause"].get<std::string>()) != std::string::npos);
    if (m["taken"] == true)
      reached = m["to_coord_bits"];
    else
      CHECK(i + 1 == w["more_coord_bits"].size());
  }
  CHECK(reached == w["chosen_coord_bits"].get<int>());
  CHECK(r.output.find("(fewer node visits)") == std::string::npos);  // no cause claimed unmeasured
  CHECK(j["plan"]["coord_bits"] == w["chosen_coord_bits"]);
  CHECK(j["plan"]["error_bound"].get<double>() <= 2e-3);
  CHECK(j["plan"]["cycles"].get<uint64_t>() > 0);
  // The plan skips bits: fewer than the default format's 24 are enough for this budget.
  CHECK(b < 24);
  // Every child-bit candidate that met the budget costs at least the chosen cycles.
  for (const auto& k : w["child_bits"])
    if (k["meets"] == true) CHECK(k["cycles"].get<uint64_t>() >= j["plan"]["cycles"].get<uint64_t>());
  // No format can have a mean t error of exactly 0 at 2 coordinate bits only: exit 1, saying so.
  const Run none = run_rtusim(
      "plan --scene builtin:cornell --metric t --max-error 0 --bvh-width 4 --coord-bits 2 "
      "--child-bits 8 --rays 500 --image-width 0");
  CHECK(none.status == 1);
  CHECK(none.output.find("no format meets") != std::string::npos);
  CHECK(run_rtusim("plan --scene builtin:cornell --max-error -1").status == 2);
  CHECK(run_rtusim("plan --scene builtin:cornell --max-error 1e-3 --metric psnr").status != 0);
}

namespace {

// What a pipeline trace file holds: spans (checked to overlap [from, to) and to be of a known kind), the units
// (processes) and (unit, slot) tracks with spans, those named by metadata, and counter samples.
struct PipelineFile {
  size_t spans = 0, counters = 0;
  std::set<uint64_t> units, named_units;
  std::set<std::pair<uint64_t, uint64_t>> slots, named_slots;
};

PipelineFile read_pipeline(const std::string& path, uint64_t from, uint64_t to) {
  const nlohmann::json p = read_json(path);
  REQUIRE(p["traceEvents"].is_array());
  PipelineFile f;
  const std::set<std::string> kinds = {"setup",  "node fetch", "box",          "record fetch", "triangle",
                                       "sphere", "plane",      "stack refill", "write-back"};
  for (const auto& e : p["traceEvents"]) {
    const uint64_t pid = e["pid"];
    if (e["ph"] == "M") {
      if (e["name"] == "process_name") {
        f.named_units.insert(pid);
      } else {
        CHECK(e["name"] == "thread_name");
        f.named_slots.insert({pid, e["tid"].get<uint64_t>()});
      }
      continue;
    }
    if (e["ph"] == "C") {
      ++f.counters;
      CHECK(e["args"]["bytes_per_cycle"].get<double>() >= 0.0);
      continue;
    }
    REQUIRE(e["ph"] == "X");
    ++f.spans;
    const uint64_t ts = e["ts"], dur = e["dur"];
    CHECK(ts < to);
    CHECK(ts + dur > from);
    CHECK(kinds.count(e["name"].get<std::string>()) == 1);
    f.units.insert(pid);
    f.slots.insert({pid, e["tid"].get<uint64_t>()});
  }
  CHECK(p["otherData"]["spans"] == f.spans);
  return f;
}

}  // namespace

TEST_CASE("trace --device timed: timing stats, the lower bound, breakdowns, the pipeline trace file",
          "[cli][timing]") {
  const fs::path d = temp_dir("cli");
  const std::string rays = (d / "t.rays").string(), stats = (d / "t.json").string(),
                    pipe = (d / "pipe.json").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind primary --count 3000 --out " + rays).status == 0);
  const Run r = run_rtusim("trace --scene builtin:seed --rays " + rays + " --out " + (d / "t.hits").string() +
                           " --device timed --config intel --stats " + stats + " --pipeline-trace " + pipe +
                           " --trace-window 100:1100");
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("timed (intel):") != std::string::npos);
  const nlohmann::json j = read_json(stats);
  const auto& t = j["timing"];
  const double cycles = t["cycles"].get<double>();
  CHECK(t["rays"] == 3000);
  CHECK(t["packets"] == 1);
  CHECK(cycles > 0);
  // The bound is the largest of its parts, named, and below the simulated cycles.
  const auto& b = t["lower_bound"];
  const double box = b["box"].get<double>(), tri = b["triangle"].get<double>(), dram = b["dram"].get<double>();
  const double latency = b["latency"].get<double>();
  CHECK(b["fetch"].get<double>() == 3000.0);  // one ray per clock
  CHECK(b["cycles"].get<double>() == std::max({box, tri, dram, 3000.0, latency}));
  // Little's law: the slots' busy cycles less the waits for units and memory, over the slots.
  const double slot_busy = t["utilization"]["ray_slots"].get<double>() * cycles * 64.0;  // intel: 64 slots
  CHECK(latency ==
        Approx((slot_busy - t["unit_wait_cycles"].get<double>() - t["mem_wait_cycles"].get<double>()) / 64.0));
  const std::string lim = b["limited_by"];
  REQUIRE((lim == "box" || lim == "triangle" || lim == "dram" || lim == "fetch" || lim == "latency"));
  CHECK(b[lim].get<double>() == b["cycles"].get<double>());
  CHECK(b["cycles"].get<double>() <= cycles);
  CHECK(b["cycles_over_bound"].get<double>() == Approx(cycles / b["cycles"].get<double>()));
  CHECK(box == Approx(t["utilization"]["box_units"].get<double>() * cycles));
  // One batch of rays (trace gives them the ray type "other", bounce 0): its breakdowns are the total.
  REQUIRE(t["by_ray_type"].size() == 1);
  CHECK(t["by_ray_type"]["other"]["cycles"] == t["cycles"]);
  CHECK(t["by_bounce"].size() == 1);
  CHECK(t["by_bounce"]["0"]["box_tests"] == t["box_tests"]);
  CHECK(t["config"]["box_units"] == 2);  // intel's two box units of 6 tests
  CHECK(t["config"]["box_rate"] == 6);
  // `config --stats` lists every statistic of the timing object, each with its unit and meaning.
  const Run list = run_rtusim("config --stats");
  REQUIRE(list.status == 0);
  std::vector<std::string> leaves;
  for (const auto& [key, v] : t.items()) {
    if (key == "by_ray_type" || key == "by_bounce" || key == "config" || key == "sample") continue;
    if (!v.is_object()) leaves.push_back(key);
    for (const auto& [sub, x] : v.items())
      if (v.is_object()) leaves.push_back(key + "." + sub);
  }
  for (const std::string& leaf : leaves) {
    CAPTURE(leaf);
    CHECK(list.output.find("\n" + leaf + " ") != std::string::npos);
  }
  CHECK(leaves.size() >= 30);
  // The memory timeline: the DRAM bytes over time add up to the total.
  uint64_t timeline_bytes = 0;
  for (const auto& b : t["timeline"]["dram_bytes"]) timeline_bytes += b.get<uint64_t>();
  CHECK(timeline_bytes == t["dram_bytes"].get<uint64_t>());
  CHECK(t.count("units") == 0);  // one unit: no per-unit list
  // The pipeline trace: Chrome trace events, spans overlapping the window, every slot named.
  const PipelineFile p = read_pipeline(pipe, 100, 1100);
  CHECK(p.spans > 100);
  CHECK(p.units == std::set<uint64_t>{0});
  CHECK(p.slots.rbegin()->second < 64);  // intel: 64 ray slots
  CHECK(p.named_slots == p.slots);
  CHECK(p.counters > 0);  // the memory's bandwidth tracks
  // A window that is not FROM < TO is refused.
  CHECK(run_rtusim("trace --scene builtin:seed --rays " + rays + " --out " + (d / "t.hits").string() +
                   " --device timed --pipeline-trace " + pipe + " --trace-window 9:9")
            .status == 2);
}

TEST_CASE("trace on a chip: per-unit statistics, the memory timeline, a pipeline track group per unit",
          "[cli][timing][chip]") {
  const fs::path d = temp_dir("cli");
  const std::string rays = (d / "c.rays").string(), stats = (d / "c.json").string(),
                    pipe = (d / "c-pipe.json").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind primary --count 3000 --out " + rays).status == 0);
  const Run r = run_rtusim("trace --scene builtin:seed --rays " + rays + " --out " + (d / "c.hits").string() +
                           " --device timed --config embedded-chip --stats " + stats + " --pipeline-trace " +
                           pipe + " --trace-window 0:2000");
  INFO(r.output);
  REQUIRE(r.status == 0);
  const nlohmann::json j = read_json(stats);
  const auto& t = j["timing"];
  // embedded-chip: 4 units; waves of 16 rays (the embedded unit's slots) in turn: 3000 rays are 187.5 waves.
  REQUIRE(t["units"].size() == 4);
  uint64_t rays_sum = 0, box_sum = 0;
  for (const auto& u : t["units"]) {
    rays_sum += u["rays"].get<uint64_t>();
    box_sum += u["box_tests"].get<uint64_t>();
    CHECK(u["utilization"]["box_units"].get<double>() > 0.0);
    CHECK(u["utilization"]["box_units"].get<double>() <= 1.0);
    CHECK(u["cache"]["hit_rate"].get<double>() > 0.0);
  }
  CHECK(rays_sum == 3000);
  CHECK(box_sum == t["box_tests"].get<uint64_t>());
  CHECK(t["units"][0]["rays"] == 47 * 16);
  CHECK(t["units"][3]["rays"] == 46 * 16 + 8);
  // The timeline: DRAM bytes and L2 line accesses add up to the totals.
  uint64_t dram = 0, l2 = 0;
  for (const auto& b : t["timeline"]["dram_bytes"]) dram += b.get<uint64_t>();
  for (const auto& b : t["timeline"]["l2_bytes"]) l2 += b.get<uint64_t>();
  CHECK(dram == t["dram_bytes"].get<uint64_t>());
  CHECK(l2 == 64 * (t["l2"]["hits"].get<uint64_t>() + t["l2"]["misses"].get<uint64_t>()));
  // The pipeline trace: a process per unit, each named, each with its slots' tracks; the memory's counters.
  const PipelineFile p = read_pipeline(pipe, 0, 2000);
  CHECK(p.units == std::set<uint64_t>{0, 1, 2, 3});
  CHECK(p.named_units.size() == 5);  // four units and the memory
  CHECK(p.named_slots == p.slots);
  CHECK(p.counters > 0);
}

TEST_CASE("trace --sample: --sample-seed draws the sample, the same seed, the same estimate", "[cli][timing]") {
  const fs::path d = temp_dir("cli");
  const std::string rays = (d / "s.rays").string(), stats = (d / "s.json").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind incoherent --count 20000 --out " + rays).status == 0);
  // Units of 16 rays with 16 warm-up rays: 1,250 units, every 20th measured (F = 0.05), cycles only.
  auto estimate = [&](int seed) {
    const Run r =
        run_rtusim("trace --scene builtin:seed --rays " + rays + " --device timed --sample 0.05 --sample-unit 16" +
                   " --sample-warmup 16 --sample-seed " + std::to_string(seed) + " --stats " + stats);
    INFO(r.output);
    REQUIRE(r.status == 0);
    const nlohmann::json j = read_json(stats);
    REQUIRE(j["timing"]["sample"]["units_measured"].get<uint64_t>() > 50);
    return j["timing"]["cycles"].get<uint64_t>();
  };
  const uint64_t a = estimate(1), b = estimate(1), c = estimate(2), e = estimate(3);
  CHECK(a == b);
  CHECK((c != a || e != a));  // other offsets, other units measured
  const Run bad =
      run_rtusim("trace --scene builtin:seed --rays " + rays + " --device timed --sample 0.05 --sample-seed x");
  CHECK(bad.status != 0);
  CHECK(bad.status < 128);
  CHECK(bad.output.find("--sample-seed") != std::string::npos);
}

TEST_CASE("render --mode hybrid on the timed device: raster and trace cycles, rays saved, both modes",
          "[cli][hybrid]") {
  const fs::path d = temp_dir("cli");
  const std::string stats = (d / "hy.json").string();
  const Run r = run_rtusim(
      "render --scene builtin:seed --width 80 --height 60 --device timed --mode hybrid --max-depth 2 "
      "--compare-modes --threads 2 --out " +
      (d / "hy.png").string() + " --stats " + stats);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("rasterizer:") != std::string::npos);
  CHECK(r.output.find("(4800 primary rays saved)") != std::string::npos);
  const nlohmann::json j = read_json(stats);
  CHECK(j["render_mode"] == "hybrid");
  CHECK(j["rays"]["primary"] == 0);
  CHECK(j["rays_saved"]["primary"] == 80 * 60);
  CHECK(j["raster"]["fragments"].get<uint64_t>() > 0);
  CHECK(j["skipped"]["primary"] == "rasterized (hybrid mode)");
  const auto& t = j["timing"];
  CHECK(t["raster_cycles"].get<uint64_t>() > 0);
  CHECK(t["raster"]["limit"].is_string());
  CHECK(t["frame_cycles"].get<uint64_t>() ==
        t["raster_cycles"].get<uint64_t>() + t["trace_cycles"].get<uint64_t>());
  CHECK(t["config"]["raster_setup_cycles"].is_number());
  // Both modes: the raytrace render traced the primary rays hybrid saved, and its frame has no raster cycles.
  const auto& m = j["modes"];
  CHECK(m["raytrace"]["primary_rays"] == 80 * 60);
  CHECK(m["hybrid"]["primary_rays"] == 0);
  CHECK(m["rays_saved"] == 80 * 60);
  CHECK(m["raytrace"]["raster_cycles"] == 0);
  CHECK(m["raytrace"]["frame_cycles"] == m["raytrace"]["trace_cycles"]);
  CHECK(m["hybrid"]["frame_cycles"] == t["frame_cycles"]);
  CHECK((m["psnr_db"].is_null() || m["psnr_db"].get<double>() >= 30.0));
  // raytrace is the default; an unknown mode is refused.
  const Run rt = run_rtusim("render --scene builtin:cornell --width 16 --height 16 --out " +
                            (d / "rt.png").string() + " --stats " + (d / "rt.json").string());
  REQUIRE(rt.status == 0);
  CHECK(read_json(d / "rt.json")["render_mode"] == "raytrace");
  CHECK(run_rtusim("render --scene builtin:cornell --mode raster --out " + (d / "x.png").string()).status != 0);
}

namespace {

// Every src="..." of an HTML page.
std::vector<std::string> html_sources(const std::string& html) {
  std::vector<std::string> srcs;
  for (size_t p = html.find("src=\""); p != std::string::npos; p = html.find("src=\"", p)) {
    p += 5;
    const size_t e = html.find('"', p);
    if (e == std::string::npos) break;
    srcs.push_back(html.substr(p, e - p));
    p = e;
  }
  return srcs;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

TEST_CASE("report --quick: a static page, its images, consistent figures", "[cli][report]") {
  const fs::path d = temp_dir("cli") / "report";
  fs::remove_all(d);
  const Run r = run_rtusim("report --quick --threads 2 --out " + d.string());
  INFO(r.output);
  REQUIRE(r.status == 0);
  for (const char* f :
       {"index.html", "report.json", "render_float.png", "render_fixed.png", "render_heatmap.png", "sweep.csv"})
    CHECK(fs::exists(d / f));
  const std::string html = slurp(d / "index.html");
  CHECK(html.rfind("<!DOCTYPE html>", 0) == 0);
  CHECK(html.find("</html>") != std::string::npos);
  CHECK(html.find("<script") == std::string::npos);  // no JavaScript needed
  CHECK(html.find("href=\"report.json\"") != std::string::npos);
  const nlohmann::json j = read_json(d / "report.json");
  // The page embeds exactly the images report.json lists; each is a relative path to a readable PNG.
  const std::vector<std::string> srcs = html_sources(html);
  std::vector<std::string> listed = j.at("images").get<std::vector<std::string>>();
  CHECK(srcs == listed);
  for (const std::string& s : srcs) {
    INFO(s);
    CHECK(s.find('/') == std::string::npos);
    const rtu::host::Image img = rtu::host::read_png((d / s).string());
    CHECK(img.width > 0);
  }
  for (const char* f : {"render_float.png", "render_fixed.png", "render_heatmap.png"})
    CHECK(std::count(srcs.begin(), srcs.end(), f) == 1);
  // Renders: PSNR finite (>= the 32 dB the render tests hold) or null (identical); cycles per frame > 0.
  const auto& rj = j.at("renders");
  CHECK(rj.at("scene") == "builtin:seed");
  if (!rj.at("psnr_db").is_null()) {
    CHECK(std::isfinite(rj.at("psnr_db").get<double>()));
    CHECK(rj.at("psnr_db").get<double>() >= 32.0);
  } else {
    CHECK(rj.at("pixels_differing") == 0);
  }
  CHECK(rj.at("fixed").at("cycles_per_frame").get<uint64_t>() > 0);
  CHECK(rj.at("fixed").at("rays").get<uint64_t>() >=
        uint64_t(rj.at("width").get<int>() * rj.at("height").get<int>()));
  // Cycles: one row per preset and scene, cycles > 0, cycles/ray = cycles / rays.
  const auto& cyc = j.at("cycles");
  REQUIRE(cyc.size() == rtu::hw::timing_preset_names().size() * 2);
  for (const auto& c : cyc) {
    INFO(c.dump());
    CHECK(c.at("cycles").get<uint64_t>() > 0);
    CHECK(c.at("cycles_per_ray").get<double>() ==
          Approx(double(c.at("cycles").get<uint64_t>()) / double(c.at("rays").get<uint64_t>())));
    CHECK(c.at("cycles_over_bound").get<double>() >= 1.0);
    std::string cell = ">";
    cell += std::to_string(c.at("cycles").get<uint64_t>());
    cell += "<";
    CHECK(html.find(cell) != std::string::npos);
  }
  // The sweep run here: 5 formats x 1 width x 1 preset on each of the two scenes; plots when gnuplot exists.
  const auto& sw = j.at("sweep");
  CHECK(sw.at("points") == 10);
  std::ifstream csv(d / "sweep.csv");
  size_t lines = 0;
  for (std::string l; std::getline(csv, l);) ++lines;
  CHECK(lines == 11);
  if (!sw.at("gnuplot").is_null()) {
    CHECK(sw.at("message") == "ok");
    REQUIRE(sw.at("plots").size() == 4);  // 2 scenes x 2 error measures
    for (const auto& p : sw.at("plots")) {
      CHECK(std::count(srcs.begin(), srcs.end(), p.at("image").get<std::string>()) == 1);
      CHECK(p.at("points") == 5);
      CHECK(!p.at("front").at("cycles").empty());
      CHECK(p.at("front").at("cycles").size() <= 5);
    }
  } else {
    CHECK(html.find("gnuplot was not found") != std::string::npos);
  }
  // Stress: every category, no failures at the default format.
  CHECK(j.at("stress").at("failures") == 0);
  CHECK(j.at("stress").at("categories").size() >= 10);
  CHECK(j.at("seconds").get<double>() > 0.0);

  // Without gnuplot the page says so instead of failing; `pareto` exits 2.
  {
    const fs::path d2 = temp_dir("cli") / "report_nognuplot";
    fs::remove_all(d2);
    // rtusim by its absolute path needs no PATH; gnuplot is not found on it.
    const Run r2 = run_rtusim("PATH=/nonexistent", "report --quick --threads 2 --scene builtin:cornell --sweep " +
                                                       (d / "sweep.csv").string() + " --out " + d2.string());
    INFO(r2.output);
    CHECK(r2.status == 0);
    const std::string h2 = slurp(d2 / "index.html");
    CHECK(h2.find("gnuplot was not found") != std::string::npos);
    const nlohmann::json j2 = read_json(d2 / "report.json");
    CHECK(j2.at("sweep").at("gnuplot").is_null());
    CHECK(j2.at("sweep").at("plots").empty());
    CHECK(j2.at("sweep").at("points") == 10);  // the given sweep's rows
    for (const std::string& s : html_sources(h2)) CHECK(fs::exists(d2 / s));
    // The message goes to stderr: the command sends stderr to a file.
    const Run p2 = run_rtusim("PATH=/nonexistent", "pareto --sweep " + (d / "sweep.csv").string() + " --out " +
                                                       (d2 / "p").string() + " 2>" + (d2 / "err.txt").string());
    CHECK(p2.exited);
    CHECK(p2.status == 2);
    CHECK(slurp(d2 / "err.txt").find("gnuplot not found") != std::string::npos);
  }
}

TEST_CASE("report and pareto: bad input gives a clear error and exit 2", "[cli][report]") {
  const fs::path d = temp_dir("cli") / "report_bad";
  fs::remove_all(d);
  fs::create_directories(d);
  {
    std::ofstream(d / "file.txt") << "x\n";
    std::ofstream(d / "foreign.csv") << "a,b,c\n1,2,3\n";
    std::ofstream(d / "short.csv") << rtu::host::sweep_csv_header() << "\nbuiltin:seed,default,4\n";
    std::ofstream(d / "nan.csv") << rtu::host::sweep_csv_header()
                                 << "\nbuiltin:seed,default,4,rdna2,10,1,48,0,x,1,0,0,0,0,0,0,0,inf,5,0.5,64,100,"
                                    "100,2.5,-1,-1,0.5,900,0.1\n";
    std::ofstream(d / "empty_rows.csv") << rtu::host::sweep_csv_header() << "\n";
  }
  const std::string out = " --out " + (d / "o").string();
  for (const auto& [args, words] : std::vector<std::pair<std::string, std::string>>{
           {"report --quick --out " + (d / "file.txt" / "sub").string(), "cannot create the directory"},
           {"report --quick --sweep " + (d / "foreign.csv").string() + out, "not a sweep file"},
           {"report --quick --sweep " + (d / "short.csv").string() + out, "fields, expected"},
           {"report --quick --sweep " + (d / "nan.csv").string() + out, "not a number"},
           {"report --quick --sweep " + (d / "empty_rows.csv").string() + out, "no rows"},
           {"report --quick --sweep " + (d / "missing.csv").string() + out, "cannot read"},
           {"report --quick --scene nosuch.obj" + out, "nosuch.obj"},
           {"report --quick --area " + (d / "foreign.csv").string() + out, "params,cells"},
           {"pareto --sweep " + (d / "foreign.csv").string() + out, "not a sweep file"},
           {"pareto --sweep " + (d / "missing.csv").string() + out, "cannot read"}}) {
    const auto t0 = std::chrono::steady_clock::now();
    const Run r = run_rtusim(args);
    INFO(args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(words) != std::string::npos);
    CHECK(r.output.find("rtusim: error:") != std::string::npos);
    // Rejected before any long step.
    CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 5.0);
  }
}

TEST_CASE("usage errors exit 2 with CLI11's message, --help and --version exit 0", "[cli]") {
  const fs::path d = temp_dir("cli");
  struct Case {
    std::string args, words;
  };
  const Case cases[] = {
      {"info --scene builtin:seed --frobnicate", "--frobnicate"},  // an unknown option
      {"stress --count 0", "--count"},                             // a value out of range
      {"info --scene builtin:seed --bvh-width x", "--bvh-width"},  // a value that does not parse
      {"rays --scene builtin:seed", "--out"},                      // a required option missing
      {"frobnicate", "subcommand"},                                // an unknown subcommand
      {"", "subcommand"},                                          // none
  };
  for (const Case& c : cases) {
    const Run r = run_rtusim(c.args);
    INFO(c.args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(c.words) != std::string::npos);
    CHECK(r.output.find("--help") != std::string::npos);  // "Run with --help for more information."
  }
  CHECK(run_rtusim("--version").status == 0);
  CHECK(run_rtusim("trace --help").status == 0);
}

TEST_CASE("device options: a command lists only those it uses, and refuses those the device ignores", "[cli]") {
  const fs::path d = temp_dir("cli");
  const std::string rays = (d / "dev_opts.rays").string(), hits = (d / "dev_opts.hits").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --count 500 --out " + rays).status == 0);
  auto help = [](const std::string& sub) {
    const Run r = run_rtusim(sub + " --help");
    REQUIRE(r.status == 0);
    return r.output;
  };
  // An option is listed when a line of the help starts with it (descriptions may name other options).
  auto lists = [](const std::string& text, const std::string& option) {
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      const size_t at = line.find_first_not_of(' ');
      if (at == std::string::npos || line.compare(at, option.size(), option) != 0) continue;
      const size_t end = at + option.size();
      if (end == line.size() || line[end] == ' ' || line[end] == ',') return true;
    }
    return false;
  };
  // info and stress never run the timed device; stress builds no BVH of its own options either.
  for (const char* sub : {"info", "stress"}) {
    const std::string h = help(sub);
    INFO(h);
    for (const char* option : {"--config", "--set", "--sample", "--sample-unit", "--sample-warmup",
                               "--sample-seed", "--watchdog-steps", "--device"})
      CHECK_FALSE(lists(h, option));
    CHECK(lists(h, "--format"));
    CHECK(lists(h, "--coord-bits"));
    CHECK(lists(h, "--bvh-width"));
  }
  CHECK(lists(help("info"), "--leaf-size"));
  CHECK_FALSE(lists(help("stress"), "--leaf-size"));
  CHECK_FALSE(lists(help("stress"), "--accel"));
  // compare reports no cycles: the timing configuration (the timed device's format) but no sampling.
  const std::string ch = help("compare");
  CHECK(lists(ch, "--config"));
  CHECK(lists(ch, "--watchdog-steps"));
  CHECK_FALSE(lists(ch, "--sample"));
  for (const char* sub : {"trace", "render"})
    for (const char* option : {"--config", "--set", "--sample", "--sample-seed", "--watchdog-steps"})
      CHECK(lists(help(sub), option));
  CHECK(run_rtusim("info --scene builtin:seed --sample 0.1").status == 2);

  // Given for a device that does not use them: a usage error naming the option and the device it applies to.
  const std::string trace = "trace --scene builtin:seed --rays " + rays + " --out " + hits + " ";
  struct Case {
    std::string args, words;
  };
  const Case cases[] = {
      {trace + "--device float --sample 0.1", "--sample applies to --device timed only"},
      {trace + "--device fixed --sample-seed 3", "--sample-seed applies to --device timed only"},
      {trace + "--device fixed --config intel", "--config applies to --device timed only"},
      {trace + "--device fixed --set cache_kib=64", "--set applies to --device timed only"},
      {trace + "--device fixed --pipeline-trace " + (d / "p.json").string(), "--pipeline-trace applies"},
      {trace + "--device float --watchdog-steps 10", "--watchdog-steps applies to --device fixed or timed only"},
      {trace + "--device float --coord-bits 16", "--coord-bits applies to --device fixed or timed only"},
      {"compare --scene builtin:seed --rays primary:100 --device fixed --config intel", "--config applies"},
      {"render --scene builtin:seed --width 8 --height 8 --out " + (d / "x.png").string() +
           " --device float --sample 0.5",
       "--sample applies"},
  };
  for (const Case& c : cases) {
    const Run r = run_rtusim(c.args);
    INFO(c.args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(c.words) != std::string::npos);
  }
  // The same options where the device uses them, and defaults given on no device, are fine.
  CHECK(run_rtusim(trace + "--device timed --config intel --sample 0.5 --sample-seed 3").status == 0);
  CHECK(run_rtusim(trace + "--device fixed --watchdog-steps 100000 --coord-bits 16").status == 0);
  CHECK(run_rtusim(trace + "--device float --bvh-width 8").status == 0);
  CHECK(run_rtusim(trace + "--device fixed --bvh-width 6").status == 0);
}

TEST_CASE("rays: --count 0 refused, options of the other kind refused", "[cli]") {
  const fs::path d = temp_dir("cli");
  const std::string out = (d / "r.rays").string();
  fs::remove(out);
  const Run zero = run_rtusim("rays --scene builtin:seed --count 0 --out " + out);
  INFO(zero.output);
  CHECK(zero.status == 2);
  CHECK(zero.output.find("--count") != std::string::npos);
  CHECK_FALSE(fs::exists(out));  // not the whole image
  for (const auto& [args, words] : std::vector<std::pair<std::string, std::string>>{
           {"--kind incoherent --count 10 --width 4", "--width applies to --kind primary only"},
           {"--kind incoherent --count 10 --height 4", "--height applies to --kind primary only"},
           {"--kind primary --seed 7", "--seed applies to --kind incoherent only"}}) {
    const Run r = run_rtusim("rays --scene builtin:seed " + args + " --out " + out);
    INFO(args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(words) != std::string::npos);
  }
  const Run one = run_rtusim("rays --scene builtin:seed --count 1 --out " + out);
  CHECK(one.status == 0);
  CHECK(rtu::host::read_rays(out).size() == 1);
}

TEST_CASE("compare --rays: incoherent without a count, and a spec that is neither a kind nor a file", "[cli]") {
  const fs::path d = temp_dir("cli");
  const std::string json = (d / "c_inc.json").string();
  const Run r = run_rtusim("compare --scene builtin:cornell --rays incoherent --json " + json);
  INFO(r.output);
  REQUIRE(r.status == 0);
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

TEST_CASE("config --config as everywhere else (--preset still works), timing presets listed and checked",
          "[cli][timing][config]") {
  const Run a = run_rtusim("config --config intel"), b = run_rtusim("config --preset intel");
  REQUIRE(a.status == 0);
  REQUIRE(b.status == 0);
  CHECK(a.output == b.output);
  CHECK(a.output.find("preset intel") != std::string::npos);
  const Run h = run_rtusim("config --help");
  CHECK(h.output.find("--config") != std::string::npos);
  CHECK(h.output.find("--preset") == std::string::npos);  // the old name, not listed
  for (const char* args :
       {"config --preset intel --config rdna2", "config --preset intel --list", "config --stats --json x.json",
        "config --stats --config intel", "config --list --set ray_slots=4"}) {
    const Run r = run_rtusim(args);
    INFO(args << "\n" << r.output);
    CHECK(r.status == 2);
  }
  // sweep and plan list the presets and refuse others, as the device options do.
  for (const char* sub : {"sweep", "plan"}) {
    const Run r = run_rtusim(std::string(sub) + " --help");
    INFO(r.output);
    CHECK(r.output.find("rdna2,intel,embedded") != std::string::npos);
  }
  const Run p = run_rtusim("plan --scene builtin:cornell --max-error 1e-3 --config amd");
  CHECK(p.status == 2);
  CHECK(p.output.find("amd not in") != std::string::npos);
  const Run s = run_rtusim("sweep --scene builtin:cornell --config rdna2,amd --out " +
                           (temp_dir("cli") / "presets.csv").string());
  CHECK(s.status == 2);
  CHECK(s.output.find("amd not in") != std::string::npos);
}

TEST_CASE("options that would be ignored are refused: diff, info, report, sweep --merge, render", "[cli]") {
  const fs::path d = temp_dir("cli");
  const std::string png = (d / "ign.png").string();
  REQUIRE(run_rtusim("render --scene builtin:cornell --width 8 --height 8 --out " + png).status == 0);
  for (const auto& [args, words] : std::vector<std::pair<std::string, std::string>>{
           {"diff " + png + " " + png + " --scale 4", "--heatmap"},
           {"info --formats --json " + (d / "f.json").string(), "--scene"},
           {"report --sweep " + (d / "s.csv").string() + " --area " + (d / "a.csv").string() + " --out " +
                (d / "rep").string(),
            "--area"},
           {"sweep --merge " + png + " --rays 64 --out " + (d / "m.csv").string(), "--rays"},
           {"render --scene builtin:cornell --ao-distance 2 --out " + png, "--ao"},
           {"render --scene builtin:cornell --ao --no-indirect --out " + png, "--no-indirect"}}) {
    const Run r = run_rtusim(args);
    INFO(args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(words) != std::string::npos);
  }
}

TEST_CASE("render: a progress line on a terminal, none otherwise", "[cli]") {
  if (rtu::test::run_process("command -v script").status != 0) {
    WARN("no `script` (util-linux) to give rtusim a terminal: the terminal half is not checked");
    return;
  }
  const fs::path d = temp_dir("cli");
  const std::string args =
      "render --scene builtin:cornell --width 32 --height 32 --spp 2 --out " + (d / "prog.png").string();
  // script(1) runs the command on a pseudo-terminal: stderr is a terminal there.
  const Run tty = rtu::test::run_process("script -qec '" + std::string(RTUSIM_EXE) + " " + args + "' /dev/null");
  INFO(tty.output);
  REQUIRE(tty.status == 0);
  CHECK(tty.output.find("render: ") != std::string::npos);
  CHECK(tty.output.find("(batch 1/1, bounce 0)") != std::string::npos);
  CHECK(tty.output.find("\033[K") != std::string::npos);  // cleared before the summary
  const Run pipe = run_rtusim(args);
  INFO(pipe.output);
  REQUIRE(pipe.status == 0);
  CHECK(pipe.output.find("batch 1/") == std::string::npos);
  CHECK(pipe.output.find('\r') == std::string::npos);
}

TEST_CASE("sweep: resume reruns points made with other --rays, --seed or --image-width, merge refuses a mix",
          "[cli][sweep]") {
  const fs::path d = temp_dir("cli");
  const std::string f = (d / "params.csv").string(), g = (d / "params_g.csv").string(),
                    m = (d / "params_m.csv").string();
  for (const std::string& x : {f, g, m}) fs::remove(x);
  const std::string grid = "sweep --scene builtin:cornell --formats default,compact ";
  Run r = run_rtusim(grid + "--rays 64 --image-width 0 --out " + f);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("2 run, 0 already") != std::string::npos);
  r = run_rtusim(grid + "--rays 64 --image-width 0 --out " + f);  // the same parameters: nothing to do
  CHECK(r.output.find("0 run, 2 already") != std::string::npos);
  r = run_rtusim(grid + "--rays 128 --image-width 0 --out " + f);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("2 run, 0 already") != std::string::npos);
  CHECK(r.output.find("other run parameters") != std::string::npos);
  r = run_rtusim(grid + "--rays 128 --seed 2 --image-width 0 --out " + f);
  CHECK(r.output.find("2 run, 0 already") != std::string::npos);
  r = run_rtusim(grid + "--rays 128 --seed 2 --image-width 8 --out " + f);
  CHECK(r.output.find("2 run, 0 already") != std::string::npos);
  const std::vector<rtu::host::SweepRow> rows = rtu::host::read_sweep_csv(f);
  REQUIRE(rows.size() == 8);
  CHECK(rows[0].rays == 128);  // 64 camera + 64 incoherent rays
  CHECK(rows[2].rays == 256);
  CHECK(rows[4].seed == 2);
  CHECK(rows[6].image_width == 8);
  CHECK(rtu::host::sweep_run_params(rows[6]) == "--rays 128 --seed 2 --image-width 8");

  REQUIRE(run_rtusim(grid + "--rays 128 --image-width 0 --out " + g).status == 0);
  const Run mixed = run_rtusim("sweep --merge " + f + " --out " + m);
  CHECK(mixed.status == 2);
  CHECK(mixed.output.find("only rows made with the same run parameters merge") != std::string::npos);
  REQUIRE(run_rtusim(grid + "--rays 64 --image-width 0 --out " + m).status == 0);
  const Run two = run_rtusim("sweep --merge " + g + " " + m + " --out " + (d / "params_mm.csv").string());
  INFO(two.output);
  CHECK(two.status == 2);
  CHECK(two.output.find("--rays 128 --seed 1 --image-width 0") != std::string::npos);
  CHECK(two.output.find("--rays 64 --seed 1 --image-width 0") != std::string::npos);
}

TEST_CASE(
    "sweep: a PSNR not measured is an empty cell, merge warns of conflicting duplicates, CRLF and a BOM read",
    "[cli][sweep]") {
  const fs::path d = temp_dir("cli") / "sweep_cells";
  fs::remove_all(d);
  fs::create_directories(d);
  const std::string a = (d / "a.csv").string(), b = (d / "b.csv").string();
  const Run r =
      run_rtusim("sweep --scene builtin:cornell --formats default,compact --rays 64 --image-width 0 --out " + a);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("no render") != std::string::npos);
  std::vector<std::string> lines;
  {
    std::ifstream in(a);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
  }
  REQUIRE(lines.size() == 3);
  // psnr_db (the 18th column) is empty, not 0: no render measured it.
  for (size_t i = 1; i < lines.size(); ++i) {
    std::vector<std::string> f;
    std::stringstream ss(lines[i]);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    REQUIRE(f.size() == 29);
    CHECK(f[17].empty());
    CHECK(lines[i].find("nan") == std::string::npos);
  }
  const std::vector<rtu::host::SweepRow> rows = rtu::host::read_sweep_csv(a);
  REQUIRE(rows.size() == 2);
  CHECK_FALSE(rows[0].psnr_measured());

  // The same rows with CRLF line ends and a UTF-8 byte order mark (as a spreadsheet saves them) read the same.
  const std::string crlf = (d / "crlf.csv").string();
  {
    std::ofstream f(crlf, std::ios::binary);
    f << "\xEF\xBB\xBF";
    for (const std::string& l : lines) f << l << "\r\n";
  }
  const std::vector<rtu::host::SweepRow> again = rtu::host::read_sweep_csv(crlf);
  REQUIRE(again.size() == 2);
  CHECK(again[1].p.key() == rows[1].p.key());
  CHECK(rtu::host::same_sweep_results(again[1], rows[1]));

  // Identical duplicates merge silently; a duplicate point with other results is kept out with a warning that
  // names the point and the column.
  const std::string m1 = (d / "m1.csv").string();
  Run mr = run_rtusim("sweep --merge " + a + " " + crlf + " --out " + m1);
  INFO(mr.output);
  REQUIRE(mr.status == 0);
  CHECK(mr.output.find("warning") == std::string::npos);
  CHECK(mr.output.find("2 duplicates dropped, 0 of them with other results") != std::string::npos);
  CHECK(rtu::host::read_sweep_csv(m1).size() == 2);
  {
    std::ofstream f(b);
    f << lines[0] << '\n';
    rtu::host::SweepRow row = rows[1];  // compact, its cycles changed
    row.cycles += 1;
    f << rtu::host::sweep_csv_line(row) << '\n';
  }
  mr = run_rtusim("sweep --merge " + a + " " + b + " --out " + (d / "m2.csv").string());
  INFO(mr.output);
  REQUIRE(mr.status == 0);
  CHECK(mr.output.find("warning: --merge: point " + rows[1].p.key()) != std::string::npos);
  // The kept row's value first.
  CHECK(mr.output.find("(cycles " + std::to_string(rows[1].cycles) + " against " +
                       std::to_string(rows[1].cycles + 1) + ")") != std::string::npos);
  CHECK(mr.output.find("1 of them with other results") != std::string::npos);
  const std::vector<rtu::host::SweepRow> kept = rtu::host::read_sweep_csv((d / "m2.csv").string());
  REQUIRE(kept.size() == 2);
  CHECK(kept[1].cycles == rows[1].cycles);  // the first file's row

  // A file of the version before the flatten column reads as two-level rows, and a resumed sweep rewrites it in
  // this version before it appends.
  const std::string old = (d / "old.csv").string();
  {
    std::string header = lines[0];
    header.replace(header.find(",flatten"), 8, "");
    std::string row = lines[1];
    size_t comma = 0;
    for (int i = 0; i < 7; ++i) comma = row.find(',', comma) + 1;  // after image_width
    row.erase(comma, 2);                                           // "0,"
    std::ofstream f(old);
    f << header << '\n' << row << '\n';
  }
  const std::vector<rtu::host::SweepRow> old_rows = rtu::host::read_sweep_csv(old);
  REQUIRE(old_rows.size() == 1);
  CHECK_FALSE(old_rows[0].flatten);
  CHECK(rtu::host::same_sweep_results(old_rows[0], rows[0]));
  const Run resumed =
      run_rtusim("sweep --scene builtin:cornell --formats default,compact --rays 64 --image-width 0 --out " + old);
  INFO(resumed.output);
  REQUIRE(resumed.status == 0);
  CHECK(resumed.output.find("1 run, 1 already") != std::string::npos);
  CHECK(rtu::host::read_sweep_csv(old).size() == 2);
}

TEST_CASE("sweep, plan and report --flatten: one image for an instanced scene, recorded in the CSV and JSON",
          "[cli][sweep]") {
  const fs::path d = temp_dir("cli") / "flatten";
  fs::remove_all(d);
  fs::create_directories(d);
  const std::string csv = (d / "city.csv").string();
  const std::string grid =
      "sweep --scene " RTU_SOURCE_DIR "/scenes/instances.json --rays 64 --image-width 0 --threads 2 --out " + csv;
  REQUIRE(run_rtusim(grid).status == 0);
  const Run r = run_rtusim(grid + " --flatten");
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("flattened") != std::string::npos);
  CHECK(r.output.find("1 run, 0 already") != std::string::npos);  // another run parameter: not resumed
  const std::vector<rtu::host::SweepRow> rows = rtu::host::read_sweep_csv(csv);
  REQUIRE(rows.size() == 2);
  CHECK_FALSE(rows[0].flatten);
  CHECK(rows[1].flatten);
  CHECK(rtu::host::sweep_run_params(rows[1]) == "--rays 64 --seed 1 --image-width 0 --flatten");
  // The example places three meshes 40 times: flattened, the image (9.4x: 882 against 94 kB) and the DRAM
  // traffic are larger. (builtin:city, 51x, takes minutes here under ASan.)
  CHECK(rows[1].bvh_bytes > 5 * rows[0].bvh_bytes);
  CHECK(rows[1].dram_bytes_per_ray != rows[0].dram_bytes_per_ray);
  // --merge refuses the mix (other run parameters).
  CHECK(run_rtusim("sweep --merge " + csv + " --out " + (d / "m.csv").string()).status == 2);
  CHECK(run_rtusim("sweep --merge " + csv + " --flatten --out " + (d / "m.csv").string()).status != 0);

  const std::string plan = "plan --scene " RTU_SOURCE_DIR
                           "/scenes/instances.json --max-error 0.05 --bvh-width 4 --coord-bits 16 "
                           "--child-bits 8 --rays 64 --image-width 0 --threads 2 --json ";
  const std::string one = (d / "one.json").string(), two = (d / "two.json").string();
  const Run p1 = run_rtusim(plan + one + " --flatten");
  INFO(p1.output);
  REQUIRE(p1.status == 0);
  CHECK(p1.output.find("instanced scene flattened") != std::string::npos);
  REQUIRE(run_rtusim(plan + two).status == 0);
  const nlohmann::json j1 = read_json(one), j2 = read_json(two);
  CHECK(j1["flatten"] == true);
  CHECK(j2["flatten"] == false);
  CHECK(j1["plan"]["bytes"].get<uint64_t>() > 5 * j2["plan"]["bytes"].get<uint64_t>());
  CHECK(j1["plan"]["psnr_db"].is_null());  // no render: not measured

  // The report: its cycles table and the sweep it runs trace the example flattened, and report.json says so.
  const fs::path r1 = d / "report1", r2 = d / "report2";
  REQUIRE(run_rtusim("report --quick --threads 2 --scene " RTU_SOURCE_DIR "/scenes/instances.json --out " +
                     r1.string())
              .status == 0);
  const Run rf =
      run_rtusim("report --quick --threads 2 --flatten --scene " RTU_SOURCE_DIR "/scenes/instances.json --out " +
                 r2.string());
  INFO(rf.output);
  REQUIRE(rf.status == 0);
  const nlohmann::json k1 = read_json(r1 / "report.json"), k2 = read_json(r2 / "report.json");
  CHECK(k1["flatten"] == false);
  CHECK(k2["flatten"] == true);
  REQUIRE(k1["cycles"].size() == k2["cycles"].size());
  CHECK(k1["cycles"][0]["cycles"] != k2["cycles"][0]["cycles"]);
  const auto s1 = rtu::host::read_sweep_csv((r1 / "sweep.csv").string());
  const auto s2 = rtu::host::read_sweep_csv((r2 / "sweep.csv").string());
  REQUIRE(!s1.empty());
  REQUIRE(s1.size() == s2.size());
  CHECK_FALSE(s1[0].flatten);
  CHECK(s2[0].flatten);
  CHECK(s2[0].bvh_bytes > 5 * s1[0].bvh_bytes);
}

TEST_CASE("plan: budgets no sample can show and NaN options are refused up front, naming the option",
          "[cli][sweep]") {
  for (const char* m : {"0", "1e-20", "4.9e-324", "1e-12"}) {
    const Run r = run_rtusim(std::string("plan --scene builtin:cornell --max-error ") + m);
    INFO(r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find("below the smallest hit disagreement a plan can show") != std::string::npos);
  }
  // Reachable with more rays: the message names how many.
  const Run more = run_rtusim("plan --scene builtin:cornell --max-error 1e-6");
  CHECK(more.status == 2);
  CHECK(more.output.find("use --rays 1497866 or more") != std::string::npos);
  for (const char* opt : {"--max-error", "--min-psnr", "--confidence", "--area-budget"}) {
    const std::string args = std::string("plan --scene builtin:cornell ") +
                             (std::string(opt) == "--max-error" ? "" : "--max-error 0.01 ") + opt + " nan";
    const Run r = run_rtusim(args);
    INFO(args << ": " << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(std::string(opt) + ": 'nan' is not a finite number") != std::string::npos);
  }
}
