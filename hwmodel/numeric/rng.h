// PCG32 (O'Neill, "PCG: A Family of Simple Fast Space-Efficient Statistically Good Algorithms", 2014): a small
// generator with the same output on every platform, unlike std:: distributions. Freestanding.
#pragma once

#include <cstdint>

namespace rtu::hw {

class Pcg32 {
 public:
  explicit Pcg32(uint64_t seed, uint64_t stream = 0x853c49e6748fea9bULL) : m_inc((stream << 1u) | 1u) {
    next_u32();
    m_state += seed;
    next_u32();
  }
  uint32_t next_u32() {
    const uint64_t old = m_state;
    m_state = old * 6364136223846793005ULL + m_inc;
    const uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
    const uint32_t rot = uint32_t(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((32u - rot) & 31u));
  }
  // Uniform in [0, 1): the top 24 bits, exactly representable in float.
  float next_float() { return float(next_u32() >> 8) * 0x1p-24f; }

 private:
  uint64_t m_state = 0;
  uint64_t m_inc;
};

// SplitMix64's output function (Steele, Lea and Flood, "Fast Splittable Pseudorandom Number Generators",
// OOPSLA 2014): a 64-bit mix in which nearby inputs give unrelated outputs, for seeds drawn per item.
constexpr uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ULL;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
  return x ^ (x >> 31);
}

}  // namespace rtu::hw
