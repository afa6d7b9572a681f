// The parameters of rtl/tri_core.sv (the triangle test unit) for a fixed-point format and a pipeline depth: its
// widths derived from the C++ model's formats (hwmodel/numeric/fixed_format.h), its latency from the timing
// presets (hwmodel/timing/timing_config.h, tri_latency). CMake runs rtl_params_main.cpp at configure time to
// verilate the unit with these values; the testbench derives them again and checks that the Verilated models
// match.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::rtl {

struct TriUnitParams {
  int b = 0;        // B: grid bits of a vertex coordinate
  int a = 0;        // A: translated magnitude bits B + G + F + 1 (the origin port is A bits signed)
  int f = 0;        // F: fraction bits of the origin
  int d = 0;        // D: fraction bits of the direction
  int tb = 0;       // TB: t magnitude bits (t_bits)
  int s = 0;        // S: t_shift, D - F + T
  int latency = 0;  // LATENCY: pipeline depth in clocks (>= 6)

  // Derived widths, as tri_core.sv computes them.
  int dw() const { return d + 2; }                    // direction port, signed
  int ew() const { return 2 * a + d + 4; }            // e1, e2, det ports, signed
  int qw() const { return tb > s ? tb + 1 : s + 1; }  // quotient bits before saturation
  int div_stages() const { return latency - 5; }
  int bits_per_stage() const { return (qw() + div_stages() - 1) / div_stages(); }
};

// The unit of a format with a given pipeline depth. Throws std::invalid_argument when the depth leaves no
// divider stage (latency < 6) or the edge functions need more than 127 bits (they are compared as __int128).
inline TriUnitParams tri_unit_params(const hw::FixedFormat& f, int latency) {
  f.validate();
  TriUnitParams p;
  p.b = f.coord_bits;
  p.a = f.translated_bits();
  p.f = f.frac_bits;
  p.d = f.dir_bits;
  p.tb = f.t_bits;
  p.s = f.t_shift();
  p.latency = latency;
  if (latency < 6)
    throw std::invalid_argument("tri_unit: latency " + std::to_string(latency) +
                                " < 6 (translate, cross, dot, decide, one divider stage, finish)");
  if (p.ew() > 127)
    throw std::invalid_argument("tri_unit: format " + f.name + ": edge functions wider than 127 bits");
  return p;
}

// The triangle unit of a timing configuration: its format and tri_latency. One test per clock: tri_rate must
// be 1 (a faster unit is several of these).
inline TriUnitParams tri_unit_params(const hw::TimingConfig& c) {
  if (c.tri_rate != 1)
    throw std::invalid_argument("tri_unit: tri_rate " + std::to_string(c.tri_rate) +
                                ": the unit tests one triangle per clock");
  return tri_unit_params(hw::format_from_spec(c.format), c.tri_latency);
}

// The unit's parameters by name, in tri_core.sv's order.
inline std::vector<std::pair<std::string, int>> param_list(const TriUnitParams& p) {
  return {{"B", p.b}, {"A", p.a}, {"F", p.f}, {"D", p.d}, {"TB", p.tb}, {"S", p.s}, {"LATENCY", p.latency}};
}

// Verilator's -G options for these parameters, separated by spaces.
inline std::string verilator_args(const TriUnitParams& p) {
  std::string s;
  for (const auto& [name, value] : param_list(p)) {
    if (!s.empty()) s += ' ';
    s += "-G" + name + '=' + std::to_string(value);
  }
  return s;
}

}  // namespace rtu::rtl
