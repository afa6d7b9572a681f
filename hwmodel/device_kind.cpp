#include "hwmodel/device_kind.h"

#include <stdexcept>

namespace rtu::hw {

const char* device_kind_name(DeviceKind k) {
  switch (k) {
    case DeviceKind::kFloat:
      return "float";
    case DeviceKind::kFixed:
      return "fixed";
    case DeviceKind::kTimed:
      return "timed";
  }
  return "unknown";
}

const std::vector<std::string>& device_kind_names() {
  static const std::vector<std::string> names = {"float", "fixed", "timed"};
  return names;
}

DeviceKind parse_device_kind(std::string_view name) {
  for (DeviceKind k : {DeviceKind::kFloat, DeviceKind::kFixed, DeviceKind::kTimed})
    if (name == device_kind_name(k)) return k;
  throw std::invalid_argument("unknown device '" + std::string(name) + "' (known: float, fixed, timed)");
}

}  // namespace rtu::hw
