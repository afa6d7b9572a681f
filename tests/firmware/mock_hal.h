// A recording mock of fw::Hal for testing the firmware's ring driver alone, without a model device behind it.
//
// It owns a byte vector as device memory, logs every MMIO write (offset, value) and every barrier in one ordered
// list, and emulates only what fw::Ring needs of the register file: ID (settable, to play a foreign device),
// status (enabled, idle, error: set by the test, cleared by reset), head (device-owned: advanced only by consume()
// or by the consume-on-doorbell policy), tail, error code/info (set by the test). Consuming a FENCE packet writes
// its value at its address, so sync() and wait() can be exercised; every other packet is just skipped. At each
// doorbell the mock copies the packets between the old and the new tail as they are in memory at that moment,
// so a test can check that a packet's bytes were in its slot before the doorbell rang.
#pragma once

#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "firmware/hal.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/interface/regs.h"

namespace rtu::test {

class MockHal final : public fw::Hal {
 public:
  struct Event {
    enum class Kind { kWrite, kBarrier };
    Kind kind;
    uint32_t offset = 0;  // kWrite: register offset
    uint32_t value = 0;   // kWrite: value written
    bool operator==(const Event&) const = default;
  };
  static Event write_event(uint32_t offset, uint32_t value) { return {Event::Kind::kWrite, offset, value}; }
  static Event barrier_event() { return {Event::Kind::kBarrier, 0, 0}; }

  // What a doorbell saw: the tail written and the packets of the slots it made visible, read from memory at the
  // moment of the write.
  struct Doorbell {
    uint32_t tail = 0;
    std::vector<hw::cmd::Packet> packets;
  };

  enum class Policy {
    kManual,             // the head moves only when the test calls consume()
    kConsumeOnDoorbell,  // every doorbell consumes everything up to the new tail at once (like the model device)
    kConsumeAfterPolls,  // everything pending is consumed once the head has been read `polls` times since the
                         // last doorbell (a device that takes a while)
  };

  explicit MockHal(size_t memory_bytes) : m_mem(memory_bytes, 0) {}

  // --- fw::Hal
  uint32_t read32(uint32_t offset) override {
    ++m_reads;
    switch (offset) {
      case hw::reg::kId:
        return m_id;
      case hw::reg::kStatus: {
        uint32_t s = 0;
        if (m_control & hw::reg::kCtrlEnable) s |= hw::reg::kStatusEnabled;
        if (m_head == m_tail) s |= hw::reg::kStatusIdle;
        if (m_error != 0) s |= hw::reg::kStatusError;
        return s;
      }
      case hw::reg::kErrorCode:
        return m_error;
      case hw::reg::kErrorInfo:
        return m_error_info;
      case hw::reg::kRingHead:
        ++m_head_reads;
        if (m_policy == Policy::kConsumeAfterPolls && m_head != m_tail && ++m_polls_since_doorbell >= m_polls)
          consume(pending());
        return m_head;
      case hw::reg::kRingTail:
        return m_tail;
      case hw::reg::kRingSize:
        return m_size;
      default:
        return 0;
    }
  }
  void write32(uint32_t offset, uint32_t value) override {
    m_log.push_back(write_event(offset, value));
    switch (offset) {
      case hw::reg::kControl:
        if (value & hw::reg::kCtrlReset) {
          m_control = 0;
          m_head = m_tail = 0;
          m_base = 0;
          m_size = 0;
          m_error = m_error_info = 0;
        } else if (m_enable_error != 0 && (value & hw::reg::kCtrlEnable)) {
          set_error(m_enable_error, offset);  // a device that refuses the ring
        } else {
          m_control = value;
          if (value & hw::reg::kCtrlEnable) m_head = m_tail = 0;
        }
        break;
      case hw::reg::kRingBaseLo:
        m_base = (m_base & ~uint64_t(0xFFFFFFFFu)) | value;
        break;
      case hw::reg::kRingBaseHi:
        m_base = (m_base & 0xFFFFFFFFu) | (uint64_t(value) << 32);
        break;
      case hw::reg::kRingSize:
        m_size = value;
        break;
      case hw::reg::kRingTail: {
        if (m_size == 0 || value >= m_size) throw std::logic_error("mock: doorbell outside the ring");
        Doorbell d{value, {}};
        for (uint32_t s = m_tail; s != value; s = (s + 1) & (m_size - 1)) d.packets.push_back(slot(s));
        m_doorbells.push_back(std::move(d));
        m_tail = value;
        m_polls_since_doorbell = 0;
        if (m_policy == Policy::kConsumeOnDoorbell) consume(pending());
        break;
      }
      default:
        break;
    }
  }
  void barrier() override { m_log.push_back(barrier_event()); }
  uint8_t* mem() override { return m_mem.data(); }
  uint64_t mem_size() override { return m_mem.size(); }
  void set_any_hit(const hw::AnyHitStage* stage) override { m_any_hit = stage; }

  // --- the device side, driven by the test
  // The any-hit stage the firmware installed (null: none).
  const hw::AnyHitStage* any_hit() const { return m_any_hit; }
  void set_id(uint32_t id) { m_id = id; }
  void set_policy(Policy p, uint32_t polls = 0) {
    m_policy = p;
    m_polls = polls;
  }
  // The next enable raises error `code` (info: the control register) instead of enabling; 0 turns this off.
  void fail_enable(uint32_t code) { m_enable_error = code; }
  // Raises (code != 0) or clears the error status (reset clears it too).
  void set_error(uint32_t code, uint32_t info = 0) {
    m_error = code;
    m_error_info = info;
  }
  // Consumes n pending packets in ring order (at most what is pending); a FENCE writes its value.
  void consume(uint32_t n) {
    for (uint32_t i = 0; i < n && m_head != m_tail; ++i) {
      const hw::cmd::Packet p = slot(m_head);
      if (p.opcode == uint8_t(hw::cmd::Opcode::kFence) && m_mem.size() >= 8 && p.addr0 <= m_mem.size() - 8)
        std::memcpy(m_mem.data() + p.addr0, &p.value, 8);
      ++m_consumed;
      m_head = (m_head + 1) & (m_size - 1);
    }
  }
  uint32_t pending() const { return m_size ? (m_tail - m_head) & (m_size - 1) : 0; }

  // The packet in ring slot s, as it is in memory now.
  hw::cmd::Packet slot(uint32_t s) const {
    const uint64_t at = m_base + uint64_t(s) * hw::cmd::kPacketBytes;
    if (at + hw::cmd::kPacketBytes > m_mem.size()) throw std::logic_error("mock: ring slot outside memory");
    hw::cmd::Packet p;
    std::memcpy(&p, m_mem.data() + at, sizeof p);
    return p;
  }

  // --- what happened
  const std::vector<Event>& log() const { return m_log; }
  void clear_log() {
    m_log.clear();
    m_doorbells.clear();
  }
  const std::vector<Doorbell>& doorbells() const { return m_doorbells; }
  uint64_t reads() const { return m_reads; }
  uint64_t head_reads() const { return m_head_reads; }
  uint64_t consumed() const { return m_consumed; }
  uint32_t head() const { return m_head; }
  uint32_t tail() const { return m_tail; }
  uint64_t ring_base() const { return m_base; }
  uint32_t ring_size() const { return m_size; }
  uint32_t control() const { return m_control; }

 private:
  std::vector<uint8_t> m_mem;
  const hw::AnyHitStage* m_any_hit = nullptr;
  std::vector<Event> m_log;
  std::vector<Doorbell> m_doorbells;
  Policy m_policy = Policy::kManual;
  uint32_t m_polls = 0, m_polls_since_doorbell = 0;
  uint32_t m_id = hw::reg::kIdValue;
  uint32_t m_control = 0;
  uint32_t m_error = 0, m_error_info = 0, m_enable_error = 0;
  uint64_t m_base = 0;
  uint32_t m_size = 0, m_head = 0, m_tail = 0;
  uint64_t m_reads = 0, m_head_reads = 0, m_consumed = 0;
};

}  // namespace rtu::test
