#include "host/box_units.h"

#include <stdexcept>

#include "host/error.h"
#ifdef RTU_HAVE_RTL
#include "rtl_sim/cosim/rtl_box_unit.h"
#endif

namespace rtu::host {

bool have_rtl_box_unit() {
#ifdef RTU_HAVE_RTL
  return true;
#else
  return false;
#endif
}

std::unique_ptr<hw::BoxUnit> make_box_unit(const hw::TimingConfig& c) {
  if (c.box_unit != "rtl") return nullptr;
#ifdef RTU_HAVE_RTL
  try {
    return rtl::make_rtl_box_unit(c);
  } catch (const std::invalid_argument& e) {
    throw Error(e.what());
  }
#else
  throw Error(
      "box_unit = rtl: this build has no RTL box unit (rtl_sim/ needs Verilator: run scripts/setup.sh, "
      "then configure and build again)");
#endif
}

}  // namespace rtu::host
