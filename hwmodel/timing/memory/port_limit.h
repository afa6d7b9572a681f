// The unit's memory port when it takes one request and hands out one response a clock (key fetch_port_rate = 1),
// as the RTL traversal unit's port does (rtl_sim/trav/trav_unit.sv): node and record fetches, stack spills and
// refills each take the first clock at or after their cycle that no earlier request took; a read's data leaves
// at the first clock at or after its ready cycle that no earlier read's data took (claimed in request order). Off
// (the default): every request goes at its own cycle and every answer at its ready cycle, however many share it.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace rtu::hw {

class PortLimit {
 public:
  explicit PortLimit(int rate) : m_on(rate > 0), m_claimed(m_on ? kWindow : 0, ~uint64_t(0)) {}
  bool on() const { return m_on; }

  // The cycle a request wanting cycle t goes out; `waits` counts the cycles it waited.
  uint64_t request(uint64_t t, uint64_t& waits) {
    if (!m_on) return t;
    const uint64_t r = std::max(t, m_free);
    m_free = r + 1;
    waits += r - t;
    return r;
  }
  // The cycle a read's data ready at `ready` reaches the unit.
  uint64_t response(uint64_t ready, uint64_t& waits) {
    if (!m_on) return ready;
    uint64_t r = ready;
    while (m_claimed[r % kWindow] == r) ++r;
    m_claimed[r % kWindow] = r;
    waits += r - ready;
    return r;
  }

 private:
  // Responses claimed, by cycle modulo the window (a response due more than kWindow cycles after another that
  // shares its slot is simply not seen as taken: answers are never that far apart in one unit's port).
  static constexpr uint64_t kWindow = 1u << 16;
  bool m_on;
  uint64_t m_free = 0;
  std::vector<uint64_t> m_claimed;
};

}  // namespace rtu::hw
