#include "firmware/ring.h"

#include "hwmodel/interface/enum_names.h"

namespace rtu::fw {

namespace reg = hw::reg;

const char* status_name(Status s) {
  static constexpr const char* names[] = {"ok",           "no_device", "no_memory",
                                          "device_error", "timeout",   "bad_argument"};
  static_assert(hw::count_of(names) == std::size_t(Status::kBadArgument) + 1, "a name for every status");
  return hw::enum_name(names, s);
}

Status Ring::init(Hal& hal, Arena& arena, uint32_t slots) {
  m_hal = &hal;
  if (hal.read32(reg::kId) != reg::kIdValue) return Status::kNoDevice;
  if (slots < 2 || slots > reg::kMaxRingSlots || (slots & (slots - 1)) != 0) return Status::kBadArgument;
  const uint64_t mark = arena.mark();
  const uint64_t ring = arena.alloc(uint64_t(slots) * hw::cmd::kPacketBytes, hw::cmd::kPacketBytes);
  const uint64_t fence = arena.alloc(8, 8);
  if (ring == Arena::kNull || fence == Arena::kNull) {
    arena.release(mark);  // nothing kept from a failed init
    return Status::kNoMemory;
  }
  m_base = ring;
  m_fence_addr = fence;
  m_slots = slots;
  m_tail = m_committed = 0;
  m_fence_value = 0;
  *at<uint64_t>(hal, fence) = 0;
  hal.write32(reg::kControl, reg::kCtrlReset);
  hal.write32(reg::kRingBaseLo, uint32_t(ring));
  hal.write32(reg::kRingBaseHi, uint32_t(ring >> 32));
  hal.write32(reg::kRingSize, slots);
  hal.write32(reg::kIrqEnable, reg::kIrqFence | reg::kIrqError);
  hal.write32(reg::kControl, reg::kCtrlEnable);
  if (hal.read32(reg::kStatus) & reg::kStatusError) return Status::kDeviceError;
  return Status::kOk;
}

Status Ring::submit(const hw::cmd::Packet& p) {
  const uint32_t next = (m_tail + 1) & (m_slots - 1);
  if (next == m_hal->read32(reg::kRingHead)) {
    // Full: hand the unit what is written and wait for it to free a slot.
    ++m_counters.full;
    commit();
    uint32_t polls = 0;
    while (next == m_hal->read32(reg::kRingHead)) {
      if (m_hal->read32(reg::kStatus) & reg::kStatusError) return Status::kDeviceError;
      if (++polls >= kMaxPolls) return Status::kTimeout;
    }
  }
  *at<hw::cmd::Packet>(*m_hal, m_base + uint64_t(m_tail) * hw::cmd::kPacketBytes) = p;
  m_tail = next;
  ++m_counters.packets;
  if (p.opcode == uint8_t(hw::cmd::Opcode::kFence)) ++m_counters.fences;
  return Status::kOk;
}

void Ring::commit() {
  if (m_tail == m_committed) return;
  m_hal->barrier();  // the packets (and the buffers they name) before the doorbell
  m_hal->write32(reg::kRingTail, m_tail);
  m_committed = m_tail;
  ++m_counters.doorbells;
}

Status Ring::sync() {
  const uint64_t value = ++m_fence_value;
  const Status s = submit(hw::cmd::fence(m_fence_addr, value, true));
  if (s != Status::kOk) return s;
  commit();
  return wait(value);
}

Status Ring::wait(uint64_t value) {
  volatile const uint64_t* word = at<volatile const uint64_t>(*m_hal, m_fence_addr);
  uint32_t polls = 0;
  while (*word < value) {
    if (m_hal->read32(reg::kStatus) & reg::kStatusError) return Status::kDeviceError;
    if (++polls >= kMaxPolls) return Status::kTimeout;
  }
  // The unit may have stopped after the fence; report it at the next wait.
  ++m_counters.waits;
  return Status::kOk;
}

hw::reg::ErrorCode Ring::error_code() const {
  return hw::reg::ErrorCode(m_hal->read32(reg::kErrorCode));
}
uint32_t Ring::error_info() const {
  return m_hal->read32(reg::kErrorInfo);
}

}  // namespace rtu::fw
