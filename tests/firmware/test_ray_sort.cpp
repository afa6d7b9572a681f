// Ray sorting on the controller alone (firmware/ray_sort.h): keys worked by hand, the radix sort against
// std::stable_sort, the hits back in ray order, and the firmware's keys against the cost model's table.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "firmware/ray_sort.h"
#include "hwmodel/timing/sort_timing.h"
#include "tests/firmware/mock_hal.h"

using namespace rtu::fw;
using rtu::hw::Hit;
using rtu::hw::Ray;
using rtu::hw::Vec3;

namespace {

constexpr float kInf = __builtin_inff();

RaySortJob unit_box_job(RaySortKey key, uint32_t radix_bits = 8) {
  RaySortJob j{};
  j.key = uint32_t(key);
  j.radix_bits = radix_bits;
  j.lo = {0.0f, 0.0f, 0.0f};
  j.hi = {1.0f, 1.0f, 1.0f};
  j.distance = 0.5f;
  return j;
}

uint32_t key_of(RaySortKey key, Vec3 o, Vec3 d, float tmax = kInf) {
  return rtu::fw::ray_sort_key(unit_box_job(key), Ray{o, 0.0f, d, tmax});
}

}  // namespace

TEST_CASE("ray sort keys worked by hand", "[sort]") {
  using K = RaySortKey;
  // Origin: 10 bits an axis of the unit box, x's bit above y's above z's at each level.
  CHECK(key_of(K::kOrigin, Vec3(0.0f), Vec3(1, 0, 0)) == 0);
  CHECK(key_of(K::kOrigin, Vec3(1.0f), Vec3(1, 0, 0)) == (1u << 30) - 1);  // the top cell, clamped
  CHECK(key_of(K::kOrigin, Vec3(0.5f, 0, 0), Vec3(1, 0, 0)) == 1u << 29);  // x = 512: bit 9 of x
  CHECK(key_of(K::kOrigin, Vec3(0, 0.5f, 0), Vec3(1, 0, 0)) == 1u << 28);
  CHECK(key_of(K::kOrigin, Vec3(0, 0, 1.0f / 1024), Vec3(1, 0, 0)) == 1u);  // z = 1: bit 0 of z
  CHECK(key_of(K::kOrigin, Vec3(-5.0f, 0, 0), Vec3(1, 0, 0)) == 0);         // outside: clamped
  // Direction: octant (x, y, z negative) in bits 26..28, then |dx| / |d|_1 and |dy| / |d|_1 at 13 bits each.
  CHECK(key_of(K::kDirection, Vec3(0.0f), Vec3(0, 0, -2)) == 1u << 26);
  CHECK(key_of(K::kDirection, Vec3(0.0f), Vec3(0, -1, 0)) == ((2u << 26) | 0x1555555u));  // v = 8191: odd bits
  CHECK(key_of(K::kDirection, Vec3(0.0f), Vec3(-3, 0, 0)) == ((4u << 26) | 0x2AAAAAAu));  // u = 8191: even bits
  CHECK(key_of(K::kDirection, Vec3(0.0f), Vec3(0, 0, 0)) == 0);                           // no direction
  // Origin and direction: six 5-bit coordinates, origin x highest at each level. d = +z: dz / |d|_1 = 1 is the
  // top cell (31), dx and dy = 0 the middle one (16: bit 4 only).
  const uint32_t dz_top = 0x1041041u, mid = 1u << 24;  // dz: bit 0 of every level; dx, dy: level 4 only
  CHECK(key_of(K::kOriginDirection, Vec3(0.0f), Vec3(0, 0, 1)) == (dz_top | (mid << 2) | (mid << 1)));
  // Termination: o + min(tmax, L / |d|) d with L = 0.5: from the origin along +x the point (0.5, 0, 0); a shadow
  // ray of tmax 0.25 ends at (0.25, 0, 0) (x = 256: bit 8 of x).
  CHECK(key_of(K::kTermination, Vec3(0.0f), Vec3(4, 0, 0)) == 1u << 29);
  CHECK(key_of(K::kTermination, Vec3(0.0f), Vec3(1, 0, 0), 0.25f) == 1u << 26);
}

TEST_CASE("the firmware's sort keys are the cost model's", "[sort]") {
  REQUIRE(rtu::hw::kRaySortKeys.size() == rtu::fw::kRaySortKeyCount);
  for (uint32_t k = 0; k < rtu::fw::kRaySortKeyCount; ++k) {
    INFO(rtu::hw::kRaySortKeys[k].name);
    CHECK(rtu::fw::ray_sort_key_bits(RaySortKey(k)) == uint32_t(rtu::hw::kRaySortKeys[k].bits));
  }
  CHECK(std::string(rtu::hw::kRaySortKeys[uint32_t(RaySortKey::kOriginDirection)].name) == "origin_direction");
  CHECK(std::string(rtu::hw::kRaySortKeys[uint32_t(RaySortKey::kTermination)].name) == "termination");
}

TEST_CASE("the radix sort orders rays by key, stably, and puts the hits back", "[sort]") {
  const uint32_t seed = 42;
  INFO("seed " << seed);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-0.2f, 1.2f);
  for (uint32_t radix : {1u, 3u, 8u, 16u}) {  // odd and even pass counts (30 bits: 30, 10, 4, 2 passes)
    for (RaySortKey key :
         {RaySortKey::kOrigin, RaySortKey::kDirection, RaySortKey::kOriginDirection, RaySortKey::kTermination}) {
      INFO("radix " << radix << ", key " << uint32_t(key));
      const RaySortJob job = unit_box_job(key, radix);
      const uint32_t n = 500, capacity = 700, place = 123;
      std::vector<Ray> rays(n);
      for (uint32_t i = 0; i < n; ++i) {
        // Few distinct origins, so that equal keys are common and stability shows.
        const float o = float(i % 7) / 7.0f;
        rays[i] = Ray{Vec3(o, u(rng), o), 0.0f, Vec3(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f), kInf};
      }
      rtu::test::MockHal hal(size_t(1) << 20);
      rtu::fw::Arena arena(0, hal.mem_size());
      rtu::fw::SortStats st;
      rtu::fw::RaySorter sorter;
      REQUIRE(sorter.init(hal, arena, job, capacity, st));
      sorter.sort(rays.data(), n, place, rtu::hw::cmd::RayType::kDiffuse);
      // The reference: indices stably sorted by key.
      std::vector<uint32_t> order(n);
      std::iota(order.begin(), order.end(), 0u);
      std::stable_sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
        return rtu::fw::ray_sort_key(job, rays[a]) < rtu::fw::ray_sort_key(job, rays[b]);
      });
      const Ray* sorted = rtu::fw::at<const Ray>(hal, sorter.ray_addr(place));
      for (uint32_t i = 0; i < n; ++i) {
        INFO("sorted place " << i);
        REQUIRE(std::memcmp(&sorted[i], &rays[order[i]], sizeof(Ray)) == 0);
      }
      // The unit writes hit i for sorted ray i; unsort puts it at the ray's own index.
      Hit* sorted_hits = rtu::fw::at<Hit>(hal, sorter.hit_addr(place));
      for (uint32_t i = 0; i < n; ++i) sorted_hits[i] = Hit{float(order[i]), order[i], 0.0f, 0.0f};
      std::vector<Hit> hits(n);
      sorter.unsort(hits.data(), n, place);
      for (uint32_t i = 0; i < n; ++i) CHECK(hits[i].prim == i);
      const uint32_t passes = (rtu::fw::ray_sort_key_bits(key) + radix - 1) / radix;
      CHECK(st.sorts == 1);
      CHECK(st.rays == n);
      CHECK(st.passes == passes);
      CHECK(st.pass_rays == uint64_t(passes) * n);
      CHECK(st.by_type[uint32_t(rtu::hw::cmd::RayType::kDiffuse)] == n);
    }
  }
}
