#include "rtl_sim/cosim/rtl_box_unit.h"

#include <stdexcept>

#include "rtl_models.h"
#include "rtl_sim/cosim/box_ports.h"
#include "rtl_sim/cosim/rtl_unit.h"
#include "rtl_sim/params/rtl_params.h"

namespace rtu::rtl {

namespace {

const UnitRegistry<BoxPorts>& registry() {
  static const UnitRegistry<BoxPorts> r({RTU_RTL_BOX_MODELS(RTU_RTL_UNIT_ENTRY)});
  return r;
}

class RtlBoxUnit final : public hw::BoxUnit {
 public:
  explicit RtlBoxUnit(std::unique_ptr<UnitDriver<BoxPorts>> driver) : m_driver(std::move(driver)) {}

  const char* name() const override { return "rtl"; }

  void check_format(const hw::FixedFormat& f, int width) const override {
    const BoxUnitParams& p = m_driver->params();
    const BoxUnitParams q = box_unit_params(f, width, p.lanes, p.latency);
    if (verilator_args(q) != verilator_args(p))
      throw std::invalid_argument(m_driver->prefix() + "the Verilated unit (" + m_driver->model() + ": " +
                                  verilator_args(p) + ") cannot test nodes of format " + f.name + " at width " +
                                  std::to_string(width) + " (" + verilator_args(q) + ")");
  }

  void test(const hw::FixedRay& r, const hw::BoxUnitNode& node, int64_t tmin, int64_t tlim,
            hw::BoxUnitResult& out) override {
    if (!r.narrow)
      throw std::invalid_argument(m_driver->prefix() + "the unit has the 64-bit (narrow) datapath only");
    const Answer<BoxPorts> a = m_driver->run(unit_inputs(r, node, tmin, tlim));
    out.hit = a.out.hit;  // slots >= count never hit (the unit's contract; the testbench checks it)
    for (int i = 0; i < m_driver->params().n; ++i) out.t_near[i] = a.out.tnear[i];
    out.issue = a.issue;
    out.result = a.result;
  }

 private:
  std::unique_ptr<UnitDriver<BoxPorts>> m_driver;
};

}  // namespace

const std::vector<RtlUnitInfo>& rtl_units() {
  return registry().infos();
}

std::unique_ptr<hw::BoxUnit> make_rtl_box_unit(const hw::TimingConfig& c) {
  const BoxUnitParams p = box_unit_params(c);
  const std::string args = verilator_args(p);
  if (auto driver = registry().make(p, args)) return std::make_unique<RtlBoxUnit>(std::move(driver));
  throw std::invalid_argument("box_unit = rtl: no Verilated box unit for format " + c.format + ", bvh_width " +
                              std::to_string(c.bvh_width) + ", box_rate " + std::to_string(c.box_rate) +
                              ", box_latency " + std::to_string(c.box_latency) + " (" + args + "); " +
                              registry().built());
}

}  // namespace rtu::rtl
