// Which box unit and which triangle unit a timing configuration asks for (its keys box_unit and tri_unit): null
// for the C++ tests, the Verilated RTL units of rtl_sim/ for "rtl" (co-simulation). rtu_host depends only on
// hwmodel's seams (box_unit.h, tri_unit.h): the RTL units' makers are registered here by the executables that
// have them (rtl_box_unit.cpp and rtl_tri_unit.cpp, linked as rtu_host_rtl).
#pragma once

#include <memory>

#include "hwmodel/datapath/box_unit.h"
#include "hwmodel/datapath/tri_unit.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

// Why a build has no RTL unit, and what to do: the end of every such refusal.
inline constexpr const char* kNoVerilatorHint =
    "(rtl_sim/ needs Verilator: run scripts/setup.sh, then configure and build again)";

// Makes the RTL unit of a configuration; throws std::invalid_argument when none matches it.
using BoxUnitFactory = std::unique_ptr<hw::BoxUnit> (*)(const hw::TimingConfig& c);
void register_rtl_box_unit(BoxUnitFactory make);

// Throws host::Error when the configuration asks for the RTL unit and this build has none (no Verilator), or
// when no Verilated parameter set matches the configuration.
std::unique_ptr<hw::BoxUnit> make_box_unit(const hw::TimingConfig& c);

// True when this executable has the RTL unit (rtl_sim/ built with Verilator, and rtu_host_rtl linked).
bool have_rtl_box_unit();

// The same for the triangle unit (key tri_unit).
using TriUnitFactory = std::unique_ptr<hw::TriUnit> (*)(const hw::TimingConfig& c);
void register_rtl_tri_unit(TriUnitFactory make);
std::unique_ptr<hw::TriUnit> make_tri_unit(const hw::TimingConfig& c);
bool have_rtl_tri_unit();

}  // namespace rtu::host
