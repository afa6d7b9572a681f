// Plugs the Verilated triangle unit of rtl_sim/ (rtl::make_rtl_tri_unit) into the host's triangle-unit seam
// (box_units.h), as rtl_box_unit.cpp does for the box unit; part of the object library rtu_host_rtl.
#include "rtl_sim/cosim/rtl_tri_unit.h"
#include "host/devices/box_units.h"

namespace {

[[maybe_unused]] const bool kRegistered = [] {
  rtu::host::register_rtl_tri_unit(&rtu::rtl::make_rtl_tri_unit);
  return true;
}();

}  // namespace
