// A ray slot's traversal stack (timing_model.h): a short stack in the slot, and what happens to the entries
// beyond it (spilled to memory, or dropped and found again by a restart along a trail, restart_trail.h), and the
// order the ray takes its entries in (one stack, or two for treelet-first order).
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

// The order a ray takes its stacked entries in (the traversal key; hwmodel/datapath/traverse.h).
enum class TraversalOrder : uint8_t {
  kDepthFirst,    // one stack, nearest child first
  kTreeletFirst,  // two stacks: the ray finishes its treelet before it leaves it (Chou et al., MICRO 2023)
};
inline std::span<const TimingChoice> choices(TraversalOrder) {
  static constexpr TimingChoice list[] = {
      {"depth_first", "one stack, nearest child first"},
      {"treelet_first",
       "two stacks, one for the ray's treelet and one for other treelets: a ray finishes its treelet before it "
       "leaves it (Chou et al., MICRO 2023; needs treelet_bytes > 0). Each stack is stack_entries deep. Of two "
       "primitives hit at the same t it may report the other"},
  };
  return list;
}

// The order a node's accepted children are taken in (the child_order key).
enum class ChildOrder : uint8_t {
  kNearest,  // sorted by entry distance, nearest first
  kSlot,     // in the node's slot order (Vulkan-Sim's traversal)
};
inline std::span<const TimingChoice> choices(ChildOrder) {
  static constexpr TimingChoice list[] = {
      {"nearest", "a node's accepted children sorted by entry distance, nearest first"},
      {"slot",
       "a node's accepted children in slot order, unsorted, as Vulkan-Sim's traversal loop takes them; may report "
       "the other of two primitives hit at the same t"},
  };
  return list;
}

struct StackConfig {
  int stack_entries = 8;  // short stack per slot; deeper entries spill to memory (8 bytes each)
  StackMode stack_mode = StackMode::kSpill;
  TraversalOrder traversal = TraversalOrder::kDepthFirst;
  ChildOrder child_order = ChildOrder::kNearest;
};

struct StackCounters {
  uint64_t stack_spills = 0, stack_refills = 0;
  uint64_t restarts = 0, restart_nodes = 0;  // stack_mode restart: restarts from the root, nodes re-visited
};

const TimingKeyTable& stack_keys();
std::span<const TimingCounter> stack_counters();

}  // namespace rtu::hw
