// A device as a user describes it, by names: a number-format preset with per-field overrides, the BVH build and
// acceleration, and for the timed device a timing preset with key=value overrides and sampled timing (the device
// options of rtusim's tracing commands). options() resolves them into the DeviceOptions a device is made with.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "host/devices/direct_device.h"
#include "hwmodel/device/device_kind.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

struct DeviceSettings {
  int bvh_width = 0;  // 0: the format's width (4 in the default format)
  int leaf_size = 8;
  std::string accel = "auto";  // auto, bvh or brute
  // Fixed-point format spec (hw::format_from_spec: a preset, optionally with :key=value changes, as sweep
  // --formats takes it); empty: "default" on the fixed device, the timing configuration's own (key `format`) on
  // the timed device. Named on the timed device it replaces the configuration's `format` key, as `--set
  // format=SPEC` does: one design point, one set of cycles, whichever way it is named.
  std::string format;
  // Overrides of the format preset's fields (hw::format_fields() but width, which bvh_width sets), by key; a field
  // not named keeps the preset's value.
  std::map<std::string, int> format_fields;
  // The timed device: a timing preset and key=value overrides. Its format preset and BVH width are the
  // configuration's keys `format` and `bvh_width`, which `format` and `bvh_width` above replace when set (a
  // --set of the same key with another value is an error); the per-field format options apply on top.
  std::string config = "rdna2";
  std::vector<std::string> sets;
  // The timed device: simulate this fraction of each TRACE packet's rays in the timing model and extrapolate
  // (hw::SampleOptions); 0: every ray.
  double sample = 0.0;
  uint32_t sample_unit = 256, sample_warmup = 0;
  uint64_t sample_seed = 1;
  uint64_t watchdog_steps = 0;  // fixed, timed: node and leaf visits per ray before the watchdog (0: automatic)
  bool flatten = false;         // fixed, timed: trace an instanced scene flattened, in one image

  hw::FixedFormat fixed_format() const;  // spec + overrides + width; validated (std::invalid_argument)
  // The options of a device of `kind`; throws as timing_config_from and fixed_format do.
  DeviceOptions options(hw::DeviceKind kind) const;
};

// A timing preset with "key=value" overrides applied in order (the `--config P --set k=v` options); throws Error
// naming the override for a malformed one, an unknown preset or key, or a bad value.
hw::TimingConfig timing_config_from(const std::string& preset, const std::vector<std::string>& sets);

}  // namespace rtu::host
