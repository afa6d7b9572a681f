#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "host/io/error.h"
#include "host/scene/scene.h"
#include "tests/common/test_util.h"
#include "tests/fuzz/fuzz.h"

namespace rtu::fuzz {

namespace {
std::string g_dir;
}

void init() {
  if (!g_dir.empty()) return;
  ::setenv("RTU_MEMORY_LIMIT", "256M", 0);
  ::setenv("RTU_IMPORT_TIMEOUT", "10", 0);  // below libFuzzer's -timeout=30: an importer hang is an Error
  g_dir = test::temp_dir("fuzz").string();
  std::atexit([] {
    std::error_code ec;
    std::filesystem::remove_all(g_dir, ec);
  });
}

std::string scratch_file(const std::string& name, const uint8_t* data, size_t size) {
  init();
  const std::string path = g_dir + "/" + name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  out.close();
  if (!out) {
    std::fprintf(stderr, "rtu fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
  return path;
}

const hw::Geometry& tiny_geometry() {
  static const hw::Geometry g = [] {
    hw::Geometry t = host::load_scene("builtin:icosphere?subdiv=1").geometry;
    t.spheres = {{hw::Vec3(1.5f, 0.0f, 0.0f), 0.5f}, {hw::Vec3(-1.0f, 1.0f, 0.5f), 0.25f}};
    t.planes = {{hw::Vec3(0.0f, 1.0f, 0.0f), 1.5f}};
    return t;
  }();
  return g;
}

std::vector<hw::Ray> rays_around(const hw::Aabb& b, size_t n, uint64_t seed) {
  uint64_t s = seed * 0x9E3779B97F4A7C15ull + 1;
  auto next = [&] {
    s = s * 6364136223846793005ull + 1442695040888963407ull;
    return float(double(s >> 40) / double(1ull << 24));  // [0, 1)
  };
  const hw::Vec3 lo = b.lo - 0.5f * (b.hi - b.lo), span = 2.0f * (b.hi - b.lo);
  std::vector<hw::Ray> rays;
  for (size_t i = 0; i < n; ++i) {
    const hw::Vec3 o = lo + hw::Vec3(next(), next(), next()) * span;
    const hw::Vec3 target = b.lo + hw::Vec3(next(), next(), next()) * (b.hi - b.lo);
    hw::Vec3 d = target - o;
    if (d == hw::Vec3(0.0f)) d = hw::Vec3(0.0f, 0.0f, 1.0f);
    rays.push_back(hw::Ray{o, 0.0f, d, 1e30f});
  }
  return rays;
}

}  // namespace rtu::fuzz
