#include "host/devices/box_units.h"

#include <stdexcept>

#include "host/io/error.h"

namespace rtu::host {

namespace {

BoxUnitFactory g_make_rtl = nullptr;      // constant-initialized: set before main by rtl_box_unit.cpp
TriUnitFactory g_make_rtl_tri = nullptr;  // likewise, by rtl_tri_unit.cpp

}  // namespace

void register_rtl_box_unit(BoxUnitFactory make) {
  g_make_rtl = make;
}

bool have_rtl_box_unit() {
  return g_make_rtl != nullptr;
}

std::unique_ptr<hw::BoxUnit> make_box_unit(const hw::TimingConfig& c) {
  if (c.box_unit != hw::UnitModel::kRtl) return nullptr;
  if (!g_make_rtl)
    throw Error(
        "box_unit = rtl: this build has no RTL box unit (rtl_sim/ needs Verilator: run scripts/setup.sh, "
        "then configure and build again)");
  try {
    return g_make_rtl(c);
  } catch (const std::invalid_argument& e) {
    throw Error(e.what());
  }
}

void register_rtl_tri_unit(TriUnitFactory make) {
  g_make_rtl_tri = make;
}

bool have_rtl_tri_unit() {
  return g_make_rtl_tri != nullptr;
}

std::unique_ptr<hw::TriUnit> make_tri_unit(const hw::TimingConfig& c) {
  if (c.tri_unit != hw::UnitModel::kRtl) return nullptr;
  if (!g_make_rtl_tri)
    throw Error(
        "tri_unit = rtl: this build has no RTL triangle unit (rtl_sim/ needs Verilator: run scripts/setup.sh, "
        "then configure and build again)");
  try {
    return g_make_rtl_tri(c);
  } catch (const std::invalid_argument& e) {
    throw Error(e.what());
  }
}

}  // namespace rtu::host
