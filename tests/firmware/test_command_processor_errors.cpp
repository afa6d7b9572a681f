// The command processor's error paths (hwmodel/device/command_processor.cpp) on the model device
// (host::FirmwareDevice over the float and fixed engines), driven by the firmware ring driver as the firmware
// would (model_rig.h):
// - each malformed packet (unknown opcodes, addresses outside memory and ends that overflow 64 bits, misaligned
//   buffers, bad counts, reserved fields of each opcode, overlapping ray and hit buffers, scenes the engine cannot
//   use, a TRACE before any scene) and each bad register access (read-only, unknown and unaligned offsets,
//   reserved control bits, ring registers while enabled, doorbells past the ring or while disabled, enabling an
//   invalid ring): its error code, kStatusError, kIrqError, the error info (the faulting ring slot or register),
//   the head left on the faulting slot, later doorbells consuming nothing, and kCtrlReset recovering so that a
//   valid job then runs and gives the right hits;
// - the valid extremes next to them (buffers at the end of memory, the smallest and largest rings) run.
// The processor's watchdog is tested in tests/hwmodel/test_watchdog.cpp, random packets and register writes in
// test_fuzz_cp.cpp.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "firmware/hal.h"
#include "firmware/ring.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/interface/regs.h"
#include "hwmodel/numeric/rng.h"
#include "tests/firmware/model_rig.h"

using namespace rtu;
using namespace rtu::test;

namespace {

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
        {"trace flag bit 2", with(trace_ok, [](cmd::Packet& p) { p.flags = 4; }), ErrorCode::kReservedBits},
        {"trace any-hit and all-hit", with(trace_ok, [](cmd::Packet& p) { p.flags = 3; }),
         ErrorCode::kReservedBits},
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
        // all-hit TRACEs: the bound, the lists' bytes
        {"all-hit k 257", cmd::trace_all_hits(rays, hits, 1, cmd::kMaxAllHits + 1, cmd::RayType::kOther, 0),
         ErrorCode::kBadCount},
        {"all-hit k 2^32",
         with(cmd::trace_all_hits(rays, hits, 1, 1, cmd::RayType::kOther, 0),
              [](cmd::Packet& p) { p.value = uint64_t(1) << 32; }),
         ErrorCode::kBadCount},
        {"all-hit lists past the end", cmd::trace_all_hits(rays, M - 63 * 5 * 16, 64, 4, cmd::RayType::kOther, 0),
         ErrorCode::kBadAddress},
        {"all-hit lists of 256 hits past the end",
         cmd::trace_all_hits(rays, M - 64 * 256 * 16, 64, cmd::kMaxAllHits, cmd::RayType::kOther, 0),
         ErrorCode::kBadAddress},
        {"all-hit lists % 16 = 8", cmd::trace_all_hits(rays, hits + 8, 1, 2, cmd::RayType::kOther, 0),
         ErrorCode::kMisaligned},
        {"all-hit lists end in the rays", cmd::trace_all_hits(rays + 64, rays + 16, 2, 1, cmd::RayType::kOther, 0),
         ErrorCode::kOverlap},
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
        {"bind of the image's header only", cmd::bind_scene(r.image, sizeof(hw::ImageHeader)),
         ErrorCode::kBadScene},
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
