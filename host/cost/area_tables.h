// The RTL units' synthesis and switching-activity tables by their Verilator parameters: what the area and energy
// estimate (cost_model.h) and the sweep's area figures (host/jobs/sweep.h) look a unit up in.
#pragma once

#include <cstdint>
#include <map>
#include <string>

namespace rtu::host {

// Synthesis results of the RTL box unit by its Verilator parameters (rtl_sim/params/rtl_params.h verilator_args),
// read from a CSV with the columns params,cells,flip_flops,transistors (bench/rtl_area.sh with RTL_AREA_CSV
// writes it).
struct AreaTable {
  struct Entry {
    int64_t cells = -1, transistors = -1;
  };
  std::map<std::string, Entry> by_params;
  static AreaTable load(const std::string& path);  // throws Error for a malformed file
  // The CSV's text; `name` is what errors call it. Throws Error for a malformed table.
  static AreaTable parse(const std::string& text, const std::string& name);
  // The table the project ships, bench/data/rtl_area.csv, compiled into the library (host/CMakeLists.txt), so
  // that it is there wherever rtusim runs.
  static AreaTable shipped();
};
inline constexpr const char* kShippedAreaTable = "bench/data/rtl_area.csv";
// The text of the shipped table (generated from kShippedAreaTable at configure time).
const char* shipped_area_csv();

// Switching activity of the RTL units by their Verilator parameters, measured in Verilator on tests captured from
// real traversals (bench/rtl_activity.sh writes it): the CSV columns params,unit,tests,signal_bits,
// toggles_per_test (bit transitions of the RTL's signals per test).
struct ActivityTable {
  struct Entry {
    std::string unit;
    uint64_t tests = 0;
    double signal_bits = 0.0, toggles_per_test = 0.0;
  };
  std::map<std::string, Entry> by_params;
  static ActivityTable parse(const std::string& text, const std::string& name);  // throws Error when malformed
  static ActivityTable shipped();  // bench/data/rtl_activity.csv, compiled in (empty when the file is absent)
};
inline constexpr const char* kShippedActivityTable = "bench/data/rtl_activity.csv";
const char* shipped_activity_csv();

}  // namespace rtu::host
