// The co-simulation adapter of the triangle unit: hw::TriUnit (hwmodel/datapath/tri_unit.h) answered by a
// Verilated model of rtl/tri_core.sv, so that the timed device (`--set tri_unit=rtl`) takes its triangle tests,
// and the clocks of each, from the RTL.
#pragma once

#include <memory>
#include <vector>

#include "hwmodel/datapath/tri_unit.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_sim/cosim/rtl_unit_info.h"

namespace rtu::rtl {

// The unit verilated for the configuration's triangle unit: its format and tri_latency must be those of one of
// the Verilated parameter sets (rtl_tri_units(): the timing presets rdna2 and embedded; rtl_sim/CMakeLists.txt),
// and tri_rate 1. Throws std::invalid_argument naming the parameters and the sets built otherwise. Each triangle
// is driven through the valid/ready handshake on its own; one that does not come out within 4096 clocks is an
// error (std::runtime_error), as is an input outside the unit's port ranges (std::invalid_argument).
std::unique_ptr<hw::TriUnit> make_rtl_tri_unit(const hw::TimingConfig& c);

// The triangle units this build verilated (each one's spec is the preset it was derived from).
const std::vector<RtlUnitInfo>& rtl_tri_units();

}  // namespace rtu::rtl
