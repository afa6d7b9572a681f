// The parameters of rtl/box_unit.sv for a fixed-point format, a node width and a pipeline depth: the one place
// where the RTL's widths are derived from the C++ model's formats (hwmodel/numeric/fixed_format.h) and its latency
// from the timing presets (hwmodel/timing/timing_config.h). CMake runs rtl_params_main.cpp at configure time to
// verilate the unit with these values; the testbench derives them again and checks that the Verilated models
// match.
#pragma once

#include <bit>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::rtl {

struct BoxUnitParams {
  int n = 0;        // N: child boxes per node
  int lanes = 0;    // LANES: box tests per clock (the timing model's box_rate, at most N)
  int k = 0;        // K: child offset bits
  int a = 0;        // A: translated-delta magnitude bits, B + G + F + 1
  int m = 0;        // M: reciprocal mantissa significant bits, R + 1
  int tb = 0;       // TB: t magnitude bits (t_bits)
  int shw = 0;      // SHW: width of the node shift exp + F (at most B + 1 + F)
  int rsh = 0;      // RSH: largest right shift of a product, F + R - T
  int lsh = 0;      // LSH: largest left shift, max(0, D - RSH) (rcp_sh >= RSH - D: d = 1 raw)
  int latency = 0;  // LATENCY: pipeline depth in clocks
  int frac = 0;     // F (not an RTL parameter: the testbench computes sh = exp + F)

  // Derived widths of the ports (as box_unit.sv computes them).
  int cw() const { return std::bit_width(unsigned(n)); }  // $clog2(N + 1)
  int rsw() const { return std::bit_width(unsigned(lsh > rsh ? lsh : rsh)) + 1; }
};

// Throws std::invalid_argument when the format is not narrow (the unit implements the 64-bit path only).
// `rate` is the box tests per clock (the timing model's box_rate); the unit has min(rate, width) lanes.
inline BoxUnitParams box_unit_params(const hw::FixedFormat& f, int width, int rate, int latency) {
  f.validate();
  BoxUnitParams p;
  p.n = width;
  p.lanes = rate < width ? rate : width;
  p.k = f.child_bits;
  p.a = f.translated_bits();
  p.m = f.rcp_bits + 1;
  p.tb = f.t_bits;
  p.shw = std::bit_width(unsigned(f.coord_bits + 1 + f.frac_bits));
  p.rsh = f.frac_bits + f.rcp_bits - f.t_frac_bits;
  p.lsh = f.dir_bits > p.rsh ? f.dir_bits - p.rsh : 0;
  p.latency = latency;
  p.frac = f.frac_bits;
  // The conditions of FixedRay::narrow (set_direction): products fit 63 bits, right shifts stay below 62.
  if (f.translated_bits() + f.rcp_bits + 2 > 63 || p.rsh > 61)
    throw std::invalid_argument("box_unit: format " + f.name + " is not narrow (needs 128-bit products)");
  if (width < 1 || width > 8 || rate < 1 || latency < 1)
    throw std::invalid_argument("box_unit: bad width, rate or latency");
  return p;
}

// The unit of a timing preset: its format, its BVH width, its box rate and its box latency.
inline BoxUnitParams box_unit_params(const hw::TimingConfig& c) {
  return box_unit_params(hw::format_from_spec(c.format), c.bvh_width, c.box_rate, c.box_latency);
}

// A unit's configuration from its spec: a timing preset ("intel") or a preset with keys changed as by `--set`
// ("intel:box_rate=3"). Throws std::invalid_argument for an unknown preset or key or a bad value.
inline hw::TimingConfig unit_config(const std::string& spec) {
  size_t colon = spec.find(':');
  hw::TimingConfig c = hw::timing_preset(spec.substr(0, colon));
  while (colon != std::string::npos) {
    const size_t from = colon + 1;
    colon = spec.find(':', from);
    const std::string kv = spec.substr(from, colon == std::string::npos ? std::string::npos : colon - from);
    const size_t k = kv.find('=');
    if (k == std::string::npos)
      throw std::invalid_argument("unit spec " + spec + ": '" + kv + "' is not key=value");
    hw::set_timing_key(c, kv.substr(0, k), kv.substr(k + 1));
  }
  return c;
}

// The unit's parameters by name, in box_unit.sv's order.
inline std::vector<std::pair<std::string, int>> param_list(const BoxUnitParams& p) {
  return {{"N", p.n},   {"LANES", p.lanes}, {"K", p.k},     {"A", p.a},     {"M", p.m},
          {"TB", p.tb}, {"SHW", p.shw},     {"RSH", p.rsh}, {"LSH", p.lsh}, {"LATENCY", p.latency}};
}

// Verilator's -G options for these parameters, separated by spaces.
inline std::string verilator_args(const BoxUnitParams& p) {
  std::string s;
  for (const auto& [name, value] : param_list(p)) {
    if (!s.empty()) s += ' ';
    s += "-G";
    s += name;
    s += '=';
    s += std::to_string(value);
  }
  return s;
}

}  // namespace rtu::rtl
