// The firmware's only door to the unit: MMIO registers, a write barrier and device memory. Backends: the
// in-process device (host::FirmwareDevice, host/devices/firmware_device.h) and a recording mock for unit tests
// (tests/firmware/). Freestanding: no heap, no exceptions, no RTTI, no I/O.
#pragma once

#include <cstddef>
#include <cstdint>

#include "hwmodel/interface/any_hit.h"

namespace rtu::fw {

class Hal {
 public:
  // 32-bit register access at a byte offset of the unit's MMIO window (hw::reg).
  virtual uint32_t read32(uint32_t offset) = 0;
  virtual void write32(uint32_t offset, uint32_t value) = 0;
  // Orders every earlier write to device memory before any later MMIO write (the doorbell).
  virtual void barrier() = 0;
  // Device memory as mapped into the controller's address space: device address a is mem() + a.
  virtual uint8_t* mem() = 0;
  virtual uint64_t mem_size() = 0;
  // Installs the firmware's any-hit stage (hwmodel/interface/any_hit.h; null removes it): the handler of the
  // unit's any-hit requests, called with each candidate hit on a non-opaque triangle while the ray waits for the
  // answer.
  virtual void set_any_hit(const hw::AnyHitStage* stage) = 0;

 protected:
  ~Hal() = default;  // not deleted through a Hal*: no virtual destructor (it would need operator delete)
};

// Device memory handed out from a fixed region, bump-pointer style; no free, only reset.
class Arena {
 public:
  static constexpr uint64_t kNull = ~uint64_t(0);

  Arena() = default;
  Arena(uint64_t base, uint64_t size) : m_base(base), m_size(size), m_top(base) {}

  // A device address aligned to `align` (a power of two) with `bytes` free behind it, or kNull.
  uint64_t alloc(uint64_t bytes, uint64_t align = 16) {
    const uint64_t at = (m_top + align - 1) & ~(align - 1);
    if (at < m_top || at > m_base + m_size || bytes > m_base + m_size - at) return kNull;
    m_top = at + bytes;
    return at;
  }
  void reset() { m_top = m_base; }
  // Undo every allocation made since mark() returned m (for a request that fails halfway).
  uint64_t mark() const { return m_top; }
  void release(uint64_t m) {
    if (m >= m_base && m <= m_top) m_top = m;
  }
  uint64_t used() const { return m_top - m_base; }
  uint64_t size() const { return m_size; }

 private:
  uint64_t m_base = 0, m_size = 0, m_top = 0;
};

// A typed view of device memory at `addr` (allocated from an Arena with T's alignment).
template <class T>
T* at(Hal& hal, uint64_t addr) {
  return reinterpret_cast<T*>(hal.mem() + addr);
}

}  // namespace rtu::fw
