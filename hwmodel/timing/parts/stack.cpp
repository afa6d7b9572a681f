#include "hwmodel/timing/parts/stack.h"

#include <array>
#include <string>

#include "hwmodel/timing/prefetch/prefetchers.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

const TimingKeyTable& stack_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"stack_entries", &C::stack_entries, 1, 64, "short stack per slot; deeper entries spill (8 bytes each)"},
      {"stack_mode", choice_field<&C::stack_mode>(), 0, 0,
       "entries beyond the short stack: spilled to memory and read back at their pop, or the oldest dropped and "
       "its pop a restart from the root along a trail that re-fetches the nodes above it"},
      {"traversal", choice_field<&C::traversal>(), 0, 0,
       "the order of the stacked entries: depth_first (one stack, nearest child first) or treelet_first (two "
       "stacks: a ray finishes its treelet, treelet_bytes > 0, before it leaves it; each stack stack_entries "
       "deep; may report the other of two primitives hit at the same t)",
       [](const C& c) -> std::string {
         if (c.traversal != TraversalOrder::kTreeletFirst) return {};
         if (c.stack_mode == StackMode::kRestart)
           return "traversal treelet_first keeps two stacks; stack_mode restart's trail is of one";
         if (prefetcher_wants_stack_refs(c))
           return std::string("traversal treelet_first keeps two stacks; prefetcher ") +
                  prefetcher_info(c.prefetcher).name + " watches one";
         return {};
       }},
      {"child_order", choice_field<&C::child_order>(), 0, 0,
       "a node's accepted children: nearest (sorted by entry distance) or slot (unsorted, Vulkan-Sim's order; may "
       "report the other of two primitives hit at the same t)"},
  };
  return keys;
}

std::span<const TimingCounter> stack_counters() {
  using S = TimingStats;
  static constexpr std::array<TimingCounter, 4> counters = {{
      {"stack_spills", &S::stack_spills, "entries", "stack entries beyond the short stack written to memory",
       kPerRay},
      {"stack_refills", &S::stack_refills, "entries", "spilled stack entries read back", kPerRay},
      {"restarts", &S::restarts, "restarts",
       "stack_mode restart: pops of a dropped entry, each a restart from the root along the trail", kPerRay},
      {"restart_nodes", &S::restart_nodes, "nodes",
       "stack_mode restart: nodes fetched and tested again by restarts (in node_fetches and box_tests too)",
       kPerRay},
  }};
  return counter_table<StackCounters>(counters);
}

}  // namespace rtu::hw
