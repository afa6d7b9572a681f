// rtusim end to end: rays, trace and info on the float and fixed devices.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "host/io/ray_io.h"
#include "tests/host/cli_checks.h"

namespace fs = std::filesystem;
using namespace rtu::test;

TEST_CASE("rays -> trace round trip on a built-in scene, CSV and binary give the same hits", "[cli]") {
  const fs::path d = temp_dir("cli");
  const std::string rays = (d / "p.rays").string(), rays_csv = (d / "p.csv").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind primary --count 20000 --out " + rays).status == 0);
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind primary --count 20000 --out " + rays_csv).status == 0);
  const std::string stats = (d / "s.json").string();
  REQUIRE_RTUSIM_OK(t, "trace --scene builtin:seed --rays " + rays + " --out " + (d / "h.bin").string() +
                           " --stats " + stats + " --bvh-width 8");
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

TEST_CASE("trace on the fixed device: formats, out-of-frame origins rejected with their reason", "[cli][fixed]") {
  const fs::path d = temp_dir("cli");
  std::ofstream(d / "far.csv") << "ox,oy,oz,tmin,dx,dy,dz,tmax\n0,1,8,0,0,-0.3,-1,inf\n1e12,0,0,0,-1,0,0,inf\n";
  const std::string stats = (d / "s.json").string();
  REQUIRE_RTUSIM_OK(r, "trace --device fixed --format compact --scene builtin:seed --rays " +
                           (d / "far.csv").string() + " --out " + (d / "h.csv").string() + " --stats " + stats);
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
  for (const char* p :
       {"default", "wide6", "wide8", "binary", "compact", "precise", "cwbvh", "packed", "xe6", "rdna4"})
    CHECK(list.output.find(p) != std::string::npos);
  for (const auto& [format, node_bytes] :
       {std::pair{"default", 56}, std::pair{"wide6", 76}, std::pair{"wide8", 96}, std::pair{"binary", 36},
        std::pair{"precise", 80}, std::pair{"cwbvh", 80}, std::pair{"xe6", 64}, std::pair{"rdna4", 128}}) {
    const std::string json = (d / (std::string(format) + ".json")).string();
    REQUIRE_RTUSIM_OK(r, std::string("info --scene builtin:seed --format ") + format + " --json " + json);
    const nlohmann::json j = read_json(json);
    CHECK(j["bvh"]["image"]["bytes_per_node"] == node_bytes);
    CHECK(j["bvh"]["image"]["total_bytes"].get<uint64_t>() > j["bvh"]["image"]["node_bytes"].get<uint64_t>());
  }
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

TEST_CASE("trace prices the run's format: its bits and node kind, as sweep prices the same point",
          "[cli][energy]") {
  // One design point, one price: the area in trace's stats is the format the image was encoded with (a
  // --coord-bits override, a --node-kind), not the preset's, and equals sweep's area for the same point.
  const fs::path d = temp_dir("cli_price");
  auto area = [&](const std::string& opts) {
    const std::string json = (d / "t.json").string();
    const Run r =
        run_rtusim("trace --scene builtin:seed --rays primary:16x16 --device timed " + opts + " --stats " + json);
    INFO(r.output);
    REQUIRE(r.status == 0);
    const nlohmann::json j = read_json(json)["timing"]["energy"]["area"];
    return std::make_pair(j["total_mm2"].get<double>(), j["rotate_stage"]["nand2_eq"].get<double>());
  };
  const auto preset = area("--config rdna2");
  const auto narrow = area("--config rdna2 --coord-bits 12");
  CHECK(narrow.first < preset.first);  // a narrower datapath is a smaller unit
  // rdna4's format has oriented nodes: its rotation stage is priced, and gone with --node-kind 0.
  const auto obb = area("--config rdna4");
  const auto aabb = area("--config rdna4 --node-kind 0");
  CHECK(obb.second > 0);
  CHECK(aabb.second == 0);
  CHECK(aabb.first < obb.first);
  // sweep's area for the point of the default format (rdna2's) with coord_bits 12, to the digits its CSV prints.
  const std::string csv = (d / "s.csv").string();
  fs::remove(csv);
  REQUIRE_RTUSIM_OK(s,
                    "sweep --scene builtin:seed --formats default:coord_bits=12 --config rdna2 --rays 64 "
                    "--image-width 0 --out " +
                        csv);
  const std::vector<std::string> lines = read_lines(csv);
  REQUIRE(lines.size() == 2);
  auto fields = [](const std::string& line) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    return f;
  };
  const std::vector<std::string> head = fields(lines[0]), row = fields(lines[1]);
  const auto col = std::find(head.begin(), head.end(), "area_mm2");
  REQUIRE(col != head.end());
  const double swept = std::stod(row[size_t(col - head.begin())]);
  CHECK(swept == Approx(narrow.first).epsilon(1e-4));  // the CSV prints 6 significant digits or more
}

TEST_CASE("trace --packet-rays: the same hits in any packets, each packet's fill and drain in the cycles",
          "[cli][timing]") {
  const fs::path d = temp_dir("cli");
  const std::string base = "trace --scene builtin:cornell --rays incoherent:3000 --device timed --config rdna2";
  nlohmann::json j[2];
  for (int k = 0; k < 2; ++k) {
    const std::string tag = std::to_string(k);
    REQUIRE_RTUSIM_OK(r, base + (k ? " --packet-rays 1000" : "") + " --out " + (d / ("h" + tag)).string() +
                             " --stats " + (d / ("s" + tag + ".json")).string());
    j[k] = read_json((d / ("s" + tag + ".json")).string());
  }
  const auto a = rtu::host::read_hits((d / "h0").string()), b = rtu::host::read_hits((d / "h1").string());
  REQUIRE(a.size() == 3000);
  CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0);
  CHECK(j[0]["packet_rays"] == 262144);
  CHECK(j[1]["packet_rays"] == 1000);
  CHECK(j[0]["timing"]["packets"] == 1);
  CHECK(j[1]["timing"]["packets"] == 3);
  // Each packet starts with empty slots and ends when its last ray leaves: two more fills and drains.
  CHECK(j[1]["timing"]["cycles"].get<uint64_t>() > j[0]["timing"]["cycles"].get<uint64_t>());

  // A chip's sample thins only a packet long enough: 40,000 rays on 4 units of 8 slots are 5,000 waves (1,250
  // turns, 310 bursts of 4 between fill and drain, 31 measured at 1 in 10) in one packet; in packets of 4,000
  // rays, 500 waves each hold 29 bursts, 2 measured: each simulated in full, and the note names the option.
  const std::string chip =
      "trace --scene builtin:cornell --rays incoherent:40000 --device timed --set units=4 "
      "--set ray_slots=8 --set ray_policy=dynamic --sample 0.1 --stats ";
  REQUIRE_RTUSIM_OK(one, chip + (d / "c0.json").string());
  REQUIRE_RTUSIM_OK(ten, chip + (d / "c1.json").string() + " --packet-rays 4000");
  const nlohmann::json s0 = read_json((d / "c0.json").string())["timing"]["sample"],
                       s1 = read_json((d / "c1.json").string())["timing"]["sample"];
  CHECK(s0["packets_sampled"] == 1);
  CHECK(s0["packets_unthinned"] == 0);
  CHECK(s1["packets_sampled"] == 0);
  CHECK(s1["packets_unthinned"] == 10);
  CHECK(ten.output.find("longer packets (trace --packet-rays)") != std::string::npos);
  check_refused({{base + " --packet-rays 0", "--packet-rays: Value 0 not in range"}});
}
