// The firmware ring driver (firmware/ring.h) alone, against the recording mock HAL (mock_hal.h): the order of its
// register writes and barriers, where its packets land and when, wraparound, a full ring, every wait bounded, and
// every refusal (foreign device, bad slot counts, arena exhausted).
#include <catch2/catch.hpp>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "firmware/hal.h"
#include "firmware/ring.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/interface/regs.h"
#include "hwmodel/numeric/rng.h"
#include "tests/firmware/mock_hal.h"

using rtu::fw::Arena;
using rtu::fw::Ring;
using rtu::fw::Status;
using rtu::test::MockHal;
namespace cmd = rtu::hw::cmd;
namespace reg = rtu::hw::reg;

namespace {

using Event = MockHal::Event;

bool same_packet(const cmd::Packet& a, const cmd::Packet& b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

// A packet that names its index in every field the driver could mix up (it never interprets them).
cmd::Packet tagged(uint64_t i) {
  return cmd::trace(0x1000 + 16 * i, 0x80000 + 16 * i, uint32_t(i + 1), (i & 1) != 0, cmd::RayType(i % 7),
                    uint8_t(i));
}

// A ring of 4 slots, set up without fault, on a mock device of 4 KiB: what most ring tests start from.
struct RingOf4 {
  MockHal hal{4096};
  Arena arena{0, 4096};
  Ring ring;
  RingOf4() { REQUIRE(ring.init(hal, arena, 4) == Status::kOk); }
  // Submits the 3 packets tagged 0..2 that fill the ring (one slot stays free), without committing them.
  void fill() {
    for (uint64_t i = 0; i < 3; ++i) REQUIRE(ring.submit(tagged(i)) == Status::kOk);
  }
};

// Events of the log from index `from` on.
std::vector<Event> since(const MockHal& hal, size_t from) {
  return std::vector<Event>(hal.log().begin() + long(from), hal.log().end());
}

}  // namespace

TEST_CASE("ring init resets, programs base, size and interrupts, then enables, in that order", "[ring][mock]") {
  MockHal hal(64 * 1024);
  std::memset(hal.mem(), 0xAB, hal.mem_size());
  Arena arena(1000, 60 * 1024);  // a base that is not 32-byte aligned: the ring must be
  Ring ring;
  REQUIRE(ring.init(hal, arena, 8) == Status::kOk);
  const uint64_t base = 1024;
  const std::vector<Event> expected = {
      MockHal::write_event(reg::kControl, reg::kCtrlReset),
      MockHal::write_event(reg::kRingBaseLo, uint32_t(base)),
      MockHal::write_event(reg::kRingBaseHi, 0),
      MockHal::write_event(reg::kRingSize, 8),
      MockHal::write_event(reg::kIrqEnable, reg::kIrqFence | reg::kIrqError),
      MockHal::write_event(reg::kControl, reg::kCtrlEnable),
  };
  CHECK(hal.log() == expected);
  CHECK(hal.ring_base() == base);
  CHECK(hal.ring_size() == 8);
  CHECK(ring.slots() == 8);
  // The ring and one 8-byte fence word behind it.
  CHECK(arena.used() == base - 1000 + 8 * cmd::kPacketBytes + 8);
  CHECK(ring.counters().packets == 0);
  CHECK(ring.counters().doorbells == 0);

  // The fence word: inside the arena, after the ring, aligned, zeroed by init; sync() names it.
  hal.set_policy(MockHal::Policy::kConsumeOnDoorbell);
  const size_t before = hal.log().size();
  REQUIRE(ring.sync() == Status::kOk);
  REQUIRE(hal.doorbells().size() == 1);
  REQUIRE(hal.doorbells()[0].packets.size() == 1);
  const cmd::Packet f = hal.doorbells()[0].packets[0];
  CHECK(f.opcode == uint8_t(cmd::Opcode::kFence));
  CHECK(f.flags == cmd::kFenceIrq);
  CHECK(f.value == 1);
  CHECK(f.addr0 % 8 == 0);
  CHECK(f.addr0 >= base + 8 * cmd::kPacketBytes);
  CHECK(f.addr0 + 8 <= 1000 + arena.used());
  const std::vector<Event> commit = {MockHal::barrier_event(), MockHal::write_event(reg::kRingTail, 1)};
  CHECK(since(hal, before) == commit);
}

TEST_CASE("ring init zeroes the fence word", "[ring][mock]") {
  MockHal hal(4096);
  std::memset(hal.mem(), 0xAB, hal.mem_size());
  Arena arena(0, 4096);
  Ring ring;
  REQUIRE(ring.init(hal, arena, 4) == Status::kOk);
  // The fence word is the 8 bytes after the ring; a wait for value 0 needs no device at all, for value 1 it needs
  // a FENCE (the mock never consumes here), so it times out rather than seeing 0xABAB... as a completed fence.
  uint64_t word;
  std::memcpy(&word, hal.mem() + 4 * cmd::kPacketBytes, 8);
  CHECK(word == 0);
  CHECK(ring.wait(0) == Status::kOk);
  CHECK(ring.wait(1) == Status::kTimeout);
}

TEST_CASE("ring init refuses a device whose ID is not the unit's and touches nothing", "[ring][mock]") {
  for (uint32_t id : {0u, 0xFFFFFFFFu, reg::kIdValue ^ 1u, 0x52545531u}) {
    CAPTURE(id);
    MockHal hal(4096);
    hal.set_id(id);
    Arena arena(0, 4096);
    Ring ring;
    CHECK(ring.init(hal, arena, 4) == Status::kNoDevice);
    CHECK(hal.log().empty());
    CHECK(arena.used() == 0);
  }
}

TEST_CASE("ring init refuses slot counts that are not a power of two in [2, kMaxRingSlots]", "[ring][mock]") {
  for (uint32_t slots : {0u, 1u, 3u, 6u, 12u, 1000u, reg::kMaxRingSlots - 1, reg::kMaxRingSlots + 1,
                         2 * reg::kMaxRingSlots, 0x80000000u, 0xFFFFFFFFu}) {
    CAPTURE(slots);
    MockHal hal(4096);
    Arena arena(0, 4096);
    Ring ring;
    CHECK(ring.init(hal, arena, slots) == Status::kBadArgument);
    CHECK(hal.log().empty());
    CHECK(arena.used() == 0);
  }
  // Both ends of the range are accepted.
  for (uint32_t slots : {2u, reg::kMaxRingSlots}) {
    CAPTURE(slots);
    const uint64_t bytes = uint64_t(slots) * cmd::kPacketBytes + 64;
    MockHal hal(bytes);
    Arena arena(0, bytes);
    Ring ring;
    CHECK(ring.init(hal, arena, slots) == Status::kOk);
    CHECK(hal.ring_size() == slots);
  }
}

TEST_CASE("ring init reports an arena too small for the ring or its fence word", "[ring][mock]") {
  const uint64_t ring_bytes = 8 * cmd::kPacketBytes;
  for (uint64_t size : {uint64_t(0), uint64_t(31), ring_bytes - 1, ring_bytes, ring_bytes + 7}) {
    CAPTURE(size);
    MockHal hal(4096);
    Arena arena(64, size);
    Ring ring;
    CHECK(ring.init(hal, arena, 8) == Status::kNoMemory);
    CHECK(hal.log().empty());  // no register written
  }
  MockHal hal(4096);
  Arena arena(64, ring_bytes + 8);  // exactly enough
  Ring ring;
  CHECK(ring.init(hal, arena, 8) == Status::kOk);
  CHECK(arena.used() == ring_bytes + 8);
}

TEST_CASE("ring init reports a device that refuses the ring at enable", "[ring][mock]") {
  MockHal hal(4096);
  hal.fail_enable(uint32_t(reg::ErrorCode::kBadRing));
  Arena arena(0, 4096);
  Ring ring;
  CHECK(ring.init(hal, arena, 4) == Status::kDeviceError);
  CHECK(ring.error_code() == reg::ErrorCode::kBadRing);
  CHECK(ring.error_info() == reg::kControl);
}

TEST_CASE("ring submit writes only memory, each commit is a barrier, then the tail", "[ring][mock]") {
  MockHal hal(64 * 1024);
  Arena arena(0, 64 * 1024);
  Ring ring;
  REQUIRE(ring.init(hal, arena, 16) == Status::kOk);
  hal.clear_log();

  REQUIRE(ring.submit(tagged(0)) == Status::kOk);
  CHECK(hal.log().empty());  // a submit alone rings nothing
  CHECK(hal.tail() == 0);
  ring.commit();
  std::vector<Event> expected = {MockHal::barrier_event(), MockHal::write_event(reg::kRingTail, 1)};
  CHECK(hal.log() == expected);

  REQUIRE(ring.submit(tagged(1)) == Status::kOk);
  REQUIRE(ring.submit(tagged(2)) == Status::kOk);
  CHECK(hal.log().size() == 2);
  ring.commit();
  expected.push_back(MockHal::barrier_event());
  expected.push_back(MockHal::write_event(reg::kRingTail, 3));
  CHECK(hal.log() == expected);

  // Nothing new: no barrier, no doorbell.
  ring.commit();
  ring.commit();
  CHECK(hal.log() == expected);
  CHECK(ring.counters().doorbells == 2);
  CHECK(ring.counters().packets == 3);
  CHECK(ring.counters().full == 0);
}

TEST_CASE("ring packets are in their slots, byte for byte, when the doorbell rings", "[ring][mock]") {
  MockHal hal(64 * 1024);
  Arena arena(0, 64 * 1024);
  Ring ring;
  REQUIRE(ring.init(hal, arena, 16) == Status::kOk);
  hal.set_policy(MockHal::Policy::kConsumeOnDoorbell);
  std::vector<cmd::Packet> sent;
  uint64_t i = 0;
  for (int batch : {1, 3, 5, 2, 15, 1, 7}) {
    for (int k = 0; k < batch; ++k) {
      sent.push_back(tagged(i++));
      REQUIRE(ring.submit(sent.back()) == Status::kOk);
    }
    ring.commit();
    const MockHal::Doorbell& d = hal.doorbells().back();
    REQUIRE(d.packets.size() == size_t(batch));
    for (int k = 0; k < batch; ++k) {
      INFO("batch of " << batch << ", packet " << k);
      CHECK(same_packet(d.packets[k], sent[sent.size() - batch + k]));
    }
  }
  CHECK(hal.consumed() == sent.size());
}

TEST_CASE_METHOD(RingOf4, "ring tail wraps around after `slots` packets", "[ring][mock]") {
  hal.set_policy(MockHal::Policy::kConsumeOnDoorbell);
  hal.clear_log();
  for (uint64_t i = 0; i < 10; ++i) {
    REQUIRE(ring.submit(tagged(i)) == Status::kOk);
    ring.commit();
  }
  std::vector<uint32_t> tails;
  for (const Event& e : hal.log())
    if (e.kind == Event::Kind::kWrite) tails.push_back(e.value);
  CHECK(tails == std::vector<uint32_t>{1, 2, 3, 0, 1, 2, 3, 0, 1, 2});
  // Packet i went to slot i mod 4 (the doorbell saw it there).
  REQUIRE(hal.doorbells().size() == 10);
  for (uint64_t i = 0; i < 10; ++i) CHECK(same_packet(hal.doorbells()[i].packets.at(0), tagged(i)));
  CHECK(same_packet(hal.slot(1), tagged(9)));
  CHECK(same_packet(hal.slot(3), tagged(7)));
}

TEST_CASE_METHOD(RingOf4, "ring: 1000 packets through 4 slots with random commits arrive complete and in order",
                 "[ring][mock]") {
  const uint64_t seed = 0x5EED0001;
  CAPTURE(seed);
  rtu::hw::Pcg32 rng(seed);
  hal.set_policy(MockHal::Policy::kConsumeOnDoorbell);
  std::vector<cmd::Packet> sent;
  for (uint64_t i = 0; i < 1000; ++i) {
    sent.push_back(tagged(i));
    REQUIRE(ring.submit(sent.back()) == Status::kOk);
    if (rng.next_u32() % 3 == 0) ring.commit();
  }
  ring.commit();
  std::vector<cmd::Packet> seen;
  for (const MockHal::Doorbell& d : hal.doorbells()) {
    CHECK(d.tail < 4);
    CHECK(d.packets.size() <= 3);  // never more than slots - 1 pending
    seen.insert(seen.end(), d.packets.begin(), d.packets.end());
  }
  REQUIRE(seen.size() == sent.size());
  for (size_t i = 0; i < sent.size(); ++i) {
    if (!same_packet(seen[i], sent[i])) FAIL("packet " << i << " differs");
  }
  CHECK(ring.counters().packets == 1000);
  CHECK(ring.counters().full > 0);  // runs of 3 uncommitted packets filled the ring
  CHECK(ring.counters().doorbells == hal.doorbells().size());
  CHECK(hal.consumed() == 1000);
}

TEST_CASE_METHOD(RingOf4,
                 "ring: a full ring is committed, then waited on, a device that never moves gives kTimeout",
                 "[ring][mock]") {
  hal.clear_log();
  fill();
  CHECK(hal.log().empty());

  const uint64_t reads_before = hal.head_reads();
  CHECK(ring.submit(tagged(3)) == Status::kTimeout);
  const std::vector<Event> expected = {MockHal::barrier_event(), MockHal::write_event(reg::kRingTail, 3)};
  CHECK(hal.log() == expected);  // what was written was handed to the device before waiting
  CHECK(hal.head_reads() - reads_before >= Ring::kMaxPolls);
  CHECK(ring.counters().full == 1);
  CHECK(ring.counters().packets == 3);
  uint8_t zero[cmd::kPacketBytes] = {};
  CHECK(std::memcmp(hal.mem() + 3 * cmd::kPacketBytes, zero, sizeof zero) == 0);  // slot 3 untouched

  // Once the device frees a slot the same packet goes in.
  hal.consume(1);
  CHECK(ring.submit(tagged(3)) == Status::kOk);
  CHECK(same_packet(hal.slot(3), tagged(3)));
  ring.commit();
  CHECK(hal.tail() == 0);
  CHECK(ring.counters().packets == 4);
}

TEST_CASE_METHOD(RingOf4, "ring: a full ring waits for a slow device", "[ring][mock]") {
  hal.set_policy(MockHal::Policy::kConsumeAfterPolls, 1000);
  fill();
  const uint64_t reads_before = hal.head_reads();
  CHECK(ring.submit(tagged(3)) == Status::kOk);
  CHECK(hal.head_reads() - reads_before >= 1000);
  CHECK(ring.counters().full == 1);
  CHECK(hal.consumed() == 3);
  CHECK(same_packet(hal.slot(3), tagged(3)));
}

TEST_CASE_METHOD(RingOf4, "ring: a full ring on a stopped device gives kDeviceError at once", "[ring][mock]") {
  fill();
  hal.set_error(uint32_t(reg::ErrorCode::kBadOpcode), 0);
  const uint64_t reads_before = hal.reads();
  CHECK(ring.submit(tagged(3)) == Status::kDeviceError);
  CHECK(hal.reads() - reads_before < 10);
  CHECK(ring.error_code() == reg::ErrorCode::kBadOpcode);
}

TEST_CASE_METHOD(RingOf4,
                 "ring wait: kDeviceError on the error bit, kTimeout when nothing happens, kOk once written",
                 "[ring][mock]") {
  SECTION("no progress: bounded") {
    const uint64_t reads_before = hal.reads();
    CHECK(ring.wait(1) == Status::kTimeout);
    CHECK(hal.reads() - reads_before >= Ring::kMaxPolls);
    CHECK(ring.counters().waits == 0);
    // sync on a device that never consumes: the fence is committed, then the wait times out.
    CHECK(ring.sync() == Status::kTimeout);
    CHECK(hal.doorbells().size() == 1);
  }
  SECTION("error bit") {
    hal.set_error(uint32_t(reg::ErrorCode::kRingMisuse), 2);
    const uint64_t reads_before = hal.reads();
    CHECK(ring.wait(1) == Status::kDeviceError);
    CHECK(hal.reads() - reads_before < 10);
    CHECK(ring.error_code() == reg::ErrorCode::kRingMisuse);
    CHECK(ring.error_info() == 2);
    CHECK(ring.sync() == Status::kDeviceError);
  }
  SECTION("fences complete") {
    hal.set_policy(MockHal::Policy::kConsumeOnDoorbell);
    for (uint64_t v = 1; v <= 20; ++v) {
      CHECK(ring.sync() == Status::kOk);
      const cmd::Packet& f = hal.doorbells().back().packets.at(0);
      CHECK(f.value == v);
      CHECK(f.opcode == uint8_t(cmd::Opcode::kFence));
    }
    CHECK(ring.wait(20) == Status::kOk);
    CHECK(ring.wait(21) == Status::kTimeout);
    CHECK(ring.counters().fences == 20);
    CHECK(ring.counters().waits == 21);
  }
}

TEST_CASE("ring status names are distinct", "[ring][mock]") {
  const Status all[] = {Status::kOk,          Status::kNoDevice, Status::kNoMemory,
                        Status::kDeviceError, Status::kTimeout,  Status::kBadArgument};
  for (Status a : all) {
    CHECK(std::string(rtu::fw::status_name(a)) != "unknown");
    for (Status b : all)
      if (a != b) CHECK(std::string(rtu::fw::status_name(a)) != rtu::fw::status_name(b));
  }
}
