#include "rtl_sim/trav/rtl_trav_unit.h"

#include <stdexcept>
#include <string>

#include "rtl_models.h"
#include "rtl_sim/trav/trav_driver.h"

namespace rtu::rtl {

namespace {

template <class Model>
host::RtlTravRun run(const char* name, const hw::TimingConfig& c, const hw::DeviceImage& img, const hw::Ray* rays,
                     size_t n, bool any_hit) {
  host::RtlTravRun r;
  r.unit = name;
  r.hits.resize(n);
  r.cycles = run_trav_packet<Model>(c, img, rays, n, any_hit, r.hits.data()).cycles;
  return r;
}

}  // namespace

host::RtlTravRun run_rtl_trav_unit(const hw::TimingConfig& c, const hw::DeviceImage& img, const hw::Ray* rays,
                                   size_t n, bool any_hit) {
  const std::string args = verilator_args(trav_params(c));  // throws what c lacks
  std::string built;
#define RTU_TRAV_RUN(cls, name, spec, unit_args)                          \
  if (args == unit_args) return run<cls>(name, c, img, rays, n, any_hit); \
  built += std::string(built.empty() ? "" : ", ") + name + " (" + spec + ")";
  RTU_RTL_TRAV_MODELS(RTU_TRAV_RUN)
#undef RTU_TRAV_RUN
  throw std::invalid_argument("no verilated traversal unit has this configuration's parameters (" + args +
                              "); this build has " + built +
                              "; to build one: cmake --preset default -DRTU_RTL_TRAV_EXTRA_UNITS=NAME=SPEC, the "
                              "SPEC a preset and its --set keys, e.g. rdna2:ray_slots=32 (docs/guide/rtl.md)");
}

}  // namespace rtu::rtl
