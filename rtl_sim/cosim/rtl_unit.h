// What every RTL unit shares, whatever it computes: the handshake driver over its Verilated model (one item at a
// time through valid/ready, with the issue and result clocks measured on the ports) and the registry of the
// models a build verilated. A unit is described by its port traits (box_ports.h: BoxPorts, tri_ports.h:
// TriPorts), which provide:
//   Params, Inputs, Out       its parameter set, its inputs before packing, its outputs after unpacking (Out has
//                             a tag member)
//   kKey, kItem, kVcd         the timing key that selects it ("box_unit"), what one input is called in messages
//                             ("node"), the stem of its VCD files
//   kTagBits                  the width of its tag port
//   same(p, a, b)             whether two outputs are equal (the ports that exist for p)
//   describe(info)            a Verilated model's line in "this build verilated ..." messages
// and the free functions drive_inputs(model, p, in, tag), read_outputs(model, p) and contract_error(p, in),
// overloaded on Params. The generated models header (rtl_sim/CMakeLists.txt, rtu_verilate_unit) lists each
// kind's models as RTU_RTL_<KIND>_MODELS(X): X(Model, name, spec, args) per model.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "rtl_sim/cosim/rtl_unit_info.h"
#include "rtl_sim/cosim/sim.h"

namespace rtu::rtl {

inline constexpr uint64_t kItemTimeout = 4096;  // clocks one item may take before the unit counts as stuck

// One answer of the unit: its outputs, the clocks until the input was free again (issue) and until the result
// left (result), both counted from the edge that took the input.
template <class Ports>
struct Answer {
  typename Ports::Out out;
  uint32_t issue = 0, result = 0;
};

// The handshake driver of one Verilated model, behind an interface that does not name the model.
template <class Ports>
class UnitDriver {
 public:
  using Params = typename Ports::Params;
  UnitDriver(const Params& p, std::string model) : m_p(p), m_model(std::move(model)) {}
  virtual ~UnitDriver() = default;
  UnitDriver(const UnitDriver&) = delete;
  UnitDriver& operator=(const UnitDriver&) = delete;

  const Params& params() const { return m_p; }
  const std::string& model() const { return m_model; }
  // Drives one item through the handshake on its own (the unit is idle before and after). Throws
  // std::invalid_argument for inputs outside the unit's contract, std::runtime_error when the unit does not take
  // the item or return its result within kItemTimeout clocks or returns another tag.
  virtual Answer<Ports> run(const typename Ports::Inputs& in) = 0;

  // "box_unit = rtl: ", the start of every message about the unit.
  static std::string prefix() { return std::string(Ports::kKey) + " = rtl: "; }

 private:
  Params m_p;
  std::string m_model;
};

template <class Ports, class Model>
class ModelDriver final : public UnitDriver<Ports> {
 public:
  using Params = typename Ports::Params;
  ModelDriver(const Params& p, std::string model) : UnitDriver<Ports>(p, std::move(model)) {
    Model& m = m_sim.dut();
    m.in_valid = 0;
    m.out_ready = 0;
    m_sim.reset();
  }

  Answer<Ports> run(const typename Ports::Inputs& in) override {
    const Params& p = this->params();
    const std::string bad = contract_error(p, in);
    if (!bad.empty()) throw std::invalid_argument(this->prefix() + bad);
    Model& m = m_sim.dut();
    const uint32_t tag = m_tag++ & ((1u << Ports::kTagBits) - 1);
    drive_inputs(m, p, in, tag);
    m.in_valid = 1;
    m.out_ready = 1;
    // Present the item until it is taken (the unit is idle between items: at once).
    if (!m_sim.run_until([&] { return m.in_ready != 0; }, kItemTimeout))
      stuck(std::string("does not take a ") + Ports::kItem);
    const uint64_t taken = m_sim.cycle();
    m_sim.tick();
    m.in_valid = 0;
    // Issue: clocks until the input is free again; result: clocks until the result leaves.
    uint64_t free_at = 0, out_at = 0;
    Answer<Ports> a;
    for (uint64_t k = 0; k < kItemTimeout && (free_at == 0 || out_at == 0); ++k) {
      m_sim.eval();
      if (free_at == 0 && m.in_ready) free_at = m_sim.cycle();
      if (out_at == 0 && m.out_valid) {
        a.out = read_outputs(m, p);
        out_at = m_sim.cycle();
      }
      m_sim.tick();  // the output handshake (out_ready is high) happens at this edge
    }
    if (free_at == 0 || out_at == 0) stuck(std::string("does not return a ") + Ports::kItem + "'s result");
    if (a.out.tag != tag)
      throw std::runtime_error(this->prefix() + "result tag " + std::to_string(a.out.tag) + ", expected " +
                               std::to_string(tag));
    a.issue = uint32_t(free_at - taken);
    a.result = uint32_t(out_at - taken);
    return a;
  }

 private:
  [[noreturn]] void stuck(const std::string& what) const {
    throw std::runtime_error(this->prefix() + "the Verilated unit " + this->model() + " " + what + " within " +
                             std::to_string(kItemTimeout) + " clocks (cycle " + std::to_string(m_sim.cycle()) +
                             ")");
  }

  Sim<Model> m_sim;
  uint32_t m_tag = 0;
};

// A Verilated model in a unit's registry: what it is and how to drive it.
template <class Ports>
struct UnitEntry {
  RtlUnitInfo info;
  std::unique_ptr<UnitDriver<Ports>> (*make)(const typename Ports::Params& p, const std::string& name);
};

// The factory of a model's driver; Ports is deduced from the entry it is stored in.
template <class Model>
struct DriverOf {
  template <class Ports>
  static std::unique_ptr<UnitDriver<Ports>> make(const typename Ports::Params& p, const std::string& name) {
    return std::make_unique<ModelDriver<Ports, Model>>(p, name);
  }
};

// The X of RTU_RTL_<KIND>_MODELS(X): one registry entry per model.
#define RTU_RTL_UNIT_ENTRY(Model, name, spec, args) {{name, spec, args}, &::rtu::rtl::DriverOf<Model>::make},

// The models of one kind this build verilated, found by their -G options.
template <class Ports>
class UnitRegistry {
 public:
  explicit UnitRegistry(std::vector<UnitEntry<Ports>> entries) : m_entries(std::move(entries)) {
    for (const UnitEntry<Ports>& e : m_entries) m_infos.push_back(e.info);
  }
  const std::vector<RtlUnitInfo>& infos() const { return m_infos; }
  // The driver of the model verilated with `args`, or null.
  std::unique_ptr<UnitDriver<Ports>> make(const typename Ports::Params& p, const std::string& args) const {
    for (const UnitEntry<Ports>& e : m_entries)
      if (e.info.args == args) return e.make(p, e.info.name);
    return nullptr;
  }
  // "this build verilated a (...): args; b (...): args", for messages.
  std::string built() const {
    std::string list;
    for (const UnitEntry<Ports>& e : m_entries) list += (list.empty() ? "" : "; ") + Ports::describe(e.info);
    return "this build verilated " + list;
  }

 private:
  std::vector<UnitEntry<Ports>> m_entries;
  std::vector<RtlUnitInfo> m_infos;
};

}  // namespace rtu::rtl
