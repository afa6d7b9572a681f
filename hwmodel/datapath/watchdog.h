// The watchdog's error, thrown by the engines (a ray over its traversal step bound) and by the timing model (a
// ray in its slot longer than watchdog_cycles).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace rtu::hw {

// Thrown by TraceEngine::trace and trace_cycles when the watchdog fires: a ray exceeded its traversal step bound
// (fixed-point devices) or stayed in its ray slot longer than watchdog_cycles (timed device). what() is a dump
// of the unit's state (the ray; on the timed device the cycle, ray slots, queues and units). The command
// processor turns it into reg::ErrorCode::kWatchdog; no hits of the TRACE are written.
class WatchdogError : public std::runtime_error {
 public:
  WatchdogError(const std::string& dump, uint64_t cycles) : std::runtime_error(dump), m_cycles(cycles) {}
  // Cycles into the TRACE packet when it fired (timed device; 0 for the functional ones).
  uint64_t cycles() const { return m_cycles; }

 private:
  uint64_t m_cycles;
};

}  // namespace rtu::hw
