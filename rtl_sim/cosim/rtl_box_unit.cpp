#include "rtl_sim/cosim/rtl_box_unit.h"

#include <stdexcept>

#include "Vbox_unit_embedded.h"
#include "Vbox_unit_intel.h"
#include "Vbox_unit_rdna2.h"
#include "Vbox_unit_wide8_lanes3.h"
#include "rtl_models.h"
#include "rtl_sim/cosim/box_ports.h"
#include "rtl_sim/cosim/sim.h"
#include "rtl_sim/params/rtl_params.h"

namespace rtu::rtl {

namespace {

constexpr uint64_t kNodeTimeout = 4096;  // clocks a node may take before the unit counts as stuck

template <class Model>
class RtlBoxUnit final : public hw::BoxUnit {
 public:
  RtlBoxUnit(const BoxUnitParams& p, std::string model) : m_p(p), m_model(std::move(model)) {
    Model& m = m_sim.dut();
    m.in_valid = 0;
    m.out_ready = 0;
    m_sim.reset();
  }

  const char* name() const override { return "rtl"; }

  void check_format(const hw::FixedFormat& f, int width) const override {
    const BoxUnitParams q = box_unit_params(f, width, m_p.lanes, m_p.latency);
    if (verilator_args(q) != verilator_args(m_p))
      throw std::invalid_argument("box_unit = rtl: the Verilated unit (" + m_model + ": " + verilator_args(m_p) +
                                  ") cannot test nodes of format " + f.name + " at width " +
                                  std::to_string(width) + " (" + verilator_args(q) + ")");
  }

  void test(const hw::FixedRay& r, const hw::BoxUnitNode& node, int64_t tmin, int64_t tlim,
            hw::BoxUnitResult& out) override {
    if (!r.narrow) throw std::invalid_argument("box_unit = rtl: the unit has the 64-bit (narrow) datapath only");
    const BoxInputs in = unit_inputs(r, node, tmin, tlim);
    const std::string bad = contract_error(m_p, in);
    if (!bad.empty()) throw std::invalid_argument("box_unit = rtl: " + bad);
    Model& m = m_sim.dut();
    const uint32_t tag = m_tag++ & ((1u << kTagBits) - 1);
    drive_inputs(m, m_p, in, tag);
    m.in_valid = 1;
    m.out_ready = 1;
    // Present the node until it is taken (the unit is idle between nodes: at once).
    if (!m_sim.run_until([&] { return m.in_ready != 0; }, kNodeTimeout)) stuck("does not take a node");
    const uint64_t taken = m_sim.cycle();
    m_sim.tick();
    m.in_valid = 0;
    // Issue: clocks until the input is free again; result: clocks until the result leaves.
    uint64_t free_at = 0, out_at = 0;
    BoxOut o;
    for (uint64_t k = 0; k < kNodeTimeout && (free_at == 0 || out_at == 0); ++k) {
      m_sim.eval();
      if (free_at == 0 && m.in_ready) free_at = m_sim.cycle();
      if (out_at == 0 && m.out_valid) {
        o = read_outputs(m, m_p);
        out_at = m_sim.cycle();
      }
      m_sim.tick();  // the output handshake (out_ready is high) happens at this edge
    }
    if (free_at == 0 || out_at == 0) stuck("does not return a node's result");
    if (o.tag != tag)
      throw std::runtime_error("box_unit = rtl: result tag " + std::to_string(o.tag) + ", expected " +
                               std::to_string(tag));
    out.hit = o.hit;  // slots >= count never hit (the unit's contract; the testbench checks it)
    for (int i = 0; i < m_p.n; ++i) out.t_near[i] = o.tnear[i];
    out.issue = uint32_t(free_at - taken);
    out.result = uint32_t(out_at - taken);
  }

 private:
  [[noreturn]] void stuck(const char* what) const {
    throw std::runtime_error("box_unit = rtl: the Verilated unit " + m_model + " " + what + " within " +
                             std::to_string(kNodeTimeout) + " clocks (cycle " + std::to_string(m_sim.cycle()) +
                             ")");
  }

  BoxUnitParams m_p;
  std::string m_model;
  Sim<Model> m_sim;
  uint32_t m_tag = 0;
};

template <class Model>
std::unique_ptr<hw::BoxUnit> make(const BoxUnitParams& p, const std::string& name) {
  return std::make_unique<RtlBoxUnit<Model>>(p, name);
}

struct Built {
  RtlUnitInfo info;
  std::unique_ptr<hw::BoxUnit> (*make)(const BoxUnitParams&, const std::string&);
};

const std::vector<Built>& built() {
  static const std::vector<Built> units = {
      {{"rdna2", RTU_RTL_SPEC_rdna2, RTU_RTL_ARGS_rdna2}, make<Vbox_unit_rdna2>},
      {{"intel", RTU_RTL_SPEC_intel, RTU_RTL_ARGS_intel}, make<Vbox_unit_intel>},
      {{"embedded", RTU_RTL_SPEC_embedded, RTU_RTL_ARGS_embedded}, make<Vbox_unit_embedded>},
      {{"wide8_lanes3", RTU_RTL_SPEC_wide8_lanes3, RTU_RTL_ARGS_wide8_lanes3}, make<Vbox_unit_wide8_lanes3>},
  };
  return units;
}

}  // namespace

const std::vector<RtlUnitInfo>& rtl_units() {
  static const std::vector<RtlUnitInfo> infos = [] {
    std::vector<RtlUnitInfo> v;
    for (const Built& b : built()) v.push_back(b.info);
    return v;
  }();
  return infos;
}

std::unique_ptr<hw::BoxUnit> make_rtl_box_unit(const hw::TimingConfig& c) {
  const BoxUnitParams p = box_unit_params(c);
  const std::string args = verilator_args(p);
  std::string list;
  for (const Built& b : built()) {
    if (args == b.info.args) return b.make(p, b.info.name);
    list += (list.empty() ? "" : "; ") + b.info.name + " (" + b.info.spec + "): " + b.info.args;
  }
  throw std::invalid_argument("box_unit = rtl: no Verilated box unit for format " + c.format + ", bvh_width " +
                              std::to_string(c.bvh_width) + ", box_rate " + std::to_string(c.box_rate) +
                              ", box_latency " + std::to_string(c.box_latency) + " (" + args +
                              "); this build verilated " + list);
}

}  // namespace rtu::rtl
