#include "hwmodel/device/device_kind.h"

#include <stdexcept>
#include <utility>

namespace rtu::hw {

namespace {

constexpr std::pair<DeviceKind, const char*> kKinds[] = {
    {DeviceKind::kFloat, "float"},
    {DeviceKind::kFixed, "fixed"},
    {DeviceKind::kTimed, "timed"},
};

}  // namespace

const char* device_kind_name(DeviceKind k) {
  for (const auto& [kind, name] : kKinds)
    if (kind == k) return name;
  return "unknown";
}

const std::vector<std::string>& device_kind_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const auto& [kind, name] : kKinds) v.push_back(name);
    return v;
  }();
  return names;
}

DeviceKind parse_device_kind(std::string_view name) {
  std::string known;
  for (const auto& [kind, n] : kKinds) {
    if (name == n) return kind;
    known += (known.empty() ? "" : ", ") + std::string(n);
  }
  throw std::invalid_argument("unknown device '" + std::string(name) + "' (known: " + known + ")");
}

}  // namespace rtu::hw
