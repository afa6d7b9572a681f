// Plugs the Verilated traversal units of rtl_sim/ (rtl::run_rtl_trav_unit) into the host's seam (trav_units.h),
// in the object library rtu_host_rtl, as rtl_box_unit.cpp does for the box unit.
#include "rtl_sim/trav/rtl_trav_unit.h"
#include "host/devices/trav_units.h"

namespace {

[[maybe_unused]] const bool kRegistered = [] {
  rtu::host::register_rtl_trav_unit(&rtu::rtl::run_rtl_trav_unit);
  return true;
}();

}  // namespace
