// A short stack with a restart trail, as the fixed tracer's recorder sees it (FixedTraceOptions::record_restart).
//
// The unit keeps the last K entries a ray pushed (stack_entries) and drops the oldest instead of spilling it to
// memory. Beside it, a trail of one counter per tree level says how many of that level's children, nearest first,
// the ray has taken (Laine, "Restart Trail for Stackless BVH Traversal", HPG 2010: one bit per level for binary
// trees; Vaidyanathan, Woop, Benthin, "Wide BVH Traversal with a Short Stack", HPG 2019: the counters and the
// short stack for wide trees). When the ray pops an entry the short stack no longer holds, the unit restarts from
// the root: it fetches and tests again every node on the path from the root to that entry's parent, following the
// trail to the child it took at each level, and there finds the entry. While it descends it pushes the
// untaken siblings it meets again, so the short stack then holds the K entries nearest to the top of the full
// stack.
//
// The traversal itself is the full-stack loop of traverse.h; this recorder only adds what the restarts cost, so
// the hits are those of the full stack, bit for bit. That holds for the unit because the restart descends with
// the ray's original interval (not the closest hit so far): the children of a node then come in the same order,
// and the trail's counters name the same children. The entries the full stack pops are exactly the ones the unit
// finds (a full stack's entries at level L + 1 are untaken children of the path's node at level L).
//
// What it records: at a pop of a dropped entry at level L (the root is level 0, its children level 1), a kRestart
// event (index L, count min(L, 255)) and then the kNode events of the L nodes re-visited, as the first visits
// recorded them (with a co-simulated box unit, its clocks too). Pops of held entries and all pushes record
// nothing: there is no spill traffic.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

class RestartTrail {
 public:
  explicit RestartTrail(int short_stack) : m_k(std::max(short_stack, 0)) {}

  // The node event just recorded for a visit of an inner node at the current level; `accepted` children follow.
  void expanded(const TraceEvent& node_event, int accepted) {
    if (m_level < kMaxLevels) m_path[m_level] = node_event;
    if (accepted > 0) ++m_level;  // the traversal descends to the nearest accepted child
  }
  // n entries pushed, all children of the node just expanded (so at the current level).
  void pushed(int n) {
    for (int j = 0; j < n && m_depth < kMaxLevels; ++j) m_entry_level[m_depth++] = uint16_t(m_level);
    m_held_lo = std::max(m_held_lo, m_depth - m_k);
  }
  // One entry popped (taken, or skipped as farther than the closest hit). A dropped entry is a restart.
  void popped(std::vector<TraceEvent>& rec) {
    if (m_depth == 0) return;
    const int level = m_entry_level[--m_depth];
    if (m_depth < m_held_lo) {
      rec.push_back(TraceEvent{TraceEvent::kRestart, uint8_t(std::min(level, 255)), 0, 0, uint32_t(level)});
      for (int j = 0; j < level && j < kMaxLevels; ++j) rec.push_back(m_path[j]);
      m_held_lo = std::max(0, m_depth - m_k);  // the descent pushed the untaken siblings again
    }
    m_level = level;
  }

 private:
  // Levels and stack entries of any image DeviceImage::from_bytes accepts fit (its depth check); beyond them the
  // recorder stops tracking rather than write out of bounds.
  static constexpr int kMaxLevels = kTraversalStackSize;
  int m_k;
  int m_level = 0, m_depth = 0, m_held_lo = 0;
  uint16_t m_entry_level[kMaxLevels];
  TraceEvent m_path[kMaxLevels];
};

}  // namespace rtu::hw
