// Shared by the timed device's tests (test_timed.cpp, test_timed_chip.cpp): a device's options as a timing preset
// sets them (its node format and BVH width).
#pragma once

#include <string>

#include "host/devices/direct_device.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::test {

// The options of device `device` (float, fixed, timed) with timing preset `preset`, its format and BVH width.
inline rtu::host::DeviceOptions preset_options(const std::string& device, const std::string& preset) {
  rtu::host::DeviceOptions o;
  o.kind = rtu::hw::parse_device_kind(device);
  o.timing = rtu::hw::timing_preset(preset);
  o.format = rtu::hw::format_preset(o.timing.format);
  o.format.width = o.timing.bvh_width;
  o.tracer.bvh.width = o.format.width;
  return o;
}

}  // namespace rtu::test
