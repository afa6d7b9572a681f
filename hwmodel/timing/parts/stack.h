// A ray slot's traversal stack (timing_model.h): a short stack in the slot, and what happens to the entries
// beyond it (spilled to memory, or dropped and found again by a restart along a trail, restart_trail.h).
#pragma once

#include <cstdint>
#include <span>

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

// What happens to entries beyond the short stack (the stack_mode key).
enum class StackMode : uint8_t {
  kSpill,    // to memory, read back when popped
  kRestart,  // the oldest is dropped; popping a dropped entry restarts from the root along a trail
};
inline std::span<const TimingChoice> choices(StackMode) {
  static constexpr TimingChoice list[] = {
      {"spill", "entries beyond the short stack go to memory and are read back at their pop"},
      {"restart", "the oldest entry is dropped; its pop restarts from the root along a trail (restart_trail.h)"},
  };
  return list;
}

struct StackConfig {
  int stack_entries = 8;  // short stack per slot; deeper entries spill to memory (8 bytes each)
  StackMode stack_mode = StackMode::kSpill;
};

struct StackCounters {
  uint64_t stack_spills = 0, stack_refills = 0;
  uint64_t restarts = 0, restart_nodes = 0;  // stack_mode restart: restarts from the root, nodes re-visited
};

const TimingKeyTable& stack_keys();
std::span<const TimingCounter> stack_counters();

}  // namespace rtu::hw
