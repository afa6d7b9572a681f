// Shared helpers of what drives a Verilated model (the co-simulation adapter and the testbenches): a clocked
// simulation (clock, synchronous reset, bounded waits so that a test that would hang fails after a number of
// cycles, VCD dump), bit packing of wide ports, and the testbench's environment knobs:
//   RTU_RTL_SEED=S          seed of the randomized tests (default: each test's fixed seed; printed on failure)
//   RTU_RTL_TRACE=1         dump a VCD of every simulation run (first RTU_RTL_TRACE_CYCLES cycles, default 20000)
//   RTU_RTL_VCD_DIR=DIR     where VCDs go (default: the working directory); a failing comparison always re-runs
//                           its batch of vectors with a VCD there and names the file in the failure message
#pragma once

#include <verilated.h>
#include <verilated_vcd_c.h>

#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>
#include <type_traits>

namespace rtu::rtl {

inline uint64_t env_u64(const char* name, uint64_t fallback) {
  const char* v = std::getenv(name);
  if (!v || !*v) return fallback;
  char* end = nullptr;
  const unsigned long long x = std::strtoull(v, &end, 0);
  return (end && *end == 0) ? uint64_t(x) : fallback;
}
inline uint64_t test_seed(uint64_t fallback) {
  return env_u64("RTU_RTL_SEED", fallback);
}
inline bool trace_requested() {
  return env_u64("RTU_RTL_TRACE", 0) != 0;
}
inline std::string vcd_path(const std::string& name) {
  const char* dir = std::getenv("RTU_RTL_VCD_DIR");
  return (dir && *dir ? std::string(dir) + "/" : std::string()) + name + ".vcd";
}
// The VCD path for a simulation named `name` when RTU_RTL_TRACE=1, else "" (no dump).
inline std::string requested_vcd(const std::string& name) {
  return trace_requested() ? vcd_path(name) : std::string();
}
inline uint64_t requested_vcd_cycles() {
  return env_u64("RTU_RTL_TRACE_CYCLES", 20000);
}

// ---- bit packing of ports (Verilator: CData/SData/IData/QData up to 64 bits, VlWide<W> above) ---------------

template <class T>
requires std::is_integral_v<T>
void put_bits(T& port, int lsb, int width, uint64_t v) {
  const uint64_t mask = width >= 64 ? ~uint64_t(0) : (uint64_t(1) << width) - 1;
  uint64_t x = uint64_t(port);
  x = (x & ~(mask << lsb)) | ((v & mask) << lsb);
  port = T(x);
}
template <std::size_t W>
void put_bits(VlWide<W>& port, int lsb, int width, uint64_t v) {
  for (int b = 0; b < width;) {
    const int bit = lsb + b, word = bit / 32, off = bit % 32;
    const int n = std::min(32 - off, width - b);
    const uint32_t m = (n == 32 ? ~0u : ((1u << n) - 1u)) << off;
    const uint32_t val = uint32_t(v >> b) << off;
    port[size_t(word)] = (port[size_t(word)] & ~m) | (val & m);
    b += n;
  }
}
template <class T>
requires std::is_integral_v<T> uint64_t get_bits(const T& port, int lsb, int width) {
  const uint64_t mask = width >= 64 ? ~uint64_t(0) : (uint64_t(1) << width) - 1;
  return (uint64_t(port) >> lsb) & mask;
}
template <std::size_t W>
uint64_t get_bits(const VlWide<W>& port, int lsb, int width) {
  uint64_t v = 0;
  for (int b = 0; b < width;) {
    const int bit = lsb + b, word = bit / 32, off = bit % 32;
    const int n = std::min(32 - off, width - b);
    const uint64_t chunk = (uint64_t(port[size_t(word)]) >> off) & ((uint64_t(1) << n) - 1);
    v |= chunk << b;
    b += n;
  }
  return v;
}
inline int64_t sign_extend(uint64_t v, int width) {
  if (width >= 64) return int64_t(v);
  const uint64_t sign = uint64_t(1) << (width - 1);
  return int64_t((v ^ sign) - sign);
}

// ---- clocked simulation ---------------------------------------------------------------------------------------

// A Verilated model with ports clk and rst, in its own context. tick() is one clock period: the inputs set
// before it are sampled at the rising edge. The VCD (when a path is given) covers the clock periods
// [vcd_from, vcd_to), with a period of 10 time units and rising edges at 10 c + 5.
template <class Model>
class Sim {
 public:
  explicit Sim(const std::string& vcd = "", uint64_t vcd_from = 0, uint64_t vcd_to = ~uint64_t(0))
      : m_ctx(std::make_unique<VerilatedContext>()), m_vcd_from(vcd_from), m_vcd_to(vcd_to) {
    m_ctx->traceEverOn(!vcd.empty());
    m_model = std::make_unique<Model>(m_ctx.get(), "top");
    if (!vcd.empty()) {
      m_vcd = std::make_unique<VerilatedVcdC>();
      m_model->trace(m_vcd.get(), 99);
      m_vcd->open(vcd.c_str());
    }
    m_model->clk = 0;
    m_model->rst = 0;
    m_model->eval();
  }
  ~Sim() {
    if (m_vcd) m_vcd->close();
    m_model->final();
  }
  Sim(const Sim&) = delete;
  Sim& operator=(const Sim&) = delete;

  Model& dut() { return *m_model; }
  // The model's context (its coverage counters: rtl_sim/activity/toggle_count.h).
  VerilatedContext& context() { return *m_ctx; }
  // Settles the combinational logic after inputs changed (outputs such as a ready that depend on inputs).
  void eval() { m_model->eval(); }
  // One clock: rising edge, then falling edge.
  void tick() {
    m_model->eval();
    dump(10 * m_cycle);
    m_model->clk = 1;
    m_model->eval();
    dump(10 * m_cycle + 5);
    m_model->clk = 0;
    m_model->eval();
    ++m_cycle;
  }
  // Synchronous reset held for `cycles` clocks; the caller drives the other inputs to idle before.
  void reset(int cycles = 3) {
    m_model->rst = 1;
    for (int i = 0; i < cycles; ++i) tick();
    m_model->rst = 0;
    m_model->eval();
  }
  // Ticks until done() holds (checked before each clock), at most max_cycles clocks. False on timeout: the
  // caller fails the test, so a wait that never ends cannot hang the run.
  template <class Done>
  bool run_until(Done done, uint64_t max_cycles) {
    for (uint64_t i = 0; i < max_cycles; ++i) {
      m_model->eval();
      if (done()) return true;
      tick();
    }
    m_model->eval();
    return done();
  }
  uint64_t cycle() const { return m_cycle; }  // rising edges so far

 private:
  void dump(uint64_t t) {
    if (m_vcd && m_cycle >= m_vcd_from && m_cycle < m_vcd_to) m_vcd->dump(t);
  }

  std::unique_ptr<VerilatedContext> m_ctx;
  std::unique_ptr<Model> m_model;
  std::unique_ptr<VerilatedVcdC> m_vcd;
  uint64_t m_vcd_from, m_vcd_to;
  uint64_t m_cycle = 0;
};

}  // namespace rtu::rtl
