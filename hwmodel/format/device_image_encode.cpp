// The encoder of the device memory image (device_image.h): encode_scene and encode_top_level. The scene's
// primitives become records on the quantization frame's grid and its planes plane records; the float BVH's nodes
// become nodes of the format's kind (quantized or oriented child boxes, each checked to contain its exact box),
// stored as structs or, through packed_tree.h, in the format's packed layouts. The writer lays out the header
// and the sections, then decodes what it wrote as a bound image would. Reading an image back and checking it is
// device_image.cpp's.
#include "hwmodel/format/device_image.h"
#include "hwmodel/scene/bvh.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "hwmodel/format/cluster_layout.h"
#include "hwmodel/format/node_kinds.h"
#include "hwmodel/format/packed_layout.h"
#include "hwmodel/format/packed_tree.h"

namespace rtu::hw {

namespace {

class Encoder {
 public:
  Encoder(const Geometry& g, const FixedFormat& f) : m_g(g), m_f(f) {
    Aabb b = g.bounds();
    if (b.empty()) b = Aabb{Vec3(-1.0f), Vec3(1.0f)};  // planes only: any frame will do
    m_frame = QuantFrame::fit(b, f.coord_bits);
  }
  // A top level: record p is the instance ids[p] with world bounds boxes[p]; g gives the planes.
  Encoder(const std::vector<Aabb>& boxes, const std::vector<uint32_t>& ids, const Geometry& g,
          const FixedFormat& f)
      : m_g(g), m_f(f), m_boxes(&boxes), m_ids(&ids) {
    Aabb b;
    for (const Aabb& x : boxes) b.extend(x);
    if (b.empty()) b = Aabb{Vec3(-1.0f), Vec3(1.0f)};
    m_frame = QuantFrame::fit(b, f.coord_bits);
  }

  const QuantFrame& frame() const { return m_frame; }
  uint32_t record_count() const { return m_boxes ? uint32_t(m_boxes->size()) : m_g.num_bounded(); }

  // The record of bounded primitive p and its grid bounds.
  void make_record(uint32_t p, uint8_t* out, GridBox& box) const {
    if (m_boxes) {
      InstanceRecord rec{};
      const GridBox g = outward((*m_boxes)[p]);
      for (int a = 0; a < 3; ++a) {
        rec.lo[a] = int32_t(g.lo[a]);
        rec.hi[a] = int32_t(g.hi[a]);
      }
      box.extend(g);
      rec.prim = record_word(RecordKind::kInstance, (*m_ids)[p]);
      std::memcpy(out, &rec, sizeof rec);
    } else {
      const RecordEncoding e{m_g, m_f, m_frame};
      with_prim_kind(m_g.kind(p), [&](auto k) {
        using K = decltype(k);
        if constexpr (PrimitiveKind<K>) K::encode(e, p, out, box);
      });
    }
  }

  PlaneRecord make_plane(uint32_t i) const { return PlanePrim::encode(RecordEncoding{m_g, m_f, m_frame}, i); }

  // Triangle pairs (FixedFormat::tri_pairs): in the records [first, first + count), each triangle that shares an
  // edge with the next (and is not the second of a pair) becomes a kTrianglePair; the order stays, so every ray
  // tests the same triangles in the same order as without pairs.
  static void mark_pairs(uint8_t* records, uint32_t first, uint32_t count) {
    for (uint32_t i = first; i + 1 < first + count; ++i) {
      uint8_t* a = records + size_t(i) * kRecordBytes;
      const uint8_t* b = a + kRecordBytes;
      if (record_kind(a) != RecordKind::kTriangle || record_kind(b) != RecordKind::kTriangle) continue;
      TriangleRecord ta, tb;
      std::memcpy(&ta, a, sizeof ta);
      std::memcpy(&tb, b, sizeof tb);
      if (!share_edge(ta, tb)) continue;
      ta.prim = with_record_kind(ta.prim, RecordKind::kTrianglePair);
      std::memcpy(a, &ta, sizeof ta);
      ++i;  // b is the pair's second
    }
  }

  GridBox outward(const Aabb& b) const { return NodeBuild{m_f, m_frame, nullptr, nullptr}.outward(b); }

  template <NodeKind K>
  void encode_tree(const WideBvh<K::kWidth>& t, std::vector<typename K::Node>& nodes,
                   std::vector<uint8_t>& records) {
    records.assign(t.prim_ids.size() * kRecordBytes, 0);
    m_record_boxes.assign(t.prim_ids.size(), GridBox{});
    for (size_t i = 0; i < t.prim_ids.size(); ++i)
      make_record(t.prim_ids[i], records.data() + i * kRecordBytes, m_record_boxes[i]);
    if (m_f.tri_pairs) {
      if (is_leaf(t.root_ref) && t.root_ref != kEmptyChild)
        mark_pairs(records.data(), leaf_first(t.root_ref), leaf_count(t.root_ref));
      for (const WideNode<K::kWidth>& n : t.nodes)
        for (uint32_t ref : n.child)
          if (ref != kEmptyChild && is_leaf(ref)) mark_pairs(records.data(), leaf_first(ref), leaf_count(ref));
    }
    nodes.resize(t.nodes.size());
    if (is_leaf(t.root_ref) || t.root_ref == kEmptyChild) return;
    K::build(NodeBuild{m_f, m_frame, records.data(), m_record_boxes.data()}, t, nodes.data());
  }

 private:
  const Geometry& m_g;
  const FixedFormat& m_f;
  QuantFrame m_frame;
  std::vector<GridBox> m_record_boxes;
  const std::vector<Aabb>* m_boxes = nullptr;  // top level: instance bounds, and their instance indices
  const std::vector<uint32_t>* m_ids = nullptr;
};

size_t align8(size_t x) {
  return (x + 7) & ~size_t(7);
}

}  // namespace

// Writes an image: the encoder's records over the BVH (or every record), the planes of g, the counts of g.
class ImageWriter {
 public:
  static DeviceImage write(Encoder& enc, const Geometry& g, const FixedFormat& f, const Bvh* bvh, uint32_t flags);
};

DeviceImage encode_scene(const Geometry& g, const FixedFormat& f, const Bvh* bvh) {
  f.validate();
  if (bvh && bvh->width() != f.width)
    throw std::invalid_argument("encode_scene: BVH width " + std::to_string(bvh->width()) +
                                " differs from the format's width " + std::to_string(f.width));
  if (g.num_bounded() > kRecordPrimMask + 1)
    throw std::invalid_argument(
        "encode_scene: more than 2^27 bounded primitives (a record's index holds 27 bits)");
  Encoder enc(g, f);
  return ImageWriter::write(enc, g, f, bvh, 0);
}

DeviceImage encode_top_level(const std::vector<Aabb>& boxes, const std::vector<uint32_t>& ids,
                             const Geometry& flat, const FixedFormat& format, const Bvh& bvh) {
  format.validate();
  if (bvh.width() != format.width)
    throw std::invalid_argument("encode_top_level: BVH width " + std::to_string(bvh.width()) +
                                " differs from the format's width " + std::to_string(format.width));
  if (ids.size() != boxes.size()) throw std::invalid_argument("encode_top_level: one instance index per box");
  for (const uint32_t id : ids)
    if (id > kRecordPrimMask) throw std::invalid_argument("encode_top_level: instance index beyond 2^27 - 1");
  FixedFormat f = format;
  f.prim_layout = int(PrimLayout::kRecords);
  Encoder enc(boxes, ids, flat, f);
  return ImageWriter::write(enc, flat, f, &bvh, kImageTopLevel);
}

namespace {

// The node and primitive sections over the BVH: its nodes of the format's kind and its records in leaf order, as
// structs or, packed, in the format's layouts (with what they must decode to).
PackedTree tree_sections(Encoder& enc, const FixedFormat& f, const Bvh& bvh, NodeKindId kind) {
  PackedTree tree;
  const int q_bytes = f.offset_bytes();
  const bool packed = f.node_layout_id() != NodeLayout::kStructs;
  bvh.visit([&](const auto& t) {
    constexpr int N = std::decay_t<decltype(t)>::kWidth;
    with_node_kind(kind, N, q_bytes, [&](auto kind_tag) {
      using K = decltype(kind_tag);
      if constexpr (K::kWidth == N) {
        std::vector<typename K::Node> nodes;
        std::vector<uint8_t> records;
        enc.encode_tree<K>(t, nodes, records);
        if (packed) {
          tree = pack_tree<K>(f, nodes, records, t.root_ref);
          return;
        }
        tree.nodes.resize(nodes.size() * sizeof(typename K::Node));
        if (!nodes.empty()) std::memcpy(tree.nodes.data(), nodes.data(), tree.nodes.size());
        tree.prims = std::move(records);
        tree.node_count = uint32_t(nodes.size());
        tree.node_bytes = sizeof(typename K::Node);
        tree.root = t.root_ref;
      }
    });
  });
  return tree;
}

// Without a BVH: every record in primitive order, in the format's primitive layout, and the bytes a node of the
// format would take.
PackedTree record_sections(Encoder& enc, const FixedFormat& f, NodeKindId kind) {
  PackedTree tree;
  const int q_bytes = f.offset_bytes();
  const bool packed = f.node_layout_id() != NodeLayout::kStructs;
  const uint32_t n = enc.record_count();
  tree.records.assign(size_t(n) * kRecordBytes, 0);
  for (uint32_t p = 0; p < n; ++p) {
    GridBox unused;
    enc.make_record(p, tree.records.data() + size_t(p) * kRecordBytes, unused);
  }
  if (f.tri_pairs) Encoder::mark_pairs(tree.records.data(), 0, n);
  // Blocks of up to 16 records (the group size a block holds), in order.
  for (uint32_t p = 0; p < n && f.prim_layout_id() == PrimLayout::kBlocks; p += uint32_t(kMaxLeafSize))
    encode_block(tree.records.data() + size_t(p) * kRecordBytes, int(std::min<uint32_t>(kMaxLeafSize, n - p)),
                 f.coord_bits, tree.prims);
  // Clusters: leaves of up to 16 records without internal nodes, or raw blocks, in order.
  for (uint32_t p = 0; p < n && f.prim_layout_id() == PrimLayout::kClusters; p += uint32_t(kMaxLeafSize)) {
    const uint8_t* rec = tree.records.data() + size_t(p) * kRecordBytes;
    const uint32_t count = std::min<uint32_t>(kMaxLeafSize, n - p);
    Cluster c;
    c.records.assign(rec, rec + size_t(count) * kRecordBytes);
    if (!clusterable(rec, count))
      encode_raw_unit(rec, int(count), f, tree.prims);
    else if (encode_cluster(c, f, tree.prims) == 0)
      throw std::logic_error("encoder: a leaf that fits no cluster");
  }
  if (f.prim_layout_id() == PrimLayout::kRecords) tree.prims = tree.records;
  tree.node_bytes =
      packed ? node_fields(f, 0, 0, 0).bytes(f.node_align) : node_struct_bytes(kind, f.width, q_bytes);
  return tree;
}

// The header of an image of these sections and `plane_count` planes: the format's widths, the frame, the flags,
// the counts and where each section starts.
ImageHeader image_header(const Encoder& enc, const Geometry& g, const FixedFormat& f, const PackedTree& tree,
                         size_t plane_count, uint32_t flags) {
  const int q_bytes = f.offset_bytes();
  ImageHeader h{};
  h.magic = kImageMagic;
  h.version = kImageVersion;
  h.width = uint8_t(f.width);
  h.q_bytes = uint8_t(q_bytes);
  h.coord_bits = uint8_t(f.coord_bits);
  h.child_bits = uint8_t(f.child_bits);
  h.guard_bits = uint8_t(f.guard_bits);
  h.frac_bits = uint8_t(f.frac_bits);
  h.dir_bits = uint8_t(f.dir_bits);
  h.rcp_bits = uint8_t(f.rcp_bits);
  h.t_frac_bits = uint8_t(f.t_frac_bits);
  h.t_bits = uint8_t(f.t_bits);
  h.step_exp = enc.frame().step_exp;
  h.flags = flags;
  for (int a = 0; a < 3; ++a) h.frame_origin[a] = enc.frame().origin[a];
  h.root_ref = tree.root;
  h.node_count = tree.node_count;
  h.record_count = enc.record_count();
  h.plane_count = uint32_t(plane_count);
  h.num_triangles = uint32_t(g.triangles.size());
  h.num_spheres = g.num_round();
  h.node_layout = uint8_t(f.node_layout);
  h.prim_layout = uint8_t(f.prim_layout);
  h.node_bytes = uint16_t(tree.node_bytes);
  const bool bit_packed = f.node_layout_id() == NodeLayout::kBitPacked;
  h.base_bits = uint8_t(bit_packed ? tree.base_bits : 0);
  h.prim_bits = uint8_t(bit_packed ? tree.prim_bits : 0);
  h.group_bits = uint8_t(bit_packed ? tree.group_bits : 0);
  h.node_align = uint8_t(f.node_align);
  h.record_bytes = tree.prims.size();
  h.node_offset = align8(sizeof(ImageHeader));
  h.record_offset = align8(h.node_offset + tree.nodes.size());
  if (f.prim_layout_id() == PrimLayout::kClusters)  // clusters start on 64-byte lines of the image
    h.record_offset = (h.record_offset + kClusterLineBytes - 1) / kClusterLineBytes * kClusterLineBytes;
  h.plane_offset = align8(h.record_offset + tree.prims.size());
  h.total_bytes = align8(h.plane_offset + plane_count * sizeof(PlaneRecord));
  return h;
}

}  // namespace

DeviceImage ImageWriter::write(Encoder& enc, const Geometry& g, const FixedFormat& f, const Bvh* bvh,
                               uint32_t flags) {
  PackedTree tree;  // the node and primitive sections (and, packed, their expected decoding)
  const bool packed = f.node_layout_id() != NodeLayout::kStructs;
  const NodeKindId kind = f.node_kind_id();
  flags |= uint32_t(kind) << kImageNodeKindShift;
  flags |= with_node_kind(kind, f.width, f.offset_bytes(), [&](auto k) { return decltype(k)::image_flags(f); });
  if (!g.curves.empty()) {
    if (const std::string why = f.curve_limits(); !why.empty()) throw std::invalid_argument(why);
    flags |= uint32_t(f.curve_bits) << kImageCurveBitsShift;
  }
  if (bvh) {
    tree = tree_sections(enc, f, *bvh, kind);
  } else {
    flags |= kImageNoBvh;
    tree = record_sections(enc, f, kind);
  }
  std::vector<PlaneRecord> planes;
  for (uint32_t i = 0; i < g.planes.size(); ++i) planes.push_back(enc.make_plane(i));

  const ImageHeader h = image_header(enc, g, f, tree, planes.size(), flags);

  DeviceImage img;
  img.m_words.assign(h.total_bytes / 8, 0);
  uint8_t* base = reinterpret_cast<uint8_t*>(img.m_words.data());
  std::memcpy(base, &h, sizeof h);
  if (!tree.nodes.empty()) std::memcpy(base + h.node_offset, tree.nodes.data(), tree.nodes.size());
  if (!tree.prims.empty()) std::memcpy(base + h.record_offset, tree.prims.data(), tree.prims.size());
  if (!planes.empty()) std::memcpy(base + h.plane_offset, planes.data(), planes.size() * sizeof(PlaneRecord));
  if (packed || f.prim_layout_id() != PrimLayout::kRecords) {
    // Decode as a bound image would, and hold the decoding to the values encoded.
    img.check();
    const auto* dn = reinterpret_cast<const uint8_t*>(img.m_nodes.data());
    const bool nodes_ok = tree.qnodes.empty() || (img.m_nodes.size() * 8 >= tree.qnodes.size() &&
                                                  std::memcmp(dn, tree.qnodes.data(), tree.qnodes.size()) == 0);
    const uint8_t* dr = img.record(0);
    const bool records_ok = tree.records.empty() || std::memcmp(dr, tree.records.data(), tree.records.size()) == 0;
    if (!nodes_ok || !records_ok) throw std::logic_error("encoder: a packed layout does not decode to its values");
  }
  return img;
}

}  // namespace rtu::hw
