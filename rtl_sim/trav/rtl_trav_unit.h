// The Verilated traversal units a build has, run by configuration (host/devices/trav_units.h's runner).
#pragma once

#include "host/devices/trav_units.h"

namespace rtu::rtl {

// The unit verilated with configuration c's parameters (trav_params.h) runs the packet; std::invalid_argument
// when c or the image is one the unit refuses, or no such unit was verilated (the message lists those that were).
host::RtlTravRun run_rtl_trav_unit(const hw::TimingConfig& c, const hw::DeviceImage& img, const hw::Ray* rays,
                                   size_t n, bool any_hit);

}  // namespace rtu::rtl
