// The firmware ring driver against the real model device (host::FirmwareDevice over the float and fixed engines),
// and every error path of the command processor (hwmodel/command_processor.cpp):
// - wraparound (4 slots, 1000 packets, their order proven by TIMESTAMPs), a full ring, many fences (fence word,
//   kFenceLo/Hi, the fence interrupt and its write-1-to-clear), TIMESTAMPs, counters by ray type;
// - several TRACEs in one commit, closest and any hit, whose hits equal FloatTracer / FixedTracer called directly
//   on the same rays, bit for bit;
// - each malformed packet and register access: its error code, kStatusError, kIrqError, the error info (the
//   faulting ring slot or register), the head left on the faulting slot, later doorbells consuming nothing, and
//   kCtrlReset recovering so that a valid job then runs and gives the right hits.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "firmware/hal.h"
#include "firmware/ring.h"
#include "host/firmware_device.h"
#include "host/ray_gen.h"
#include "host/scene.h"
#include "hwmodel/bvh.h"
#include "hwmodel/commands.h"
#include "hwmodel/device_image.h"
#include "hwmodel/engine.h"
#include "hwmodel/fixed_format.h"
#include "hwmodel/fixed_tracer.h"
#include "hwmodel/float_tracer.h"
#include "hwmodel/regs.h"
#include "hwmodel/rng.h"

using namespace rtu;
namespace cmd = hw::cmd;
namespace reg = hw::reg;
using fw::Status;
using reg::ErrorCode;

namespace {

constexpr uint64_t kMemBytes = 8u << 20;        // device memory of every rig
constexpr uint64_t kRingArenaBytes = 64 << 10;  // [0, 64 KiB): the ring and its fence word; buffers above
const char* const kEngines[] = {"float", "fixed"};

// The seed scene and its images for both engines, built once. The float engine builds its BVH from the float
// image with default options; the fixed image is encoded over the BVH the host would choose
// (host/direct_device.cpp).
struct SceneData {
  host::Scene scene;
  hw::TracerOptions tracer;
  std::optional<hw::Bvh> bvh;
  std::unique_ptr<hw::DeviceImage> fixed_image;
  std::vector<uint64_t> float_image;
  std::unique_ptr<hw::FloatTracer> float_tracer;
  std::unique_ptr<hw::FixedTracer> fixed_tracer;
};

const SceneData& seed_scene() {
  static const SceneData* data = [] {
    auto* d = new SceneData;
    d->scene = host::load_scene("builtin:seed");
    const hw::FixedFormat format;
    d->tracer.bvh.width = format.width;
    d->bvh = hw::choose_accel(d->scene.geometry, d->tracer);
    d->fixed_image = std::make_unique<hw::DeviceImage>(
        hw::encode_scene(d->scene.geometry, format, d->bvh ? &*d->bvh : nullptr));
    d->float_image = hw::encode_float_scene(d->scene.geometry);
    d->float_tracer = std::make_unique<hw::FloatTracer>(d->scene.geometry, hw::EngineOptions{}.tracer);
    d->fixed_tracer = std::make_unique<hw::FixedTracer>(*d->fixed_image);
    return d;
  }();
  return *data;
}

// What the engine `name` computes for these rays when called directly (no device, no ring).
std::vector<hw::Hit> direct_hits(const std::string& name, const std::vector<hw::Ray>& rays, bool any_hit,
                                 hw::TraversalStats& s) {
  std::vector<hw::Hit> hits(rays.size());
  if (name == "float")
    seed_scene().float_tracer->trace_batch(rays.data(), hits.data(), rays.size(), any_hit, 1, s);
  else
    seed_scene().fixed_tracer->trace_batch(rays.data(), hits.data(), rays.size(), any_hit, 1, s);
  return hits;
}
std::vector<hw::Hit> direct_hits(const std::string& name, const std::vector<hw::Ray>& rays, bool any_hit) {
  hw::TraversalStats s;
  return direct_hits(name, rays, any_hit, s);
}

// Rays of every kind: camera rays, incoherent rays, and rays every device rejects at setup.
std::vector<hw::Ray> test_rays(size_t primary, size_t incoherent, uint64_t seed) {
  const host::Scene& sc = seed_scene().scene;
  std::vector<hw::Ray> rays = host::primary_rays(sc.camera, uint64_t(primary));
  const std::vector<hw::Ray> inc = host::incoherent_rays(sc.geometry.bounds(), incoherent, seed);
  rays.insert(rays.end(), inc.begin(), inc.end());
  hw::Ray bad = rays[0];
  bad.origin.x = std::numeric_limits<float>::quiet_NaN();
  rays.push_back(bad);
  bad = rays[0];
  bad.dir = hw::Vec3(0.0f);
  rays.push_back(bad);
  bad = rays[0];
  bad.tmin = 5.0f;
  bad.tmax = 1.0f;  // empty interval: valid, misses
  rays.push_back(bad);
  return rays;
}

bool same_hits(const std::vector<hw::Hit>& a, const std::vector<hw::Hit>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(hw::Hit)) == 0;
}

// A model device driven by the firmware ring driver, with the scene image of its engine in device memory.
struct Rig {
  explicit Rig(const std::string& engine, uint32_t ring_slots = 16)
      : name(engine),
        dev(rtu::hw::parse_device_kind(engine), kMemBytes),
        slots(ring_slots),
        buffers(kRingArenaBytes, kMemBytes - kRingArenaBytes) {
    const SceneData& sd = seed_scene();
    if (engine == "float") {
      image_bytes = sd.float_image.size() * 8;
      image = put(sd.float_image.data(), image_bytes, 8);
    } else {
      image_bytes = sd.fixed_image->size();
      image = put(sd.fixed_image->data(), image_bytes, 8);
    }
    start();
  }

  uint32_t rd(uint32_t offset) { return dev.read32(offset); }
  void wr(uint32_t offset, uint32_t value) { dev.write32(offset, value); }
  const hw::DeviceCounters& counters() { return dev.processor().counters(); }

  uint64_t alloc(uint64_t bytes, uint64_t align = 16) {
    const uint64_t a = buffers.alloc(bytes, align);
    REQUIRE(a != fw::Arena::kNull);
    return a;
  }
  uint64_t put(const void* src, uint64_t bytes, uint64_t align = 16) {
    const uint64_t a = alloc(bytes, align);
    std::memcpy(dev.mem() + a, src, bytes);
    return a;
  }
  template <class T>
  T load(uint64_t addr) {
    T v;
    std::memcpy(&v, dev.mem() + addr, sizeof v);
    return v;
  }

  // (Re)initializes the ring: resets the unit, which unbinds the scene.
  void start() {
    ring_arena = fw::Arena(0, kRingArenaBytes);
    REQUIRE(ring.init(dev, ring_arena, slots) == Status::kOk);
    REQUIRE(rd(reg::kStatus) == (reg::kStatusEnabled | reg::kStatusIdle));
  }
  void bind() {
    REQUIRE(ring.submit(cmd::bind_scene(image, image_bytes)) == Status::kOk);
    REQUIRE(ring.sync() == Status::kOk);
    REQUIRE((rd(reg::kStatus) & reg::kStatusBound) != 0);
  }
  void submit(const cmd::Packet& p) { REQUIRE(ring.submit(p) == Status::kOk); }

  // A TRACE of `rays` through the ring; returns the hits the device wrote.
  std::vector<hw::Hit> trace(const std::vector<hw::Ray>& rays, bool any_hit) {
    const uint64_t r = put(rays.data(), rays.size() * sizeof(hw::Ray));
    const uint64_t h = alloc(rays.size() * sizeof(hw::Hit));
    submit(cmd::trace(r, h, uint32_t(rays.size()), any_hit, cmd::RayType::kPrimary, 0));
    REQUIRE(ring.sync() == Status::kOk);
    std::vector<hw::Hit> hits(rays.size());
    std::memcpy(hits.data(), dev.mem() + h, hits.size() * sizeof(hw::Hit));
    return hits;
  }

  std::string name;
  host::FirmwareDevice dev;
  uint32_t slots;
  fw::Arena ring_arena, buffers;
  fw::Ring ring;
  uint64_t image = 0, image_bytes = 0;
};

// kCtrlReset clears the error, the interrupts, the ring and the scene; the ring driver then starts over and a
// valid job runs and gives the hits of the direct tracer.
void recover_and_run(Rig& r) {
  r.wr(reg::kControl, reg::kCtrlReset);
  CHECK(r.rd(reg::kStatus) == reg::kStatusIdle);  // not enabled, no error, no scene
  CHECK(r.rd(reg::kErrorCode) == 0);
  CHECK(r.rd(reg::kErrorInfo) == 0);
  CHECK(r.rd(reg::kIrqStatus) == 0);
  CHECK(r.rd(reg::kControl) == 0);
  CHECK(r.rd(reg::kRingSize) == 0);
  CHECK(r.rd(reg::kRingHead) == 0);
  CHECK(r.rd(reg::kRingTail) == 0);
  CHECK(r.rd(reg::kFenceLo) == 0);
  CHECK(r.rd(reg::kFenceHi) == 0);
  CHECK_FALSE(r.dev.processor().irq_line());
  r.start();
  r.bind();
  const std::vector<hw::Ray> rays = test_rays(40, 24, 7);
  CHECK(same_hits(r.trace(rays, false), direct_hits(r.name, rays, false)));
  CHECK(same_hits(r.trace(rays, true), direct_hits(r.name, rays, true)));
  CHECK(r.rd(reg::kStatus) == (reg::kStatusEnabled | reg::kStatusIdle | reg::kStatusBound));
  CHECK(r.rd(reg::kErrorCode) == 0);
}

// After an error: the unit stays stopped, whatever the firmware rings. `head` is where it stopped.
void check_stopped(Rig& r, ErrorCode code, uint32_t info, uint32_t head) {
  CHECK(r.rd(reg::kErrorCode) == uint32_t(code));
  CHECK(r.rd(reg::kErrorInfo) == info);
  CHECK((r.rd(reg::kStatus) & reg::kStatusError) != 0);
  CHECK((r.rd(reg::kIrqStatus) & reg::kIrqError) != 0);
  CHECK(r.dev.processor().irq_line() == ((r.rd(reg::kIrqEnable) & reg::kIrqError) != 0));
  CHECK(r.dev.processor().error() == code);
  CHECK(r.rd(reg::kRingHead) == head);

  const uint64_t packets = r.counters().packets, errors = r.counters().errors;
  const uint32_t tail = r.rd(reg::kRingTail);
  // Later doorbells, through the driver and raw: nothing consumed, nothing changed, the first error kept.
  for (int i = 0; i < 3; ++i) {
    const Status s = r.ring.submit(cmd::nop());
    CHECK((s == Status::kOk || s == Status::kDeviceError));
    r.ring.commit();
  }
  r.wr(reg::kRingTail, (tail + 1) % std::max<uint32_t>(r.slots, 2));
  r.wr(reg::kId, 0);  // would be a second error
  CHECK(r.ring.wait(~uint64_t(0)) == Status::kDeviceError);
  CHECK(r.rd(reg::kRingHead) == head);
  CHECK(r.rd(reg::kRingTail) == tail);
  CHECK(r.counters().packets == packets);
  CHECK(r.counters().errors == errors);
  CHECK(r.rd(reg::kErrorCode) == uint32_t(code));
  CHECK(r.rd(reg::kErrorInfo) == info);
}

// Runs `bad` on a started ring at a slot that has wrapped around at least once, behind `lead` NOPs in the same
// commit and followed by a FENCE that must not run; then checks the stop and the recovery.
void expect_packet_fault(Rig& r, const cmd::Packet& bad, ErrorCode code, bool bind = true, uint32_t lead = 3) {
  r.start();
  if (bind) r.bind();
  for (uint32_t i = 0; i < r.slots + 1; ++i) r.submit(cmd::nop());
  REQUIRE(r.ring.sync() == Status::kOk);
  r.wr(reg::kIrqStatus, reg::kIrqFence);  // acknowledge the sync's fence interrupt
  const uint64_t fence_word = r.alloc(8, 8);
  std::memset(r.dev.mem() + fence_word, 0, 8);
  const uint64_t packets = r.counters().packets, errors = r.counters().errors;
  const uint32_t fence_reg = r.rd(reg::kFenceLo);
  for (uint32_t i = 0; i < lead; ++i) r.submit(cmd::nop());
  const uint32_t slot = (r.rd(reg::kRingHead) + lead) % r.slots;
  r.submit(bad);
  r.submit(cmd::fence(fence_word, 0x77, true));
  r.ring.commit();

  CHECK(r.counters().packets == packets + lead);  // the NOPs before it ran, nothing from it on
  CHECK(r.counters().errors == errors + 1);
  CHECK(r.load<uint64_t>(fence_word) == 0);
  CHECK(r.rd(reg::kFenceLo) == fence_reg);
  CHECK((r.rd(reg::kIrqStatus) & reg::kIrqFence) == 0);
  CHECK((r.rd(reg::kStatus) & reg::kStatusIdle) == 0);  // packets still pending
  CHECK(r.dev.processor().irq_line());                  // the ring driver enabled the error interrupt
  check_stopped(r, code, slot, slot);
  recover_and_run(r);
}

// Runs `poke` (register writes) on a started ring with a bound scene whose head is past slot 0; then checks the
// stop and the recovery.
void expect_register_fault(Rig& r, const std::function<void(Rig&)>& poke, ErrorCode code, uint32_t info) {
  r.start();
  r.bind();
  for (int i = 0; i < 5; ++i) r.submit(cmd::nop());
  r.ring.commit();
  const uint64_t errors = r.counters().errors;
  poke(r);
  CHECK(r.counters().errors == errors + 1);
  check_stopped(r, code, info, r.rd(reg::kRingHead));
  recover_and_run(r);
}

std::string hex(uint64_t v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "0x%llx", static_cast<unsigned long long>(v));
  return buf;
}

}  // namespace

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

TEST_CASE("ring on the model device: buffers at the very end of memory are accepted", "[ring]") {
  Rig r("fixed", 8);
  r.bind();
  const std::vector<hw::Ray> rays = test_rays(10, 6, 1);
  const uint64_t n = rays.size();
  const uint64_t hit_addr = kMemBytes - n * sizeof(hw::Hit);
  const uint64_t ray_addr = hit_addr - n * sizeof(hw::Ray);  // adjacent to the hits: no overlap
  std::memcpy(r.dev.mem() + ray_addr, rays.data(), n * sizeof(hw::Ray));
  r.submit(cmd::trace(ray_addr, hit_addr, uint32_t(n), false, cmd::RayType::kPrimary, 0));
  // Hits right before the rays, touching them.
  const uint64_t hit2 = ray_addr - n * sizeof(hw::Hit);
  r.submit(cmd::trace(ray_addr, hit2, uint32_t(n), true, cmd::RayType::kShadow, 0));
  r.submit(cmd::fence(kMemBytes - 8, 99, false));
  r.submit(cmd::timestamp(kMemBytes - 16));
  REQUIRE(r.ring.sync() == Status::kOk);
  CHECK(r.rd(reg::kErrorCode) == 0);
  std::vector<hw::Hit> got(n);
  std::memcpy(got.data(), r.dev.mem() + hit_addr, n * sizeof(hw::Hit));
  got.back() = hw::Hit{};  // the fence and the timestamp overwrote the last hit
  std::vector<hw::Hit> want = direct_hits("fixed", rays, false);
  want.back() = hw::Hit{};
  CHECK(same_hits(got, want));
  std::memcpy(got.data(), r.dev.mem() + hit2, n * sizeof(hw::Hit));
  CHECK(same_hits(got, direct_hits("fixed", rays, true)));
  CHECK(r.load<uint64_t>(kMemBytes - 8) == 99);
}

TEST_CASE("command processor errors: malformed packets", "[ring]") {
  for (const char* engine : kEngines) {
    CAPTURE(engine);
    Rig r(engine, 8);
    const uint64_t M = kMemBytes;
    const uint64_t rays = r.alloc(64 * sizeof(hw::Ray));
    const uint64_t hits = r.alloc(64 * sizeof(hw::Hit));
    const uint64_t word = r.alloc(8, 8);
    const std::vector<hw::Ray> some = test_rays(40, 21, 2);
    std::memcpy(r.dev.mem() + rays, some.data(), some.size() * sizeof(hw::Ray));
    const cmd::Packet fence_ok = cmd::fence(word, 1, false);
    const cmd::Packet trace_ok = cmd::trace(rays, hits, 64, false, cmd::RayType::kPrimary, 0);
    const cmd::Packet ts_ok = cmd::timestamp(word);
    const cmd::Packet bind_ok = cmd::bind_scene(r.image, r.image_bytes);
    auto with = [](cmd::Packet p, const std::function<void(cmd::Packet&)>& f) {
      f(p);
      return p;
    };
    struct Case {
      std::string name;
      cmd::Packet packet;
      ErrorCode code;
    };
    const uint64_t top8 = ~uint64_t(7), top16 = ~uint64_t(15);
    std::vector<Case> cases = {
        // unknown opcodes
        {"opcode 5", with(cmd::nop(), [](cmd::Packet& p) { p.opcode = 5; }), ErrorCode::kBadOpcode},
        {"opcode 0x80", with(fence_ok, [](cmd::Packet& p) { p.opcode = 0x80; }), ErrorCode::kBadOpcode},
        {"opcode 0xFF", with(cmd::nop(), [](cmd::Packet& p) { p.opcode = 0xFF; }), ErrorCode::kBadOpcode},
        // addresses outside memory, and ends that overflow 64 bits
        {"fence at the end", cmd::fence(M, 1, false), ErrorCode::kBadAddress},
        {"fence far", cmd::fence(uint64_t(1) << 40, 1, false), ErrorCode::kBadAddress},
        {"fence end wraps", cmd::fence(top8, 1, false), ErrorCode::kBadAddress},
        {"timestamp at the end", cmd::timestamp(M), ErrorCode::kBadAddress},
        {"timestamp end wraps", cmd::timestamp(top8), ErrorCode::kBadAddress},
        {"trace hits past the end", cmd::trace(rays, M - 63 * 16, 64, false, cmd::RayType::kPrimary, 0),
         ErrorCode::kBadAddress},
        {"trace rays past the end", cmd::trace(M - 63 * 32, hits, 64, false, cmd::RayType::kPrimary, 0),
         ErrorCode::kBadAddress},
        {"trace rays end wraps", cmd::trace(top16, hits, 1, false, cmd::RayType::kPrimary, 0),
         ErrorCode::kBadAddress},
        {"trace hits end wraps", cmd::trace(rays, top16, 1, false, cmd::RayType::kPrimary, 0),
         ErrorCode::kBadAddress},
        {"trace of kMaxTraceCount rays",
         cmd::trace(rays, hits, cmd::kMaxTraceCount, false, cmd::RayType::kPrimary, 0), ErrorCode::kBadAddress},
        {"bind past the end", cmd::bind_scene(r.image, M), ErrorCode::kBadAddress},
        {"bind end wraps", cmd::bind_scene(8, top8), ErrorCode::kBadAddress},
        {"bind far", cmd::bind_scene(uint64_t(1) << 63, 8), ErrorCode::kBadAddress},
        // misaligned buffers
        {"trace rays % 16 = 8", cmd::trace(rays + 8, hits, 1, false, cmd::RayType::kPrimary, 0),
         ErrorCode::kMisaligned},
        {"trace rays % 16 = 1", cmd::trace(rays + 1, hits, 1, false, cmd::RayType::kPrimary, 0),
         ErrorCode::kMisaligned},
        {"trace hits % 16 = 4", cmd::trace(rays, hits + 4, 1, false, cmd::RayType::kPrimary, 0),
         ErrorCode::kMisaligned},
        {"trace hits % 16 = 8", cmd::trace(rays, hits + 8, 1, false, cmd::RayType::kPrimary, 0),
         ErrorCode::kMisaligned},
        {"fence % 8 = 4", cmd::fence(word + 4, 1, false), ErrorCode::kMisaligned},
        {"fence % 8 = 1", cmd::fence(word + 1, 1, true), ErrorCode::kMisaligned},
        {"timestamp % 8 = 2", cmd::timestamp(word + 2), ErrorCode::kMisaligned},
        {"bind % 8 = 4", cmd::bind_scene(r.image + 4, r.image_bytes - 8), ErrorCode::kMisaligned},
        // counts
        {"count 0", with(trace_ok, [](cmd::Packet& p) { p.count = 0; }), ErrorCode::kBadCount},
        {"count kMaxTraceCount + 1", with(trace_ok, [](cmd::Packet& p) { p.count = cmd::kMaxTraceCount + 1; }),
         ErrorCode::kBadCount},
        {"count 2^32 - 1", with(trace_ok, [](cmd::Packet& p) { p.count = 0xFFFFFFFFu; }), ErrorCode::kBadCount},
        // reserved fields, each opcode
        {"nop flags", with(cmd::nop(), [](cmd::Packet& p) { p.flags = 1; }), ErrorCode::kReservedBits},
        {"nop ray_type", with(cmd::nop(), [](cmd::Packet& p) { p.ray_type = 1; }), ErrorCode::kReservedBits},
        {"nop bounce", with(cmd::nop(), [](cmd::Packet& p) { p.bounce = 1; }), ErrorCode::kReservedBits},
        {"nop count", with(cmd::nop(), [](cmd::Packet& p) { p.count = 1; }), ErrorCode::kReservedBits},
        {"nop addr0", with(cmd::nop(), [](cmd::Packet& p) { p.addr0 = 8; }), ErrorCode::kReservedBits},
        {"nop addr1", with(cmd::nop(), [](cmd::Packet& p) { p.addr1 = 1ull << 63; }), ErrorCode::kReservedBits},
        {"nop value", with(cmd::nop(), [](cmd::Packet& p) { p.value = 1; }), ErrorCode::kReservedBits},
        {"bind flags", with(bind_ok, [](cmd::Packet& p) { p.flags = 0x80; }), ErrorCode::kReservedBits},
        {"bind ray_type", with(bind_ok, [](cmd::Packet& p) { p.ray_type = 2; }), ErrorCode::kReservedBits},
        {"bind bounce", with(bind_ok, [](cmd::Packet& p) { p.bounce = 3; }), ErrorCode::kReservedBits},
        {"bind count", with(bind_ok, [](cmd::Packet& p) { p.count = 4; }), ErrorCode::kReservedBits},
        {"bind addr1", with(bind_ok, [](cmd::Packet& p) { p.addr1 = 16; }), ErrorCode::kReservedBits},
        {"trace flag bit 1", with(trace_ok, [](cmd::Packet& p) { p.flags = 2; }), ErrorCode::kReservedBits},
        {"trace flag bit 7", with(trace_ok, [](cmd::Packet& p) { p.flags = 0x81; }), ErrorCode::kReservedBits},
        {"trace ray_type 7", with(trace_ok, [](cmd::Packet& p) { p.ray_type = cmd::kRayTypeCount; }),
         ErrorCode::kReservedBits},
        {"trace ray_type 255", with(trace_ok, [](cmd::Packet& p) { p.ray_type = 0xFF; }),
         ErrorCode::kReservedBits},
        {"trace value", with(trace_ok, [](cmd::Packet& p) { p.value = 1; }), ErrorCode::kReservedBits},
        {"fence flag bit 1", with(fence_ok, [](cmd::Packet& p) { p.flags = 2; }), ErrorCode::kReservedBits},
        {"fence ray_type", with(fence_ok, [](cmd::Packet& p) { p.ray_type = 1; }), ErrorCode::kReservedBits},
        {"fence bounce", with(fence_ok, [](cmd::Packet& p) { p.bounce = 1; }), ErrorCode::kReservedBits},
        {"fence count", with(fence_ok, [](cmd::Packet& p) { p.count = 1; }), ErrorCode::kReservedBits},
        {"fence addr1", with(fence_ok, [](cmd::Packet& p) { p.addr1 = 8; }), ErrorCode::kReservedBits},
        {"timestamp flags", with(ts_ok, [](cmd::Packet& p) { p.flags = 1; }), ErrorCode::kReservedBits},
        {"timestamp ray_type", with(ts_ok, [](cmd::Packet& p) { p.ray_type = 1; }), ErrorCode::kReservedBits},
        {"timestamp bounce", with(ts_ok, [](cmd::Packet& p) { p.bounce = 1; }), ErrorCode::kReservedBits},
        {"timestamp count", with(ts_ok, [](cmd::Packet& p) { p.count = 1; }), ErrorCode::kReservedBits},
        {"timestamp addr1", with(ts_ok, [](cmd::Packet& p) { p.addr1 = 8; }), ErrorCode::kReservedBits},
        {"timestamp value", with(ts_ok, [](cmd::Packet& p) { p.value = 1; }), ErrorCode::kReservedBits},
        // overlapping ray and hit buffers
        {"hits = rays", cmd::trace(rays, rays, 4, false, cmd::RayType::kPrimary, 0), ErrorCode::kOverlap},
        {"hits in the rays' last 16 bytes",
         cmd::trace(rays, rays + 4 * 32 - 16, 4, false, cmd::RayType::kPrimary, 0), ErrorCode::kOverlap},
        {"hits end 16 bytes into the rays",
         cmd::trace(rays + 4 * 16, rays + 16, 4, false, cmd::RayType::kPrimary, 0), ErrorCode::kOverlap},
        {"hits inside the rays", cmd::trace(rays, rays + 32, 2, true, cmd::RayType::kShadow, 0),
         ErrorCode::kOverlap},
        // scenes the engine cannot use
        {"bind of 0 bytes at the end of memory", cmd::bind_scene(M, 0), ErrorCode::kBadScene},
        {"bind of the truncated image", cmd::bind_scene(r.image, r.image_bytes - 8), ErrorCode::kBadScene},
        {"bind of the image's header only", cmd::bind_scene(r.image, 104), ErrorCode::kBadScene},
        {"bind of the image with 8 bytes more", cmd::bind_scene(r.image, r.image_bytes + 8), ErrorCode::kBadScene},
        {"bind of ray bytes", cmd::bind_scene(rays, 64 * 32), ErrorCode::kBadScene},
    };
    for (const Case& c : cases) {
      INFO(c.name << " (" << reg::error_name(c.code) << ")");
      expect_packet_fault(r, c.packet, c.code);
    }

    // Garbage and the other engine's image: kBadScene, and nothing stays bound (the old scene is dropped).
    hw::Pcg32 rng(77);
    std::vector<uint8_t> garbage(4096);
    for (uint8_t& b : garbage) b = uint8_t(rng.next_u32());
    const uint64_t g = r.put(garbage.data(), garbage.size(), 8);
    const SceneData& sd = seed_scene();
    const uint64_t other = std::string(engine) == "float"
                               ? r.put(sd.fixed_image->data(), sd.fixed_image->size(), 8)
                               : r.put(sd.float_image.data(), sd.float_image.size() * 8, 8);
    const uint64_t other_bytes =
        std::string(engine) == "float" ? sd.fixed_image->size() : sd.float_image.size() * 8;
    for (const cmd::Packet& p : {cmd::bind_scene(g, garbage.size()), cmd::bind_scene(other, other_bytes)}) {
      INFO("bad scene at " << hex(p.addr0));
      expect_packet_fault(r, p, ErrorCode::kBadScene);
    }
    r.start();
    r.bind();
    r.submit(cmd::bind_scene(g, garbage.size()));
    r.ring.commit();
    CHECK(r.rd(reg::kErrorCode) == uint32_t(ErrorCode::kBadScene));
    CHECK((r.rd(reg::kStatus) & reg::kStatusBound) == 0);
    CHECK_FALSE(r.dev.engine().bound());

    // TRACE without a scene (the reset of start() dropped the one bound before).
    INFO("trace before bind");
    expect_packet_fault(r, trace_ok, ErrorCode::kNoScene, /*bind=*/false);

    // The valid versions of the packets above run (the harness is not failing everything).
    r.start();
    r.bind();
    for (const cmd::Packet& p :
         {fence_ok, trace_ok, ts_ok, cmd::fence(M - 8, 5, false), cmd::timestamp(M - 8),
          cmd::trace(rays, rays + 64 * 32, 64, false, cmd::RayType::kPrimary, 0),
          cmd::trace(rays + 64 * 16, rays, 4, false, cmd::RayType::kPrimary, 0),
          cmd::Packet{uint8_t(cmd::Opcode::kTrace), cmd::kTraceAnyHit, 6, 255, 1, rays, hits, 0}, bind_ok})
      r.submit(p);
    REQUIRE(r.ring.sync() == Status::kOk);
    CHECK(r.rd(reg::kErrorCode) == 0);
  }
}

TEST_CASE("command processor errors: register accesses", "[ring]") {
  for (const char* engine : kEngines) {
    CAPTURE(engine);
    Rig r(engine, 8);
    const uint64_t M = kMemBytes;
    struct Case {
      std::string name;
      std::function<void(Rig&)> poke;
      ErrorCode code;
      uint32_t info;
    };
    std::vector<Case> cases;
    // Read-only registers.
    for (uint32_t off :
         {reg::kId, reg::kVersion, reg::kCaps, reg::kStatus, reg::kErrorCode, reg::kErrorInfo, reg::kRingHead,
          reg::kClockLo, reg::kClockHi, reg::kFenceLo, reg::kFenceHi, reg::kMemSizeLo, reg::kMemSizeHi})
      cases.push_back({"read-only " + hex(off), [off](Rig& r) { r.wr(off, 0); }, ErrorCode::kBadRegister, off});
    // Unknown and unaligned offsets; their reads are all ones and raise nothing.
    for (uint32_t off :
         {reg::kWindowBytes, 0x54u, 0x100u, 0x1000u, 0xFFFFFFFCu, 0x1u, 0x2u, 0xEu, 0x35u, 0xFFFFFFFFu})
      cases.push_back({"unknown " + hex(off),
                       [off](Rig& r) {
                         CHECK(r.rd(off) == 0xFFFFFFFFu);
                         CHECK(r.rd(reg::kErrorCode) == 0);
                         r.wr(off, 1);
                       },
                       ErrorCode::kBadRegister, off});
    // Reserved control bits.
    for (uint32_t v : {4u, 0x80000000u, reg::kCtrlEnable | 8u, reg::kCtrlReset | 4u})
      cases.push_back(
          {"control " + hex(v), [v](Rig& r) { r.wr(reg::kControl, v); }, ErrorCode::kReservedBits, reg::kControl});
    // Ring registers while enabled; doorbells past the ring or while disabled.
    for (uint32_t off : {reg::kRingBaseLo, reg::kRingBaseHi, reg::kRingSize})
      cases.push_back({"ring register while enabled " + hex(off), [off](Rig& r) { r.wr(off, r.rd(off)); },
                       ErrorCode::kRingMisuse, off});
    for (uint32_t v : {8u, 9u, 0x80000000u, 0xFFFFFFFFu})
      cases.push_back(
          {"tail " + hex(v), [v](Rig& r) { r.wr(reg::kRingTail, v); }, ErrorCode::kRingMisuse, reg::kRingTail});
    cases.push_back({"doorbell after reset",
                     [](Rig& r) {
                       r.wr(reg::kControl, reg::kCtrlReset);
                       r.wr(reg::kRingTail, 1);
                     },
                     ErrorCode::kRingMisuse, reg::kRingTail});
    cases.push_back({"doorbell after disable",
                     [](Rig& r) {
                       r.wr(reg::kControl, 0);
                       CHECK((r.rd(reg::kStatus) & reg::kStatusEnabled) == 0);
                       r.wr(reg::kRingTail, (r.rd(reg::kRingTail) + 1) % 8);
                     },
                     ErrorCode::kRingMisuse, reg::kRingTail});
    // Enabling an invalid ring.
    auto bad_ring = [](uint64_t base, uint32_t size) {
      return [base, size](Rig& r) {
        r.wr(reg::kControl, reg::kCtrlReset);
        r.wr(reg::kRingBaseLo, uint32_t(base));
        r.wr(reg::kRingBaseHi, uint32_t(base >> 32));
        r.wr(reg::kRingSize, size);
        r.wr(reg::kControl, reg::kCtrlEnable);
        CHECK((r.rd(reg::kStatus) & reg::kStatusEnabled) == 0);
      };
    };
    for (uint32_t size :
         {0u, 1u, 3u, 6u, 100u, reg::kMaxRingSlots + 1, 2 * reg::kMaxRingSlots, 0x80000000u, 0xFFFFFFFFu})
      cases.push_back({"ring size " + hex(size), bad_ring(0, size), ErrorCode::kBadRing, reg::kControl});
    for (uint64_t base : {uint64_t(16), uint64_t(8), uint64_t(1), uint64_t(4096 + 4)})
      cases.push_back({"ring base " + hex(base), bad_ring(base, 8), ErrorCode::kBadRing, reg::kControl});
    for (uint64_t base : {M - 7 * 32, M, M + 32 * 1024, uint64_t(1) << 32, ~uint64_t(31), ~uint64_t(255)})
      cases.push_back(
          {"ring outside memory at " + hex(base), bad_ring(base, 8), ErrorCode::kBadRing, reg::kControl});

    for (const Case& c : cases) {
      INFO(c.name << " (" << reg::error_name(c.code) << ")");
      expect_register_fault(r, c.poke, c.code, c.info);
    }

    // The valid extremes of the ring: the last 8 slots of memory, 2 slots, kMaxRingSlots.
    for (auto [base, size] : {std::pair<uint64_t, uint32_t>{M - 8 * 32, 8}, {0, 2}, {0, reg::kMaxRingSlots}}) {
      INFO("valid ring at " << hex(base) << " of " << size);
      r.wr(reg::kControl, reg::kCtrlReset);
      r.wr(reg::kRingBaseLo, uint32_t(base));
      r.wr(reg::kRingBaseHi, uint32_t(base >> 32));
      r.wr(reg::kRingSize, size);
      r.wr(reg::kControl, reg::kCtrlEnable);
      CHECK(r.rd(reg::kStatus) == (reg::kStatusEnabled | reg::kStatusIdle));
      std::memset(r.dev.mem() + base, 0, 32);  // a NOP in slot 0
      r.wr(reg::kRingTail, 1);
      CHECK(r.rd(reg::kRingHead) == 1);
      CHECK(r.rd(reg::kErrorCode) == 0);
    }
    // Disable, reprogram, enable again without reset: allowed, and head and tail restart at 0.
    r.start();
    r.wr(reg::kControl, 0);
    r.wr(reg::kRingSize, 4);
    r.wr(reg::kControl, reg::kCtrlEnable);
    CHECK(r.rd(reg::kErrorCode) == 0);
    CHECK(r.rd(reg::kRingHead) == 0);
    CHECK(r.rd(reg::kRingSize) == 4);
    // The read-only registers read what they say.
    CHECK(r.rd(reg::kId) == reg::kIdValue);
    CHECK(r.rd(reg::kVersion) == reg::kVersionValue);
    CHECK(r.rd(reg::kMemSizeLo) == uint32_t(M));
    CHECK(r.rd(reg::kMemSizeHi) == uint32_t(M >> 32));
    CHECK((r.rd(reg::kCaps) & reg::kCapAnyHit) != 0);
    CHECK(((r.rd(reg::kCaps) & reg::kCapFixed) != 0) == (std::string(engine) == "fixed"));
  }
}
