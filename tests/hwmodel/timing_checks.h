// Shared by the timing tests: two runs that must agree cycle for cycle agree in every timing statistic, each
// checked on its own so that a failure names the field.
#pragma once

#include <catch2/catch.hpp>

#include "hwmodel/timed_engine.h"

inline void check_same_timing(const rtu::hw::TimingStats& a, const rtu::hw::TimingStats& b) {
  CHECK(a.packets == b.packets);
  CHECK(a.cycles == b.cycles);
  CHECK(a.rays == b.rays);
  CHECK(a.box_tests == b.box_tests);
  CHECK(a.tri_tests == b.tri_tests);
  CHECK(a.sphere_tests == b.sphere_tests);
  CHECK(a.plane_tests == b.plane_tests);
  CHECK(a.box_issue_cycles == b.box_issue_cycles);
  CHECK(a.tri_issue_cycles == b.tri_issue_cycles);
  CHECK(a.node_fetches == b.node_fetches);
  CHECK(a.prim_fetches == b.prim_fetches);
  CHECK(a.cache_hits == b.cache_hits);
  CHECK(a.cache_misses == b.cache_misses);
  CHECK(a.dram_bytes == b.dram_bytes);
  CHECK(a.dram_busy_cycles == b.dram_busy_cycles);
  CHECK(a.stream_bytes == b.stream_bytes);
  CHECK(a.stack_spills == b.stack_spills);
  CHECK(a.stack_refills == b.stack_refills);
  CHECK(a.queue_stall_cycles == b.queue_stall_cycles);
  CHECK(a.slot_busy_cycles == b.slot_busy_cycles);
}
