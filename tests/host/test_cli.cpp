// rtusim end to end: the subcommands on the built-in scenes, and bad input giving a clear error and a non-zero
// exit, never a crash.
#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <unistd.h>
#include <cstdio>
#include <cstring>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "host/ray_io.h"

namespace fs = std::filesystem;

namespace {

struct Run {
  int status;
  std::string output;  // stdout and stderr
};

Run run(const std::string& args) {
  const std::string cmd = std::string(RTUSIM_EXE) + " " + args + " 2>&1";
  std::FILE* p = popen(cmd.c_str(), "r");
  REQUIRE(p != nullptr);
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int st = pclose(p);
  return Run{WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st), out};
}

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("rtu_test_cli_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

}  // namespace

TEST_CASE("every subcommand has --help", "[cli]") {
  for (const char* sub : {"info", "rays", "trace", "demo"}) {
    const Run r = run(std::string(sub) + " --help");
    INFO(r.output);
    CHECK(r.status == 0);
    CHECK(r.output.find("--") != std::string::npos);
  }
  CHECK(run("frobnicate").status != 0);
  CHECK(run("").status != 0);
}

TEST_CASE("rays -> trace round trip on a built-in scene, CSV and binary give the same hits", "[cli]") {
  const fs::path d = temp_dir();
  const std::string rays = (d / "p.rays").string(), rays_csv = (d / "p.csv").string();
  REQUIRE(run("rays --scene builtin:seed --kind primary --count 20000 --out " + rays).status == 0);
  REQUIRE(run("rays --scene builtin:seed --kind primary --count 20000 --out " + rays_csv).status == 0);
  const std::string stats = (d / "s.json").string();
  const Run t = run("trace --scene builtin:seed --rays " + rays + " --out " + (d / "h.bin").string() +
                    " --stats " + stats + " --bvh-width 8");
  INFO(t.output);
  REQUIRE(t.status == 0);
  REQUIRE(run("trace --scene builtin:seed --rays " + rays_csv + " --out " + (d / "h.csv").string()).status == 0);
  const auto a = rtu::host::read_hits((d / "h.bin").string()), b = rtu::host::read_hits((d / "h.csv").string());
  REQUIRE(a.size() == 20000);
  REQUIRE(std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0);

  const nlohmann::json j = nlohmann::json::parse(std::ifstream(stats));
  for (const char* key : {"rays", "hits", "trace_seconds", "rays_per_second", "nodes_visited", "box_tests",
                          "prim_tests", "invalid_rays"})
    CHECK(j.contains(key));
  CHECK(j["rays"] == 20000);
  CHECK(j["hits"].get<uint64_t>() > 10000);
  CHECK(j["hits"].get<uint64_t>() <= 20000);
  CHECK(j["bvh"]["width"] == 8);
}

TEST_CASE("trace with NaN rays warns, counts them and writes misses", "[cli]") {
  const fs::path d = temp_dir();
  std::ofstream(d / "nan.csv") << "ox,oy,oz,tmin,dx,dy,dz,tmax\n0,1,8,0,0,0,-1,inf\nnan,0,0,0,1,0,0,inf\n"
                                  "0,0,0,0,0,-0,0,inf\n";
  const Run r = run("trace --scene builtin:seed --rays " + (d / "nan.csv").string() + " --out " +
                    (d / "h.csv").string() + " --stats " + (d / "s.json").string());
  INFO(r.output);
  CHECK(r.status == 0);
  CHECK(r.output.find("2 invalid rays") != std::string::npos);
  CHECK(r.output.find("ray 1 (nan_origin)") != std::string::npos);
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(d / "s.json"));
  CHECK(j["invalid_rays"] == 2);
  CHECK(j["invalid_by_reason"]["zero_direction"] == 1);
  const auto hits = rtu::host::read_hits((d / "h.csv").string());
  REQUIRE(hits.size() == 3);
  CHECK_FALSE(hits[1].hit());
  CHECK_FALSE(hits[2].hit());
}

TEST_CASE("bad input: clear error, non-zero exit, no crash", "[cli]") {
  const fs::path d = temp_dir();
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
  };
  for (const Case& c : cases) {
    const Run r = run(c.args);
    INFO(c.args << "\n" << r.output);
    CHECK(r.status != 0);
    CHECK(r.status < 128);  // not killed by a signal
    CHECK(r.output.find(c.words) != std::string::npos);
  }
}

TEST_CASE("demo writes an image, hits and a report", "[cli]") {
  const fs::path d = temp_dir() / "demo";
  const Run r = run("demo --out " + d.string());
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(fs::file_size(d / "primary_float.png") > 1000);
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(d / "report.json"));
  CHECK(j["devices"]["float"]["hits"].get<uint64_t>() > 0);
}
