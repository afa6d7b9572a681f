// Which box unit a timing configuration asks for (its key box_unit): null for the C++ box test, the Verilated
// RTL unit of rtl_sim/ for "rtl" (co-simulation). The one place where host/ wires rtl_sim/ into the model.
#pragma once

#include <memory>

#include "hwmodel/box_unit.h"
#include "hwmodel/timing_config.h"

namespace rtu::host {

// Throws host::Error when the configuration asks for the RTL unit and this build has none (no Verilator), or
// when no Verilated parameter set matches the configuration.
std::unique_ptr<hw::BoxUnit> make_box_unit(const hw::TimingConfig& c);

// True when this build has the RTL unit (rtl_sim/ built with Verilator).
bool have_rtl_box_unit();

}  // namespace rtu::host
