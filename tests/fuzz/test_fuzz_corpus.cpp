// The fuzz targets (tests/fuzz/fuzz_*.cpp) over every committed input: the seed corpora (corpus/TARGET/, valid
// inputs that reach deep into each target) and the reproducers of crashes the fuzzers found (regressions/TARGET/,
// README "Hardening"). A target aborts on a broken invariant or an unexpected exception, so each input either
// passes or fails this test; the asan preset runs the same with AddressSanitizer and UBSan.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "tests/fuzz/fuzz.h"

namespace fs = std::filesystem;

namespace {

std::vector<fs::path> inputs(const std::string& kind, const std::string& target) {
  std::vector<fs::path> files;
  const fs::path dir = fs::path(RTU_SOURCE_DIR) / "tests" / "fuzz" / kind / target;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.is_regular_file()) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

void run_all(const rtu::fuzz::Target& t) {
  const std::vector<fs::path> seeds = inputs("corpus", t.name);
  CHECK(seeds.size() >= 3);  // every target has a seed corpus
  std::vector<fs::path> all = seeds;
  const std::vector<fs::path> crashes = inputs("regressions", t.name);
  all.insert(all.end(), crashes.begin(), crashes.end());
  for (const fs::path& p : all) {
    INFO(p.string());
    std::ifstream in(p, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    CHECK(t.run(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()) == 0);
  }
  // The empty input and a few degenerate ones.
  const uint8_t zeros[64] = {};
  CHECK(t.run(zeros, 0) == 0);
  CHECK(t.run(zeros, 1) == 0);
  CHECK(t.run(zeros, sizeof zeros) == 0);
}

// n copies of s.
std::string repeat(const std::string& s, size_t n) {
  std::string out;
  out.reserve(s.size() * n);
  for (size_t i = 0; i < n; ++i) out += s;
  return out;
}

int run_text(const rtu::fuzz::Target& t, const std::string& bytes) {
  return t.run(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
}

}  // namespace

// Deeply nested inputs, generated rather than committed (megabytes): the reproducers of issue 25, where a scene
// file of 10^6 nested arrays overflowed the stack, and the nested mesh formats at a depth that overflows the
// importer's stack. Each must be refused (the target returns 0), not crash the target.
TEST_CASE("fuzz targets: deeply nested inputs", "[fuzz][corpus]") {
  const std::string deep = repeat("[", 1000000) + repeat("]", 1000000);
  CHECK(run_text(rtu::fuzz::kTargets[0], "{\"materials\": " + deep + "}") == 0);
  CHECK(run_text(rtu::fuzz::kTargets[0], "{\"camera\": {\"width\": " + deep + "}}") == 0);
  // mesh_import: byte 0 picks the format, 'm' % 8 = 5 Collada, 'o' % 8 = 7 AC3D; 10^5 levels each.
  const size_t n = 100000;
  CHECK(run_text(rtu::fuzz::kTargets[1],
                 "m<?xml version=\"1.0\"?><COLLADA version=\"1.4.1\"><library_visual_scenes>"
                 "<visual_scene id=\"s\">" +
                     repeat("<node>", n) + repeat("</node>", n) +
                     "</visual_scene></library_visual_scenes><scene>"
                     "<instance_visual_scene url=\"#s\"/></scene></COLLADA>") == 0);
  CHECK(run_text(rtu::fuzz::kTargets[1], "oAC3Db\nOBJECT world\nkids 1\n" + repeat("OBJECT group\nkids 1\n", n) +
                                             "OBJECT group\nkids 0\n") == 0);
}

TEST_CASE("fuzz corpus: scene_file", "[fuzz][corpus]") {
  run_all(rtu::fuzz::kTargets[0]);
}
TEST_CASE("fuzz corpus: mesh_import", "[fuzz][corpus]") {
  run_all(rtu::fuzz::kTargets[1]);
}
TEST_CASE("fuzz corpus: ray_file", "[fuzz][corpus]") {
  run_all(rtu::fuzz::kTargets[2]);
}
TEST_CASE("fuzz corpus: command_processor", "[fuzz][corpus]") {
  run_all(rtu::fuzz::kTargets[3]);
}
TEST_CASE("fuzz corpus: device_image", "[fuzz][corpus]") {
  run_all(rtu::fuzz::kTargets[4]);
}
TEST_CASE("fuzz corpus: config", "[fuzz][corpus]") {
  run_all(rtu::fuzz::kTargets[5]);
}
TEST_CASE("fuzz corpus: texture", "[fuzz][corpus]") {
  run_all(rtu::fuzz::kTargets[6]);
}
