// Treelets (Aila and Karras, "Architecture considerations for tracing incoherent rays", HPG 2010; Chou, Nowicki
// and Aamodt, "Treelet Prefetching for Ray Tracing", MICRO 2023): the BVH cut into connected pieces of at most a
// byte budget, each piece's nodes placed contiguously, so that entering a piece's root can prefetch the piece.
//
// Formation here is greedy and breadth-first: the root's piece takes nodes in breadth-first order below it while
// they fit the budget (at least the root); every inner child left out roots a piece of its own, formed in the
// order they were left out. Chou et al.'s code forms treelets the same way (breadth-first from each root, a node
// that does not fit closing the treelet and every node then pending rooting one of its own); its budget counts
// the leaves' primitive bytes as well, as their leaves are nodes of the tree, where here the records lie in a
// section of their own and the budget is of nodes. A simple rule: another formation (by the children most likely
// to be visited, say) replaces this function. The pieces are placed in formation order, so the root's piece comes
// first, as the image's node 0 does.
//
// A timing layout (treelet_bytes > 0, TimingModel::Layout::treelets) places node i at node_offset + position[i]
// * stride instead of i * stride: the hits and the image stay as they are, only where the unit fetches changes.
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/format/device_image.h"

namespace rtu::hw {

struct Treelets {
  std::vector<uint32_t> position;  // node index -> its place in the treelet layout
  std::vector<uint32_t> size;      // node index -> nodes of the treelet it roots (0: not a treelet root)
  std::vector<uint32_t> id;        // node index -> its treelet, numbered in formation order (treelet-first order)
  uint32_t count = 0;              // treelets
};

// The treelets of `image`'s tree with at most `budget_bytes` of nodes each (`node_stride` bytes per node, at
// least one node). Empty for an image without nodes.
Treelets form_treelets(const DeviceImage& image, uint64_t budget_bytes, uint64_t node_stride);

}  // namespace rtu::hw
