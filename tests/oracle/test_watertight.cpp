// Watertightness: rays from inside the closed icosphere aimed exactly at its vertices and at points on its edges
// never escape (zero leaks), centered and 2.7e5 units from the origin. The float reference, and the fixed
// device at the default format: with world rays (through ray setup: the ray and the mesh are both quantized,
// and a closed mesh stays closed because shared vertices quantize alike) and with rays built on the grid that
// pass exactly through quantized vertices and edge points (where the integer edge functions are exactly 0).
#include <catch2/catch.hpp>

#include <cstring>

#include "host/scene/scene.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/rng.h"

using namespace rtu;

namespace {

// Rays from inside, aimed exactly (up to float rounding) at vertices and edge points of the mesh.
std::vector<hw::Ray> rays_at_edges(const hw::Geometry& g, size_t n, uint64_t seed) {
  const hw::Aabb b = g.bounds();
  const hw::Vec3 center = b.center();
  const float radius = 0.5f * b.extent().x;
  hw::Pcg32 rng(seed);
  std::vector<hw::Ray> rays(n);
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
  return rays;
}

uint64_t count_leaks(const std::vector<hw::Hit>& hits, size_t& first) {
  uint64_t leaks = 0;
  for (size_t i = 0; i < hits.size(); ++i) {
    if (!hits[i].hit() && leaks++ == 0) first = i;
  }
  return leaks;
}

void check_closed(const std::string& spec, uint64_t n_rays, uint64_t seed) {
  const host::Scene scene = host::load_scene(spec);
  const hw::Geometry& g = scene.geometry;
  REQUIRE(g.triangles.size() >= 1280);
  const std::vector<hw::Ray> rays = rays_at_edges(g, n_rays / 3, seed);
  for (int width : {2, 4, 6, 8}) {
    hw::TracerOptions opt;
    opt.accel = hw::AccelMode::kBvh;
    opt.bvh.width = width;
    const hw::FloatTracer tracer(g, opt);
    std::vector<hw::Hit> hits(rays.size());
    hw::TraversalStats stats;
    tracer.trace_batch(rays.data(), hits.data(), rays.size(), false, 0, stats);
    size_t first = 0;
    const uint64_t leaks = count_leaks(hits, first);
    INFO(spec << " width " << width << ": " << leaks << " leaks of " << rays.size() << ", first ray " << first
              << " seed " << seed);
    CHECK(stats.invalid_rays == 0);
    CHECK(leaks == 0);
  }
}

// The fixed device: n_world world rays (as above) and n_grid rays built on the grid per width, in `format`'s
// bits and layouts (its width replaced).
void check_closed_fixed(const std::string& spec, uint64_t n_world, uint64_t n_grid, uint64_t seed,
                        const std::string& format = "default") {
  const host::Scene scene = host::load_scene(spec);
  const hw::Geometry& g = scene.geometry;
  REQUIRE(g.triangles.size() >= 1280);
  const std::vector<hw::Ray> rays = rays_at_edges(g, n_world / 3, seed);
  for (int width : {2, 4, 6, 8}) {
    hw::FixedFormat f = hw::format_from_spec(format);
    f.width = width;
    hw::BvhBuildParams bp;
    bp.width = width;
    const hw::Bvh bvh = hw::Bvh::build(g, bp);
    const hw::DeviceImage img = hw::encode_scene(g, f, &bvh);
    const hw::FixedTracer tracer(img);

    std::vector<hw::Hit> hits(rays.size());
    hw::TraversalStats stats;
    tracer.trace_batch(rays.data(), hits.data(), rays.size(), false, 0, stats);
    size_t first = 0;
    uint64_t leaks = count_leaks(hits, first);
    INFO(spec << " fixed " << format << ", width " << width << ", world rays: " << leaks << " leaks of "
              << rays.size() << ", first ray " << first << " seed " << seed);
    CHECK(stats.invalid_rays == 0);
    CHECK(leaks == 0);

    // Grid rays: target = a quantized vertex, or the point a + (c - a) j / 2^F of a quantized edge (exact in
    // grid.F); origin = target - delta with delta a random vector pointing away from the mesh center, at most
    // 2^20 raw units (2^12 grid steps, 2^-12 of the extent: inside the sphere); direction = delta scaled up by
    // a power of two, exact. So the ray passes exactly through the vertex or edge point.
    const int F = f.frac_bits, D = f.dir_bits;
    hw::FixedRay proto;
    REQUIRE(hw::setup_ray(hw::Ray{g.bounds().center(), 0.0f, hw::Vec3(1.0f, 0.0f, 0.0f), INFINITY}, tracer.frame(),
                          f, proto) == hw::RayStatus::kOk);
    int64_t center[3];
    for (int a = 0; a < 3; ++a) center[a] = proto.o[a];
    hw::Pcg32 rng(seed * 7 + uint64_t(width));
    const uint32_t n_rec = img.header().record_count;
    uint64_t grid_leaks = 0, edge_rays = 0;
    hw::TraversalStats gs;
    for (uint64_t i = 0; i < n_grid; ++i) {
      hw::TriangleRecord rec;
      std::memcpy(&rec, img.record(rng.next_u32() % n_rec), sizeof rec);
      const int k = int(rng.next_u32() % 3);
      const int32_t* a = rec.v[k];
      const int32_t* c = rec.v[(k + 1) % 3];
      const int64_t j = (rng.next_u32() & 1) ? 0 : int64_t(rng.next_u32() % ((1u << F) + 1));
      edge_rays += j != 0;
      int64_t target[3], delta[3];
      int64_t out_max = 0;
      for (int ax = 0; ax < 3; ++ax) {
        target[ax] = (int64_t(a[ax]) << F) + (int64_t(c[ax]) - a[ax]) * j;
        out_max = std::max(out_max, std::abs(target[ax] - center[ax]));
      }
      int sh = 0;
      while ((out_max >> sh) > (int64_t(1) << 19)) ++sh;
      int64_t dmax = 0;
      for (int ax = 0; ax < 3; ++ax) {
        delta[ax] = ((target[ax] - center[ax]) >> sh) + int64_t(rng.next_u32() % 4097) - 2048;
        dmax = std::max(dmax, std::abs(delta[ax]));
      }
      int up = 0;
      while ((dmax << (up + 1)) <= (int64_t(1) << D)) ++up;
      hw::FixedRay r = proto;
      int64_t d[3];
      for (int ax = 0; ax < 3; ++ax) {
        r.o[ax] = target[ax] - delta[ax];
        d[ax] = delta[ax] << up;
      }
      hw::set_direction(r, d, f);
      r.tmin = 0;
      r.tmax = r.t_limit;
      if (!tracer.trace_fixed(r, false, gs).hit()) {
        if (grid_leaks++ == 0) first = i;
      }
    }
    INFO(spec << " fixed " << format << ", width " << width << ", grid rays: " << grid_leaks << " leaks of "
              << n_grid << " (" << edge_rays << " at edge points), first " << first);
    CHECK(grid_leaks == 0);
    CHECK(gs.saturations == 0);
  }
}

}  // namespace

TEST_CASE("float reference is watertight on the centered icosphere", "[float][watertight]") {
  check_closed("builtin:icosphere", 3000000, 1);
}

TEST_CASE("float reference is watertight on the far-offset icosphere", "[float][watertight]") {
  check_closed("builtin:icosphere_far", 3000000, 2);
}

TEST_CASE("fixed device is watertight on the centered icosphere", "[fixed][watertight]") {
  check_closed_fixed("builtin:icosphere", 600000, 350000, 3);
}

TEST_CASE("fixed device is watertight on the far-offset icosphere", "[fixed][watertight]") {
  check_closed_fixed("builtin:icosphere_far", 600000, 350000, 4);
}

// Triangle blocks store each leaf's vertices against the block's own anchor: a vertex shared by two blocks must
// decode to the same grid point in both, or rays leak between them. Bit-packed and compressed-wide nodes.
TEST_CASE("fixed device with triangle blocks is watertight on the icospheres", "[fixed][watertight]") {
  check_closed_fixed("builtin:icosphere", 300000, 150000, 5, "packed");
  check_closed_fixed("builtin:icosphere_far", 300000, 150000, 6, "cwbvh");
}

// Oriented nodes change only which boxes contain what: a closed mesh stays closed.
TEST_CASE("fixed device with oriented nodes is watertight on the icospheres", "[fixed][watertight][obb]") {
  check_closed_fixed("builtin:icosphere", 200000, 100000, 7, "default:node_kind=1");
  check_closed_fixed("builtin:icosphere_far", 200000, 100000, 8, "default:node_kind=1");
}
