#include "host/devices/device_settings.h"

#include <stdexcept>

#include "host/io/error.h"

namespace rtu::host {

hw::FixedFormat DeviceSettings::fixed_format() const {
  hw::FixedFormat f = hw::format_from_spec(format.empty() ? "default" : format);
  std::string changed;
  auto set = [&](int& field, int value, const char* key) {
    if (value < 0) return;
    field = value;
    changed += std::string(changed.empty() ? "+" : ",") + key + "=" + std::to_string(value);
  };
  for (const hw::FormatField& d : hw::format_fields()) {
    if (d.member == &hw::FixedFormat::width) continue;  // last, from bvh_width
    const auto it = format_fields.find(d.key);
    if (it != format_fields.end()) set(f.*d.member, it->second, d.key);
  }
  for (const auto& [key, value] : format_fields)
    if (key == "width" || !hw::format_field(f, key)) throw Error("unknown format field '" + key + "'");
  set(f.width, bvh_width > 0 ? bvh_width : -1, "width");
  f.name += changed;
  f.validate();
  return f;
}

DeviceOptions DeviceSettings::options(hw::DeviceKind kind) const {
  DeviceOptions d;
  d.kind = kind;
  if (kind == hw::DeviceKind::kTimed) {
    d.timing = timing_config_from(config, sets);
    // --format and --bvh-width name the configuration's keys; both spellings of one point must agree.
    auto replace_key = [&](const char* key, const std::string& value, const char* option) {
      for (const std::string& s : sets)
        if (s.rfind(std::string(key) + "=", 0) == 0 && s.substr(s.find('=') + 1) != value)
          throw Error(std::string(option) + " " + value + " and --set " + s + " name two values of one key");
      hw::set_timing_key(d.timing, key, value);
    };
    if (!format.empty()) replace_key("format", format, "--format");
    if (bvh_width > 0) replace_key("bvh_width", std::to_string(bvh_width), "--bvh-width");
    d.sample.fraction = sample;
    d.sample.unit_rays = sample_unit;
    d.sample.warmup_rays = sample_warmup;
    d.sample.seed = sample_seed;
    DeviceSettings a = *this;
    a.format = d.timing.format;
    if (a.bvh_width <= 0) a.bvh_width = d.timing.bvh_width;
    d.format = a.fixed_format();
  } else {
    d.format = fixed_format();
  }
  d.tracer.bvh.width = d.format.width;
  d.tracer.bvh.max_leaf_size = leaf_size;
  d.max_steps = watchdog_steps;
  d.flatten = flatten;
  d.tracer.accel =
      accel == "bvh" ? hw::AccelMode::kBvh : (accel == "brute" ? hw::AccelMode::kBrute : hw::AccelMode::kAuto);
  return d;
}

hw::TimingConfig timing_config_from(const std::string& preset, const std::vector<std::string>& sets) {
  hw::TimingConfig c;
  try {
    c = hw::timing_preset(preset);
  } catch (const std::invalid_argument& e) {
    throw Error(e.what());
  }
  for (const std::string& s : sets) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos) throw Error("--set '" + s + "' is not key=value");
    try {
      hw::set_timing_key(c, s.substr(0, eq), s.substr(eq + 1));
    } catch (const std::invalid_argument& e) {
      throw Error("--set " + s + ": " + e.what());
    }
  }
  return c;
}

}  // namespace rtu::host
