#include "host/jobs/soak.h"

#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>

#include "host/devices/direct_device.h"
#include "host/io/error.h"
#include "host/jobs/render.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

namespace {

uint64_t fnv(const void* p, size_t n, uint64_t h) {
  const auto* b = static_cast<const uint8_t*>(p);
  for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 0x100000001b3ull;
  return h;
}

// A random valid scene: 0-300 triangles, 0-8 spheres, 0-2 planes (at least one primitive), each of the four
// material kinds, 0-2 point lights and an area light sometimes, at a random scale (1e-3 .. 1e4) and offset.
Scene random_scene(hw::Pcg32& rng) {
  auto uni = [&](float lo, float hi) { return lo + (hi - lo) * rng.next_float(); };
  auto pick = [&](uint32_t n) { return rng.next_u32() % n; };
  const float scale = std::pow(10.0f, uni(-3.0f, 4.0f));
  const hw::Vec3 offset = hw::Vec3(uni(-1, 1), uni(-1, 1), uni(-1, 1)) * scale * uni(0.0f, 100.0f);
  auto point = [&] { return offset + scale * hw::Vec3(uni(-1, 1), uni(-1, 1), uni(-1, 1)); };
  Scene s;
  s.name = "soak";
  auto material = [](const char* name, MaterialType type, float color, float ior, float emission) {
    return Material{
        .name = name, .type = type, .color = hw::Vec3(color), .ior = ior, .emission = hw::Vec3(emission)};
  };
  s.materials = {material("diffuse", MaterialType::kDiffuse, 0.7f, 1.5f, 0.0f),
                 material("mirror", MaterialType::kMirror, 0.9f, 1.5f, 0.0f),
                 material("glass", MaterialType::kGlass, 1.0f, 1.45f, 0.0f),
                 material("light", MaterialType::kEmissive, 0.0f, 1.5f, 4.0f)};
  hw::Geometry& g = s.geometry;
  const uint32_t nt = pick(301), ns = pick(9), np = pick(3);
  const float size = uni(0.01f, 0.5f);  // triangle size relative to the scene
  for (uint32_t i = 0; i < nt; ++i) {
    const hw::Vec3 a = point();
    auto near = [&] { return a + size * scale * hw::Vec3(uni(-1, 1), uni(-1, 1), uni(-1, 1)); };
    g.triangles.push_back({a, near(), near()});
  }
  for (uint32_t i = 0; i < ns; ++i) g.spheres.push_back({point(), scale * uni(0.01f, 0.5f)});
  for (uint32_t i = 0; i < np; ++i) {
    hw::Vec3 n(uni(-1, 1), uni(-1, 1), uni(-1, 1));
    if (n == hw::Vec3(0.0f)) n = hw::Vec3(0, 1, 0);
    g.planes.push_back({n, uni(-1, 1) * scale + (n.x * offset.x + n.y * offset.y + n.z * offset.z)});
  }
  if (g.num_prims() == 0) g.spheres.push_back({offset, scale});
  s.prim_material.resize(g.num_prims());
  for (uint32_t& m : s.prim_material) m = pick(4);
  for (uint32_t i = pick(3); i > 0; --i) {
    Light l;
    l.position = point() + hw::Vec3(0, 2 * scale, 0);
    l.intensity = hw::Vec3(scale * scale * uni(1, 50));
    s.lights.push_back(l);
  }
  s.camera = frame_camera(g.bounds());
  s.camera.width = 16;
  s.camera.height = 12;
  finish_scene(s);
  return s;
}

}  // namespace

SoakResult soak(const SoakOptions& o) {
  SoakResult res;
  res.digest = 0xcbf29ce484222325ull;
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  const std::vector<hw::FixedFormat>& formats = hw::format_presets();
  const std::vector<std::string>& timings = hw::timing_preset_names();
  for (uint64_t it = 0;; ++it) {
    if (it > 0 && (elapsed() >= o.seconds || (o.max_iterations && it >= o.max_iterations))) break;
    const uint64_t seed = o.seed + it;
    hw::Pcg32 rng(seed);
    const Scene scene = random_scene(rng);
    DeviceOptions fixed;
    fixed.kind = hw::DeviceKind::kFixed;
    fixed.format = formats[rng.next_u32() % formats.size()];
    static constexpr int kWidths[] = {2, 4, 6, 8};
    fixed.format.width = kWidths[rng.next_u32() % 4];
    fixed.tracer.bvh.width = fixed.format.width;
    fixed.tracer.bvh.max_leaf_size = 1 + int(rng.next_u32() % 8);
    DeviceOptions timed = fixed;
    timed.kind = hw::DeviceKind::kTimed;
    timed.timing = hw::timing_preset(timings[rng.next_u32() % timings.size()]);
    timed.timing.format = fixed.format.name;
    timed.timing.bvh_width = fixed.format.width;
    const std::string setup = "seed " + std::to_string(seed) + ": " + std::to_string(scene.geometry.num_prims()) +
                              " primitives, format " + fixed.format.name + " width " +
                              std::to_string(fixed.format.width) + ", timing " + timed.timing.name;
    if (o.verbose) std::fprintf(stderr, "soak: iteration %llu, %s\n", (unsigned long long)it, setup.c_str());
    auto mismatch = [&](const std::string& what) { res.mismatches.push_back(setup + ": " + what); };

    std::vector<hw::Ray> rays = incoherent_rays(scene.geometry.bounds(), 400, seed);
    const std::vector<hw::Ray> primary = primary_rays(scene.camera, 16, 12);
    rays.insert(rays.end(), primary.begin(), primary.end());

    // Two runs of each device, fresh each time, 1 and 2 threads.
    std::vector<hw::Hit> hits[2][2];  // [device fixed/timed][run]
    uint64_t cycles[2] = {0, 0};
    for (int dev = 0; dev < 2; ++dev) {
      for (int run = 0; run < 2; ++run) {
        const std::unique_ptr<DirectDevice> d = make_device(scene.geometry, dev == 0 ? fixed : timed);
        if (dev == 0 && run == 0 && d->bvh()) ++res.scenes_with_bvh;
        hits[dev][run].resize(rays.size());
        hw::TraversalStats s;
        d->trace_batch(rays.data(), hits[dev][run].data(), rays.size(), false, run + 1, s);
        if (dev == 1) {
          const uint64_t c = d->timed()->timing().cycles;
          if (run == 1 && c != cycles[0])
            mismatch("timed cycles differ between runs: " + std::to_string(cycles[0]) + " and " +
                     std::to_string(c));
          cycles[run] = c;
        }
      }
      if (std::memcmp(hits[dev][0].data(), hits[dev][1].data(), rays.size() * sizeof(hw::Hit)) != 0)
        mismatch(std::string(dev == 0 ? "fixed" : "timed") + " hits differ between runs");
    }
    if (std::memcmp(hits[0][0].data(), hits[1][0].data(), rays.size() * sizeof(hw::Hit)) != 0)
      mismatch("timed hits differ from fixed hits");
    res.digest = fnv(hits[1][0].data(), rays.size() * sizeof(hw::Hit), res.digest);
    res.digest = fnv(&cycles[0], sizeof cycles[0], res.digest);
    res.rays += 4 * rays.size();
    res.cycles += cycles[0];

    // The firmware renderer on the timed device, twice (1 and 2 worker threads).
    RenderResult r[2];
    const int spp = 1 + int(rng.next_u32() % 2);
    for (int run = 0; run < 2; ++run) {
      RenderOptions ro;
      ro.device = timed;
      ro.threads = run + 1;
      ro.spp = spp;
      ro.max_depth = 2;
      ro.seed = uint32_t(seed);
      ro.ao = (seed % 3) == 0;
      r[run] = render(scene, ro);
    }
    if (r[0].rgb.size() != r[1].rgb.size() ||
        std::memcmp(r[0].rgb.data(), r[1].rgb.data(), r[0].rgb.size() * sizeof(float)) != 0)
      mismatch("rendered pixels differ between runs");
    if (r[0].device_clock != r[1].device_clock || r[0].timing.cycles != r[1].timing.cycles)
      mismatch("render cycles differ between runs: " + std::to_string(r[0].device_clock) + " and " +
               std::to_string(r[1].device_clock));
    res.digest = fnv(r[0].rgb.data(), r[0].rgb.size() * sizeof(float), res.digest);
    res.digest = fnv(&r[0].device_clock, sizeof r[0].device_clock, res.digest);
    res.renders += 2;
    res.pixels += 2 * uint64_t(r[0].width) * uint64_t(r[0].height);
    res.cycles += r[0].device_clock;
    res.prims += scene.geometry.num_prims();
    ++res.iterations;
  }
  res.seconds = elapsed();
  return res;
}

}  // namespace rtu::host
