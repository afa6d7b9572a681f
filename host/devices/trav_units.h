// The RTL traversal unit (rtl_sim/trav/) behind a seam, as the RTL box and triangle units are (box_units.h): the
// executables that have the Verilated units (rtusim, the RTL tests; object library rtu_host_rtl) register the
// runner here, so rtu_host needs no Verilator.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "hwmodel/format/device_image.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

struct RtlTravRun {
  std::string unit;  // the Verilated configuration that ran (rtl_sim/CMakeLists.txt: RTU_RTL_TRAV_UNITS)
  uint64_t cycles = 0;
  std::vector<hw::Hit> hits;
};
// Runs rays[0, n) in one packet on the Verilated unit whose parameters are configuration c's; throws
// std::invalid_argument when the unit cannot run c or the image, or no unit of c's parameters was verilated.
using TravUnitRunner = RtlTravRun (*)(const hw::TimingConfig& c, const hw::DeviceImage& img, const hw::Ray* rays,
                                      size_t n, bool any_hit);
void register_rtl_trav_unit(TravUnitRunner run);
bool have_rtl_trav_unit();
// Throws host::Error when this build has no RTL traversal unit or the unit refuses (the reason named).
RtlTravRun run_rtl_trav_unit(const hw::TimingConfig& c, const hw::DeviceImage& img, const hw::Ray* rays, size_t n,
                             bool any_hit);

}  // namespace rtu::host
