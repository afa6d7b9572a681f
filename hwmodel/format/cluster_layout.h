// Triangle clusters (FixedFormat::prim_layout 2): a subtree of the BVH of up to cluster_tris (<= 256) opaque
// triangles stored as one unit of the primitive section, in the spirit of the cluster acceleration structures of
// NVIDIA's RTX Mega Geometry, whose Blackwell RT core tests clusters of up to 256 triangles.
//
// A cluster holds its triangles' distinct grid vertices as offsets from the cluster's anchor in as many bits per
// axis as its extent needs, three vertex indices per triangle, the scene primitive indices as offsets from a
// base, and its internal hierarchy: the subtree's nodes with their origins relative to the same anchor. The leaves
// of that hierarchy are the sub-groups of at most 16 triangles (the BVH's leaves) the unit tests after their
// boxes. Decoding is exact: every vertex decodes to the grid point of its 40-byte record, and every internal node
// to the node the other layouts store, so a cluster image traces bit for bit as prim_layout 0 and 1 do over the
// same tree.
//
// In the primitive section of prim_layout 2 every unit (a cluster, or a raw block of a leaf with spheres or
// non-opaque triangles, as in packed_layout.h) starts on a 64-byte line and is sized in lines, so a packed node's
// group field (7 bits) addresses clusters of up to 8 KiB. A leaf of the top tree outside any cluster is a cluster
// without internal nodes.
//
// Cluster bits, each field least significant bit first (packed_layout.h's bit order): kind (1: cluster; 0 is a
// raw block), triangles - 1 (8), internal nodes (8), vertices - 1 (10), bits per axis x, y, z (6 each), anchor x,
// y, z (the node origin field of node_fields(): B + 2 bits, stored plus 2^B; oriented nodes B + 4, plus 2^(B+2)),
// bits of a primitive offset (5), primitive base (30), the triangles' primitive offsets, the vertices (x, y, z
// offsets each), the triangles' vertex indices (3 each, as many bits as the vertex count needs), then the internal
// nodes breadth first: origin x, y, z as offsets from the anchor (the axis's bits), scales (node_fields' exp bits
// each), count - 1, the rotation index (oriented nodes), per child slot a leaf bit and group size - 1 (4 bits,
// triangles), then the child offsets in QNode's row order (child_bits each). Padding to the line is zero.
// Children are addressed implicitly: node i's inner children are the next unnumbered nodes, its leaves the next
// triangles, in slot order.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "hwmodel/format/packed_layout.h"
#include "hwmodel/numeric/fixed_format.h"

namespace rtu::hw {

inline constexpr uint64_t kClusterLineBytes = 64;  // prim_layout 2: units are aligned to and sized in these
inline constexpr int kMaxClusterTris = 256;
inline constexpr int kMaxClusterNodes = 255;
inline constexpr int kMaxClusterVerts = 1024;
inline constexpr uint32_t kMaxClusterLines = 128;  // a packed node's 7-bit group field

// One cluster in the encoder's and decoder's terms.
struct Cluster {
  // Internal nodes, breadth first (node 0 the cluster's root; none: the cluster is one leaf). Fields as
  // PackedNode; leaf[i] and group[i] (triangles) per child; node_base and prim_base are unused (implicit).
  std::vector<PackedNode> nodes;
  std::vector<uint8_t> records;  // 40-byte triangle records in leaf order (breadth first, slot order)
};

// True when the 40-byte records can go into a cluster: opaque triangles only.
bool clusterable(const uint8_t* records, uint32_t count);

// Appends the cluster, padded to whole lines, to out and returns its size in lines; returns 0 and appends
// nothing when it does not fit the format (more than kMaxClusterLines lines, vertices or nodes). Throws
// std::logic_error for a cluster the encoder should not have formed (no triangles, too many, a group size
// beyond 16, a node that does not fit its fields).
uint32_t encode_cluster(const Cluster& c, const FixedFormat& f, std::vector<uint8_t>& out);

// Decodes the unit at data (at most `bytes` available): a cluster into `out` (nodes and records), or a raw block
// (out.nodes empty). Returns the unit's size in lines. Throws std::invalid_argument naming the field when it is
// malformed. Vertices are checked to lie on the grid and node origins in their field's range; the records'
// primitive indices and the nodes' boxes are the caller's to check.
uint32_t decode_cluster_unit(const uint8_t* data, uint64_t bytes, const FixedFormat& f, Cluster& out,
                             const std::string& at);

// A raw block (packed_layout.h's encode_block of records that are not all opaque triangles) padded to lines.
uint32_t encode_raw_unit(const uint8_t* records, int count, const FixedFormat& f, std::vector<uint8_t>& out);

}  // namespace rtu::hw
