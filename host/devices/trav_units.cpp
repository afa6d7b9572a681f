#include "host/devices/trav_units.h"

#include <stdexcept>

#include "host/devices/box_units.h"
#include "host/io/error.h"

namespace rtu::host {

namespace {
TravUnitRunner g_run = nullptr;  // constant-initialized: set before main by rtl_trav_unit.cpp
}  // namespace

void register_rtl_trav_unit(TravUnitRunner run) {
  g_run = run;
}

bool have_rtl_trav_unit() {
  return g_run != nullptr;
}

RtlTravRun run_rtl_trav_unit(const hw::TimingConfig& c, const hw::DeviceImage& img, const hw::Ray* rays, size_t n,
                             bool any_hit) {
  if (!g_run) throw Error(std::string("--rtl-unit: this build has no RTL traversal unit ") + kNoVerilatorHint);
  try {
    return g_run(c, img, rays, n, any_hit);
  } catch (const std::invalid_argument& e) {
    throw Error(std::string("--rtl-unit: ") + e.what());
  }
}

}  // namespace rtu::host
