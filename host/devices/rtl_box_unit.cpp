// Plugs the Verilated box unit of rtl_sim/ (rtl::make_rtl_box_unit) into the host's box-unit seam (box_units.h).
// Built as the object library rtu_host_rtl, so that every executable linking it (rtusim, the RTL tests) links this
// registration, which runs before main.
#include "rtl_sim/cosim/rtl_box_unit.h"
#include "host/devices/box_units.h"

namespace {

[[maybe_unused]] const bool kRegistered = [] {
  rtu::host::register_rtl_box_unit(&rtu::rtl::make_rtl_box_unit);
  return true;
}();

}  // namespace
