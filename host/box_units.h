// Which box unit a timing configuration asks for (its key box_unit): null for the C++ box test, the Verilated
// RTL unit of rtl_sim/ for "rtl" (co-simulation). rtu_host depends only on hwmodel's box-unit seam: the RTL unit's
// maker is registered here by the executables that have it (rtl_box_unit.cpp, linked as rtu_host_rtl).
#pragma once

#include <memory>

#include "hwmodel/box_unit.h"
#include "hwmodel/timing_config.h"

namespace rtu::host {

// Makes the RTL unit of a configuration; throws std::invalid_argument when none matches it.
using BoxUnitFactory = std::unique_ptr<hw::BoxUnit> (*)(const hw::TimingConfig& c);
void register_rtl_box_unit(BoxUnitFactory make);

// Throws host::Error when the configuration asks for the RTL unit and this build has none (no Verilator), or
// when no Verilated parameter set matches the configuration.
std::unique_ptr<hw::BoxUnit> make_box_unit(const hw::TimingConfig& c);

// True when this executable has the RTL unit (rtl_sim/ built with Verilator, and rtu_host_rtl linked).
bool have_rtl_box_unit();

}  // namespace rtu::host
