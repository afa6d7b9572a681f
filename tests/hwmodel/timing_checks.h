// Shared by the timing tests: two runs that must agree cycle for cycle agree in every timing statistic, each
// checked on its own so that a failure names the counter (the counters are those of the table in timing_stats.h).
#pragma once

#include <catch2/catch.hpp>

#include "hwmodel/timing/timing_stats.h"

inline void check_same_timing(const rtu::hw::TimingStats& a, const rtu::hw::TimingStats& b) {
  for (const rtu::hw::TimingCounter& c : rtu::hw::timing_counters()) {
    CAPTURE(c.name);
    CHECK(a.*c.member == b.*c.member);
  }
}
