// The box unit's parameters from the C++ model (rtl_params.h), for the build and for synthesis scripts.
//   rtu_rtl_params NAME=SPEC...        "NAME: -GN=.. -GLANES=.. ..." per unit: what CMake verilates (run at
//   configure
//                                  time by try_run). A bare preset name is its own NAME and SPEC ("rdna2");
//                                  SPEC is a preset with timing keys changed, as unit_config() reads it
//                                  ("wide8_lanes3=intel:format=wide8:bvh_width=8:box_rate=3").
//   rtu_rtl_params --chparam SPEC [FORMAT_KEY=VALUE...]
//                                  yosys `chparam -set` arguments for the unit of SPEC with its format's widths
//                                  changed (coord_bits, child_bits, guard_bits, frac_bits, dir_bits, rcp_bits,
//                                  t_frac_bits, t_bits), e.g. `--chparam rdna2 coord_bits=16` (bench/rtl_area.sh).
//   rtu_rtl_params ... --tri NAME=SPEC...
//                                  after --tri: "tri:NAME: -GB=.. -GA=.. ..." per triangle unit (rtl/tri_core.sv,
//                                  params/tri_params.h: the format's widths and the preset's tri_latency)
//   rtu_rtl_params ... --trav NAME=SPEC...
//                                  after --trav: "trav:NAME: -GSLOTS=.. ..." per traversal unit
//                                  (trav/trav_unit.sv, trav/trav_params.h)
//   rtu_rtl_params --chparam-tri SPEC [FORMAT_KEY=VALUE...]
//                                  the same as --chparam for the triangle unit (bench/rtl_area.sh)
#include <cstdio>
#include <exception>
#include <string>

#include "rtl_sim/params/rtl_params.h"
#include "rtl_sim/params/tri_params.h"
#include "rtl_sim/trav/trav_params.h"

namespace {

std::string chparam(int argc, char** argv, bool tri) {
  if (argc < 3) throw std::invalid_argument("--chparam needs a unit spec");
  const rtu::hw::TimingConfig c = rtu::rtl::unit_config(argv[2]);
  rtu::hw::FixedFormat f = rtu::hw::format_from_spec(c.format);
  for (int i = 3; i < argc; ++i) {
    const std::string kv = argv[i];
    const size_t eq = kv.find('=');
    int* field = eq == std::string::npos ? nullptr : rtu::hw::format_field(f, kv.substr(0, eq));
    if (!field || kv.substr(0, eq) == "width")
      throw std::invalid_argument("'" + kv +
                                  "' is not FORMAT_KEY=VALUE with a format key (the width is bvh_width)");
    *field = std::stoi(kv.substr(eq + 1));
  }
  const auto list =
      tri ? rtu::rtl::param_list(rtu::rtl::tri_unit_params(f, c.tri_latency))
          : rtu::rtl::param_list(rtu::rtl::box_unit_params(f, c.bvh_width, c.box_rate, c.box_latency));
  std::string r;
  for (const auto& [name, value] : list) {
    if (!r.empty()) r += ' ';
    r += "-set ";
    r += name;
    r += ' ';
    r += std::to_string(value);
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc >= 2 && (std::string(argv[1]) == "--chparam" || std::string(argv[1]) == "--chparam-tri")) {
      std::printf("%s\n", chparam(argc, argv, std::string(argv[1]) == "--chparam-tri").c_str());
      return 0;
    }
    bool tri = false, trav = false;
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg == "--tri" || arg == "--trav") {
        tri = arg == "--tri";
        trav = arg == "--trav";
        continue;
      }
      const size_t eq = arg.find('=');
      const std::string name = arg.substr(0, eq), spec = eq == std::string::npos ? arg : arg.substr(eq + 1);
      const rtu::hw::TimingConfig c = rtu::rtl::unit_config(spec);
      if (trav)
        std::printf("trav:%s: %s\n", name.c_str(), rtu::rtl::verilator_args(rtu::rtl::trav_params(c)).c_str());
      else if (tri)
        std::printf("tri:%s: %s\n", name.c_str(), rtu::rtl::verilator_args(rtu::rtl::tri_unit_params(c)).c_str());
      else
        std::printf("%s: %s\n", name.c_str(), rtu::rtl::verilator_args(rtu::rtl::box_unit_params(c)).c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtl_params: %s\n", e.what());
    return 1;
  }
  return 0;
}
