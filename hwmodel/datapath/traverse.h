// The traversal loop shared by every datapath (float and fixed point): a stack of child references with
// their entry distances, nearest child first, entries farther than the closest hit skipped, early exit for
// any-hit. The datapath is a Policy:
//   using Dist = ...;                                   // entry-distance type (float, or a fixed-point t)
//   static constexpr int kWidth;                        // children per node
//   int expand(uint32_t node, uint32_t refs[kWidth], Dist dists[kWidth], int& tested);
//       // tests the occupied children of an inner node; writes the accepted ones; returns how many
//   bool leaf(uint32_t ref);                            // tests a leaf's primitives; true if the closest changed
//   Dist limit() const;                                 // the current end of the ray interval (closest hit)
//   void pushed(const uint32_t* refs, int n, int stack); void popped(int stack);
//       // stack traffic, for the timing model's recorder (stack 0; treelet-first order also 1)
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>

#include "hwmodel/datapath/stats.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

// A node's visit: its accepted children in refs and dists (k of them, returned), nearest first unless
// nearest_first is false (then in slot order); insertion sort, ties keep slot order (deterministic).
template <class Policy>
int expand_ordered(Policy& p, uint32_t node, uint32_t* refs, typename Policy::Dist* dists, TraversalStats& s,
                   bool nearest_first) {
  ++s.nodes_visited;
  int tested = 0;
  const int k = p.expand(node, refs, dists, tested);
  s.box_tests += uint64_t(tested);
  for (int i = 1; i < k && nearest_first; ++i) {
    for (int j = i; j > 0 && dists[j] < dists[j - 1]; --j) {
      std::swap(dists[j], dists[j - 1]);
      std::swap(refs[j], refs[j - 1]);
    }
  }
  return k;
}

// nearest_first false: a node's accepted children are taken in slot order, not sorted by entry distance (the
// order of Vulkan-Sim's traversal loop, which the papers measured against); ties aside, the same hits.
template <class Policy>
void traverse(Policy& p, uint32_t root, bool any_hit, TraversalStats& s, bool nearest_first = true) {
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
      uint32_t refs[N];
      Dist dists[N];
      const int k = expand_ordered(p, cur, refs, dists, s, nearest_first);
      if (k > 0) {
        for (int i = k - 1; i > 0; --i) stack[sp++] = Entry{refs[i], dists[i]};
        if (k > 1) p.pushed(&refs[1], k - 1, 0);  // refs[1] is popped first
        cur = refs[0];
        continue;
      }
    }
    // Pop the next entry that can still hold a closer hit.
    for (;;) {
      if (sp == 0) return;
      const Entry e = stack[--sp];
      p.popped(0);
      if (!(p.limit() < e.dist)) {
        cur = e.ref;
        break;
      }
    }
  }
}

// Which treelet (prefetch/treelets.h) each node is in, for treelet-first order: of[i] for node i < count.
// References to nodes at or beyond count (a cluster's nodes) and leaves go with the node that references them.
struct TreeletMap {
  const uint32_t* of = nullptr;
  uint32_t count = 0;
};

// Treelet-first order (Chou, Nowicki and Aamodt, "Treelet Prefetching for Ray Tracing", MICRO 2023, as the
// authors' Vulkan-Sim code runs it): two stacks, stack 0 for entries in the treelet the ray is in and stack 1
// for entries in other treelets. The ray takes entries from stack 0 while it has any; then the top of stack 1,
// whose treelet it is in from then on. So a ray finishes a treelet before it leaves it, and a prefetched treelet
// is used while it is in the cache. Within a treelet the order is traverse()'s: nearest child first, the
// nearest child in the treelet taken without a push, entries farther than the closest hit skipped at their
// pop (nearest_first false: slot order, as traverse()). The same nodes can be visited in another order, so of two
// primitives hit at the same t the other may be reported (a tie; any other hit is the same, as every entry is
// still tested against the closest hit).
template <class Policy>
void traverse_treelet_first(Policy& p, uint32_t root, bool any_hit, TraversalStats& s, TreeletMap map,
                            bool nearest_first = true) {
  using Dist = typename Policy::Dist;
  constexpr int N = Policy::kWidth;
  struct Entry {
    uint32_t ref;
    Dist dist;
  };
  // Every entry is on one of the two stacks, so together they hold what traverse()'s one stack would.
  Entry stack[2][kTraversalStackSize];
  int sp[2] = {0, 0};
  const auto treelet = [&](uint32_t ref, uint32_t current) {
    return is_leaf(ref) || ref >= map.count ? current : map.of[ref];
  };
  uint32_t cur = root;
  uint32_t current = treelet(root, 0);
  for (;;) {
    if (is_leaf(cur)) {
      ++s.leaves_visited;
      if (p.leaf(cur) && any_hit) return;
    } else {
      uint32_t refs[N];
      Dist dists[N];
      const int k = expand_ordered(p, cur, refs, dists, s, nearest_first);
      if (k > 0) {
        int next = -1;  // the nearest child in the current treelet, taken without a push
        for (int i = 0; i < k && next < 0; ++i)
          if (treelet(refs[i], current) == current) next = i;
        uint32_t pushed[2][N];
        int n[2] = {0, 0};
        for (int i = k - 1; i >= 0; --i) {
          if (i == next) continue;
          const int b = treelet(refs[i], current) == current ? 0 : 1;
          stack[b][sp[b]++] = Entry{refs[i], dists[i]};
          pushed[b][n[b]++] = refs[i];
        }
        for (int b = 0; b < 2; ++b) {
          if (n[b] == 0) continue;
          std::reverse(pushed[b], pushed[b] + n[b]);  // nearest first: popped first
          p.pushed(pushed[b], n[b], b);
        }
        if (next >= 0) {
          cur = refs[next];
          continue;
        }
      }
    }
    for (;;) {
      const int b = sp[0] > 0 ? 0 : 1;
      if (sp[b] == 0) return;
      const Entry e = stack[b][--sp[b]];
      p.popped(b);
      if (!(p.limit() < e.dist)) {
        cur = e.ref;
        if (b == 1) current = treelet(e.ref, current);
        break;
      }
    }
  }
}

}  // namespace rtu::hw
