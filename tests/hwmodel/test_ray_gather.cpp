// The ray coherence gathering unit (timing/ray_gather.h): bins issued when full, by timeout, forced by a full
// buffer and flushed by the packet's last ray, with cycles worked by hand; hits and cycles unchanged by the host's
// threads and on a chip; the keys' checks.
#include <catch2/catch.hpp>

#include <cstring>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/ray_gather.h"
#include "hwmodel/timing/timing_model.h"
#include "timing_checks.h"

using namespace rtu::hw;

namespace {

// Rays that only carry their bin key: each takes setup, then its write-back.
uint64_t run_keys(const TimingConfig& c, const std::vector<uint32_t>& keys, TimingStats& s,
                  std::vector<uint64_t>& entered) {
  TimingModel::Layout l;
  TimingModel m(c, l);
  std::vector<std::vector<TraceEvent>> ev;
  for (uint32_t k : keys) ev.push_back({TraceEvent{TraceEvent::kRayKey, 0, 0, 0, k}});
  std::vector<uint64_t> done;
  m.record_done(&done, &entered);
  m.begin(keys.size(), s);
  m.feed(ev.data(), ev.size());
  return m.finish();
}

}  // namespace

TEST_CASE("gathering: bins issued full, by timeout, forced by a full buffer and at the last ray", "[timing]") {
  TimingConfig c = test_config();  // packet 20, ray fetch 10, setup 8, write-back 5
  c.ray_slots = 1;
  set_timing_key(c, "gather", "octant");
  set_timing_key(c, "gather_buffer", "8");
  set_timing_key(c, "gather_rays", "2");
  set_timing_key(c, "gather_timeout", "3");
  {
    // Rays 0..4 (keys A B A C C) are fetched at 20 + i and arrive at 30 + i. A is full at 32 (rays 0, 2); B times
    // out at 31 + 3 = 34; C is full at 34 (rays 3, 4), the last ray. The one slot takes them in issue order: 0 and
    // 2 (issued 32), then 1, 3, 4 (issued 34). A ray holds the slot from entry through setup (8) to its
    // write-back, free the clock after: entries 32, 41, 50, 59, 68; the last hit is written at 76 + 5.
    TimingStats s;
    std::vector<uint64_t> entered;
    CHECK(run_keys(c, {0, 1, 0, 2, 2}, s, entered) == 81);
    CHECK(entered == std::vector<uint64_t>{32, 41, 50, 59, 68});
    CHECK(s.gather_bins == 3);
    CHECK(s.gather_bins_full == 2);
    CHECK(s.gather_bins_timeout == 1);
    CHECK(s.gather_wait_cycles == 2 + 0 + 3 + 1 + 0);
  }
  {
    // Without gathering the rays go in order as they arrive: entries 30, 39, 48, 57, 66.
    TimingConfig off = c;
    set_timing_key(off, "gather", "none");
    TimingStats s;
    std::vector<uint64_t> entered;
    CHECK(run_keys(off, {0, 1, 0, 2, 2}, s, entered) == 79);
    CHECK(entered == std::vector<uint64_t>{30, 39, 48, 57, 66});
    CHECK(s.gather_bins == 0);
  }
  {
    // A buffer of two rays, keys A B C, bins never full, a long timeout. At 31 the buffer is full with nothing
    // issued: the fullest bin, on a tie the oldest (A), goes. Ray 2's fetch waits for ray 0 to leave the buffer
    // (its entry at 31) and arrives at 41, the last ray: B and C are flushed. Entries 31, 41, 50; the last hit at
    // 58 + 5.
    set_timing_key(c, "gather_buffer", "2");
    set_timing_key(c, "gather_rays", "16");
    set_timing_key(c, "gather_timeout", "1000");
    TimingStats s;
    std::vector<uint64_t> entered;
    CHECK(run_keys(c, {0, 1, 2}, s, entered) == 63);
    CHECK(entered == std::vector<uint64_t>{31, 41, 50});
    CHECK(s.gather_bins == 3);
    CHECK(s.gather_bins_full == 0);
    CHECK(s.gather_bins_timeout == 0);
    CHECK(s.gather_wait_cycles == 1 + 10 + 0);
  }
}

TEST_CASE("gathering never changes a hit: the same cycles on 1 and 2 threads, on one unit and a chip",
          "[timing]") {
  const std::vector<Ray> rays = random_box_rays(7, 4000);
  const FixedReference ref = fixed_reference(12, rays);
  for (const char* preset : {"rdna2-mem", "rdna2-chip"})
    for (const char* key : {"octant", "origin_octant", "two_point"}) {
      TimingConfig c = timing_preset(preset);
      set_timing_key(c, "gather", key);
      set_timing_key(c, "gather_rays", "8");
      uint64_t cycles[2] = {0, 0};
      for (int threads : {1, 2}) {
        CAPTURE(preset, key, threads);
        std::vector<Hit> got;
        TimingStats ts;
        cycles[threads - 1] = trace_timed(c, ref.bytes, rays, threads, got, &ts);
        CHECK(std::memcmp(got.data(), ref.hits.data(), rays.size() * sizeof(Hit)) == 0);
        CHECK(ts.gather_bins > 0);
        if (std::strcmp(key, "octant") == 0) CHECK(ts.gather_bins_full > 0);  // 8 bins in a buffer of 64 rays
        CHECK(ts.rays == rays.size());
      }
      CHECK(cycles[0] == cycles[1]);
    }
  // Sampling measures units of consecutive rays; the gathering unit reorders them: refused.
  TimingConfig c = timing_preset("rdna2");
  set_timing_key(c, "gather", "octant");
  TimedEngine timed(EngineOptions{}, c);
  SampleOptions so;
  so.fraction = 0.1;
  CHECK_THROWS_WITH(timed.set_sampling(so), Catch::Contains("do not model ray gathering"));
  CHECK_THROWS_WITH(set_timing_key(c, "gather", "morton"), Catch::Contains("must be none, octant"));
}

TEST_CASE("gather keys: octant from the direction's signs, cells from the frame", "[timing]") {
  const double lo[3] = {0.0, 0.0, 0.0};
  Ray r;
  r.origin = Vec3(0.9f, 0.1f, 0.6f);
  r.dir = Vec3(-1.0f, 1.0f, -0.0f);
  CHECK(gather_key(GatherKey::kOctant, 1, r, lo, 1.0) == (1u | 4u));  // -x, -0 z: the sign bit counts
  // Two cells per axis: x in the upper half, y lower, z upper.
  CHECK(gather_key(GatherKey::kOrigin, 1, r, lo, 1.0) == 0b101u);
  CHECK(gather_key(GatherKey::kOriginOctant, 1, r, lo, 1.0) == (0b101u << 3 | 5u));
  // The second point lies a quarter of the extent along the direction: x 0.9 - 0.177 stays upper, y 0.277 lower.
  CHECK(gather_key(GatherKey::kTwoPoint, 1, r, lo, 1.0) == (0b101u << 3 | 0b101u));
  // Outside the frame: clamped to the border cells; a NaN coordinate goes to cell 0.
  r.origin = Vec3(-5.0f, 7.0f, std::numeric_limits<float>::quiet_NaN());
  CHECK(gather_key(GatherKey::kOrigin, 2, r, lo, 1.0) == (0u << 4 | 3u << 2 | 0u));
}
