#include "rtl_sim/cosim/rtl_tri_unit.h"

#include <stdexcept>

#include "rtl_models.h"
#include "rtl_sim/cosim/rtl_unit.h"
#include "rtl_sim/cosim/tri_ports.h"
#include "rtl_sim/params/tri_params.h"

namespace rtu::rtl {

namespace {

const UnitRegistry<TriPorts>& registry() {
  static const UnitRegistry<TriPorts> r({RTU_RTL_TRI_MODELS(RTU_RTL_UNIT_ENTRY)});
  return r;
}

class RtlTriUnit final : public hw::TriUnit {
 public:
  explicit RtlTriUnit(std::unique_ptr<UnitDriver<TriPorts>> driver) : m_driver(std::move(driver)) {}

  const char* name() const override { return "rtl"; }

  void check_format(const hw::FixedFormat& f) const override {
    const TriUnitParams& p = m_driver->params();
    std::string args;
    try {
      args = verilator_args(tri_unit_params(f, p.latency));
    } catch (const std::invalid_argument& e) {
      args = e.what();
    }
    if (args != verilator_args(p))
      throw std::invalid_argument(m_driver->prefix() + "the Verilated unit (" + m_driver->model() + ": " +
                                  verilator_args(p) + ") cannot test triangles of format " + f.name + " (" + args +
                                  ")");
  }

  void test(const hw::FixedRay& r, const int32_t v[3][3], int64_t tmin, int64_t tlim,
            hw::TriUnitResult& out) override {
    const Answer<TriPorts> a = m_driver->run(tri_unit_inputs(r, v, tmin, tlim));
    out.hit = a.out.hit;
    out.t = a.out.t;
    out.e1 = a.out.e1;
    out.e2 = a.out.e2;
    out.det = a.out.det;
    out.issue = a.issue;
    out.result = a.result;
  }

 private:
  std::unique_ptr<UnitDriver<TriPorts>> m_driver;
};

}  // namespace

const std::vector<RtlUnitInfo>& rtl_tri_units() {
  return registry().infos();
}

std::unique_ptr<hw::TriUnit> make_rtl_tri_unit(const hw::TimingConfig& c) {
  const std::string what = "tri_unit = rtl: no Verilated triangle unit for format " + c.format + ", tri_rate " +
                           std::to_string(c.tri_rate) + ", tri_latency " + std::to_string(c.tri_latency);
  std::string args;
  TriUnitParams p;
  try {
    p = tri_unit_params(c);
    args = verilator_args(p);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(what + " (" + e.what() + "); " + registry().built());
  }
  if (auto driver = registry().make(p, args)) return std::make_unique<RtlTriUnit>(std::move(driver));
  throw std::invalid_argument(what + " (" + args + "); " + registry().built());
}

}  // namespace rtu::rtl
