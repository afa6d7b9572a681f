// Inputs beyond what the machine or the unit can hold are refused with a message and exit status 2, before
// anything large is allocated: the memory budget (RTU_MEMORY_LIMIT), ray files and generated rays, scenes, mesh
// files, render sizes; the primitive index width. And the watchdogs from the command line: a clear error with
// the unit's state, exit status 2. (Ring and packet limits: tests/firmware/test_command_processor_errors.cpp;
// BVH depth and shared subtrees: tests/hwmodel/test_watchdog.cpp.)
#include <catch2/catch.hpp>

#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>

#include <stb/stb_image_write.h>
#include <nlohmann/json.hpp>

#include "host/devices/direct_device.h"
#include "host/io/error.h"
#include "host/io/image.h"
#include "host/io/limits.h"
#include "host/io/ray_io.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/scene/bvh.h"
#include "tests/common/test_util.h"
#include "tests/host/error_checks.h"
#include "tests/host/run_process.h"

using namespace rtu;
namespace fs = std::filesystem;
using namespace rtu::test;  // run_rtusim, temp_dir, contains

namespace {

// Sets RTU_MEMORY_LIMIT for the scope.
struct MemoryLimit {
  explicit MemoryLimit(const char* v) { ::setenv("RTU_MEMORY_LIMIT", v, 1); }
  ~MemoryLimit() { ::unsetenv("RTU_MEMORY_LIMIT"); }
};

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
  const fs::path dir = temp_dir("limits");
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
  const fs::path dir = temp_dir("limits");
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
  const fs::path dir = temp_dir("limits");
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
  const fs::path dir = temp_dir("limits");
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
  // process (host/scene/mesh_import_process.cpp), so the abort becomes an Error naming the file.
  const fs::path dir = temp_dir("limits");
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
  const fs::path dir = temp_dir("limits");
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

// Memory the input justifies (issue 40): each path below is refused against RTU_MEMORY_LIMIT before its memory is
// taken, or streams; the command's peak resident size (run_measured) stays within the limit plus what rtusim
// takes for itself on a small job (its code, libraries and a small scene).
namespace {

// Under AddressSanitizer a process's resident size says little of what it allocated: shadow memory and the
// quarantine of freed blocks multiply it. Peaks that follow real allocations are compared in the default build
// only; the refusals (a few MiB before anything large is taken) are compared in both.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif
#else
constexpr bool kSanitized = false;
#endif

uint64_t mib(uint64_t kib) {
  return kib >> 10;
}

// rtusim's own resident size on a small job, in KiB.
uint64_t baseline_kib() {
  static const uint64_t kib =
      rtu::test::run_measured(std::string(RTUSIM_EXE) + " info --scene builtin:seed").peak_kib;
  return kib;
}

rtu::test::Run measured_rtusim(const std::string& env, const std::string& args) {
  return rtu::test::run_measured(env + " " + std::string(RTUSIM_EXE) + " " + args);
}

// rtusim with `env` refuses the job `args`, exit status 2, saying `message`, before it holds 64 MiB: the refusal
// comes before the memory is taken.
void check_refused_early(const std::string& env, const std::string& args, const std::string& message) {
  const rtu::test::Run r = measured_rtusim(env, args);
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(contains(r.output, message));
  CHECK(mib(r.peak_kib) < 64);
}

// A scene of `count` instances of one quad, all in the same place (nested prototypes of ten, so the file stays
// small), seen from above: every camera ray passes through every instance.
void write_coinciding_scene(const fs::path& path, int levels) {
  std::string protos = R"("q": {"meshes": [{"generate": "quad", "size": 2, "material": "m"}]})";
  std::string prev = "q";
  auto ten = [](const std::string& p) {
    std::string s = "[";
    for (int i = 0; i < 10; ++i) {
      if (i) s += ", ";
      s += R"({"prototype": ")";
      s += p;
      s += R"("})";
    }
    return s + "]";
  };
  for (int l = 1; l < levels; ++l) {
    std::string name = "p";
    name += std::to_string(l);
    protos += ", \"";
    protos += name;
    protos += "\": {\"instances\": ";
    protos += ten(prev);
    protos += "}";
    prev = name;
  }
  std::ofstream(path) << R"({"materials": {"m": {}},
    "camera": {"position": [0.3, 1, 0.2], "look_at": [0, 0, 0], "fov_y": 40, "width": 64, "height": 48},
    "prototypes": {)" << protos
                      << "}, \"instances\": " << ten(prev) << "}";
}

// 1024 rays through 10,000 instances in one place (write_coinciding_scene, 4 levels) traced on the float device
// and on the timed device with `timed` options, each with its peak memory measured.
std::pair<rtu::test::Run, rtu::test::Run> coinciding_peaks(const fs::path& dir, const std::string& timed) {
  write_coinciding_scene(dir / "coin4.json", 4);
  const std::string rays_file = (dir / "c.bin").string();
  REQUIRE(
      run_rtusim("rays --scene " + (dir / "coin4.json").string() + " --count 1024 --out " + rays_file).status ==
      0);
  const std::string trace = "trace --scene " + (dir / "coin4.json").string() + " --rays " + rays_file + " --out " +
                            (dir / "h.bin").string() + " --threads 2 --device ";
  rtu::test::Run f = measured_rtusim("", trace + "float");
  rtu::test::Run t = measured_rtusim("", trace + timed);
  INFO(t.output);
  REQUIRE(f.status == 0);
  REQUIRE(t.status == 0);
  return {f, t};
}

// The coinciding scene of 1000 instances (3 levels), written to `path` and loaded.
host::Scene coinciding_scene(const fs::path& path) {
  write_coinciding_scene(path, 3);
  return host::load_scene(path.string());
}

// The rays of a coinciding scene through the timed device with options `o` (its kind and the scene's instances
// set here) four times: whole packets on 1 thread, 64 KiB of events a chunk (a few rays) on 1 and 2 threads, and
// every ray a chunk of its own on 2 threads. Each run's hits and cycles.
struct ChunkedRuns {
  std::vector<hw::Hit> hits[4];
  uint64_t cycles[4] = {0, 0, 0, 0};
  // Ray i's hits are the same in every run, bit for bit.
  bool same_hits(size_t i) const {
    return std::memcmp(&hits[0][i], &hits[1][i], sizeof(hw::Hit)) == 0 &&
           std::memcmp(&hits[0][i], &hits[2][i], sizeof(hw::Hit)) == 0 &&
           std::memcmp(&hits[0][i], &hits[3][i], sizeof(hw::Hit)) == 0;
  }
};

ChunkedRuns run_chunked(const host::Scene& scene, const std::vector<hw::Ray>& rays, host::DeviceOptions o) {
  o.kind = hw::DeviceKind::kTimed;
  o.instances = &scene.instances;
  const uint64_t chunk_bytes[4] = {0, 64 << 10, 64 << 10, 1};
  const int threads[4] = {1, 1, 2, 2};
  ChunkedRuns r;
  for (int k = 0; k < 4; ++k) {
    const auto dev = host::make_device(scene.geometry, o);
    if (chunk_bytes[k]) dev->timed()->set_chunk_event_bytes(chunk_bytes[k]);
    r.hits[k].resize(rays.size());
    hw::TraversalStats s;
    dev->trace_batch(rays.data(), r.hits[k].data(), rays.size(), false, threads[k], s);
    r.cycles[k] = dev->timed()->timing().cycles;
  }
  return r;
}

// The four runs took the same cycles, and some.
void check_same_cycles(const ChunkedRuns& r) {
  CHECK(r.cycles[0] > 0);
  CHECK(r.cycles[1] == r.cycles[0]);
  CHECK(r.cycles[2] == r.cycles[0]);
  CHECK(r.cycles[3] == r.cycles[0]);
}

}  // namespace

TEST_CASE("memory limit: rays --count is refused before the rays are made", "[limits][memory]") {
  const fs::path dir = temp_dir("limits");
  for (const char* kind : {"primary", "incoherent"}) {
    check_refused_early("RTU_MEMORY_LIMIT=64M",
                        std::string("rays --scene builtin:seed --kind ") + kind + " --count 4000000 --out " +
                            (dir / "r.bin").string(),
                        std::string("4000000 ") + kind + " rays needs about 123 MiB of memory, above the limit");
  }
  // The generators themselves, whoever calls them.
  MemoryLimit m("1M");
  host::Camera cam;
  CHECK(
      contains(error_of([&] { host::primary_rays(cam, 1024, 1024); }), "1048576 primary rays needs about 32 MiB"));
  CHECK(host::primary_rays(cam, uint64_t(1000)).size() == 1000);
}

TEST_CASE("memory limit: sweep --rays and plan --rays are refused before the rays are made", "[limits][memory]") {
  const fs::path dir = temp_dir("limits");
  for (const std::string& job :
       {"sweep --out " + (dir / "s.csv").string(), std::string("plan --max-error 0.01")}) {
    check_refused_early("RTU_MEMORY_LIMIT=64M", job + " --scene builtin:seed --rays 1000000 --image-width 0",
                        job.substr(0, job.find(' ')) +
                            " --rays 1000000: 1000000 camera and as many incoherent rays with their hits "
                            "needs about 153 MiB of memory, above the limit of 64 MiB");
  }
}

TEST_CASE("memory limit: a scene's textures are held to the budget in sum", "[limits][memory]") {
  // Six 4096 x 4096 JPEGs (a few hundred KB each; 64 MiB of texels decoded, 128 MiB while decoding): each fits
  // a 300 MiB budget, the fourth does not beside the three before it.
  const fs::path dir = temp_dir("limits");
  {
    std::vector<uint8_t> rgb(size_t(4096) * 4096 * 3, 128);
    REQUIRE(stbi_write_jpg((dir / "t.jpg").string().c_str(), 4096, 4096, 3, rgb.data(), 50) != 0);
  }
  REQUIRE(host::texture_header_bytes((dir / "t.jpg").string()) == uint64_t(64) << 20);
  std::string textures;
  for (int i = 0; i < 6; ++i) {
    if (i) textures += ", ";
    textures += "\"t";
    textures += std::to_string(i);
    textures += "\": {\"file\": \"t.jpg\"}";
  }
  std::ofstream(dir / "tex.json") << R"({"textures": {)" << textures << R"(},
    "materials": {"m": {"texture": "t5"}}, "spheres": [{"center": [0, 0, 0], "radius": 1, "material": "m"}]})";
  const rtu::test::Run r = measured_rtusim("RTU_MEMORY_LIMIT=300M", "info --scene " + (dir / "tex.json").string());
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(contains(r.output,
                 "tex.json: textures.t3.file: 4 textures so far needs about 320 MiB of memory, above the "
                 "limit of 300 MiB"));
  if (!kSanitized) CHECK(mib(r.peak_kib) < 300 + mib(baseline_kib()));
  // The header's size without decoding, in memory too (a PNG's IHDR; anything else: 0).
  const uint8_t png[24] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n', 0, 0, 0,    13,
                           'I',  'H', 'D', 'R', 0,    0,    0x3E, 0x80, 0, 0, 0x3E, 0x80};
  CHECK(host::texture_header_bytes(png, sizeof png) == uint64_t(16000) * 16000 * 4);
  CHECK(host::texture_header_bytes(png, 20) == 0);
}

TEST_CASE("memory limit: instances are held to the budget as they are expanded", "[limits][memory]") {
  // 4 x 16 x 16 x 16 placements of a 5120-triangle sphere: 84 million triangles from a 3 KB file.
  const fs::path dir = temp_dir("limits");
  auto placements = [](const std::string& p, int n) {
    std::string s = "[";
    for (int i = 0; i < n; ++i) {
      if (i) s += ", ";
      s += R"({"prototype": ")";
      s += p;
      s += R"(", "transform": {"translate": [)";
      s += std::to_string(3 * i);
      s += ", 0, 0]}}";
    }
    return s + "]";
  };
  std::ofstream(dir / "inst.json") << R"({"materials": {"m": {}}, "prototypes": {
    "ball": {"meshes": [{"generate": "icosphere", "subdiv": 4, "radius": 1, "material": "m"}]},
    "p1": {"instances": )" << placements("ball", 16)
                                   << R"(}, "p2": {"instances": )" << placements("p1", 16)
                                   << R"(}, "p3": {"instances": )" << placements("p2", 16) << R"(}},
    "instances": )" << placements("p3", 4)
                                   << "}";
  check_refused_early("RTU_MEMORY_LIMIT=64M", "info --scene " + (dir / "inst.json").string(),
                      "inst.json: prototypes.p1.instances[3]: the instances so far: 266240 primitives needs "
                      "about 65 MiB of memory, above the limit of 64 MiB");
}

TEST_CASE("timed device: events are recorded in bounded chunks, with the same hits and cycles",
          "[limits][memory][scale]") {
  const fs::path dir = temp_dir("limits");
  const host::Scene scene = coinciding_scene(dir / "coin.json");  // 1000 instances in one place
  const std::vector<hw::Ray> rays = host::primary_rays(scene.camera, uint64_t(300));
  const ChunkedRuns r = run_chunked(scene, rays, host::DeviceOptions{});
  REQUIRE(r.hits[0].size() == rays.size());
  size_t hit = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    hit += r.hits[0][i].hit();
    CHECK(r.same_hits(i));
  }
  CHECK(hit == rays.size());
  check_same_cycles(r);

  // From the command line, 10000 instances: the timed device holds a chunk's events (at most 32 MiB) and its ray
  // slots' (32 rays in flight), not every ray's (8 bytes an event, tens of thousands of events per ray here).
  const auto [f, t] = coinciding_peaks(dir, "timed");
  if (!kSanitized) CHECK(mib(t.peak_kib) < mib(f.peak_kib) + 80);
}

TEST_CASE("the pipeline trace is streamed to its file", "[limits][memory][scale]") {
  const fs::path dir = temp_dir("limits");
  const std::string rays = (dir / "p.rays").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind incoherent --count 100000 --out " + rays).status == 0);
  const std::string trace = "trace --scene builtin:seed --rays " + rays + " --out " + (dir / "h.bin").string() +
                            " --device timed --threads 1";
  const rtu::test::Run plain = measured_rtusim("", trace);
  const rtu::test::Run piped = measured_rtusim(
      "", trace + " --pipeline-trace " + (dir / "p.json").string() + " --trace-window 0:1000000000");
  INFO(piped.output);
  REQUIRE(plain.status == 0);
  REQUIRE(piped.status == 0);
  // The file is read as text, line by line (an event a line): parsing its ~100 MB as one document takes minutes.
  std::ifstream in(dir / "p.json");
  std::string line;
  size_t xs = 0;
  uint64_t spans = 0;
  while (std::getline(in, line)) {
    xs += line.find("\"ph\":\"X\"") != std::string::npos;
    const size_t at = line.find("\"spans\":");
    if (at != std::string::npos) spans = std::stoull(line.substr(at + 8));
  }
  CHECK(spans == 1000000);  // max_spans: the window holds more
  CHECK(xs == spans);
  // The spans (32 bytes each) and no document of them: kept as one, it took about 1.4 GiB.
  if (!kSanitized) CHECK(mib(piped.peak_kib) < mib(plain.peak_kib) + 32 + 64);
}

TEST_CASE("PLY and OFF files whose counts the file or the budget cannot hold are refused, named",
          "[limits][memory]") {
  const fs::path dir = temp_dir("limits");
  std::ofstream(dir / "huge.ply")
      << "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\n"
         "property float y\nproperty float z\nelement face 1\n"
         "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  CHECK(
      contains(error_of([&] { host::import_mesh((dir / "huge.ply").string()); }),
               "huge.ply: PLY header line 3: element vertex 4000000000: more than the file's 26 bytes of data can "
               "hold (at least 6 bytes each)"));
  std::ofstream(dir / "digits.ply") << "ply\nformat binary_little_endian 1.0\nelement face 123456789012345678901\n"
                                       "property list uchar int vertex_indices\nend_header\n";
  CHECK(contains(error_of([&] { host::import_mesh((dir / "digits.ply").string()); }),
                 "element face of 20 digits or more: more than the file's"));
  // A binary PLY whose data is present (64 bytes per element and per value in Assimp) against a small budget.
  {
    std::ofstream out(dir / "many.ply", std::ios::binary);
    out << "ply\nformat binary_little_endian 1.0\nelement vertex 100000\nproperty float x\nproperty float y\n"
           "property float z\nend_header\n"
        << std::string(1200000, '\0');
  }
  {
    MemoryLimit m("16M");
    CHECK(contains(
        error_of([&] { host::import_mesh((dir / "many.ply").string()); }),
        "many.ply: the PLY header's element counts needs about 25 MiB of memory, above the limit of 16 MiB"));
  }
  std::ofstream(dir / "huge.off") << "OFF\n4000000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  CHECK(contains(error_of([&] { host::import_mesh((dir / "huge.off").string()); }),
                 "huge.off: OFF header: 4000000000 vertices and 1 faces: more than the file's 45 bytes can hold"));
  std::ofstream(dir / "ok.off") << "OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  CHECK(host::import_mesh((dir / "ok.off").string()).size() == 1);
  const rtu::test::Run r = measured_rtusim("", "info --scene " + (dir / "huge.off").string());
  CHECK(r.status == 2);
  CHECK(contains(r.output, "4000000000 vertices"));
  CHECK(mib(r.peak_kib) < 64);
}

// Memory the input does not justify (issue 55): each path below was found taking gigabytes under
// RTU_MEMORY_LIMIT=1G; it is now refused before the memory is taken, or bounded, with a message naming the input
// and the budget.
TEST_CASE("memory limit: timing keys whose caches and units pass the budget are refused", "[limits][memory]") {
  // 256 units of 64 MiB node caches (a 24-byte line record per 64-byte line): 6 GiB of cache state for any ray.
  hw::TimingConfig c;
  c.units = 256;
  c.cache_kib = 65536;
  const uint64_t lines = uint64_t(65536) * 1024 / uint64_t(c.line_bytes);
  CHECK(hw::TimedEngine::state_bytes(c, false) >= 256 * lines * 24);
  // Each part counts: the units' caches, the L2, the walk of sampled timing.
  hw::TimingConfig one;
  const uint64_t base = hw::TimedEngine::state_bytes(one, false);
  one.l2_kib = 1 << 20;  // 1 GiB of L2: 2^24 lines
  CHECK(hw::TimedEngine::state_bytes(one, false) >= base + (uint64_t(1) << 24) * 24);
  hw::TimingConfig big_cache;
  big_cache.cache_kib = 65536;
  CHECK(hw::TimedEngine::state_bytes(big_cache, true) > hw::TimedEngine::state_bytes(big_cache, false));

  const fs::path dir = temp_dir("limits");
  for (const std::string& job : {"trace --rays primary:4x4 --out " + (dir / "h.bin").string(),
                                 "render --width 4 --height 4 --out " + (dir / "i.png").string()}) {
    const rtu::test::Run r = measured_rtusim(
        "RTU_MEMORY_LIMIT=1G", job + " --scene builtin:seed --device timed --set units=256 --set cache_kib=65536");
    INFO(r.output);
    CHECK(r.status == 2);
    CHECK(contains(r.output,
                   "rtusim: error: timing configuration rdna2 (units=256 cache_kib=65536 l2_kib=0 "
                   "ray_slots=32): the timing model needs about "));
    CHECK(contains(r.output, "above the limit of 1024 MiB"));
    CHECK(mib(r.peak_kib) < 64);
  }
  // What fits runs.
  const rtu::test::Run ok =
      run_rtusim("RTU_MEMORY_LIMIT=1G", "trace --rays primary:4x4 --out " + (dir / "h.bin").string() +
                                            " --scene builtin:seed --device timed --set "
                                            "units=4 --set cache_kib=1024");
  INFO(ok.output);
  CHECK(ok.status == 0);
}

TEST_CASE("memory limit: a chip records its units' rays in bounded chunks, with the same hits and cycles",
          "[limits][memory]") {
  const fs::path dir = temp_dir("limits");
  const host::Scene scene = coinciding_scene(dir / "coin.json");  // 1000 instances in one place
  const std::vector<hw::Ray> rays = host::primary_rays(scene.camera, uint64_t(300));
  for (const char* policy : {"waves", "round_robin"}) {
    host::DeviceOptions o;
    o.timing.units = 3;
    o.timing.ray_slots = 8;
    hw::set_timing_key(o.timing, "ray_policy", policy);
    const ChunkedRuns r = run_chunked(scene, rays, o);  // 64 KiB: a few rays per unit's chunk
    size_t same = 0;
    for (size_t i = 0; i < rays.size(); ++i) same += r.same_hits(i);
    CHECK(same == rays.size());
    check_same_cycles(r);
  }

  // From the command line, 10000 instances on 4 units of 8 slots: the chip holds its units' chunks (at most twice
  // 32 MiB of events) and its 32 slots' rays (0.2 MiB each), not 2 x 256 rays per unit (about 460 MiB here).
  // A peak under the sanitizers says nothing (their shadow memory), and the chunked runs above take the same
  // code under them: the run (a minute under ASan) is the default build's only.
  if (!kSanitized) {
    const auto [f, t] = coinciding_peaks(dir, "timed --set units=4 --set ray_slots=8");
    CHECK(mib(t.peak_kib) < mib(f.peak_kib) + 64 + 32);
  }
}

TEST_CASE("memory limit: a mesh file's accessor counts are held to its buffers and the budget",
          "[limits][memory]") {
  // A 600-byte glTF declaring 10^8 line vertices as a sparse accessor (zeros but for one value): Assimp filled and
  // copied them and made a face per pair, 6.5 GiB in its child process, before rtu refused the 5 * 10^7 lines.
  const fs::path dir = temp_dir("limits");
  const std::string head = R"({"asset": {"version": "2.0"},
    "buffers": [{"byteLength": 24, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAA"}],
    "bufferViews": [{"buffer": 0, "byteLength": 4}, {"buffer": 0, "byteOffset": 12, "byteLength": 12},
                    {"buffer": 0, "byteLength": 24}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "mode": 1}]}],
    "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0, "accessors": [)";
  std::ofstream(dir / "sparse.gltf") << head << R"({"componentType": 5126, "count": 100000000, "type": "VEC3",
    "min": [0, 0, 0], "max": [1, 0, 0], "sparse": {"count": 1,
    "indices": {"bufferView": 0, "componentType": 5125}, "values": {"bufferView": 1}}}]})";
  check_refused_early("RTU_MEMORY_LIMIT=1G", "info --scene " + (dir / "sparse.gltf").string(),
                      "sparse.gltf: the glTF accessors' elements needs about 5723 MiB of memory, above the "
                      "limit of 1024 MiB");
  // On a buffer view: the count against the view's bytes, whatever the budget.
  std::ofstream(dir / "lines.gltf") << head << R"({"bufferView": 2, "componentType": 5126, "count": 100000000,
    "type": "VEC3", "min": [0, 0, 0], "max": [1, 0, 0]}]})";
  check_refused_early("", "info --scene " + (dir / "lines.gltf").string(),
                      "lines.gltf: glTF accessor 0: 100000000 elements of 12 bytes need 1200000000 bytes, "
                      "more than its buffer view's 24");
  // The same file with the count its buffer holds imports: one line of two vertices.
  std::ofstream(dir / "ok.gltf") << head << R"({"bufferView": 2, "componentType": 5126, "count": 2,
    "type": "VEC3", "min": [0, 0, 0], "max": [1, 0, 0]}]})";
  CHECK(host::import_model((dir / "ok.gltf").string()).lines.size() == 1);
}

TEST_CASE("memory limit: mesh files' textures are held to the budget beside the scene's", "[limits][memory]") {
  // An OBJ whose material has a 4096 x 4096 texture (64 MiB of texels), placed by five mesh entries of one scene
  // file: each file's textures fit a 300 MiB budget alone, not beside the earlier ones.
  const fs::path dir = temp_dir("limits");
  {
    std::vector<uint8_t> rgb(size_t(4096) * 4096 * 3, 128);
    REQUIRE(stbi_write_jpg((dir / "t.jpg").string().c_str(), 4096, 4096, 3, rgb.data(), 50) != 0);
  }
  std::ofstream(dir / "m.mtl") << "newmtl skin\nKd 1 1 1\nmap_Kd t.jpg\n";
  std::ofstream(dir / "m.obj") << "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                  "usemtl skin\nf 1/1 2/2 3/3\n";
  std::string meshes;
  for (int i = 0; i < 5; ++i) meshes += std::string(i ? ", " : "") + R"({"file": "m.obj"})";
  std::ofstream(dir / "s.json") << R"({"materials": {"m": {}}, "meshes": [)" << meshes << "]}";
  const rtu::test::Run r = measured_rtusim("RTU_MEMORY_LIMIT=300M", "info --scene " + (dir / "s.json").string());
  INFO(r.output);
  // Past the budget a file's texture is not used (a warning naming the budget); the geometry imports.
  CHECK(r.status == 0);
  CHECK(contains(r.output, "m.obj: texture not used: "));
  CHECK(contains(r.output, "m.obj: 1 textures so far beside the scene's 192 MiB of textures needs about 320 MiB"));
  CHECK(contains(r.output, "above the limit of 300 MiB"));
  if (!kSanitized) CHECK(mib(r.peak_kib) < 300 + mib(baseline_kib()));
}

TEST_CASE("memory limit: sweep's text inputs are held to the budget before they are read", "[limits][memory]") {
  const fs::path dir = temp_dir("limits");
  {
    // 96 MiB of one 256-byte line repeated: a points file, a manifest, a sweep CSV.
    std::ofstream out(dir / "big.txt", std::ios::binary);
    std::string line = "builtin:seed\tdefault\t4\trdna2";
    line += std::string(255 - line.size(), ' ') + "\n";
    for (uint64_t b = 0; b < (uint64_t(96) << 20); b += line.size()) out << line;
  }
  const std::string big = (dir / "big.txt").string();
  for (const std::string& args :
       {"sweep --points " + big + " --write-manifest " + (dir / "m.txt").string(),
        "sweep --manifest " + big + " --collect " + dir.string() + " --out " + (dir / "o.csv").string(),
        "sweep --merge " + big + " --out " + (dir / "o.csv").string(),
        "pareto --sweep " + big + " --out " + (dir / "p").string()}) {
    const rtu::test::Run r = measured_rtusim("RTU_MEMORY_LIMIT=256M", args);
    INFO(args);
    INFO(r.output);
    CHECK(r.status == 2);
    CHECK(contains(r.output,
                   "big.txt: reading a 96 MiB file needs about 384 MiB of memory, above the limit of "
                   "256 MiB"));
    CHECK(mib(r.peak_kib) < 64);
  }
  // A directory is named as such, with its path.
  for (const std::string& args :
       {"pareto --sweep " + dir.string() + " --out " + (dir / "p").string(),
        "trace --scene builtin:seed --rays " + dir.string() + " --out " + (dir / "h.bin").string()}) {
    const rtu::test::Run r = run_rtusim(args);
    INFO(r.output);
    CHECK(r.status == 2);
    CHECK(contains(r.output, dir.string() + ": is a directory, not a file"));
  }
}

TEST_CASE("memory: a mesh import that runs out of memory says so, not std::bad_alloc", "[limits][memory]") {
  if (kSanitized) {
    WARN("AddressSanitizer reserves more address space than the limit below: skipped");
    return;
  }
  // A 14 MB OBJ passes the budget's estimate under a 200 MB address space (8 times the file) but Assimp takes
  // more than that to import it: the child's std::bad_alloc, reported as Assimp's error or as the exception.
  const fs::path dir = temp_dir("limits");
  const std::string obj = (dir / "oom.obj").string();
  {
    std::ofstream f(obj);
    const int n = 420000;
    for (int i = 0; i < n; ++i) f << "v " << i % 1000 << ' ' << (i / 1000) % 1000 << ' ' << i % 7 << '\n';
    for (int i = 1; i + 2 <= n; ++i) f << "f " << i << ' ' << i + 1 << ' ' << i + 2 << '\n';
  }
  const rtu::test::Run r =
      rtu::test::run_process("ulimit -v 200000; " + std::string(RTUSIM_EXE) + " info --scene " + obj);
  INFO(r.output);
  CHECK(r.status == 2);
  CHECK(contains(r.output, obj + ": importing the mesh: out of memory"));
  CHECK(contains(r.output, "RTU_MEMORY_LIMIT"));
  CHECK_FALSE(contains(r.output, "std::bad_alloc"));
}
