// The device memory image of a scene: what BIND_SCENE points the unit at. One position-independent block:
// a header (format and frame), then BVH nodes, primitives and plane records. Offsets are bytes from the start of
// the image; every section is 8-byte aligned. Nodes and primitives are stored in the format's layouts
// (packed_layout.h): QNode structs and 40-byte records (leaf order), or bit-packed or compressed-wide nodes and
// 40-byte records or triangle blocks. A bound image decodes packed layouts into QNodes and 40-byte records,
// which is what nodes() and record() return: the values the unit's decoders hand to its tests.
//
// encode_scene() builds it from the scene and the float BVH (the same tree the float device traverses, so the
// two devices differ only in numbers). Child boxes are the union of the float child box rounded outward to the
// grid and the grid bounds of the quantized primitives below them; the encoder checks that every decoded box
// contains both and throws std::logic_error if one does not.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "hwmodel/format/hw_format.h"
#include "hwmodel/format/node_kind.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw {

inline constexpr uint32_t kImageMagic = 0x42555452u;  // "RTUB" little-endian
inline constexpr uint16_t kImageVersion = 2;
inline constexpr uint32_t kImageNoBvh = 1u;  // flags: no BVH; test every primitive record (tiny scenes)
// flags: a top level, whose records are instances (InstanceRecord); num_triangles and num_spheres count the
// flattened scene's, so its planes keep their flattened indices.
inline constexpr uint32_t kImageTopLevel = 2u;
// flags bits 27..31: FixedFormat::curve_bits (8..31) of an image that holds curve segments; 0 in any other.
inline constexpr uint32_t kImageCurveBitsShift = 27;
inline constexpr uint32_t kImageCurveBitsMask = 0x1Fu << kImageCurveBitsShift;

struct ImageHeader {
  uint32_t magic;           // kImageMagic
  uint16_t version;         // kImageVersion
  uint8_t width;            // node width 2, 4, 6 or 8
  uint8_t q_bytes;          // bytes per child offset: 1 (child_bits <= 8) or 2
  uint8_t coord_bits;       // FixedFormat fields, as encoded
  uint8_t child_bits;       //
  uint8_t guard_bits;       //
  uint8_t frac_bits;        //
  uint8_t dir_bits;         //
  uint8_t rcp_bits;         //
  uint8_t t_frac_bits;      //
  uint8_t t_bits;           //
  int32_t step_exp;         // quantization frame: grid step 2^step_exp world units
  uint32_t flags;           // kImageNoBvh, kImageTopLevel; bits 8..11 the node kind (node_kind.h)
  int64_t frame_origin[3];  // quantization frame: world position of grid 0 = origin * 2^step_exp
  uint32_t root_ref;        // node index 0, a leaf reference, or kEmptyChild (no bounded primitives)
  uint32_t node_count;      // nodes at node_offset
  uint32_t record_count;    // primitive records at record_offset
  uint32_t plane_count;     // plane records at plane_offset
  uint32_t num_triangles;   // scene primitive counts (the primitive index space)
  uint32_t num_spheres;     // round primitives: the spheres, then the curve segments (records of kind kSphere)
  uint64_t node_offset;     // byte offsets from the image start
  uint64_t record_offset;   //
  uint64_t plane_offset;    //
  uint64_t total_bytes;     // size of the image
  uint8_t node_layout;      // FixedFormat::node_layout, prim_layout (2: record_offset on a 64-byte line)
  uint8_t prim_layout;      //
  uint16_t node_bytes;      // bytes of one node in the node section (padded)
  uint8_t base_bits;        // bit-packed nodes: bits of the node base, primitive base, group size - 1
  uint8_t prim_bits;        //   (packed_layout.h node_fields); 0 in other layouts
  uint8_t group_bits;       //
  uint8_t node_align;       // FixedFormat::node_align
  uint64_t record_bytes;    // bytes of the primitive section
};
static_assert(sizeof(ImageHeader) == 120);
inline NodeKindId node_kind(const ImageHeader& h) {
  return NodeKindId((h.flags & kImageNodeKindMask) >> kImageNodeKindShift);
}
inline NodeLayout node_layout(const ImageHeader& h) {
  return NodeLayout(h.node_layout);
}
inline PrimLayout prim_layout(const ImageHeader& h) {
  return PrimLayout(h.prim_layout);
}

class DeviceImage {
 public:
  const ImageHeader& header() const { return *reinterpret_cast<const ImageHeader*>(m_words.data()); }
  const uint8_t* data() const { return reinterpret_cast<const uint8_t*>(m_words.data()); }
  size_t size() const { return header().total_bytes; }

  FixedFormat format() const;
  QuantFrame frame() const;
  size_t node_bytes() const { return header().node_bytes; }  // one node in memory, in the image's layout
  // The nodes as stored structs of the image's kind (decoded when the layout is packed); Node must be the kind's
  // Node type for the image's width and offset bytes (with_node_kind, node_kinds.h).
  template <class Node>
  const Node* nodes() const {
    return reinterpret_cast<const Node*>(m_nodes.empty() ? data() + header().node_offset
                                                         : reinterpret_cast<const uint8_t*>(m_nodes.data()));
  }
  // Primitive record i (decoded when the primitives are blocks).
  const uint8_t* record(uint32_t i) const {
    return (m_records.empty() ? data() + header().record_offset : m_records.data()) + size_t(i) * kRecordBytes;
  }
  // Where the unit fetches record i: image offset and bytes. With blocks the first record of a block carries the
  // whole block and the others nothing (the unit reads a leaf's block once); empty when records are 40 bytes.
  // With clusters (prim_layout 2) a record inside a cluster with internal nodes carries nothing: the cluster's
  // root node carries the cluster (cluster_node_spans).
  struct Span {
    uint64_t offset;
    uint32_t bytes;
  };
  const std::vector<Span>& record_spans() const { return m_spans; }
  // Nodes as decoded: the node section's header().node_count, then the internal nodes of the clusters
  // (prim_layout 2, cluster_layout.h), each cluster's breadth first, clusters in the order of the primitive
  // section. nodes() holds node_total() nodes.
  uint32_t node_total() const { return header().node_count + uint32_t(m_cluster_spans.size()); }
  // Where the unit fetches cluster node header().node_count + j: element j. A cluster's root carries the whole
  // cluster (the unit reads it once, when the ray enters the cluster: a subtree is traversed without leaving it,
  // so its other nodes and its records carry nothing). Empty without clusters.
  const std::vector<Span>& cluster_node_spans() const { return m_cluster_spans; }
  // Per record with clusters (else empty): kRecordInCluster when a cluster holds it, kRecordLeafStart when it is
  // the first of its leaf (the cluster unit tests a leaf's triangles as one request).
  static constexpr uint8_t kRecordInCluster = 1, kRecordLeafStart = 2;
  const std::vector<uint8_t>& cluster_record_flags() const { return m_record_flags; }
  const PlaneRecord* planes() const {
    return reinterpret_cast<const PlaneRecord*>(data() + header().plane_offset);
  }

  // Section sizes in bytes.
  uint64_t nodes_size() const { return uint64_t(header().node_count) * node_bytes(); }
  uint64_t records_size() const { return header().record_bytes; }
  uint64_t planes_size() const { return uint64_t(header().plane_count) * sizeof(PlaneRecord); }

  // An image from bytes written by someone else (device memory): copied, then checked field by field so that
  // tracing it cannot read outside it, loop, overflow the traversal stack or leave the ranges the format's
  // bounds are proven for. Throws std::invalid_argument naming the first problem.
  static DeviceImage from_bytes(const uint8_t* data, size_t bytes);

 private:
  friend class ImageWriter;
  void check();                    // also decodes packed layouts
  std::vector<uint64_t> m_words;   // 8-byte aligned storage
  std::vector<uint64_t> m_nodes;   // decoded QNodes of a packed layout (8-byte aligned), else empty
  std::vector<uint8_t> m_records;  // decoded records of blocks, else empty
  std::vector<Span> m_spans;
  std::vector<Span> m_cluster_spans;    // clusters' internal nodes
  std::vector<uint8_t> m_record_flags;  // clusters: kRecordInCluster, kRecordLeafStart
};

// Encodes `g` in format `f` over `bvh` (its width must be f.width), or without a BVH when bvh is null (every
// record tested). Throws std::invalid_argument for a bad format or a mismatched width, std::logic_error when a
// quantized box fails to contain its exact box (a bug, never expected).
DeviceImage encode_scene(const Geometry& g, const FixedFormat& f, const Bvh* bvh);

// The top level of a two-level scene: one instance record per box (boxes[i] is the world bounds of instance
// ids[i]), over `bvh` (built over `boxes`, of the format's width), and the planes of `flat`, the flattened scene,
// whose primitive counts it records. Triangle blocks hold only triangles, so records stay 40 bytes whatever
// f.prim_layout says. Throws as encode_scene.
DeviceImage encode_top_level(const std::vector<Aabb>& boxes, const std::vector<uint32_t>& ids,
                             const Geometry& flat, const FixedFormat& f, const Bvh& bvh);

}  // namespace rtu::hw
