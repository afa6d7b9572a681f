// Scene images as BIND_SCENE finds them in device memory: DeviceImage::from_bytes (fixed and timed devices) and
// decode_float_scene (float device). An accepted image must be safe to trace: rays inside its frame give hits
// naming one of its primitives, the traversal stays within its step bound, and the timed engine's hits equal the
// fixed tracer's bit for bit. The first byte picks which decoder sees the rest.
#include <cmath>
#include <stdexcept>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/instanced_fixed.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "tests/fuzz/fuzz.h"

namespace rtu::fuzz {

namespace {

// Rays between random grid points of the image's frame (so they pass ray setup and reach the nodes).
std::vector<hw::Ray> rays_in_frame(const hw::DeviceImage& img, size_t n) {
  const hw::QuantFrame q = img.frame();
  hw::Aabb b;
  const int64_t top = (int64_t(1) << q.bits) - 1;
  for (int a = 0; a < 3; ++a) {
    b.lo[a] = float(q.to_world(0, a));
    b.hi[a] = float(q.to_world(top, a));
  }
  return rays_around(b, n, img.size());
}

}  // namespace

int device_image(const uint8_t* data, size_t size) {
  init();
  if (size < 1) return 0;
  const bool fixed = data[0] % 2 == 0;
  ++data;
  --size;
  if (!fixed) {
    hw::Geometry g;
    try {
      g = hw::decode_float_scene(data, size);
    } catch (const std::invalid_argument&) {
      return 0;
    }
    if (g.num_prims() > 4096) return 0;
    const hw::FloatTracer t(g, hw::TracerOptions{});
    const std::vector<hw::Ray> rays =
        rays_around(g.bounds().empty() ? hw::Aabb{hw::Vec3(-1.0f), hw::Vec3(1.0f)} : g.bounds(), 16, size);
    std::vector<hw::Hit> hits(rays.size());
    hw::TraversalStats s;
    t.trace_batch(rays.data(), hits.data(), rays.size(), false, 1, s);
    for (const hw::Hit& h : hits) RTU_FUZZ_CHECK(h.prim == hw::kMissPrim || h.prim < g.num_prims());
    return 0;
  }
  if (hw::is_two_level(data, size)) {  // an instanced scene's two levels: traced as the engines trace them
    std::unique_ptr<hw::InstancedFixedTracer> two;
    try {
      two = hw::InstancedFixedTracer::from_bytes(data, size);
    } catch (const std::invalid_argument&) {
      return 0;
    }
    const hw::ImageHeader& th = two->top().header();
    const uint64_t nprims = uint64_t(th.num_triangles) + th.num_spheres + th.plane_count;
    const std::vector<hw::Ray> rays = rays_in_frame(two->top(), 16);
    std::vector<hw::Hit> hits(rays.size()), timed(rays.size());
    hw::TraversalStats s;
    two->trace_batch(rays.data(), hits.data(), rays.size(), false, 1, s);
    RTU_FUZZ_CHECK(s.watchdog_rays == 0);  // every level a tree
    for (const hw::Hit& x : hits) RTU_FUZZ_CHECK(x.prim == hw::kMissPrim || x.prim < nprims);
    hw::TimedEngine e(hw::EngineOptions{}, hw::TimingConfig{});
    e.bind(data, size);
    hw::TraversalStats st;
    e.trace_cycles(rays.data(), timed.data(), rays.size(), false, st, 0, 0);
    RTU_FUZZ_CHECK(std::memcmp(hits.data(), timed.data(), hits.size() * sizeof(hw::Hit)) == 0);
    return 0;
  }
  hw::DeviceImage img;
  try {
    img = hw::DeviceImage::from_bytes(data, size);
  } catch (const std::invalid_argument&) {
    return 0;
  }
  const hw::ImageHeader& h = img.header();
  const uint64_t nprims = uint64_t(h.num_triangles) + h.num_spheres + h.plane_count;
  const hw::FixedTracer t(img);
  const std::vector<hw::Ray> rays = rays_in_frame(img, 16);
  std::vector<hw::Hit> hits(rays.size()), timed(rays.size());
  hw::TraversalStats s;
  t.trace_batch(rays.data(), hits.data(), rays.size(), false, 1, s);
  RTU_FUZZ_CHECK(s.watchdog_rays == 0);  // a tree: every node at most once
  RTU_FUZZ_CHECK(s.nodes_visited + s.leaves_visited <= rays.size() * t.step_limit());
  for (const hw::Hit& x : hits) RTU_FUZZ_CHECK(x.prim == hw::kMissPrim || x.prim < nprims);

  hw::TimedEngine e(hw::EngineOptions{}, hw::TimingConfig{});
  if (h.flags & hw::kImageTopLevel) {
    // Without its bottom levels a top level's instance records find nothing, and no engine binds it.
    for (const hw::Hit& x : hits)
      RTU_FUZZ_CHECK(x.prim == hw::kMissPrim || x.prim >= h.num_triangles + h.num_spheres);
    bool refused = false;
    try {
      e.bind(data, size);
    } catch (const std::invalid_argument&) {
      refused = true;
    }
    RTU_FUZZ_CHECK(refused);
    return 0;
  }
  e.bind(data, size);
  hw::TraversalStats st;
  e.trace_cycles(rays.data(), timed.data(), rays.size(), false, st, 0, 0);
  RTU_FUZZ_CHECK(std::memcmp(hits.data(), timed.data(), hits.size() * sizeof(hw::Hit)) == 0);
  return 0;
}

}  // namespace rtu::fuzz

RTU_FUZZ_ENTRY(device_image)
