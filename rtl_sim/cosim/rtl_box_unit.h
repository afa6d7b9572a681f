// The co-simulation adapter: hw::BoxUnit (hwmodel/datapath/box_unit.h) answered by a Verilated model of
// rtl/box_unit.sv, so that the timed device (`--set box_unit=rtl`) takes its box tests, and the clocks of each,
// from the RTL.
#pragma once

#include <memory>
#include <vector>

#include "hwmodel/datapath/box_unit.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_sim/cosim/rtl_unit_info.h"

namespace rtu::rtl {

// The unit verilated for the configuration's box unit: its format, BVH width, box rate and box latency must be
// those of one of the Verilated parameter sets (rtl_units(): the timing presets rdna2, intel and embedded, and
// wide8_lanes3, intel with 8-wide nodes and box_rate 3; rtl_sim/CMakeLists.txt).
// Throws std::invalid_argument naming the parameters and the sets built otherwise. Each node is driven through
// the valid/ready handshake on its own; a node that does not come out within 4096 clocks is an error
// (std::runtime_error), as is an input outside the unit's port ranges (std::invalid_argument).
std::unique_ptr<hw::BoxUnit> make_rtl_box_unit(const hw::TimingConfig& c);

// The box units this build verilated.
const std::vector<RtlUnitInfo>& rtl_units();

}  // namespace rtu::rtl
