#include "host/devices/box_units.h"

#include <stdexcept>
#include <string>

#include "host/io/error.h"

namespace rtu::host {

namespace {

BoxUnitFactory g_make_rtl = nullptr;      // constant-initialized: set before main by rtl_box_unit.cpp
TriUnitFactory g_make_rtl_tri = nullptr;  // likewise, by rtl_tri_unit.cpp

// The RTL unit `make` builds when the configuration's key `key` asks for it; null for the C++ datapath.
template <class Unit>
std::unique_ptr<Unit> make_unit(std::unique_ptr<Unit> (*make)(const hw::TimingConfig&), hw::UnitModel model,
                                const hw::TimingConfig& c, const char* key, const char* unit) {
  if (model != hw::UnitModel::kRtl) return nullptr;
  if (!make) throw Error(std::string(key) + " = rtl: this build has no RTL " + unit + " " + kNoVerilatorHint);
  try {
    return make(c);
  } catch (const std::invalid_argument& e) {
    throw Error(e.what());
  }
}

}  // namespace

void register_rtl_box_unit(BoxUnitFactory make) {
  g_make_rtl = make;
}

bool have_rtl_box_unit() {
  return g_make_rtl != nullptr;
}

std::unique_ptr<hw::BoxUnit> make_box_unit(const hw::TimingConfig& c) {
  return make_unit(g_make_rtl, c.box_unit, c, "box_unit", "box unit");
}

void register_rtl_tri_unit(TriUnitFactory make) {
  g_make_rtl_tri = make;
}

bool have_rtl_tri_unit() {
  return g_make_rtl_tri != nullptr;
}

std::unique_ptr<hw::TriUnit> make_tri_unit(const hw::TimingConfig& c) {
  return make_unit(g_make_rtl_tri, c.tri_unit, c, "tri_unit", "triangle unit");
}

}  // namespace rtu::host
