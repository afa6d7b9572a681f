// A ray slot's traversal stack (timing_model.h): a short stack in the slot, and what happens to the entries
// beyond it (spilled to memory, or dropped and found again by a restart along a trail, restart_trail.h).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

struct StackConfig {
  int stack_entries = 8;  // short stack per slot; deeper entries spill to memory (8 bytes each)
  // What happens to entries beyond the short stack: "spill" (to memory, read back when popped) or "restart" (the
  // oldest is dropped; popping a dropped entry restarts from the root along a trail, restart_trail.h).
  std::string stack_mode = "spill";
};

struct StackCounters {
  uint64_t stack_spills = 0, stack_refills = 0;
  uint64_t restarts = 0, restart_nodes = 0;  // stack_mode restart: restarts from the root, nodes re-visited
};

const TimingKeyTable& stack_keys();
std::span<const TimingCounter> stack_counters();

}  // namespace rtu::hw
