// The unit's device memory: a flat, zero-initialized byte array addressed from 0. Every access names an address
// and a size and is checked (in_range), so no device address can reach outside it; the command processor turns
// a failed check into an error code, never into an out-of-bounds access.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace rtu::hw {

class DeviceMemory {
 public:
  // Throws std::invalid_argument when bytes is 0 or above kMaxBytes.
  explicit DeviceMemory(uint64_t bytes) {
    if (bytes == 0 || bytes > kMaxBytes)
      throw std::invalid_argument("device memory: size " + std::to_string(bytes) + " outside [1, 2^36]");
    m_words.assign((bytes + 7) / 8, 0);
    m_size = bytes;
  }
  static constexpr uint64_t kMaxBytes = uint64_t(1) << 36;

  uint64_t size() const { return m_size; }
  // [addr, addr + bytes) lies inside the memory (no wraparound).
  bool in_range(uint64_t addr, uint64_t bytes) const { return addr <= m_size && bytes <= m_size - addr; }

  // Base of the memory (8-byte aligned), for the in-process HAL that maps it into the firmware's address space.
  uint8_t* data() { return reinterpret_cast<uint8_t*>(m_words.data()); }
  const uint8_t* data() const { return reinterpret_cast<const uint8_t*>(m_words.data()); }

  // Checked copies; throw std::out_of_range outside the memory.
  void write(uint64_t addr, const void* src, uint64_t bytes) {
    check(addr, bytes);
    if (bytes) std::memcpy(data() + addr, src, bytes);
  }
  void read(uint64_t addr, void* dst, uint64_t bytes) const {
    check(addr, bytes);
    if (bytes) std::memcpy(dst, data() + addr, bytes);
  }
  template <class T>
  T load(uint64_t addr) const {
    T v;
    read(addr, &v, sizeof v);
    return v;
  }
  template <class T>
  void store(uint64_t addr, const T& v) {
    write(addr, &v, sizeof v);
  }

 private:
  void check(uint64_t addr, uint64_t bytes) const {
    if (!in_range(addr, bytes))
      throw std::out_of_range("device memory: [" + std::to_string(addr) + ", +" + std::to_string(bytes) +
                              ") outside " + std::to_string(m_size) + " bytes");
  }
  std::vector<uint64_t> m_words;
  uint64_t m_size = 0;
};

}  // namespace rtu::hw
