// The firmware ring driver against the real model device (host::FirmwareDevice over the float and fixed engines,
// model_rig.h):
// - wraparound (4 slots, 1000 packets, their order proven by TIMESTAMPs), a full ring (and one whose first packet
//   faults), many fences (fence word, kFenceLo/Hi, the fence interrupt and its write-1-to-clear), TIMESTAMPs,
//   counters by ray type;
// - several TRACEs in one commit, closest and any hit, whose hits equal FloatTracer / FixedTracer called directly
//   on the same rays, bit for bit.
// The command processor's error paths (and buffers at the very end of memory, the valid side of its address
// checks): test_command_processor_errors.cpp.
#include <catch2/catch.hpp>

#include <array>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "firmware/hal.h"
#include "firmware/ring.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/interface/regs.h"
#include "hwmodel/numeric/rng.h"
#include "tests/firmware/model_rig.h"

using namespace rtu;
using namespace rtu::test;

TEST_CASE("ring on the model device: 1000 packets through 4 slots, in order", "[ring]") {
  for (const char* engine : kEngines) {
    CAPTURE(engine);
    Rig r(engine, 4);
    r.bind();
    const std::vector<hw::Ray> rays = test_rays(6, 6, 3);
    const uint64_t ray_addr = r.put(rays.data(), rays.size() * sizeof(hw::Ray));
    const std::vector<hw::Hit> want = direct_hits(engine, rays, false);

    hw::Pcg32 rng(11);
    struct Stamp {
      uint64_t addr;
      uint64_t index;  // packet index in the run
    };
    std::vector<Stamp> stamps;
    std::vector<uint64_t> hit_bufs;
    const uint64_t packets0 = r.counters().packets;
    const uint64_t full0 = r.ring.counters().full;
    for (uint64_t i = 0; i < 1000; ++i) {
      const uint32_t k = rng.next_u32() % 8;
      if (k < 3) {
        stamps.push_back({r.alloc(8, 8), i});
        r.submit(cmd::timestamp(stamps.back().addr));
      } else if (k == 3) {
        hit_bufs.push_back(r.alloc(rays.size() * sizeof(hw::Hit)));
        r.submit(cmd::trace(ray_addr, hit_bufs.back(), uint32_t(rays.size()), false, cmd::RayType::kPrimary, 0));
      } else {
        r.submit(cmd::nop());
      }
      if (rng.next_u32() % 5 == 0) r.ring.commit();
    }
    REQUIRE(r.ring.sync() == Status::kOk);
    CHECK(r.counters().packets - packets0 == 1001);  // and the sync's fence
    CHECK(r.ring.counters().full > full0);           // the ring filled up and the driver waited
    CHECK(r.rd(reg::kRingHead) == r.rd(reg::kRingTail));
    CHECK(r.rd(reg::kRingHead) < 4);
    CHECK(r.rd(reg::kStatus) == (reg::kStatusEnabled | reg::kStatusIdle | reg::kStatusBound));
    // The clock counts packets: every timestamp is its packet's index after the first, so nothing was lost,
    // repeated or reordered across the wraps.
    REQUIRE(stamps.size() > 100);
    const uint64_t t0 = r.load<uint64_t>(stamps[0].addr);
    for (const Stamp& s : stamps) {
      if (r.load<uint64_t>(s.addr) != t0 + s.index - stamps[0].index)
        FAIL("timestamp of packet " << s.index << " is " << r.load<uint64_t>(s.addr));
    }
    REQUIRE(hit_bufs.size() > 50);
    for (uint64_t h : hit_bufs) {
      std::vector<hw::Hit> got(rays.size());
      std::memcpy(got.data(), r.dev.mem() + h, got.size() * sizeof(hw::Hit));
      CHECK(same_hits(got, want));
    }
  }
}

TEST_CASE("ring on the model device: a full ring is handed over and drained", "[ring]") {
  Rig r("float", 4);
  const uint64_t packets0 = r.counters().packets;
  for (int i = 0; i < 3; ++i) r.submit(cmd::nop());
  CHECK(r.rd(reg::kRingTail) == 0);  // not committed: the device has seen nothing
  CHECK(r.counters().packets == packets0);
  r.submit(cmd::nop());  // full: commits the 3, the device consumes them, the 4th goes in
  CHECK(r.ring.counters().full == 1);
  CHECK(r.counters().packets == packets0 + 3);
  CHECK(r.rd(reg::kRingHead) == 3);
  r.ring.commit();
  CHECK(r.counters().packets == packets0 + 4);
  CHECK(r.rd(reg::kRingHead) == 0);

  // A full ring whose first packet faults: the driver sees the error instead of waiting for ever.
  const uint64_t errors0 = r.counters().errors;
  r.submit(cmd::Packet{0x42, 0, 0, 0, 0, 0, 0, 0});
  r.submit(cmd::nop());
  r.submit(cmd::nop());
  CHECK(r.ring.submit(cmd::nop()) == Status::kDeviceError);
  CHECK(r.ring.error_code() == ErrorCode::kBadOpcode);
  CHECK(r.ring.error_info() == 0);
  CHECK(r.counters().errors == errors0 + 1);
  recover_and_run(r);
}

TEST_CASE("ring on the model device: fences, their registers and the fence interrupt", "[ring]") {
  for (const char* engine : kEngines) {
    CAPTURE(engine);
    Rig r(engine, 8);
    // sync(): fence values 1, 2, 3, ... each seen in kFenceLo/Hi once the wait returns.
    for (uint64_t v = 1; v <= 300; ++v) {
      REQUIRE(r.ring.sync() == Status::kOk);
      CHECK(r.rd(reg::kFenceLo) == v);
      CHECK(r.rd(reg::kFenceHi) == 0);
    }
    CHECK(r.ring.counters().waits == 300);
    CHECK(r.counters().by_opcode[size_t(cmd::Opcode::kFence)] == 300);

    // Explicit fences with 64-bit values, several per commit: each word written, the registers hold the last.
    const uint64_t words = r.alloc(8 * 200, 8);
    hw::Pcg32 rng(5);
    uint64_t last = 0;
    for (uint64_t i = 0; i < 200;) {
      const uint64_t n = 1 + rng.next_u32() % 5;
      for (uint64_t k = 0; k < n && i < 200; ++k, ++i) {
        last = (uint64_t(rng.next_u32()) << 32) | (0x1000 + i);
        r.submit(cmd::fence(words + 8 * i, last, false));
      }
      r.ring.commit();
      CHECK(r.rd(reg::kFenceLo) == uint32_t(last));
      CHECK(r.rd(reg::kFenceHi) == uint32_t(last >> 32));
      CHECK(r.load<uint64_t>(words + 8 * (i - 1)) == last);
    }
    for (uint64_t i = 0; i < 200; ++i) CHECK((r.load<uint64_t>(words + 8 * i) & 0xFFFFFFFFu) == 0x1000 + i);

    // The interrupt: raised only by a FENCE with kFenceIrq; write-1-to-clear, other bits leave it.
    r.wr(reg::kIrqStatus, 0xFFFFFFFFu);
    CHECK(r.rd(reg::kIrqStatus) == 0);
    r.submit(cmd::fence(words, 1, false));
    r.ring.commit();
    CHECK(r.rd(reg::kIrqStatus) == 0);
    CHECK_FALSE(r.dev.processor().irq_line());
    const uint64_t irqs = r.counters().irqs;
    r.submit(cmd::fence(words, 2, true));
    r.ring.commit();
    CHECK(r.rd(reg::kIrqStatus) == reg::kIrqFence);
    CHECK(r.dev.processor().irq_line());
    CHECK(r.counters().irqs == irqs + 1);
    r.wr(reg::kIrqStatus, reg::kIrqError);
    CHECK(r.rd(reg::kIrqStatus) == reg::kIrqFence);
    r.wr(reg::kIrqStatus, 0);
    CHECK(r.rd(reg::kIrqStatus) == reg::kIrqFence);
    r.wr(reg::kIrqStatus, reg::kIrqFence);
    CHECK(r.rd(reg::kIrqStatus) == 0);
    CHECK_FALSE(r.dev.processor().irq_line());
    // Masked: the status bit is raised, the line stays low.
    r.wr(reg::kIrqEnable, reg::kIrqError);
    r.submit(cmd::fence(words, 3, true));
    r.ring.commit();
    CHECK(r.rd(reg::kIrqStatus) == reg::kIrqFence);
    CHECK_FALSE(r.dev.processor().irq_line());
    r.wr(reg::kIrqEnable, 0xFFFFFFFFu);
    CHECK(r.rd(reg::kIrqEnable) == (reg::kIrqFence | reg::kIrqError));  // unknown bits read as 0
    CHECK(r.dev.processor().irq_line());
    CHECK(r.rd(reg::kErrorCode) == 0);
  }
}

TEST_CASE("ring on the model device: TIMESTAMPs count the packets before them", "[ring]") {
  Rig r("fixed", 16);
  hw::Pcg32 rng(9);
  std::vector<uint64_t> addrs;
  std::vector<uint64_t> gaps;  // NOPs before each timestamp
  for (int i = 0; i < 100; ++i) {
    gaps.push_back(rng.next_u32() % 6);
    for (uint64_t k = 0; k < gaps.back(); ++k) r.submit(cmd::nop());
    addrs.push_back(r.alloc(8, 8));
    r.submit(cmd::timestamp(addrs.back()));
    if (rng.next_u32() % 3 == 0) r.ring.commit();
  }
  REQUIRE(r.ring.sync() == Status::kOk);
  for (size_t i = 1; i < addrs.size(); ++i) {
    const uint64_t a = r.load<uint64_t>(addrs[i - 1]), b = r.load<uint64_t>(addrs[i]);
    CHECK(b > a);
    CHECK(b - a == gaps[i] + 1);
  }
  // The clock register: one tick per packet consumed since the device was made, read atomically via the latch.
  const uint32_t lo = r.rd(reg::kClockLo);
  const uint32_t hi = r.rd(reg::kClockHi);
  CHECK(((uint64_t(hi) << 32) | lo) == r.counters().packets);
  CHECK(r.load<uint64_t>(addrs.back()) == r.counters().packets - 2);  // then the sync's fence
}

TEST_CASE("ring on the model device: TRACEs in one commit equal the tracers called directly", "[ring]") {
  for (const char* engine : kEngines) {
    CAPTURE(engine);
    Rig r(engine, 32);
    r.bind();
    struct Job {
      std::vector<hw::Ray> rays;
      bool any_hit;
      cmd::RayType type;
      uint8_t bounce;
      uint64_t ray_addr = 0, hit_addr = 0;
    };
    std::vector<Job> jobs;
    jobs.push_back({test_rays(3000, 0, 0), false, cmd::RayType::kPrimary, 0});
    jobs.push_back({test_rays(0, 2000, 21), false, cmd::RayType::kReflection, 1});
    jobs.push_back({test_rays(0, 2000, 22), true, cmd::RayType::kShadow, 1});
    jobs.push_back({test_rays(1000, 1000, 23), true, cmd::RayType::kOcclusion, 2});
    jobs.push_back({test_rays(500, 0, 0), false, cmd::RayType::kDiffuse, 3});
    jobs.push_back({test_rays(1, 0, 0), false, cmd::RayType::kRefraction, 7});
    jobs.push_back({test_rays(0, 700, 24), true, cmd::RayType::kOther, 4});
    jobs.push_back({test_rays(0, 700, 24), false, cmd::RayType::kOther, 4});  // same rays, closest hit
    for (Job& j : jobs) {
      j.ray_addr = r.put(j.rays.data(), j.rays.size() * sizeof(hw::Ray));
      j.hit_addr = r.alloc(j.rays.size() * sizeof(hw::Hit));
      std::memset(r.dev.mem() + j.hit_addr, 0xCD, j.rays.size() * sizeof(hw::Hit));
    }
    const hw::DeviceCounters before = r.counters();
    for (const Job& j : jobs)
      r.submit(cmd::trace(j.ray_addr, j.hit_addr, uint32_t(j.rays.size()), j.any_hit, j.type, j.bounce));
    const uint64_t doorbells = r.ring.counters().doorbells;
    r.ring.commit();
    CHECK(r.ring.counters().doorbells == doorbells + 1);  // one commit
    REQUIRE(r.rd(reg::kErrorCode) == 0);

    std::array<uint64_t, cmd::kRayTypeCount> rays_by_type{};
    std::array<hw::TraversalStats, cmd::kRayTypeCount> stats_by_type{};
    uint64_t any_hit_rays = 0, hits_found = 0;
    for (size_t i = 0; i < jobs.size(); ++i) {
      const Job& j = jobs[i];
      INFO("job " << i);
      hw::TraversalStats s;
      const std::vector<hw::Hit> want = direct_hits(engine, j.rays, j.any_hit, s);
      std::vector<hw::Hit> got(j.rays.size());
      std::memcpy(got.data(), r.dev.mem() + j.hit_addr, got.size() * sizeof(hw::Hit));
      CHECK(same_hits(got, want));
      rays_by_type[size_t(j.type)] += j.rays.size();
      stats_by_type[size_t(j.type)].add(s);
      if (j.any_hit) any_hit_rays += j.rays.size();
      for (const hw::Hit& h : want) hits_found += h.hit();
    }
    CHECK(hits_found > 1000);  // the comparison is not between two empty images

    // Counters by ray type: rays, and the traversal statistics of the same rays traced directly.
    const hw::DeviceCounters& after = r.counters();
    for (size_t t = 0; t < cmd::kRayTypeCount; ++t) {
      INFO("ray type " << cmd::ray_type_name(cmd::RayType(t)));
      CHECK(after.rays_by_type[t] - before.rays_by_type[t] == rays_by_type[t]);
      const hw::TraversalStats& a = after.stats_by_type[t];
      const hw::TraversalStats& b = before.stats_by_type[t];
      const hw::TraversalStats& want = stats_by_type[t];
      CHECK(a.rays - b.rays == want.rays);
      CHECK(a.hits - b.hits == want.hits);
      CHECK(a.invalid_rays - b.invalid_rays == want.invalid_rays);
      CHECK(a.nodes_visited - b.nodes_visited == want.nodes_visited);
      CHECK(a.box_tests - b.box_tests == want.box_tests);
      CHECK(a.prim_tests - b.prim_tests == want.prim_tests);
    }
    CHECK(after.any_hit_rays - before.any_hit_rays == any_hit_rays);
    CHECK(after.max_bounce == 7);
    CHECK(after.by_opcode[size_t(cmd::Opcode::kTrace)] - before.by_opcode[size_t(cmd::Opcode::kTrace)] ==
          jobs.size());
    CHECK(after.stats_by_type[size_t(cmd::RayType::kPrimary)].invalid_rays >= 2);  // the rejected test rays

    // Any hit is a hit exactly where closest hit is one (same rays, jobs 6 and 7).
    std::vector<hw::Hit> any(jobs[6].rays.size()), closest(jobs[7].rays.size());
    std::memcpy(any.data(), r.dev.mem() + jobs[6].hit_addr, any.size() * sizeof(hw::Hit));
    std::memcpy(closest.data(), r.dev.mem() + jobs[7].hit_addr, closest.size() * sizeof(hw::Hit));
    for (size_t i = 0; i < any.size(); ++i) CHECK(any[i].hit() == closest[i].hit());
  }
}
