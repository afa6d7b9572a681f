// The tree of a packed layout (packed_layout.h, cluster_layout.h), as the encoder writes it: the nodes numbered
// breadth first with each node's inner children consecutive and its leaf groups stored consecutively, the
// subtrees that become triangle clusters (prim_layout 2), and what a bound image must decode the sections to.
// Function templates over the node kind, so a header; only the encoder includes it (device_image_encode.cpp).
#pragma once

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "hwmodel/format/cluster_layout.h"
#include "hwmodel/format/hw_format.h"
#include "hwmodel/format/node_kind.h"
#include "hwmodel/format/packed_layout.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

// A tree in a packed layout: the node and primitive sections, and what the image must decode them to.
struct PackedTree {
  std::vector<uint8_t> nodes, prims;
  std::vector<uint8_t> qnodes, records;  // the expected decoding: QNodes, 40-byte records, in the new order
  uint32_t root = kEmptyChild, node_count = 0;
  uint64_t node_bytes = 0;
  int base_bits = 0, prim_bits = 0, group_bits = 0;
};

// The cluster of the subtree at inner node `root` (cluster_layout.h): its nodes breadth first with their leaf
// groups, its records in leaf order; and, when `decoded` is not null, the nodes as the image decodes them, with
// references from node `node_base` and record `record_base`.
template <NodeKind K>
void gather_cluster(const std::vector<typename K::Node>& nodes, const std::vector<uint8_t>& records, uint32_t root,
                    Cluster& c, std::vector<typename K::Node>* decoded, uint32_t node_base, uint32_t record_base) {
  std::vector<uint32_t> order{root};
  uint32_t next_node = 1, next_record = 0;
  for (size_t k = 0; k < order.size(); ++k) {
    typename K::Node n = nodes[order[k]];
    PackedNode pn;
    K::to_packed(n, pn);
    for (int i = 0; i < K::count(n); ++i) {
      const uint32_t ref = K::child(n, i);
      if (is_leaf(ref)) {
        const uint8_t* rec = records.data() + size_t(leaf_first(ref)) * kRecordBytes;
        c.records.insert(c.records.end(), rec, rec + size_t(leaf_count(ref)) * kRecordBytes);
        pn.leaf[i] = true;
        pn.group[i] = leaf_count(ref);
        K::set_child(n, i, make_leaf(record_base + next_record, leaf_count(ref)));
        next_record += leaf_count(ref);
      } else {
        order.push_back(ref);
        K::set_child(n, i, node_base + next_node++);
      }
    }
    c.nodes.push_back(pn);
    if (decoded) decoded->push_back(n);
  }
}

// Triangle clusters (prim_layout 2): the inner nodes below the root that root a cluster, each with its encoded
// bytes. Top down, a subtree becomes a cluster when it holds only opaque triangles, at most cluster_tris of them
// and at most kMaxClusterNodes nodes, and its cluster fits the format (kMaxClusterLines); else its children are
// tried. The root stays a node of the top tree.
template <NodeKind K>
std::vector<std::vector<uint8_t>> choose_clusters(const FixedFormat& f, const std::vector<typename K::Node>& nodes,
                                                  const std::vector<uint8_t>& records, uint32_t root) {
  std::vector<std::vector<uint8_t>> bytes(nodes.size());
  if (root == kEmptyChild || is_leaf(root)) return bytes;
  // Below each node: triangles, nodes, and whether all are opaque triangles. Children follow their parents.
  std::vector<uint32_t> tris(nodes.size(), 0), inner(nodes.size(), 1);
  std::vector<uint8_t> ok(nodes.size(), 1);
  for (size_t n = nodes.size(); n-- > 0;) {
    for (int i = 0; i < K::count(nodes[n]); ++i) {
      const uint32_t ref = K::child(nodes[n], i);
      if (is_leaf(ref)) {
        tris[n] += leaf_count(ref);
        ok[n] &= uint8_t(clusterable(records.data() + size_t(leaf_first(ref)) * kRecordBytes, leaf_count(ref)));
      } else {
        if (ref <= n) throw std::logic_error("encoder: a child node before its parent");
        tris[n] += tris[ref];
        inner[n] += inner[ref];
        ok[n] &= ok[ref];
      }
    }
  }
  std::vector<uint32_t> todo;
  auto children = [&](uint32_t n) {
    for (int i = 0; i < K::count(nodes[n]); ++i)
      if (!is_leaf(K::child(nodes[n], i))) todo.push_back(K::child(nodes[n], i));
  };
  children(root);
  while (!todo.empty()) {
    const uint32_t n = todo.back();
    todo.pop_back();
    if (ok[n] && tris[n] <= uint32_t(f.cluster_tris) && inner[n] <= uint32_t(kMaxClusterNodes)) {
      Cluster c;
      gather_cluster<K>(nodes, records, n, c, nullptr, 0, 0);
      if (encode_cluster(c, f, bytes[n]) > 0) continue;
    }
    children(n);
  }
  return bytes;
}

// Numbers nodes breadth first, each node's inner children consecutive, and stores each node's leaf groups
// consecutively (packed_layout.h): the nodes' values are unchanged, their references follow the new order. With
// clusters (prim_layout 2) a cluster's subtree is a leaf group of the top tree: its nodes are decoded after the
// top tree's, cluster by cluster in the order of the primitive section.
template <NodeKind K>
PackedTree pack_tree(const FixedFormat& f, const std::vector<typename K::Node>& nodes,
                     const std::vector<uint8_t>& records, uint32_t root) {
  PackedTree p;
  const bool blocks = f.prim_layout_id() == PrimLayout::kBlocks,
             clusters = f.prim_layout_id() == PrimLayout::kClusters;
  std::vector<std::vector<uint8_t>> cluster_bytes;  // clusters: a cluster root's encoded cluster, else empty
  if (clusters) cluster_bytes = choose_clusters<K>(f, nodes, records, root);
  auto cluster_root = [&](uint32_t ref) { return clusters && !is_leaf(ref) && !cluster_bytes[ref].empty(); };
  std::vector<uint32_t> order;  // new index -> old
  if (root != kEmptyChild && !is_leaf(root)) order.push_back(root);
  for (size_t k = 0; k < order.size(); ++k) {
    const typename K::Node& n = nodes[order[k]];
    for (int i = 0; i < K::count(n); ++i)
      if (!is_leaf(K::child(n, i)) && !cluster_root(K::child(n, i))) order.push_back(K::child(n, i));
  }
  uint64_t units = 0;  // primitive section so far: records, or granules of blocks, or lines of clusters
  uint32_t next_record = 0;
  std::vector<typename K::Node> cluster_nodes;  // clusters: their nodes as decoded, after the top tree's
  // Appends the cluster rooted at inner node `ref`; returns its size in lines and its decoded reference.
  auto cluster = [&](uint32_t ref, uint32_t& size) {
    Cluster c;
    const uint32_t at = uint32_t(order.size() + cluster_nodes.size());
    gather_cluster<K>(nodes, records, ref, c, &cluster_nodes, at, next_record);
    p.prims.insert(p.prims.end(), cluster_bytes[ref].begin(), cluster_bytes[ref].end());
    p.records.insert(p.records.end(), c.records.begin(), c.records.end());
    size = uint32_t(cluster_bytes[ref].size() / kClusterLineBytes);
    units += size;
    next_record += uint32_t(c.records.size() / kRecordBytes);
    return at;
  };
  // Appends leaf `ref`'s group; returns its size in units and the leaf's reference in the new record order.
  auto group = [&](uint32_t ref, uint32_t& size) {
    const uint8_t* rec = records.data() + size_t(leaf_first(ref)) * kRecordBytes;
    const uint32_t count = leaf_count(ref);
    if (clusters && clusterable(rec, count)) {
      Cluster c;
      c.records.assign(rec, rec + size_t(count) * kRecordBytes);
      size = encode_cluster(c, f, p.prims);
      if (size == 0) throw std::logic_error("encoder: a leaf that fits no cluster");
    } else if (clusters) {
      size = encode_raw_unit(rec, int(count), f, p.prims);
    } else if (blocks) {
      size = encode_block(rec, int(count), f.coord_bits, p.prims);
    } else {
      p.prims.insert(p.prims.end(), rec, rec + size_t(count) * kRecordBytes);
      size = count;
    }
    p.records.insert(p.records.end(), rec, rec + size_t(count) * kRecordBytes);
    units += size;
    const uint32_t r = make_leaf(next_record, count);
    next_record += count;
    return r;
  };
  std::vector<PackedNode> packed(order.size());
  uint64_t max_base = 0, max_prim = 0, max_group = 0;
  uint32_t next_node = 1;
  for (size_t k = 0; k < order.size(); ++k) {
    typename K::Node n = nodes[order[k]];
    PackedNode& pn = packed[k];
    K::to_packed(n, pn);
    pn.node_base = next_node;
    pn.prim_base = units;
    bool any_inner = false, any_leaf = false;
    for (int i = 0; i < K::count(n); ++i) {
      const uint32_t ref = K::child(n, i);
      if (is_leaf(ref) || cluster_root(ref)) {
        pn.leaf[i] = true;
        K::set_child(n, i, is_leaf(ref) ? group(ref, pn.group[i]) : cluster(ref, pn.group[i]));
        max_group = std::max<uint64_t>(max_group, pn.group[i] - 1);
        any_leaf = true;
      } else {
        K::set_child(n, i, next_node++);
        any_inner = true;
      }
    }
    if (!any_inner) pn.node_base = 0;  // unused: zero, so it costs no base bits
    if (!any_leaf) pn.prim_base = 0;
    max_base = std::max(max_base, pn.node_base);
    max_prim = std::max(max_prim, pn.prim_base);
    const auto* b = reinterpret_cast<const uint8_t*>(&n);
    p.qnodes.insert(p.qnodes.end(), b, b + sizeof n);
  }
  if (root != kEmptyChild && is_leaf(root)) {
    uint32_t size = 0;
    p.root = group(root, size);
  } else {
    p.root = order.empty() ? kEmptyChild : 0;
  }
  for (const typename K::Node& n : cluster_nodes) {
    const auto* b = reinterpret_cast<const uint8_t*>(&n);
    p.qnodes.insert(p.qnodes.end(), b, b + sizeof n);
  }
  if (next_record * kRecordBytes != records.size())
    throw std::logic_error("encoder: packed layout did not place every record once");
  p.base_bits = bits_for(max_base);
  p.prim_bits = bits_for(max_prim);
  p.group_bits = bits_for(max_group);
  const NodeFields fields = node_fields(f, p.base_bits, p.prim_bits, p.group_bits);
  p.node_bytes = fields.bytes(f.node_align);
  if (p.node_bytes > 0xFFFF) throw std::invalid_argument("encode_scene: a packed node above 65535 bytes");
  for (const PackedNode& pn : packed) pack_node(pn, fields, p.node_bytes, p.nodes);
  p.node_count = uint32_t(order.size());
  return p;
}

}  // namespace rtu::hw
