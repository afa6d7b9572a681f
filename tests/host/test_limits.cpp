// Inputs beyond what the machine or the unit can hold are refused with a message and exit status 2, before
// anything large is allocated: the memory budget (RTU_MEMORY_LIMIT), ray files and generated rays, scenes, mesh
// files, render sizes; the primitive index width. And the watchdogs from the command line: a clear error with
// the unit's state, exit status 2. (Ring and packet limits: tests/firmware/test_command_processor_errors.cpp;
// BVH depth and shared subtrees: tests/hwmodel/test_watchdog.cpp.)
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>

#include "host/error.h"
#include "host/limits.h"
#include "host/ray_gen.h"
#include "host/ray_io.h"
#include "host/scene.h"
#include "hwmodel/bvh.h"
#include "tests/host/run_process.h"

using namespace rtu;
namespace fs = std::filesystem;
using rtu::test::Run;
using rtu::test::run_rtusim;

namespace {

fs::path temp_dir() {
  fs::path d = fs::temp_directory_path() / ("rtu_test_limits_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

// Sets RTU_MEMORY_LIMIT for the scope.
struct MemoryLimit {
  explicit MemoryLimit(const char* v) { ::setenv("RTU_MEMORY_LIMIT", v, 1); }
  ~MemoryLimit() { ::unsetenv("RTU_MEMORY_LIMIT"); }
};

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const host::Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("memory limit: RTU_MEMORY_LIMIT parses sizes and refuses the rest", "[limits]") {
  CHECK(host::parse_size("4096", "x") == 4096);
  CHECK(host::parse_size("3K", "x") == 3 * 1024);
  CHECK(host::parse_size("512M", "x") == uint64_t(512) << 20);
  CHECK(host::parse_size("2g", "x") == uint64_t(2) << 30);
  CHECK(host::parse_size("1T", "x") == uint64_t(1) << 40);
  for (const char* bad : {"", "-1", "1.5G", "12KB", "G", "99999999999999999999", "20000000T", " 1"})
    CHECK(contains(error_of([&] { host::parse_size(bad, "RTU_MEMORY_LIMIT"); }), "RTU_MEMORY_LIMIT"));
  {
    MemoryLimit m("1M");
    CHECK(host::memory_limit() == (uint64_t(1) << 20));
    CHECK_NOTHROW(host::check_memory("this", uint64_t(1) << 20));
    const std::string e = error_of([] { host::check_memory("this job", (uint64_t(1) << 20) + 1); });
    CHECK(contains(e, "this job needs about 2 MiB of memory, above the limit of 1 MiB"));
  }
  {
    MemoryLimit m("lots");
    CHECK(contains(error_of([] { host::memory_limit(); }), "'lots' is not a size"));
  }
  // Without the variable: the machine's available memory, some MiB at least, never 0.
  CHECK(host::memory_limit() > (uint64_t(16) << 20));
}

TEST_CASE("memory limit: ray files larger than the budget are refused before they are read", "[limits]") {
  const fs::path dir = temp_dir();
  const std::vector<hw::Ray> rays = host::incoherent_rays(hw::Aabb{hw::Vec3(-1.0f), hw::Vec3(1.0f)}, 1000, 1);
  host::write_rays((dir / "r.bin").string(), rays);
  host::write_rays((dir / "r.csv").string(), rays);
  {
    MemoryLimit m("64K");  // 1000 rays and their hits need 48000 bytes: fits
    CHECK(host::read_rays((dir / "r.bin").string()).size() == 1000);
  }
  MemoryLimit m("40K");
  const std::string bin = error_of([&] { host::read_rays((dir / "r.bin").string()); });
  CHECK(contains(bin, "r.bin: 1000 rays needs about 47 KiB of memory, above the limit of 40 KiB"));
  CHECK(contains(bin, "RTU_MEMORY_LIMIT"));
  // CSV: the file size bounds the rays it can hold (a line is at least 16 bytes).
  CHECK(contains(error_of([&] { host::read_rays((dir / "r.csv").string()); }), "r.csv: up to"));
  // From the command line: exit status 2 and the message.
  const Run r =
      run_rtusim("RTU_MEMORY_LIMIT=40K", "trace --scene 'builtin:icosphere?subdiv=0' --rays " +
                                             (dir / "r.bin").string() + " --out " + (dir / "h.bin").string());
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(contains(r.output, "rtusim: error: "));
  CHECK(contains(r.output, "1000 rays needs about"));
}

TEST_CASE("memory limit: generated rays, scenes, mesh files and render memory are checked", "[limits]") {
  const fs::path dir = temp_dir();
  // 10^11 incoherent rays would need 4.8 TB: refused at once, whatever the machine.
  Run r = run_rtusim("compare --scene builtin:seed --rays incoherent:100000000000");
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(contains(r.output, "--rays incoherent:100000000000: 100000000000 rays needs about"));
  r = run_rtusim("compare --scene builtin:seed --rays primary:65536x65536");
  CHECK(r.status == 2);
  CHECK(contains(r.output, "4294967296 rays needs about"));

  // A scene: 256 bytes per primitive against the budget (icosphere subdiv 6: 81920 triangles, 20 MiB).
  {
    MemoryLimit m("8M");
    const std::string e = error_of([] { host::load_scene("builtin:icosphere?subdiv=6"); });
    CHECK(contains(e, "icosphere subdiv 6: 81920 primitives needs about 20 MiB of memory"));  // before generating
  }
  // A mesh file: 8 times its bytes for the importer.
  std::ofstream(dir / "m.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n" << std::string(200000, '#') << "\n";
  {
    MemoryLimit m("1M");
    CHECK(contains(error_of([&] { host::load_scene((dir / "m.obj").string()); }), "importing a 0 MiB mesh file"));
  }
  CHECK(host::load_scene((dir / "m.obj").string()).geometry.triangles.size() == 1);
  // Render: the unit's device memory (scene image, framebuffer, arena).
  r = run_rtusim("RTU_MEMORY_LIMIT=2M",
                 "render --scene builtin:seed --width 1024 --height 1024 --out " + (dir / "i.png").string());
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(contains(r.output, "render: the unit's device memory needs about"));
}

TEST_CASE("finite but huge coordinates are refused (float products would overflow)", "[limits]") {
  // Found by fuzz_device_image: coordinates near FLT_MAX made the BVH builder's centroid bins NaN (undefined
  // behaviour converting to int); the builder is now safe for any input, and scenes keep within 2^62.
  const fs::path dir = temp_dir();
  std::ofstream(dir / "huge.json") << R"({"materials": {"m": {}},
    "spheres": [{"center": [0, 0, 0], "radius": 1, "material": "m"}, {"center": [3e38, 0, 0], "radius": 1e38,
                 "material": "m"}]})";
  const std::string e = error_of([&] { host::load_scene((dir / "huge.json").string()); });
  CHECK(contains(e, "sphere 1: a value beyond 2^62 (4.6e18), where float products overflow"));
  std::ofstream(dir / "ok.json") << R"({"materials": {"m": {}},
    "spheres": [{"center": [4e18, 0, 0], "radius": 1e18, "material": "m"}]})";
  CHECK(host::load_scene((dir / "ok.json").string()).geometry.spheres.size() == 1);
}

TEST_CASE("a PLY header Assimp would loop on is refused first", "[limits]") {
  // Found by fuzz_mesh_import (tests/fuzz/regressions/mesh_import/assimp_ply_unknown_keyword_hang): Assimp 5.2's
  // PLY parser never returns on a header line with an unknown keyword.
  const fs::path dir = temp_dir();
  const std::string head = "ply\nformat ascii 1.0\nelement vertex 3\n";
  const std::string tail =
      "property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n"
      "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  std::ofstream(dir / "hang.ply") << head << "prortyep float x\n" << tail;
  CHECK(contains(error_of([&] { host::import_mesh((dir / "hang.ply").string()); }),
                 "hang.ply: PLY header line 4: unknown keyword 'prortyep'"));
  std::ofstream(dir / "noend.ply") << "ply\nformat ascii 1.0\n";
  CHECK(contains(error_of([&] { host::import_mesh((dir / "noend.ply").string()); }), "without end_header"));
  std::ofstream(dir / "badprop.ply") << head << "property flot x\n" << tail;
  CHECK(contains(error_of([&] { host::import_mesh((dir / "badprop.ply").string()); }),
                 "expected 'property TYPE NAME'"));
  // Found by scripts/fuzz_long.sh (regressions/mesh_import/assimp_ply_vertical_tab_after_end_header_hang): a
  // vertical tab after end_header, where Assimp (waiting 10 s in the fuzzer, RTU_IMPORT_TIMEOUT) never returned.
  std::ofstream(dir / "vt.ply")
      << head << "property float x\n"
      << "property float y\nproperty float z\nelement face 1\n"
         "property list uchar int vertex_indices\nend_header\v0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  CHECK(contains(error_of([&] { host::import_mesh((dir / "vt.ply").string()); }),
                 "vt.ply: PLY header line 9: control character 11"));
  std::ofstream(dir / "ff.ply") << "ply\f\n" << tail;
  CHECK(contains(error_of([&] { host::import_mesh((dir / "ff.ply").string()); }),
                 "ff.ply: PLY header line 1: control character 12"));
  std::ofstream(dir / "ok.ply") << "ply\r\nformat ascii 1.0\r\ncomment fine\tand tabbed\nelement vertex 3\n"
                                   "property float x\n"
                                << tail;
  CHECK(host::import_mesh((dir / "ok.ply").string()).size() == 1);
}

TEST_CASE("a mesh file that crashes Assimp is an error, not a crash of rtu", "[limits]") {
  // Found by fuzz_mesh_import (regressions/mesh_import/assimp_ply_triangulate_assert_abort): a PLY body that
  // contradicts its header trips an assertion in Assimp's triangulation, which aborts. Assimp runs in a child
  // process (host/mesh_import.cpp), so the abort becomes an Error naming the file.
  const fs::path dir = temp_dir();
  std::ifstream in(
      fs::path(RTU_SOURCE_DIR) / "tests/fuzz/regressions/mesh_import/assimp_ply_triangulate_assert_abort",
      std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  REQUIRE(bytes.size() > 1);
  std::ofstream(dir / "abort.ply", std::ios::binary) << bytes.substr(1);  // byte 0 chose the format
  const std::string e = error_of([&] { host::load_scene((dir / "abort.ply").string()); });
  CHECK(contains(e, "abort.ply: the mesh importer (Assimp) crashed on this file (signal 6"));
  // The same path still imports good files, with the triangles passed back bit for bit.
  const std::vector<hw::Triangle> a = host::import_mesh("/usr/share/assimp/models/OBJ/spider.obj");
  CHECK(a.size() == 1368);
}

TEST_CASE("scenes with more primitives than the unit's index holds are refused", "[limits]") {
  // 2^27 primitives would take gigabytes to build: the rule validate_scene applies, at its boundary.
  MemoryLimit m("1T");
  CHECK_NOTHROW(host::check_scene_size("s", hw::kMaxBvhPrims - 1));
  const std::string e = error_of([] { host::check_scene_size("s", hw::kMaxBvhPrims); });
  CHECK(contains(e, "s: 134217728 primitives: more than the unit's primitive index holds (at most 134217727)"));
}

TEST_CASE("watchdogs from the command line: exit status 2 with the unit's state", "[limits][watchdog]") {
  const fs::path dir = temp_dir();
  const std::string rays = (dir / "p.rays").string(), hits = (dir / "p.hits").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind primary --count 500 --out " + rays).status == 0);
  Run r = run_rtusim("trace --scene builtin:seed --rays " + rays + " --out " + hits +
                     " --device timed --set watchdog_cycles=100");
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(contains(r.output, "rtusim: error: timed device watchdog: ray 0 of 500 has been in ray slot 0"));
  CHECK(contains(r.output, "unit state at cycle"));
  r = run_rtusim("trace --scene builtin:seed --rays " + rays + " --out " + hits +
                 " --device fixed --watchdog-steps 2");
  CHECK(r.status == 2);
  CHECK(contains(r.output, "traversal watchdog: ray"));
  // Through the firmware and the command processor: the render names the error and prints the dump.
  r = run_rtusim(
      "render --scene builtin:seed --width 32 --height 24 --device timed --set watchdog_cycles=100 --out " +
      (dir / "w.png").string());
  CHECK(r.status == 2);
  CHECK(contains(r.output, "device_error (watchdog at ring slot"));
  CHECK(contains(r.output, "ray slots: "));
  // The defaults never fire on real work.
  r = run_rtusim("trace --scene builtin:seed --rays " + rays + " --out " + hits + " --device timed");
  CHECK(r.status == 0);
}
