// The kinds of device the model can be, by what traces the rays (docs/architecture.md, "Devices, tracers and
// engines"):
// - float: the float reference datapath (robust, conservative), no timing;
// - fixed: the bit-accurate fixed-point datapath over a device memory image, no timing;
// - timed: the same fixed datapath with the cycle-approximate timing model (hits identical to fixed).
// A kind is named by a string only at the edges (command line, scene and configuration files): parse it there.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace rtu::hw {

enum class DeviceKind { kFloat, kFixed, kTimed };

// "float", "fixed" or "timed".
const char* device_kind_name(DeviceKind k);
// Every kind's name, in the enum's order.
const std::vector<std::string>& device_kind_names();
// The kind named `name`; throws std::invalid_argument "unknown device 'NAME' (known: float, fixed, timed)".
DeviceKind parse_device_kind(std::string_view name);

}  // namespace rtu::hw
