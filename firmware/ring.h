// The ring driver: sets the unit up, writes command packets into the ring in device memory, rings the doorbell
// and waits on fences. Freestanding. Protocol (firmware/README.md): alloc a slot -> write the packet -> commit
// (barrier, then the new tail to kRingTail). A full ring is committed and the head re-read; every wait is
// bounded and ends with a status, never a hang.
#pragma once

#include <cstdint>

#include "firmware/hal.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/interface/regs.h"

namespace rtu::fw {

enum class Status : uint8_t {
  kOk = 0,
  kNoDevice,     // the ID register does not read as the unit
  kNoMemory,     // the arena cannot hold the ring or a buffer
  kDeviceError,  // the unit stopped on an error (error_code() says which)
  kTimeout,      // a wait polled kMaxPolls times without progress
  kBadArgument,  // a request the driver refuses (e.g. a ring size that is not a power of two)
};
const char* status_name(Status s);

class Ring {
 public:
  static constexpr uint32_t kMaxPolls = 1u << 20;

  // Resets the unit, allocates `slots` packets (a power of two, 2..hw::reg::kMaxRingSlots) and a fence word from
  // the arena, programs the ring registers and enables the unit.
  Status init(Hal& hal, Arena& arena, uint32_t slots);

  // Writes a packet into the next free slot (committing and waiting for the device when the ring is full).
  Status submit(const hw::cmd::Packet& p);
  // Makes every submitted packet visible to the unit: barrier, then the doorbell.
  void commit();
  // Submits a FENCE with the next value, commits, and waits until the unit has written it.
  Status sync();
  // Waits until the fence word reaches `value`; kDeviceError if the unit stops on an error meanwhile.
  Status wait(uint64_t value);

  hw::reg::ErrorCode error_code() const;
  uint32_t error_info() const;

  struct Counters {
    uint64_t packets = 0;    // packets submitted
    uint64_t doorbells = 0;  // commits that moved the tail
    uint64_t fences = 0;     // FENCE packets submitted
    uint64_t waits = 0;      // waits that returned kOk
    uint64_t full = 0;       // submits that found the ring full
  };
  const Counters& counters() const { return m_counters; }
  uint32_t slots() const { return m_slots; }

 private:
  Hal* m_hal = nullptr;
  uint64_t m_base = 0;        // device address of slot 0
  uint64_t m_fence_addr = 0;  // device address of the fence word
  uint32_t m_slots = 0;
  uint32_t m_tail = 0;       // next slot to write (not yet visible to the unit until commit)
  uint32_t m_committed = 0;  // tail last written to the doorbell
  uint64_t m_fence_value = 0;
  Counters m_counters;
};

}  // namespace rtu::fw
