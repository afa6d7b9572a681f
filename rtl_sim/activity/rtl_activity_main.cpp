// rtu_rtl_activity: the switching activity of the RTL units, measured with Verilator's toggle coverage
// (toggle_count.h) on vectors captured from traversals of a real mesh (tb/box_vectors.h, tb/tri_vectors.h), for
// the energy per box and per triangle test (bench/rtl_activity.sh, bench/data/rtl_activity.csv). Units: the box
// unit (rtl/box_unit.sv) and the triangle unit (rtl/tri_core.sv) of the presets rdna2 and embedded, and the
// reference operators of rtl/ref_ops.sv (32-bit adder, 32x32->64 multiplier) on uniform random operands.
//
// Each unit: reset; a check that it shows no transition while idle with constant inputs; a run of uniformly
// random inputs (random bits in every input field: it separates the nets, toggle_count.h); the measured run, at
// full throughput (a new input at every clock the unit takes one, out_ready high). Reported per unit:
//   tests        box unit: child box tests (occupied slots of the nodes, what the timing model counts as box
//                tests); triangle unit: triangle tests; reference operators: operations
//   signal_bits  distinct RTL nets that toggle (clock and reset excluded, aliases merged; toggle_count.h)
//   toggles      their bit transitions in the measured run, fill and drain included (0->1 and 1->0 each count 1)
//   toggles_per_test = toggles / tests;  activity = toggles_per_test / signal_bits
//
//   rtu_rtl_activity [--scene FILE] [--nodes N] [--tris N] [--ops N] [--random N] [--checkpoints K]
//                    [--only LABEL] [--csv FILE] [--tmp DIR]
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "Vbox_unit_cov_embedded.h"
#include "Vbox_unit_cov_rdna2.h"
#include "Vref_add32_cov.h"
#include "Vref_mul32_cov.h"
#include "Vtri_core_cov_embedded.h"
#include "Vtri_core_cov_rdna2.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_cov_models.h"
#include "rtl_sim/activity/activity.h"
#include "rtl_sim/cosim/box_ports.h"
#include "rtl_sim/cosim/tri_ports.h"
#include "rtl_sim/params/rtl_params.h"
#include "rtl_sim/params/tri_params.h"
#include "rtl_sim/tb/box_vectors.h"
#include "rtl_sim/tb/tri_vectors.h"

namespace {

using namespace rtu;
using namespace rtu::rtl;

struct Options {
  std::string scene = "/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc";
  size_t nodes = 20000, tris = 20000, ops = 100000, random = 4000;
  int checkpoints = 32;
  std::string only, csv, tmp = ".";
  uint64_t seed = 7;
};

struct Row {
  std::string key, label;
  uint64_t tests = 0, inputs = 0, cycles = 0;
  ToggleTotals t;
  double secs = 0;
};

hw::FixedFormat preset_format(const std::string& preset) {
  const hw::TimingConfig c = hw::timing_preset(preset);
  hw::FixedFormat f = hw::format_from_spec(c.format);
  f.width = c.bvh_width;
  return f;
}

// Reset, the idle check, the random run and the measured run of one unit.
template <class Model, class RandomDrive, class Drive>
Row measure(const Options& o, const std::string& key, const std::string& label, size_t n_random,
            RandomDrive random_drive, size_t n, Drive drive, uint64_t expected_cycles) {
  const auto t0 = std::chrono::steady_clock::now();
  Sim<Model> sim;
  if constexpr (HasHandshake<Model>) {
    sim.dut().in_valid = 0;
    sim.dut().out_ready = 1;
  }
  sim.reset();
  ToggleMeter meter(sim.context(), o.tmp + "/rtl_activity_" + label + ".dat");
  const uint64_t idle = idle_toggles(sim, meter, 100);
  if (idle != 0)
    throw std::runtime_error(label + ": " + std::to_string(idle) + " transitions in 100 idle clocks (expected 0)");
  const ActivityRun rnd =
      run_activity(sim, meter, n_random, random_drive, 2 * n_random, o.checkpoints, o.seed + 1);
  const ActivityRun run = run_activity(sim, meter, n, drive, expected_cycles, o.checkpoints, o.seed + 2);
  Row r;
  r.key = key;
  r.label = label;
  r.inputs = run.inputs;
  r.cycles = run.cycles;
  r.t = net_totals(classify_nets({rnd.at, run.at}, meter.names().size()), run.total());
  r.secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

template <class Model>
Row box_unit(const Options& o, const std::string& preset, const char* model_args) {
  const BoxUnitParams p = box_unit_params(hw::timing_preset(preset));
  if (verilator_args(p) != model_args)
    throw std::runtime_error("box unit " + preset + ": the model was verilated with " + model_args +
                             ", the preset gives " + verilator_args(p));
  const CaseSet s = traversal_cases(o.scene, preset_format(preset), o.nodes, o.seed);
  std::vector<BoxInputs> in;
  for (const BoxCase& c : s.cases) {
    in.push_back(unit_inputs(s, c));
    const std::string bad = contract_error(p, in.back());
    if (!bad.empty()) throw std::runtime_error(bad + "\n" + describe(s, c));
  }
  hw::Pcg32 rng(o.seed + 11);
  auto random_drive = [&](Model& m, size_t k) {
    BoxInputs x{};
    auto r64 = [&] { return (uint64_t(rng.next_u32()) << 32) | rng.next_u32(); };
    for (int a = 0; a < 3; ++a) {
      x.base[a] = int64_t(r64());
      x.sh[a] = int(rng.next_u32());
      x.rcpm_dn[a] = int64_t(r64());
      x.rcpm_up[a] = int64_t(r64());
      x.rcp_sh[a] = int(rng.next_u32());
      x.zero[a] = rng.next_u32() & 1;
      x.neg[a] = rng.next_u32() & 1;
    }
    for (auto& row : x.q)
      for (uint32_t& q : row) q = rng.next_u32();
    x.count = int(rng.next_u32() % uint32_t(p.n + 1));
    x.tmin = int64_t(r64());
    x.tlim = int64_t(r64());
    drive_inputs(m, p, x, uint32_t(k) & 0xffffu);
  };
  auto drive = [&](Model& m, size_t k) { drive_inputs(m, p, in[k], uint32_t(k) & 0xffffu); };
  const uint64_t issue = uint64_t((p.n + p.lanes - 1) / p.lanes);
  Row r =
      measure<Model>(o, model_args, preset + "-box", o.random, random_drive, in.size(), drive, issue * in.size());
  r.tests = s.child_tests();
  return r;
}

template <class Model>
Row tri_unit(const Options& o, const std::string& preset, const char* model_args) {
  const TriUnitParams p = tri_unit_params(hw::timing_preset(preset));
  if (verilator_args(p) != model_args)
    throw std::runtime_error("tri unit " + preset + ": the model was verilated with " + model_args +
                             ", the preset gives " + verilator_args(p));
  const TriSet s = tri_traversal_cases(o.scene, preset_format(preset), o.tris, o.seed);
  std::vector<TriInputs> in;
  for (const TriCase& c : s.cases) {
    in.push_back(tri_unit_inputs(s.rays[c.ray], c.v, c.tmin, c.tlim));
    const std::string bad = contract_error(p, in.back());
    if (!bad.empty()) throw std::runtime_error(bad + "\n" + describe(s, c));
  }
  hw::Pcg32 rng(o.seed + 12);
  auto random_drive = [&](Model& m, size_t k) {
    TriInputs x{};
    auto r64 = [&] { return int64_t((uint64_t(rng.next_u32()) << 32) | rng.next_u32()); };
    for (auto& v : x.v)
      for (int64_t& c : v) c = r64();
    for (int a = 0; a < 3; ++a) {
      x.o[a] = r64();
      x.d[a] = r64();
    }
    x.tmin = r64();
    x.tlim = r64();
    drive_inputs(m, p, x, uint32_t(k) & 0xffffu);
  };
  auto drive = [&](Model& m, size_t k) { drive_inputs(m, p, in[k], uint32_t(k) & 0xffffu); };
  Row r = measure<Model>(o, model_args, preset + "-tri", o.random, random_drive, in.size(), drive, in.size());
  r.tests = in.size();
  return r;
}

template <class Model>
Row ref_op(const Options& o, const std::string& name) {
  hw::Pcg32 rng(o.seed + 13), rng2(o.seed + 14);
  auto random_drive = [&](Model& m, size_t) {
    m.in_a = rng.next_u32();
    m.in_b = rng.next_u32();
  };
  // The measured run: uniform random operands too (another seed).
  auto drive = [&](Model& m, size_t) {
    m.in_a = rng2.next_u32();
    m.in_b = rng2.next_u32();
  };
  Row r = measure<Model>(o, "ref:" + name, "ref-" + name, o.random, random_drive, o.ops, drive, o.ops);
  r.tests = o.ops;
  return r;
}

size_t count_arg(const char* v) {
  char* end = nullptr;
  const unsigned long long x = std::strtoull(v, &end, 10);
  if (!end || *end || x == 0) throw std::invalid_argument(std::string("not a positive count: ") + v);
  return size_t(x);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> const char* {
        if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
        return argv[++i];
      };
      if (a == "--scene")
        o.scene = value();
      else if (a == "--nodes")
        o.nodes = count_arg(value());
      else if (a == "--tris")
        o.tris = count_arg(value());
      else if (a == "--ops")
        o.ops = count_arg(value());
      else if (a == "--random")
        o.random = count_arg(value());
      else if (a == "--checkpoints")
        o.checkpoints = int(count_arg(value()));
      else if (a == "--only")
        o.only = value();
      else if (a == "--csv")
        o.csv = value();
      else if (a == "--tmp")
        o.tmp = value();
      else
        throw std::invalid_argument("unknown argument " + a + " (see rtl_sim/activity/rtl_activity_main.cpp)");
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtu_rtl_activity: %s\n", e.what());
    return 2;
  }
  const std::vector<std::pair<std::string, std::function<Row()>>> units = {
      {"rdna2-box", [&] { return box_unit<Vbox_unit_cov_rdna2>(o, "rdna2", RTU_RTL_COV_BOX_ARGS_rdna2); }},
      {"embedded-box",
       [&] { return box_unit<Vbox_unit_cov_embedded>(o, "embedded", RTU_RTL_COV_BOX_ARGS_embedded); }},
      {"rdna2-tri", [&] { return tri_unit<Vtri_core_cov_rdna2>(o, "rdna2", RTU_RTL_COV_TRI_ARGS_rdna2); }},
      {"embedded-tri",
       [&] { return tri_unit<Vtri_core_cov_embedded>(o, "embedded", RTU_RTL_COV_TRI_ARGS_embedded); }},
      {"ref-add32", [&] { return ref_op<Vref_add32_cov>(o, "add32"); }},
      {"ref-mul32", [&] { return ref_op<Vref_mul32_cov>(o, "mul32"); }},
  };
  std::vector<Row> rows;
  try {
    for (const auto& [label, run] : units) {
      if (!o.only.empty() && o.only != label) continue;
      const Row r = run();
      const double per_test = double(r.t.toggles) / double(r.tests);
      std::printf(
          "%-13s %-72s tests %8llu inputs %8llu cycles %8llu | points %6llu toggles %11llu | constant %5llu nets "
          "%6llu toggles %11llu | per test %9.1f activity %.4f | %.1f s\n",
          r.label.c_str(), r.key.c_str(), (unsigned long long)r.tests, (unsigned long long)r.inputs,
          (unsigned long long)r.cycles, (unsigned long long)r.t.points, (unsigned long long)r.t.toggles_raw,
          (unsigned long long)r.t.constant_points, (unsigned long long)r.t.nets, (unsigned long long)r.t.toggles,
          per_test, per_test / double(r.t.nets), r.secs);
      std::fflush(stdout);
      rows.push_back(r);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtu_rtl_activity: %s\n", e.what());
    return 1;
  }
  if (rows.empty()) {
    std::fprintf(stderr, "rtu_rtl_activity: no unit is called %s\n", o.only.c_str());
    return 2;
  }
  if (!o.csv.empty()) {
    std::ofstream out(o.csv);
    out << "params,unit,tests,signal_bits,toggles_per_test\n";
    for (const Row& r : rows) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.2f", double(r.t.toggles) / double(r.tests));
      out << r.key << ',' << r.label << ',' << r.tests << ',' << r.t.nets << ',' << buf << '\n';
    }
    if (!out) {
      std::fprintf(stderr, "rtu_rtl_activity: cannot write %s\n", o.csv.c_str());
      return 1;
    }
  }
  return 0;
}
