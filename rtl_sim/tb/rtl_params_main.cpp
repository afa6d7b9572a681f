// Run by CMake at configure time (try_run): prints "NAME: -GN=.. -GLANES=.. ..." for each unit named on the
// command line, so that the Verilated box units take their widths, lanes and latency from the C++ model. A unit is
// a timing preset ("rdna2", named after it) or "NAME=SPEC" with SPEC as unit_config() reads it
// ("intel_lanes3=intel:box_rate=3").
#include <cstdio>
#include <exception>
#include <string>

#include "rtl_sim/tb/rtl_params.h"

int main(int argc, char** argv) {
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      const size_t eq = arg.find('=');
      const std::string name = arg.substr(0, eq), spec = eq == std::string::npos ? arg : arg.substr(eq + 1);
      const rtu::rtl::BoxUnitParams p = rtu::rtl::box_unit_params(rtu::rtl::unit_config(spec));
      std::printf("%s: %s\n", name.c_str(), rtu::rtl::verilator_args(p).c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtl_params: %s\n", e.what());
    return 1;
  }
  return 0;
}
