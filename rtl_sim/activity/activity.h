// Drives a toggle-coverage model (rtl/box_unit.sv, rtl/tri_core.sv or rtl/ref_ops.sv) at full throughput and reads
// its toggle counters at checkpoints (toggle_count.h): used by rtu_rtl_activity and test_rtl_activity.
#pragma once

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "hwmodel/numeric/rng.h"
#include "rtl_sim/activity/toggle_count.h"
#include "rtl_sim/cosim/sim.h"

namespace rtu::rtl {

// A run from zeroed counters: the counts at each checkpoint (the last one after the run).
struct ActivityRun {
  uint64_t inputs = 0, cycles = 0, outputs = 0;
  std::vector<std::vector<uint64_t>> at;
  const std::vector<uint64_t>& total() const { return at.back(); }
};

template <class Model>
concept HasHandshake = requires(Model& m) {
  m.in_valid;
  m.in_ready;
  m.out_valid;
  m.out_ready;
};

// Streams n inputs (drive(model, k) sets input k's ports) through the unit at full throughput: in_valid high while
// inputs remain (a new input at every clock the unit takes one), out_ready always high, until every result is
// out. A unit without a handshake (ref_ops) takes an input at every clock edge and holds its result after it.
// The counters are zeroed with input 0 already on the ports (valid low), so the run counts what the n inputs
// cost, the pipeline's fill and drain included, and nothing before. About `checkpoints` reads at pseudo-random
// cycles (seeded; `expected_cycles` spreads them), and one at the end.
template <class Model, class Drive>
ActivityRun run_activity(Sim<Model>& sim, ToggleMeter& meter, size_t n, Drive drive, uint64_t expected_cycles,
                         int checkpoints, uint64_t seed) {
  Model& m = sim.dut();
  ActivityRun r;
  hw::Pcg32 rng(seed);
  const uint64_t period = std::max<uint64_t>(1, expected_cycles / uint64_t(std::max(1, checkpoints)));
  if (n > 0) drive(m, size_t(0));
  if constexpr (HasHandshake<Model>) {
    m.in_valid = 0;
    m.out_ready = 1;
  }
  sim.eval();
  meter.zero();
  const uint64_t c0 = sim.cycle();
  size_t next = 0;
  const uint64_t limit = 64 * (uint64_t(n) + 64);  // a stuck unit fails instead of hanging
  while (r.outputs < n) {
    if constexpr (HasHandshake<Model>) {
      m.in_valid = next < n;
      m.out_ready = 1;
      sim.eval();
      const bool in_fire = m.in_valid && m.in_ready;
      r.outputs += uint64_t(m.out_valid != 0);
      sim.tick();
      if (in_fire && ++next < n) drive(m, next);
    } else {
      sim.tick();  // input `next` is taken at this edge; its result is out after it
      if (next < n) {
        ++r.outputs;
        if (++next < n) drive(m, next);
      }
    }
    if (rng.next_u32() % period == 0) {
      sim.eval();  // the next input's logic settled: a register and its input differ here when the input moved
      r.at.push_back(meter.read());
    }
    if (sim.cycle() - c0 > limit) throw std::runtime_error("run_activity: the unit stopped taking inputs");
  }
  sim.eval();
  r.inputs = next;
  r.cycles = sim.cycle() - c0;
  r.at.push_back(meter.read());
  return r;
}

// The transitions while the unit sits `cycles` clocks with its inputs as they are (valid low): must be 0.
template <class Model>
uint64_t idle_toggles(Sim<Model>& sim, ToggleMeter& meter, int cycles) {
  if constexpr (HasHandshake<Model>) {
    sim.dut().in_valid = 0;
    sim.dut().out_ready = 1;
  }
  sim.eval();
  meter.zero();
  for (int i = 0; i < cycles; ++i) sim.tick();
  uint64_t sum = 0;
  for (uint64_t c : meter.read()) sum += c;
  return sum;
}

}  // namespace rtu::rtl
