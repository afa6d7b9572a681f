// What a build verilated, without Verilator's headers: for the host and the co-simulation tests.
#pragma once

#include <string>

namespace rtu::rtl {

// A Verilated model of a unit: its name, its configuration spec (a preset, or a preset with keys changed, as
// rtl_params.h's unit_config() reads it) and the Verilator -G options it was built with.
struct RtlUnitInfo {
  std::string name, spec, args;
};

}  // namespace rtu::rtl
