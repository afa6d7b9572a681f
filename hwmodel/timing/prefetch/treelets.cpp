#include "hwmodel/timing/prefetch/treelets.h"

#include <deque>

#include "hwmodel/format/node_kinds.h"

namespace rtu::hw {

Treelets form_treelets(const DeviceImage& image, uint64_t budget_bytes, uint64_t node_stride) {
  const ImageHeader& h = image.header();
  Treelets t;
  if ((h.flags & kImageNoBvh) || h.node_count == 0 || is_leaf(h.root_ref) || h.root_ref == kEmptyChild) return t;
  const uint64_t per_treelet = std::max<uint64_t>(1, budget_bytes / std::max<uint64_t>(1, node_stride));
  t.position.assign(h.node_count, 0);
  t.size.assign(h.node_count, 0);
  t.id.assign(h.node_count, 0);
  with_node_kind(node_kind(h), h.width, h.q_bytes, [&](auto kind) {
    using K = decltype(kind);
    const typename K::Node* nodes = image.nodes<typename K::Node>();
    std::deque<uint32_t> roots{h.root_ref};
    uint32_t next = 0;
    while (!roots.empty()) {
      const uint32_t root = roots.front();
      roots.pop_front();
      ++t.count;
      std::deque<uint32_t> frontier{root};
      uint32_t taken = 0;
      while (!frontier.empty()) {
        const uint32_t n = frontier.front();
        frontier.pop_front();
        if (taken == per_treelet) {  // full: n roots a later treelet
          roots.push_back(n);
          continue;
        }
        t.position[n] = next++;
        t.id[n] = t.count - 1;
        ++taken;
        const typename K::Node& nd = nodes[n];
        for (int i = 0; i < K::count(nd); ++i)
          if (!is_leaf(K::child(nd, i)) && K::child(nd, i) < h.node_count)  // not a cluster's node
            frontier.push_back(K::child(nd, i));
      }
      t.size[root] = taken;
    }
  });
  return t;
}

}  // namespace rtu::hw
