// Packed storage of the fixed device's nodes and primitives: the bytes a format's bits cost.
//
// The datapath's values are the same in every layout (hw_format.h's QNode and 40-byte records are what the
// unit's decoders hand to the box and primitive tests); the layouts differ in how many bytes memory holds and
// the unit fetches. DeviceImage (device_image.h) stores the packed bytes and decodes them when bound, checking
// every field; the timing model fetches the packed bytes.
//
// Nodes (FixedFormat::node_layout):
//   0 structs: QNode<N, Q> as in hw_format.h, whole-byte fields, one 32-bit reference per child.
//   1 bit-packed: every field as wide as the format and the scene need (node_fields()), padded to a multiple of
//     node_align bytes.
//   2 compressed-wide: the same fields in whole bytes, in the spirit of CWBVH (Ylitie et al., HPG 2017): origin
//     3 x 32 bits, scales 3 x 8, count 8, node base 32, primitive base 32, one meta byte per child, offsets in
//     8 or 16 bits; 24 + N (1 + 6 q_bytes) bytes, 80 for 8 children at 8-bit offsets.
// Packed nodes (1, 2) address children implicitly, as CWBVH does: a node's inner children are consecutive nodes
// from its node base, and its leaf children's primitive groups are consecutive from its primitive base. A meta
// field per child says leaf or inner and, for a leaf, the size of its group, so the unit finds child j by adding
// the sizes of the children before it. The encoder numbers nodes breadth first to make this so.
//
// Bit order: field after field, each least significant bit first, bit p of a node or block in byte p / 8 at bit
// p % 8. Node fields in order: origin x, y, z (each the origin plus 2^B, unsigned; oriented nodes: plus 2^(B+2),
// their rotated boxes reach -2^(B+2)); scale x, y, z; count - 1; oriented nodes: the rotation index; node base;
// primitive base; meta of child 0 .. N-1 (leaf bit, then group size - 1); offsets in QNode's row
// order (lo_x of child 0 .. N-1, hi_x, ...). Slots past the count and the padding are zero.
//
// Primitives (FixedFormat::prim_layout):
//   0 records: 40-byte records; a leaf's group is its records, group sizes count records.
//   1 blocks: each leaf's group is one block, 8-byte aligned, its size counted in 8-byte granules. A block of
//     triangles holds the triangles' distinct grid vertices as offsets from the block's low corner (the anchor)
//     in as many bits per axis as the block's extent needs, 3 small vertex indices per triangle, and the scene
//     primitive indices as offsets from a base. In the spirit of AMD's Dense Geometry Format (up to 64 triangles
//     and 64 vertices in a 128-byte block); a block here is a BVH leaf, up to 16 triangles and 48 vertices.
//     Decoding is exact: every vertex decodes to the grid point its 40-byte record holds, so a vertex shared by
//     two blocks decodes to the same point in both (watertightness) and the layout adds no error. A leaf holding
//     a sphere is a raw block: an 8-byte header, then its 40-byte records.
//   2 clusters: subtrees of the BVH of up to 256 triangles, each one unit of 64-byte lines with its internal nodes
//     and shared vertices (cluster_layout.h); leaves outside clusters are clusters of one leaf, or raw blocks.
//   Block bits: kind (1 triangles, 0 raw), count - 1 (4); triangles go on: vertices - 1 (6), bits per axis
//   x, y, z (5 each), anchor x, y, z (B each), bits of a primitive offset (5), primitive base (30), the
//   triangles' primitive offsets, the vertices (x, y, z offsets each), the triangles' vertex indices (3 each,
//   as many bits as the vertex count needs).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "hwmodel/numeric/fixed_format.h"

namespace rtu::hw {

// Bit widths of the fields of one packed node.
struct NodeFields {
  int width = 4;            // children N
  int origin = 0, exp = 0;  // per axis
  int count = 0;            // count - 1
  int rot = 0;              // oriented nodes: the rotation index (0 bits for axis-aligned nodes)
  int origin_bias = 0;      // the origin is stored plus 2^origin_bias (B; B + 2 for oriented nodes)
  int node_base = 0, prim_base = 0;
  int group = 0;                    // group size - 1 in a leaf child's meta (after its leaf bit)
  int q = 0;                        // one child offset
  uint64_t bits() const;            // the node's bits before padding
  uint64_t bytes(int align) const;  // padded to a multiple of align
};

// The fields of node layout 1 or 2 for format f. base_bits, prim_bits and group_bits are the scene's (bits of the
// largest node base, primitive base and group size - 1: ImageHeader); layout 2 ignores them (byte fields).
NodeFields node_fields(const FixedFormat& f, int base_bits, int prim_bits, int group_bits);

// Bytes of a compressed-wide node (node_layout 2): 24 bytes of origin, scales, count and bases, then per child a
// meta byte and 6 offsets.
constexpr uint64_t compressed_wide_node_bytes(int width, int q_bytes) {
  return 24 + uint64_t(width) * (1 + 6 * uint64_t(q_bytes));
}
static_assert(compressed_wide_node_bytes(8, 1) == 80);  // CWBVH's 80-byte node (Ylitie et al., HPG 2017)

// Bits needed to hold v (0 for 0).
inline int bits_for(uint64_t v) {
  int b = 0;
  while (b < 64 && (v >> b) != 0) ++b;
  return b;
}

// Appends fields to a byte vector, least significant bit first.
class BitWriter {
 public:
  explicit BitWriter(std::vector<uint8_t>& out) : m_out(out), m_start(out.size()) {}
  void put(uint64_t v, int bits);  // v < 2^bits (bits <= 64)
  uint64_t bits() const { return m_bits; }
  void pad_to(uint64_t bytes);  // zero bits up to this many bytes from the start

 private:
  std::vector<uint8_t>& m_out;
  size_t m_start;
  uint64_t m_bits = 0;
};

// Reads fields from [data, data + bytes); reading past the end throws std::invalid_argument naming `what`.
class BitReader {
 public:
  BitReader(const uint8_t* data, uint64_t bytes, std::string what)
      : m_d(data), m_n(bytes), m_what(std::move(what)) {}
  uint64_t get(int bits);
  uint64_t pos() const { return m_pos; }
  // True when every bit from the position to the end of `bytes` is zero.
  bool zero_to(uint64_t bytes) const;

 private:
  const uint8_t* m_d;
  uint64_t m_n, m_pos = 0;
  std::string m_what;
};

// One node in the layout's terms: the QNode's values and the implicit addresses.
struct PackedNode {
  int32_t origin[3] = {0, 0, 0};
  int exp[3] = {0, 0, 0};
  int count = 1;
  uint32_t rot = 0;  // oriented nodes
  uint64_t node_base = 0, prim_base = 0;
  bool leaf[8] = {};
  uint32_t group[8] = {};  // leaf children: group size in units (records or 8-byte granules)
  uint32_t q[6][8] = {};
};
// Writes n (the origin stored plus 2^fields.origin_bias) as `fields` and pads to `bytes`. Throws std::logic_error
// when a value does not fit its field (an encoder bug).
void pack_node(const PackedNode& n, const NodeFields& fields, uint64_t bytes, std::vector<uint8_t>& out);
// Reads one node of `bytes` bytes; throws std::invalid_argument naming the field when the node is malformed
// (count beyond the width, nonzero empty slots or padding). Ranges against the format are the caller's.
PackedNode unpack_node(const uint8_t* data, uint64_t bytes, const NodeFields& fields, const std::string& at);

// A leaf's opaque triangles as a triangle block and a cluster (cluster_layout.h) store them: their distinct grid
// vertices in order of first use, three vertex indices per triangle, the scene primitive indices and the
// vertices' bounds.
struct TriangleGroup {
  std::vector<std::array<int32_t, 3>> verts;
  std::vector<std::array<uint32_t, 3>> idx;
  std::vector<uint32_t> prims;
  uint32_t pmin = UINT32_MAX, pmax = 0;
  int64_t lo[3] = {INT64_MAX, INT64_MAX, INT64_MAX}, hi[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
  int index_bits() const { return verts.empty() ? 0 : bits_for(verts.size() - 1); }  // one vertex index
  int prim_bits() const { return prims.empty() ? 0 : bits_for(pmax - pmin); }        // one primitive offset
  // Writes what follows the anchor in both: the offsets' width (off_bits wide) and base (base_bits), the
  // primitive offsets, the vertices (axis a in axis[a] bits above lo[a]) and the vertex indices.
  void put_body(BitWriter& w, const int axis[3], int off_bits, int base_bits) const;
};
// The group of `count` 40-byte triangle records.
TriangleGroup group_triangles(const uint8_t* records, size_t count);

// Primitive blocks. Encodes `count` 40-byte records (one leaf) as one block appended to out (8-byte aligned);
// returns its size in 8-byte granules.
uint32_t encode_block(const uint8_t* records, int count, int coord_bits, std::vector<uint8_t>& out);
// Decodes the block at data (at most `bytes` bytes available), appending its 40-byte records to `records`;
// returns its size in granules. Throws std::invalid_argument naming the field when it is malformed. Range checks
// of the decoded records (vertices on the grid, primitive indices) are the caller's.
uint32_t decode_block(const uint8_t* data, uint64_t bytes, int coord_bits, std::vector<uint8_t>& records,
                      const std::string& at);

inline constexpr uint64_t kGranuleBytes = 8;  // blocks are sized and addressed in these

}  // namespace rtu::hw
