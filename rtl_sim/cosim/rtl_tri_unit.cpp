#include "rtl_sim/cosim/rtl_tri_unit.h"

#include <stdexcept>

#include "Vtri_core_embedded.h"
#include "Vtri_core_rdna2.h"
#include "rtl_sim/cosim/sim.h"
#include "rtl_sim/cosim/tri_ports.h"
#include "rtl_sim/params/tri_params.h"
#include "rtl_tri_models.h"

namespace rtu::rtl {

namespace {

constexpr uint64_t kTriTimeout = 4096;  // clocks a triangle may take before the unit counts as stuck

template <class Model>
class RtlTriUnit final : public hw::TriUnit {
 public:
  RtlTriUnit(const TriUnitParams& p, std::string model) : m_p(p), m_model(std::move(model)) {
    Model& m = m_sim.dut();
    m.in_valid = 0;
    m.out_ready = 0;
    m_sim.reset();
  }

  const char* name() const override { return "rtl"; }

  void check_format(const hw::FixedFormat& f) const override {
    std::string args;
    try {
      args = verilator_args(tri_unit_params(f, m_p.latency));
    } catch (const std::invalid_argument& e) {
      args = e.what();
    }
    if (args != verilator_args(m_p))
      throw std::invalid_argument("tri_unit = rtl: the Verilated unit (" + m_model + ": " + verilator_args(m_p) +
                                  ") cannot test triangles of format " + f.name + " (" + args + ")");
  }

  void test(const hw::FixedRay& r, const int32_t v[3][3], int64_t tmin, int64_t tlim,
            hw::TriUnitResult& out) override {
    const TriInputs in = tri_unit_inputs(r, v, tmin, tlim);
    const std::string bad = contract_error(m_p, in);
    if (!bad.empty()) throw std::invalid_argument("tri_unit = rtl: " + bad);
    Model& m = m_sim.dut();
    const uint32_t tag = m_tag++ & ((1u << kTriTagBits) - 1);
    drive_inputs(m, m_p, in, tag);
    m.in_valid = 1;
    m.out_ready = 1;
    // Present the triangle until it is taken (the unit is idle between triangles: at once).
    if (!m_sim.run_until([&] { return m.in_ready != 0; }, kTriTimeout)) stuck("does not take a triangle");
    const uint64_t taken = m_sim.cycle();
    m_sim.tick();
    m.in_valid = 0;
    // Issue: clocks until the input is free again; result: clocks until the result leaves.
    uint64_t free_at = 0, out_at = 0;
    TriOut o;
    for (uint64_t k = 0; k < kTriTimeout && (free_at == 0 || out_at == 0); ++k) {
      m_sim.eval();
      if (free_at == 0 && m.in_ready) free_at = m_sim.cycle();
      if (out_at == 0 && m.out_valid) {
        o = read_outputs(m, m_p);
        out_at = m_sim.cycle();
      }
      m_sim.tick();  // the output handshake (out_ready is high) happens at this edge
    }
    if (free_at == 0 || out_at == 0) stuck("does not return a triangle's result");
    if (o.tag != tag)
      throw std::runtime_error("tri_unit = rtl: result tag " + std::to_string(o.tag) + ", expected " +
                               std::to_string(tag));
    out.hit = o.hit;
    out.t = o.t;
    out.e1 = o.e1;
    out.e2 = o.e2;
    out.det = o.det;
    out.issue = uint32_t(free_at - taken);
    out.result = uint32_t(out_at - taken);
  }

 private:
  [[noreturn]] void stuck(const char* what) const {
    throw std::runtime_error("tri_unit = rtl: the Verilated unit " + m_model + " " + what + " within " +
                             std::to_string(kTriTimeout) + " clocks (cycle " + std::to_string(m_sim.cycle()) +
                             ")");
  }

  TriUnitParams m_p;
  std::string m_model;
  Sim<Model> m_sim;
  uint32_t m_tag = 0;
};

template <class Model>
std::unique_ptr<hw::TriUnit> make(const TriUnitParams& p, const std::string& name) {
  return std::make_unique<RtlTriUnit<Model>>(p, name);
}

struct Built {
  RtlTriUnitInfo info;
  std::unique_ptr<hw::TriUnit> (*make)(const TriUnitParams&, const std::string&);
};

const std::vector<Built>& built() {
  static const std::vector<Built> units = {
      {{"rdna2", RTU_RTL_TRI_ARGS_rdna2}, make<Vtri_core_rdna2>},
      {{"embedded", RTU_RTL_TRI_ARGS_embedded}, make<Vtri_core_embedded>},
  };
  return units;
}

// The units built, with the format and tri_latency of the preset each comes from.
std::string built_list() {
  std::string list;
  for (const Built& b : built()) {
    const hw::TimingConfig c = hw::timing_preset(b.info.name);
    list += (list.empty() ? "" : "; ") + b.info.name + " (format " + c.format + ", tri_latency " +
            std::to_string(c.tri_latency) + "): " + b.info.args;
  }
  return list;
}

}  // namespace

const std::vector<RtlTriUnitInfo>& rtl_tri_units() {
  static const std::vector<RtlTriUnitInfo> infos = [] {
    std::vector<RtlTriUnitInfo> v;
    for (const Built& b : built()) v.push_back(b.info);
    return v;
  }();
  return infos;
}

std::unique_ptr<hw::TriUnit> make_rtl_tri_unit(const hw::TimingConfig& c) {
  std::string args;
  TriUnitParams p;
  try {
    p = tri_unit_params(c);
    args = verilator_args(p);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("tri_unit = rtl: no Verilated triangle unit for format ") + c.format +
                                ", tri_rate " + std::to_string(c.tri_rate) + ", tri_latency " +
                                std::to_string(c.tri_latency) + " (" + e.what() + "); this build verilated " +
                                built_list());
  }
  for (const Built& b : built())
    if (args == b.info.args) return b.make(p, b.info.name);
  throw std::invalid_argument("tri_unit = rtl: no Verilated triangle unit for format " + c.format + ", tri_rate " +
                              std::to_string(c.tri_rate) + ", tri_latency " + std::to_string(c.tri_latency) +
                              " (" + args + "); this build verilated " + built_list());
}

}  // namespace rtu::rtl
