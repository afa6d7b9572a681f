// Run by CMake at configure time (try_run): prints "PRESET: -GN=.. -GK=.. ..." for each timing preset named on
// the command line, so that the Verilated box units take their widths and latency from the C++ model.
#include <cstdio>
#include <exception>

#include "rtl_sim/tb/rtl_params.h"

int main(int argc, char** argv) {
  try {
    for (int i = 1; i < argc; ++i) {
      const rtu::rtl::BoxUnitParams p = rtu::rtl::box_unit_params(rtu::hw::timing_preset(argv[i]));
      std::printf("%s: %s\n", argv[i], rtu::rtl::verilator_args(p).c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtl_params: %s\n", e.what());
    return 1;
  }
  return 0;
}
