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

}  // namespace

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
