// All-hit TRACEs (commands.h kTraceAllHits) through the ring on the float, fixed and timed devices: each ray's
// hit list header and kept hits are the tracer's trace_all, bit for bit; the slots after the kept hits are not
// written; the counters; and the timed device's lists are the fixed device's.
#include <catch2/catch.hpp>

#include <cstring>
#include <string>
#include <vector>

#include "hwmodel/datapath/hit_list.h"
#include "tests/firmware/model_rig.h"

using namespace rtu;
using namespace rtu::test;

namespace {

struct Lists {
  std::vector<cmd::HitListHeader> headers;
  std::vector<std::vector<hw::Hit>> hits;  // the kept hits of each ray
  bool untouched = true;                   // every byte after a ray's kept hits still holds the fill
};

constexpr uint8_t kFill = 0xA5;

// An all-hit TRACE of `rays` keeping k hits a ray, into a buffer filled with kFill beforehand.
Lists trace_lists(Rig& r, const std::vector<hw::Ray>& rays, uint32_t k) {
  const uint64_t ray_at = r.put(rays.data(), rays.size() * sizeof(hw::Ray));
  const uint64_t stride = cmd::all_hits_list_bytes(k), at = r.alloc(rays.size() * stride);
  std::memset(r.dev.mem() + at, kFill, rays.size() * stride);
  r.submit(cmd::trace_all_hits(ray_at, at, uint32_t(rays.size()), k, cmd::RayType::kOther, 2));
  REQUIRE(r.ring.sync() == Status::kOk);
  Lists out;
  for (size_t i = 0; i < rays.size(); ++i) {
    const uint8_t* p = r.dev.mem() + at + i * stride;
    cmd::HitListHeader h;
    std::memcpy(&h, p, sizeof h);
    out.headers.push_back(h);
    std::vector<hw::Hit> kept(std::min(h.kept, k));
    if (!kept.empty()) std::memcpy(kept.data(), p + 16, kept.size() * sizeof(hw::Hit));
    out.hits.push_back(kept);
    for (uint64_t b = 16 + kept.size() * 16; b < stride; ++b) out.untouched &= p[b] == kFill;
  }
  return out;
}

// The tracer's own lists for these rays (keeping k).
template <class Tracer>
Lists direct_lists(const Tracer& t, const std::vector<hw::Ray>& rays, uint32_t k) {
  Lists out;
  std::vector<hw::Hit> buf(k);
  for (const hw::Ray& ray : rays) {
    hw::TraversalStats s;
    hw::HitList l{buf.data(), k};
    t.trace_all(ray, l, s);
    out.headers.push_back(
        cmd::HitListHeader{uint32_t(l.count), l.kept(), l.overflow() ? cmd::kHitListOverflow : 0u, 0u});
    out.hits.emplace_back(buf.begin(), buf.begin() + l.kept());
  }
  return out;
}

bool same_lists(const Lists& a, const Lists& b) {
  if (a.headers.size() != b.headers.size()) return false;
  for (size_t i = 0; i < a.headers.size(); ++i) {
    if (std::memcmp(&a.headers[i], &b.headers[i], sizeof(cmd::HitListHeader)) != 0) return false;
    if (a.hits[i].size() != b.hits[i].size()) return false;
    if (!a.hits[i].empty() && std::memcmp(a.hits[i].data(), b.hits[i].data(), a.hits[i].size() * 16) != 0)
      return false;
  }
  return true;
}

}  // namespace

TEST_CASE("all-hit TRACE: the lists are trace_all's on every device, kept hits only", "[ring][allhits]") {
  // Long rays across the seed scene (through its walls and boxes), and the rays every device rejects.
  const std::vector<hw::Ray> rays = test_rays(200, 400, 31);
  const SceneData& sd = seed_scene();
  Lists fixed_lists;
  for (const char* engine : {"float", "fixed", "timed"}) {
    CAPTURE(engine);
    Rig r(engine);
    CHECK((r.rd(reg::kCaps) & reg::kCapAllHits) != 0);
    CHECK(r.rd(reg::kVersion) == ((1u << 16) | 1u));
    r.bind();
    for (const uint32_t k : {0u, 1u, 3u, 64u}) {
      CAPTURE(k);
      const Lists got = trace_lists(r, rays, k);
      const Lists want = std::string(engine) == "float" ? direct_lists(*sd.float_tracer, rays, k)
                                                        : direct_lists(*sd.fixed_tracer, rays, k);
      CHECK(same_lists(got, want));
      CHECK(got.untouched);
      uint64_t found = 0, overflowed = 0, several = 0;
      for (const cmd::HitListHeader& h : got.headers) {
        found += h.count;
        overflowed += (h.flags & cmd::kHitListOverflow) != 0;
        several += h.count >= 2;
        CHECK(h.reserved == 0);
      }
      // The test needs rays with several hits: the incoherent rays cross the closed room and its boxes (131 of
      // the 600 rays here cross two surfaces or more).
      CHECK(several > rays.size() / 8);
      if (k <= 1) CHECK(overflowed >= several);
      if (k == 64) CHECK(overflowed == 0);
      if (k == 64 && std::string(engine) == "fixed") fixed_lists = got;
      if (k == 64 && std::string(engine) == "timed") CHECK(same_lists(got, fixed_lists));
    }
    const hw::DeviceCounters& c = r.counters();
    CHECK(c.all_hit_rays == 4 * rays.size());
    CHECK(c.any_hit_rays == 0);
    CHECK(c.rays_by_type[size_t(cmd::RayType::kOther)] == 4 * rays.size());
    CHECK(c.max_bounce == 2);
    CHECK(c.all_hits_found > 0);
    CHECK(r.rd(reg::kErrorCode) == 0);
  }
}

TEST_CASE("all-hit TRACE: a closest-hit TRACE after it is unchanged, and the timed clock counts it",
          "[ring][allhits]") {
  const std::vector<hw::Ray> rays = test_rays(64, 64, 5);
  for (const char* engine : {"fixed", "timed"}) {
    CAPTURE(engine);
    Rig r(engine);
    r.bind();
    const uint64_t before = uint64_t(r.rd(reg::kClockLo)) | uint64_t(r.rd(reg::kClockHi)) << 32;
    trace_lists(r, rays, 8);
    const uint64_t after = uint64_t(r.rd(reg::kClockLo)) | uint64_t(r.rd(reg::kClockHi)) << 32;
    // The functional device counts one clock per packet (the TRACE and the sync's FENCE); the timed one cycles.
    if (std::string(engine) == "timed")
      CHECK(after - before > rays.size());
    else
      CHECK(after - before == 2);
    CHECK(same_hits(r.trace(rays, false), direct_hits("fixed", rays, false)));
  }
}
