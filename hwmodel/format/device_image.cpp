// The device memory image read back (device_image.h): the format and frame its header gives, and from_bytes,
// which checks an image from device memory field by field (header, layouts, sections, records, planes, tree) so
// that tracing it cannot go wrong, decoding packed layouts (triangle blocks, clusters, packed nodes) into the
// QNodes and 40-byte records the tracers read. Writing an image is device_image_encode.cpp's; the writer decodes
// what it wrote through the same check().
#include "hwmodel/format/device_image.h"
#include "hwmodel/scene/bvh.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <stdexcept>
#include <string>

#include "hwmodel/format/cluster_layout.h"
#include "hwmodel/format/node_kinds.h"
#include "hwmodel/format/packed_layout.h"

namespace rtu::hw {

FixedFormat DeviceImage::format() const {
  const ImageHeader& h = header();
  FixedFormat f;
  f.name = "image";
  f.width = h.width;
  f.coord_bits = h.coord_bits;
  f.child_bits = h.child_bits;
  f.guard_bits = h.guard_bits;
  f.frac_bits = h.frac_bits;
  f.dir_bits = h.dir_bits;
  f.rcp_bits = h.rcp_bits;
  f.t_frac_bits = h.t_frac_bits;
  f.t_bits = h.t_bits;
  f.node_layout = h.node_layout;
  f.prim_layout = h.prim_layout;
  f.node_align = h.node_align;
  if (const uint32_t cb = (h.flags & kImageCurveBitsMask) >> kImageCurveBitsShift) f.curve_bits = int(cb);
  if (const NodeKindInfo* kind = find_node_kind(uint32_t(node_kind(h)))) {
    f.node_kind = int(kind->id);
    if (kind->from_image_flags) kind->from_image_flags(h.flags, f);
  }
  return f;
}

QuantFrame DeviceImage::frame() const {
  const ImageHeader& h = header();
  QuantFrame q;
  q.bits = h.coord_bits;
  q.step_exp = h.step_exp;
  for (int a = 0; a < 3; ++a) q.origin[a] = h.frame_origin[a];
  return q;
}

namespace {

[[noreturn]] void bad_image(const std::string& why) {
  throw std::invalid_argument("scene image: " + why);
}

// The header of an image of `bytes` bytes in format f: magic, version, size, format, flags and frame.
void check_header(const ImageHeader& h, const FixedFormat& f, uint64_t bytes) {
  if (h.magic != kImageMagic) bad_image("bad magic");
  if (h.version != kImageVersion) bad_image("unsupported version " + std::to_string(h.version));
  if (h.total_bytes != bytes) bad_image("total_bytes differs from the bound size");
  try {
    f.validate();
  } catch (const std::invalid_argument& e) {
    bad_image(std::string("format: ") + e.what());
  }
  if (h.q_bytes != f.offset_bytes()) bad_image("offset bytes do not match child_bits");
  if (h.flags & ~(kImageNoBvh | kImageTopLevel | kImageNodeKindMask | kImageRotationsMask | kImageRotBitsMask |
                  kImageCurveBitsMask))
    bad_image("unknown flag bits");
  if (h.flags & kImageCurveBitsMask) {
    if (const std::string why = f.curve_limits(); !why.empty()) bad_image(why);
  }
  const NodeKindInfo* kind = find_node_kind(uint32_t(node_kind(h)));
  if (!kind) bad_image("unknown node kind " + std::to_string(int(node_kind(h))));
  for (const NodeKindInfo& other : kNodeKinds)  // another kind's fields (the rotation table's of oriented nodes)
    if (other.id != kind->id && (h.flags & other.image_flags & ~kind->image_flags))
      bad_image(std::string(other.flag_fields) + " fields in an image of " + kind->name + " nodes");
  if ((h.flags & kImageTopLevel) && h.prim_layout != 0) bad_image("a top level in triangle blocks");
  // The frame: grid -> world must stay exact in double (quant_frame.h) and finite.
  if (h.step_exp < -1000 || h.step_exp > 1000) bad_image("frame step exponent out of range");
  for (int a = 0; a < 3; ++a)
    if (h.frame_origin[a] <= -(int64_t(1) << 52) || h.frame_origin[a] >= (int64_t(1) << 52))
      bad_image("frame origin out of range");
}

// Layouts: the node size the format and the field widths give, the primitive section the layout gives. Returns
// the packed nodes' fields (default for struct nodes).
NodeFields check_layouts(const ImageHeader& h, const FixedFormat& f, size_t struct_bytes) {
  NodeFields fields;
  if (node_layout(h) != NodeLayout::kStructs) {
    if (h.base_bits > 32 || h.prim_bits > 32 || h.group_bits > 7)
      bad_image("node field widths out of range (base_bits, prim_bits <= 32, group_bits <= 7)");
    if (node_layout(h) == NodeLayout::kCompressedWide && (h.base_bits | h.prim_bits | h.group_bits) != 0)
      bad_image("node field widths given for compressed-wide nodes (their fields are bytes)");
    fields = node_fields(f, h.base_bits, h.prim_bits, h.group_bits);
    if (h.node_bytes != fields.bytes(f.node_align))
      bad_image("node_bytes " + std::to_string(h.node_bytes) + " differs from the layout's " +
                std::to_string(fields.bytes(f.node_align)));
  } else if (h.node_bytes != struct_bytes || (h.base_bits | h.prim_bits | h.group_bits) != 0) {
    bad_image("node_bytes or node field widths differ from the struct layout's");
  }
  if (prim_layout(h) == PrimLayout::kRecords && h.record_bytes != uint64_t(h.record_count) * kRecordBytes)
    bad_image("record_bytes differs from record_count 40-byte records");
  if (prim_layout(h) == PrimLayout::kClusters &&
      (h.record_offset % kClusterLineBytes != 0 || h.record_bytes % kClusterLineBytes != 0))
    bad_image("record_offset or record_bytes of triangle clusters not on a 64-byte line");
  return fields;
}

// Sections inside the image, aligned, not overlapping the header or each other; primitive and record counts.
void check_sections(const ImageHeader& h, uint64_t bytes) {
  const uint64_t nb = uint64_t(h.node_count) * h.node_bytes, rb = h.record_bytes,
                 pb = uint64_t(h.plane_count) * sizeof(PlaneRecord);
  auto section = [&](uint64_t off, uint64_t size, uint64_t after, const char* what) {
    if (off % 8 != 0 || off < after || off > bytes || size > bytes - off)
      bad_image(std::string(what) + " section outside the image or misaligned");
  };
  section(h.node_offset, nb, sizeof(ImageHeader), "node");
  section(h.record_offset, rb, h.node_offset + nb, "record");
  section(h.plane_offset, pb, h.record_offset + rb, "plane");
  const uint64_t num_bounded = uint64_t(h.num_triangles) + h.num_spheres;
  // A record's index holds 27 bits (prim_kind.h); a plane's index, in its own word, stays below 2^29 - 1.
  if (num_bounded > kRecordPrimMask + 1 || num_bounded + h.plane_count >= (uint64_t(1) << 29) - 1)
    bad_image("too many primitives");
  // A top level's records are its instances; its counts number the flattened scene's primitives.
  if ((h.flags & kImageTopLevel) ? h.record_count > kRecordPrimMask : h.record_count != num_bounded)
    bad_image("record count differs from the primitive counts");
}

// Where each block starts: (granule, first record), granules rising; with clusters (prim_layout 2) each unit's
// (line, first record).
using BlockStarts = std::vector<std::pair<uint64_t, uint32_t>>;

// Clusters (prim_layout 2): the decoded internal nodes (after the node section's) with their children's
// references, and each unit's reference as a leaf child of the top tree names it.
struct ClusterDecode {
  std::vector<PackedNode> nodes;
  std::vector<std::array<uint32_t, 8>> refs;
  std::vector<uint32_t> unit_ref;  // per unit of BlockStarts: its root node, or its leaf of records
};

// The units of triangle clusters one after another from the section's start into `records` and `cd`, with the
// spans the unit fetches: a cluster's root node carries the cluster, a unit without internal nodes its first
// record.
BlockStarts decode_clusters(const uint8_t* image, const ImageHeader& h, const FixedFormat& f,
                            std::vector<uint8_t>& records, std::vector<DeviceImage::Span>& spans,
                            std::vector<DeviceImage::Span>& node_spans, std::vector<uint8_t>& flags,
                            ClusterDecode& cd) {
  BlockStarts unit_at;
  const uint64_t rb = h.record_bytes;
  const uint8_t* sec = image + h.record_offset;
  uint64_t line = 0;
  Cluster c;
  while (line * kClusterLineBytes < rb) {
    const uint32_t first = uint32_t(records.size() / kRecordBytes);
    if (first >= h.record_count) bad_image("primitive section holds more records than record_count");
    const std::string at =
        "cluster at byte " + std::to_string(line * kClusterLineBytes) + " of the primitive section";
    uint32_t size = 0;
    try {
      size = decode_cluster_unit(sec + line * kClusterLineBytes, rb - line * kClusterLineBytes, f, c, at);
    } catch (const std::invalid_argument& e) {
      bad_image(e.what());
    }
    const uint32_t count = uint32_t(c.records.size() / kRecordBytes);
    if (uint64_t(first) + count > h.record_count) bad_image(at + ": records beyond record_count");
    if (uint64_t(first) + count > uint64_t(kMaxLeafFirst) + 1) bad_image(at + ": records beyond a leaf's reach");
    if (!c.nodes.empty() && (h.flags & kImageNoBvh)) bad_image(at + ": internal nodes in an image without a BVH");
    records.insert(records.end(), c.records.begin(), c.records.end());
    spans.resize(records.size() / kRecordBytes, DeviceImage::Span{0, 0});
    flags.resize(records.size() / kRecordBytes, 0);
    const DeviceImage::Span whole{h.record_offset + line * kClusterLineBytes, size * uint32_t(kClusterLineBytes)};
    const bool raw = c.nodes.empty() && !clusterable(c.records.data(), count);
    for (uint32_t i = first; i < first + count; ++i) flags[i] = raw ? 0 : DeviceImage::kRecordInCluster;
    unit_at.push_back({line, first});
    if (c.nodes.empty()) {
      spans[first] = whole;
      flags[first] |= DeviceImage::kRecordLeafStart;
      cd.unit_ref.push_back(make_leaf(first, count));
    } else {
      const uint64_t base = uint64_t(h.node_count) + cd.nodes.size();
      if (base + c.nodes.size() >= kLeafBit) bad_image(at + ": too many nodes");
      cd.unit_ref.push_back(uint32_t(base));
      uint32_t next_node = 1, next_record = first;
      for (size_t j = 0; j < c.nodes.size(); ++j) {
        const PackedNode& pn = c.nodes[j];
        std::array<uint32_t, 8> r;
        r.fill(kEmptyChild);
        for (int i = 0; i < pn.count; ++i) {
          if (pn.leaf[i]) {
            flags[next_record] |= DeviceImage::kRecordLeafStart;
            r[size_t(i)] = make_leaf(next_record, pn.group[i]);
            next_record += pn.group[i];
          } else {
            r[size_t(i)] = uint32_t(base + next_node++);
          }
        }
        cd.nodes.push_back(pn);
        cd.refs.push_back(r);
        node_spans.push_back(j == 0 ? whole : DeviceImage::Span{0, 0});
      }
    }
    line += size;
  }
  if (records.size() != size_t(h.record_count) * kRecordBytes)
    bad_image("primitive section decodes to a record count other than record_count");
  return unit_at;
}

// Blocks: decoded one after another from the section's start into `records` (40-byte records), with the span the
// unit fetches for each block's first record.
BlockStarts decode_blocks(const uint8_t* image, const ImageHeader& h, const FixedFormat& f,
                          std::vector<uint8_t>& records, std::vector<DeviceImage::Span>& spans) {
  BlockStarts block_at;
  const uint64_t rb = h.record_bytes;
  const uint8_t* sec = image + h.record_offset;
  uint64_t g = 0;
  while (g * kGranuleBytes < rb) {
    const uint32_t first = uint32_t(records.size() / kRecordBytes);
    if (first >= h.record_count) bad_image("primitive section holds more records than record_count");
    const std::string at = "block at byte " + std::to_string(g * kGranuleBytes) + " of the primitive section";
    uint32_t size = 0;
    try {
      size = decode_block(sec + g * kGranuleBytes, rb - g * kGranuleBytes, f.coord_bits, records, at);
    } catch (const std::invalid_argument& e) {
      bad_image(e.what());
    }
    block_at.push_back({g, first});
    spans.resize(records.size() / kRecordBytes, DeviceImage::Span{0, 0});
    spans[first] = DeviceImage::Span{h.record_offset + g * kGranuleBytes, size * uint32_t(kGranuleBytes)};
    g += size;
  }
  if (records.size() != size_t(h.record_count) * kRecordBytes)
    bad_image("primitive section decodes to a record count other than record_count");
  return block_at;
}

// The leaf reference of child i of a packed node: its group of `unit` granules (blocks) or records from `unit`.
uint32_t packed_leaf_ref(const ImageHeader& h, const BlockStarts& block_at, const ClusterDecode& cd,
                         const std::string& at, int i, uint64_t unit, uint64_t group) {
  uint64_t first = unit, count = group;
  if (prim_layout(h) == PrimLayout::kClusters) {
    const uint64_t end = h.record_bytes / kClusterLineBytes;
    const auto it = std::lower_bound(block_at.begin(), block_at.end(), std::make_pair(unit, uint32_t(0)));
    if (it == block_at.end() || it->first != unit)
      bad_image(at + ": leaf child " + std::to_string(i) + " does not point at the start of a cluster");
    if ((it + 1 == block_at.end() ? end : (it + 1)->first) - unit != group)
      bad_image(at + ": leaf child " + std::to_string(i) + "'s group size differs from its cluster's");
    return cd.unit_ref[size_t(it - block_at.begin())];
  }
  if (prim_layout(h) != PrimLayout::kRecords) {
    const uint64_t block_end = h.record_bytes / kGranuleBytes;
    const auto it = std::lower_bound(block_at.begin(), block_at.end(), std::make_pair(unit, uint32_t(0)));
    if (it == block_at.end() || it->first != unit)
      bad_image(at + ": leaf child " + std::to_string(i) + " does not point at the start of a block");
    const bool last = it + 1 == block_at.end();
    if ((last ? block_end : (it + 1)->first) - unit != group)
      bad_image(at + ": leaf child " + std::to_string(i) + "'s group size differs from its block's");
    first = it->second;
    count = (last ? h.record_count : (it + 1)->second) - it->second;
  } else if (count > uint64_t(kMaxLeafSize)) {
    bad_image(at + ": leaf child " + std::to_string(i) + " of more than 16 records");
  }
  if (first + count > h.record_count || first > kMaxLeafFirst) bad_image(at + ": leaf outside the records");
  return make_leaf(uint32_t(first), uint32_t(count));
}

// Packed nodes -> nodes of kind K (into `nodes`): the kind's fields, then the children's references from the node
// base, the primitive base and the meta.
template <NodeKind K>
void decode_packed_nodes(const uint8_t* image, const ImageHeader& h, const NodeFields& fl,
                         const BlockStarts& block_at, const ClusterDecode& cd, std::vector<uint64_t>& nodes) {
  using Node = typename K::Node;
  nodes.assign(((size_t(h.node_count) + cd.nodes.size()) * sizeof(Node) + 7) / 8, 0);
  uint8_t* out = reinterpret_cast<uint8_t*>(nodes.data());
  const uint8_t* in = image + h.node_offset;
  for (uint32_t n = 0; n < h.node_count; ++n) {
    const std::string at = "node " + std::to_string(n);
    PackedNode pn;
    try {
      pn = unpack_node(in + size_t(n) * h.node_bytes, h.node_bytes, fl, at);
    } catch (const std::invalid_argument& e) {
      bad_image(e.what());
    }
    Node node;
    const std::string why = K::from_packed(pn, node);
    if (!why.empty()) bad_image(at + ": " + why);
    uint64_t inner = pn.node_base, unit = pn.prim_base;
    for (int i = 0; i < K::kWidth; ++i) {
      uint32_t ref = kEmptyChild;
      if (i < pn.count && !pn.leaf[i]) {
        if (inner >= h.node_count) bad_image(at + ": child node out of range");
        ref = uint32_t(inner++);
      } else if (i < pn.count) {
        ref = packed_leaf_ref(h, block_at, cd, at, i, unit, pn.group[i]);
        unit += pn.group[i];
      }
      K::set_child(node, i, ref);
    }
    std::memcpy(out + size_t(n) * sizeof(Node), &node, sizeof(Node));
  }
  // The clusters' internal nodes: the kind's fields, the references their cluster gave them.
  for (size_t j = 0; j < cd.nodes.size(); ++j) {
    Node node;
    const std::string why = K::from_packed(cd.nodes[j], node);
    if (!why.empty()) bad_image("cluster node " + std::to_string(h.node_count + j) + ": " + why);
    for (int i = 0; i < K::kWidth; ++i) K::set_child(node, i, cd.refs[j][size_t(i)]);
    std::memcpy(out + (size_t(h.node_count) + j) * sizeof(Node), &node, sizeof(Node));
  }
}

// Records: kind and index agree, each record's fields as its primitive kind checks them (prim_kinds.h).
void check_records(const DeviceImage& img, const FixedFormat& f) {
  const ImageHeader& h = img.header();
  const bool top = h.flags & kImageTopLevel;
  const int64_t grid_max = (int64_t(1) << f.coord_bits) - 1;
  for (uint32_t i = 0; i < h.record_count; ++i) {
    const uint8_t* rec = img.record(i);
    uint32_t word;
    std::memcpy(&word, rec + 36, 4);
    const RecordKind kind = record_kind(rec);
    if ((word & kRecordNonOpaque) && !is_triangle(kind))
      bad_image("record " + std::to_string(i) + ": a sphere or instance marked non-opaque");
    if (top != (kind == RecordKind::kInstance))
      bad_image("record " + std::to_string(i) +
                (top ? ": a primitive in a top level" : ": an instance in a bottom level"));
    if (top) {
      InstanceRecord r;
      std::memcpy(&r, rec, sizeof r);
      for (int a = 0; a < 3; ++a)
        if (r.lo[a] < 0 || r.hi[a] > grid_max || r.lo[a] > r.hi[a])
          bad_image("record " + std::to_string(i) + ": instance bounds outside the grid");
      if (r.reserved[0] != 0 || r.reserved[1] != 0 || r.reserved[2] != 0)
        bad_image("record " + std::to_string(i) + ": reserved bits set");
      continue;
    }
    const RecordCheck c{f,
                        h.num_triangles,
                        uint64_t(h.num_triangles) + h.num_spheres,
                        (h.flags & kImageCurveBitsMask) != 0,
                        i,
                        i + 1 < h.record_count ? img.record(i + 1) : nullptr};
    std::string why;
    if (!with_record_prim(kind, [&](auto k) { why = decltype(k)::check(c, rec); }))
      bad_image("record " + std::to_string(i) + ": unknown kind");
    if (!why.empty()) bad_image(why);
  }
}

// Planes: a non-zero normal and an offset in range, in primitive order after the bounded primitives.
void check_planes(const DeviceImage& img, const FixedFormat& f) {
  const ImageHeader& h = img.header();
  const uint64_t num_bounded = uint64_t(h.num_triangles) + h.num_spheres;
  for (uint32_t i = 0; i < h.plane_count; ++i)
    if (const std::string why = PlanePrim::check(img.planes()[i], f, num_bounded, i); !why.empty()) bad_image(why);
}

bool leaf_in_records(uint32_t ref, const ImageHeader& h) {
  return uint64_t(leaf_first(ref)) + leaf_count(ref) <= h.record_count;
}

// The root: no nodes without a BVH, none for an empty root, a leaf root inside the records, else node 0. Returns
// whether there is a tree of nodes to check.
bool check_root(const ImageHeader& h) {
  if (h.flags & kImageNoBvh) {
    if (h.node_count != 0) bad_image("nodes in an image without a BVH");
    return false;
  }
  if (h.root_ref == kEmptyChild) {
    if (h.record_count != 0 || h.node_count != 0) bad_image("empty root with primitives");
    return false;
  }
  if (is_leaf(h.root_ref)) {
    if (!leaf_in_records(h.root_ref, h)) bad_image("root leaf outside the records");
    return false;
  }
  if (h.root_ref != 0 || h.node_count == 0) bad_image("root must be node 0");
  return true;
}

// Tree: each node's fields as its kind checks them, leaves inside the records, children after their parent (so no
// cycles), one parent per node (so no shared subtrees: a ray visits each node at most once), and no path deeper
// than the traversal stack holds.
template <NodeKind K>
void check_tree(const uint8_t* nodes, uint32_t node_total, const ImageHeader& h, const FixedFormat& f) {
  using Node = typename K::Node;
  constexpr int N = K::kWidth;
  std::vector<uint32_t> depth(node_total, 0);
  for (uint32_t n = 0; n < node_total; ++n) {
    Node nd;
    std::memcpy(&nd, nodes + size_t(n) * sizeof(Node), sizeof(Node));
    const std::string at = "node " + std::to_string(n) + ": ";
    const std::string why = K::check(nd, f);
    if (!why.empty()) bad_image(at + why);
    const int count = K::count(nd);
    for (int i = 0; i < N; ++i) {
      const uint32_t ref = K::child(nd, i);
      if (i >= count) {
        if (ref != kEmptyChild) bad_image(at + "an empty slot holds a child");
        continue;
      }
      if (is_leaf(ref)) {
        if (!leaf_in_records(ref, h)) bad_image(at + "leaf outside the records");
      } else if (ref <= n || ref >= node_total) {
        bad_image(at + "child node out of order or out of range");
      } else if (depth[ref] != 0) {
        // A node reached twice (a DAG) would be traversed once per path: exponential work for a small image.
        bad_image(at + "child node " + std::to_string(ref) + " has a second parent (the BVH must be a tree)");
      } else {
        depth[ref] = depth[n] + 1;
      }
    }
    // The stack holds at most N - 1 entries per level above the deepest node.
    if (uint64_t(depth[n] + 1) * uint64_t(N - 1) >= uint64_t(kTraversalStackSize)) bad_image(at + "too deep");
  }
}

}  // namespace

DeviceImage DeviceImage::from_bytes(const uint8_t* data, size_t bytes) {
  if (bytes < sizeof(ImageHeader) || bytes % 8 != 0)
    bad_image("size " + std::to_string(bytes) + " is below the header or not a multiple of 8");
  DeviceImage img;
  img.m_words.assign(bytes / 8, 0);
  std::memcpy(img.m_words.data(), data, bytes);
  img.check();
  return img;
}

void DeviceImage::check() {
  const ImageHeader& h = header();
  const uint64_t bytes = uint64_t(m_words.size()) * 8;
  const FixedFormat f = format();
  check_header(h, f, bytes);
  const NodeKindId kind = node_kind(h);
  const NodeFields fields = check_layouts(h, f, node_struct_bytes(kind, h.width, h.q_bytes));
  check_sections(h, bytes);
  m_records.clear();
  m_spans.clear();
  m_cluster_spans.clear();
  m_record_flags.clear();
  BlockStarts block_at;
  ClusterDecode cd;
  if (prim_layout(h) == PrimLayout::kClusters)
    block_at = decode_clusters(data(), h, f, m_records, m_spans, m_cluster_spans, m_record_flags, cd);
  else if (prim_layout(h) != PrimLayout::kRecords)
    block_at = decode_blocks(data(), h, f, m_records, m_spans);
  check_records(*this, f);
  check_planes(*this, f);
  if (!check_root(h)) {
    if (!cd.nodes.empty()) bad_image("cluster nodes without a tree of nodes to reach them");
    return;
  }
  with_node_kind(kind, h.width, h.q_bytes, [&](auto k) {
    using K = decltype(k);
    if (node_layout(h) != NodeLayout::kStructs) decode_packed_nodes<K>(data(), h, fields, block_at, cd, m_nodes);
    check_tree<K>(reinterpret_cast<const uint8_t*>(this->nodes<uint8_t>()), node_total(), h, f);
  });
}

}  // namespace rtu::hw
