// Watertightness of the float reference: rays from inside the closed icosphere aimed exactly at its vertices and
// at points on its edges never escape (zero leaks), centered and 2.7e5 units from the origin.
#include <catch2/catch.hpp>

#include "host/scene.h"
#include "hwmodel/float_tracer.h"
#include "hwmodel/rng.h"

using namespace rtu;

namespace {

void check_closed(const std::string& spec, uint64_t n_rays, uint64_t seed) {
  const host::Scene scene = host::load_scene(spec);
  const hw::Geometry& g = scene.geometry;
  REQUIRE(g.triangles.size() >= 1280);
  const hw::Aabb b = g.bounds();
  const hw::Vec3 center = b.center();
  const float radius = 0.5f * b.extent().x;
  for (int width : {2, 4, 8}) {
    hw::TracerOptions opt;
    opt.accel = hw::AccelMode::kBvh;
    opt.bvh.width = width;
    const hw::FloatTracer tracer(g, opt);
    hw::Pcg32 rng(seed);
    std::vector<hw::Ray> rays(n_rays / 3);
    for (hw::Ray& r : rays) {
      const hw::Triangle& t = g.triangles[rng.next_u32() % g.triangles.size()];
      const int k = int(rng.next_u32() % 3);
      const hw::Vec3& a = k == 0 ? t.v0 : (k == 1 ? t.v1 : t.v2);
      const hw::Vec3& c = k == 0 ? t.v1 : (k == 1 ? t.v2 : t.v0);
      // Half the rays at a vertex exactly, half at a point of an edge (rounded to float, within an ulp of it).
      const float s = (rng.next_u32() & 1) ? 0.0f : rng.next_float();
      const hw::Vec3 target = a + s * (c - a);
      hw::Vec3 o;
      for (int ax = 0; ax < 3; ++ax) o[ax] = center[ax] + (rng.next_float() - 0.5f) * radius;
      r = hw::Ray{o, 0.0f, target - o, std::numeric_limits<float>::infinity()};
    }
    std::vector<hw::Hit> hits(rays.size());
    hw::TraversalStats stats;
    tracer.trace_batch(rays.data(), hits.data(), rays.size(), false, 0, stats);
    uint64_t leaks = 0;
    size_t first = 0;
    for (size_t i = 0; i < hits.size(); ++i) {
      if (!hits[i].hit()) {
        if (leaks++ == 0) first = i;
      }
    }
    INFO(spec << " width " << width << ": " << leaks << " leaks of " << rays.size() << ", first ray " << first
              << " seed " << seed);
    CHECK(stats.invalid_rays == 0);
    CHECK(leaks == 0);
  }
}

}  // namespace

TEST_CASE("float reference is watertight on the centered icosphere", "[float][watertight]") {
  check_closed("builtin:icosphere", 3000000, 1);
}

TEST_CASE("float reference is watertight on the far-offset icosphere", "[float][watertight]") {
  check_closed("builtin:icosphere_far", 3000000, 2);
}
