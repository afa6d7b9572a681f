#include "host/cost/area_tables.h"

#include <cmath>
#include <sstream>
#include <vector>

#include "host/io/csv.h"
#include "host/io/error.h"
#include "host/io/limits.h"

namespace rtu::host {

AreaTable AreaTable::load(const std::string& path) {
  // The text and the table's strings, about as large again.
  return parse(read_file_limited(path, 2), path);
}

AreaTable AreaTable::shipped() {
  return parse(shipped_area_csv(), std::string(kShippedAreaTable) + " (compiled in)");
}

AreaTable AreaTable::parse(const std::string& text, const std::string& name) {
  AreaTable t;
  std::istringstream in(text);
  std::string line;
  size_t n = 0;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty()) continue;
    const std::vector<std::string> f = split_csv(line);
    const std::string where = name + ":" + std::to_string(n);
    if (header.empty()) {
      header = f;
      if (header.size() < 4 || header[0] != "params" || header[1] != "cells" || header[3] != "transistors")
        throw Error(where + ": expected the header params,cells,flip_flops,transistors");
      continue;
    }
    if (f.size() != header.size())
      throw Error(where + ": " + std::to_string(f.size()) + " fields, expected " + std::to_string(header.size()));
    t.by_params[f[0]] = Entry{parse_csv_int<int64_t>(f[1], where), parse_csv_int<int64_t>(f[3], where)};
  }
  return t;
}

ActivityTable ActivityTable::parse(const std::string& text, const std::string& name) {
  ActivityTable t;
  std::istringstream in(text);
  std::string line;
  size_t n = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty()) continue;
    const std::vector<std::string> f = split_csv(line);
    const std::string where = name + ":" + std::to_string(n);
    if (!header) {
      if (line != "params,unit,tests,signal_bits,toggles_per_test")
        throw Error(where + ": expected the header params,unit,tests,signal_bits,toggles_per_test");
      header = true;
      continue;
    }
    if (f.size() != 5) throw Error(where + ": " + std::to_string(f.size()) + " fields, expected 5");
    Entry e{f[1], parse_csv_int<uint64_t>(f[2], where), parse_csv_double(f[3], where),
            parse_csv_double(f[4], where)};
    if (!(e.signal_bits > 0) || !(e.toggles_per_test >= 0) || !std::isfinite(e.toggles_per_test) || e.tests == 0)
      throw Error(where + ": signal_bits and tests must be positive, toggles_per_test finite and >= 0");
    t.by_params[f[0]] = e;
  }
  return t;
}

ActivityTable ActivityTable::shipped() {
  return parse(shipped_activity_csv(), std::string(kShippedActivityTable) + " (compiled in)");
}

}  // namespace rtu::host
