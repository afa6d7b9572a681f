// The traversal loop shared by every datapath (float and fixed point): a stack of child references with
// their entry distances, nearest child first, entries farther than the closest hit skipped, early exit for
// any-hit. The datapath is a Policy:
//   using Dist = ...;                                   // entry-distance type (float, or a fixed-point t)
//   static constexpr int kWidth;                        // children per node
//   int expand(uint32_t node, uint32_t refs[kWidth], Dist dists[kWidth], int& tested);
//       // tests the occupied children of an inner node; writes the accepted ones; returns how many
//   bool leaf(uint32_t ref);                            // tests a leaf's primitives; true if the closest changed
//   Dist limit() const;                                 // the current end of the ray interval (closest hit)
//   void pushed(const uint32_t* refs, int n); void popped(); // stack traffic, for the timing model's recorder
#pragma once

#include <cstdint>

#include "hwmodel/datapath/stats.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

template <class Policy>
void traverse(Policy& p, uint32_t root, bool any_hit, TraversalStats& s) {
  using Dist = typename Policy::Dist;
  constexpr int N = Policy::kWidth;
  struct Entry {
    uint32_t ref;
    Dist dist;
  };
  Entry stack[kTraversalStackSize];
  int sp = 0;
  uint32_t cur = root;
  for (;;) {
    if (is_leaf(cur)) {
      ++s.leaves_visited;
      if (p.leaf(cur) && any_hit) return;
    } else {
      ++s.nodes_visited;
      uint32_t refs[N];
      Dist dists[N];
      int tested = 0;
      const int k = p.expand(cur, refs, dists, tested);
      s.box_tests += uint64_t(tested);
      if (k > 0) {
        // Insertion sort by distance, nearest first; ties keep slot order (deterministic).
        for (int i = 1; i < k; ++i) {
          for (int j = i; j > 0 && dists[j] < dists[j - 1]; --j) {
            std::swap(dists[j], dists[j - 1]);
            std::swap(refs[j], refs[j - 1]);
          }
        }
        for (int i = k - 1; i > 0; --i) stack[sp++] = Entry{refs[i], dists[i]};
        if (k > 1) p.pushed(&refs[1], k - 1);  // refs[1] is popped first
        cur = refs[0];
        continue;
      }
    }
    // Pop the next entry that can still hold a closer hit.
    for (;;) {
      if (sp == 0) return;
      const Entry e = stack[--sp];
      p.popped();
      if (!(p.limit() < e.dist)) {
        cur = e.ref;
        break;
      }
    }
  }
}

}  // namespace rtu::hw
