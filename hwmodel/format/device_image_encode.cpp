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
#include "hwmodel/format/rotation_table.h"

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

  // Float box -> grid, rounded outward.
  GridBox outward(const Aabb& b) const {
    GridBox g;
    for (int a = 0; a < 3; ++a) {
      g.lo[a] = m_frame.to_grid(b.lo[a], a, Round::kDown);
      g.hi[a] = m_frame.to_grid(b.hi[a], a, Round::kUp);
    }
    return g;
  }

  // Encodes one node of kind K and checks that every decoded child box contains its grid box and its float box.
  template <NodeKind K>
  void encode_node(typename K::Node& node, const GridBox* boxes, const Aabb* float_boxes, const uint32_t* refs,
                   int count) const {
    K::encode(node, boxes, refs, count, m_f);
    for (int i = 0; i < count; ++i) {
      int64_t dlo[3], dhi[3];
      K::child_box(node, i, dlo, dhi);
      for (int a = 0; a < 3; ++a) {
        const bool ok = dlo[a] <= boxes[i].lo[a] && dhi[a] >= boxes[i].hi[a] &&
                        m_frame.to_world(dlo[a], a) <= double(float_boxes[i].lo[a]) &&
                        m_frame.to_world(dhi[a], a) >= double(float_boxes[i].hi[a]);
        if (!ok) throw std::logic_error("encoder: a quantized child box does not contain its exact box");
      }
    }
  }

  template <NodeKind K>
  void encode_tree(const WideBvh<K::kWidth>& t, std::vector<typename K::Node>& nodes,
                   std::vector<uint8_t>& records) {
    records.assign(t.prim_ids.size() * kRecordBytes, 0);
    m_record_boxes.assign(t.prim_ids.size(), GridBox{});
    for (size_t i = 0; i < t.prim_ids.size(); ++i)
      make_record(t.prim_ids[i], records.data() + i * kRecordBytes, m_record_boxes[i]);
    m_records_bytes = records.data();
    if (m_f.tri_pairs) {
      if (is_leaf(t.root_ref) && t.root_ref != kEmptyChild)
        mark_pairs(records.data(), leaf_first(t.root_ref), leaf_count(t.root_ref));
      for (const WideNode<K::kWidth>& n : t.nodes)
        for (uint32_t ref : n.child)
          if (ref != kEmptyChild && is_leaf(ref)) mark_pairs(records.data(), leaf_first(ref), leaf_count(ref));
    }
    nodes.resize(t.nodes.size());
    if (is_leaf(t.root_ref) || t.root_ref == kEmptyChild) return;
    if constexpr (K::kId == NodeKindId::kOrientedAabb) {
      m_rot = &rotation_table(m_f.rotations, m_f.rot_bits);
      subtree_oriented<K>(t, nodes, t.root_ref);
    } else {
      subtree<K>(t, nodes, t.root_ref);
    }
  }

 private:
  // Oriented kinds: what lies below a subtree, as the extents of its points along each rotation's axes: element
  // 6k + 2a is the least (M_k p)_a over its points p (grid integers times the table's integers: exact), 6k + 2a +
  // 1 the greatest. A triangle's points are its vertices (its hull lies within); a curve segment's its end points,
  // widened by its larger radius times the row's length (both rounded up: the union of its spheres lies within);
  // other records' the corners of their grid boxes.
  using Extents = std::vector<int64_t>;

  Extents record_extents(uint32_t i) const {
    const std::vector<Rotation>& rot = *m_rot;
    Extents e(6 * rot.size());
    for (size_t k = 0; k < rot.size(); ++k)
      for (int a = 0; a < 3; ++a) {
        e[6 * k + 2 * a] = INT64_MAX;
        e[6 * k + 2 * a + 1] = INT64_MIN;
      }
    int64_t pts[8][3];
    int np = 0;
    int64_t pad = 0;  // curve segments: the larger radius in grid units, rounded up
    const uint8_t* rec = m_records_bytes + size_t(i) * kRecordBytes;
    if (is_curve_record(rec)) {
      CurveRecord cr;
      std::memcpy(&cr, rec, sizeof cr);
      for (int a = 0; a < 3; ++a) {
        pts[0][a] = cr.p0[a];
        pts[1][a] = cr.p1[a];
      }
      np = 2;
      const int64_t r = std::max(curve_radius(cr.r0), curve_radius(cr.r1));
      pad = ceil_shift(r, m_f.frac_bits);
    } else if (is_triangle(record_kind(rec))) {
      TriangleRecord tr;
      std::memcpy(&tr, rec, sizeof tr);
      for (; np < 3; ++np)
        for (int a = 0; a < 3; ++a) pts[np][a] = tr.v[np][a];
    } else {
      const GridBox& b = m_record_boxes[i];
      for (; np < 8; ++np)
        for (int a = 0; a < 3; ++a) pts[np][a] = (np >> a) & 1 ? b.hi[a] : b.lo[a];
    }
    for (size_t k = 0; k < rot.size(); ++k)
      for (int a = 0; a < 3; ++a) {
        const int32_t* m = rot[k].m[a];
        int64_t& lo = e[6 * k + 2 * a];
        int64_t& hi = e[6 * k + 2 * a + 1];
        // The row's length, rounded up: a sphere of radius r spans r |m| along it.
        const int64_t len =
            pad == 0 ? 0
                     : int64_t(isqrt_round(Wide(m[0]) * m[0] + Wide(m[1]) * m[1] + Wide(m[2]) * m[2], Round::kUp));
        for (int p = 0; p < np; ++p) {
          const int64_t v = m[0] * pts[p][0] + m[1] * pts[p][1] + m[2] * pts[p][2];
          lo = std::min(lo, v - pad * len);
          hi = std::max(hi, v + pad * len);
        }
      }
    return e;
  }

  static void merge(Extents& into, const Extents& e) {
    for (size_t j = 0; j < into.size(); j += 2) {
      into[j] = std::min(into[j], e[j]);
      into[j + 1] = std::max(into[j + 1], e[j + 1]);
    }
  }

  // Encodes the subtree's nodes, each in the rotation whose children's boxes have the least summed surface area
  // (the first such: the identity on a tie with it), and returns the subtree's extents.
  template <NodeKind K>
  Extents subtree_oriented(const WideBvh<K::kWidth>& t, std::vector<typename K::Node>& nodes, uint32_t ref) {
    constexpr int N = K::kWidth;
    if (is_leaf(ref)) {
      Extents all = record_extents(leaf_first(ref));
      for (uint32_t i = leaf_first(ref) + 1; i < leaf_first(ref) + leaf_count(ref); ++i)
        merge(all, record_extents(i));
      return all;
    }
    const WideNode<N>& fn = t.nodes[ref];
    Extents ext[N];
    uint32_t refs[N];
    int count = 0;
    for (int i = 0; i < N; ++i) {
      if (fn.child[i] == kEmptyChild) continue;
      ext[count] = subtree_oriented<K>(t, nodes, fn.child[i]);
      refs[count] = fn.child[i];
      ++count;
    }
    const size_t R = m_rot->size();
    size_t best = 0;
    double best_area = 0.0;
    for (size_t k = 0; k < R; ++k) {
      double area = 0.0;
      for (int i = 0; i < count; ++i) {
        const int64_t* e = ext[i].data() + 6 * k;
        const double dx = double(e[1] - e[0]), dy = double(e[3] - e[2]), dz = double(e[5] - e[4]);
        area += dx * dy + dy * dz + dz * dx;
      }
      if (k == 0 || area < best_area) {
        best = k;
        best_area = area;
      }
    }
    // The children's boxes in that frame, grid units: the extents divided by 2^rot_bits, outward.
    const int rb = m_f.rot_bits;
    GridBox boxes[N];
    for (int i = 0; i < count; ++i)
      for (int a = 0; a < 3; ++a) {
        boxes[i].lo[a] = round_shift64(ext[i][6 * best + 2 * a], rb, Round::kDown);
        boxes[i].hi[a] = round_shift64(ext[i][6 * best + 2 * a + 1], rb, Round::kUp);
      }
    typename K::Node& node = nodes[ref];
    K::encode_rotated(node, int(best), boxes, refs, count, m_f);
    for (int i = 0; i < count; ++i) {
      int64_t lo[3], hi[3];
      K::child_box(node, i, lo, hi);
      for (int a = 0; a < 3; ++a)
        if ((lo[a] << rb) > ext[i][6 * best + 2 * a] || (hi[a] << rb) < ext[i][6 * best + 2 * a + 1])
          throw std::logic_error("encoder: an oriented child box does not contain its points");
    }
    Extents all = std::move(ext[0]);
    for (int i = 1; i < count; ++i) merge(all, ext[i]);
    return all;
  }

  template <NodeKind K>
  GridBox subtree(const WideBvh<K::kWidth>& t, std::vector<typename K::Node>& nodes, uint32_t ref) {
    constexpr int N = K::kWidth;
    GridBox all;
    if (is_leaf(ref)) {
      for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) all.extend(m_record_boxes[i]);
      return all;
    }
    const WideNode<N>& fn = t.nodes[ref];
    GridBox boxes[N];
    Aabb fboxes[N];
    uint32_t refs[N];
    int count = 0;
    for (int i = 0; i < N; ++i) {
      if (fn.child[i] == kEmptyChild) continue;
      fboxes[count] = fn.child_box(i);
      boxes[count] = subtree<K>(t, nodes, fn.child[i]);
      boxes[count].extend(outward(fboxes[count]));
      refs[count] = fn.child[i];
      all.extend(boxes[count]);
      ++count;
    }
    encode_node<K>(nodes[ref], boxes, fboxes, refs, count);
    return all;
  }

  const Geometry& m_g;
  const FixedFormat& m_f;
  QuantFrame m_frame;
  std::vector<GridBox> m_record_boxes;
  const uint8_t* m_records_bytes = nullptr;  // encode_tree's records (oriented kinds read their vertices)
  const std::vector<Rotation>* m_rot = nullptr;
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
  f.prim_layout = 0;
  Encoder enc(boxes, ids, flat, f);
  return ImageWriter::write(enc, flat, f, &bvh, kImageTopLevel);
}

namespace {

// The node and primitive sections over the BVH: its nodes of the format's kind and its records in leaf order, as
// structs or, packed, in the format's layouts (with what they must decode to).
PackedTree tree_sections(Encoder& enc, const FixedFormat& f, const Bvh& bvh, NodeKindId kind) {
  PackedTree tree;
  const int q_bytes = f.offset_bytes();
  const bool packed = f.node_layout != 0;
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
  const bool packed = f.node_layout != 0;
  const uint32_t n = enc.record_count();
  tree.records.assign(size_t(n) * kRecordBytes, 0);
  for (uint32_t p = 0; p < n; ++p) {
    GridBox unused;
    enc.make_record(p, tree.records.data() + size_t(p) * kRecordBytes, unused);
  }
  if (f.tri_pairs) Encoder::mark_pairs(tree.records.data(), 0, n);
  // Blocks of up to 16 records (the group size a block holds), in order.
  for (uint32_t p = 0; p < n && f.prim_layout == 1; p += uint32_t(kMaxLeafSize))
    encode_block(tree.records.data() + size_t(p) * kRecordBytes, int(std::min<uint32_t>(kMaxLeafSize, n - p)),
                 f.coord_bits, tree.prims);
  // Clusters: leaves of up to 16 records without internal nodes, or raw blocks, in order.
  for (uint32_t p = 0; p < n && f.prim_layout == 2; p += uint32_t(kMaxLeafSize)) {
    const uint8_t* rec = tree.records.data() + size_t(p) * kRecordBytes;
    const uint32_t count = std::min<uint32_t>(kMaxLeafSize, n - p);
    Cluster c;
    c.records.assign(rec, rec + size_t(count) * kRecordBytes);
    if (!clusterable(rec, count))
      encode_raw_unit(rec, int(count), f, tree.prims);
    else if (encode_cluster(c, f, tree.prims) == 0)
      throw std::logic_error("encoder: a leaf that fits no cluster");
  }
  if (f.prim_layout == 0) tree.prims = tree.records;
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
  h.base_bits = uint8_t(f.node_layout == 1 ? tree.base_bits : 0);
  h.prim_bits = uint8_t(f.node_layout == 1 ? tree.prim_bits : 0);
  h.group_bits = uint8_t(f.node_layout == 1 ? tree.group_bits : 0);
  h.node_align = uint8_t(f.node_align);
  h.record_bytes = tree.prims.size();
  h.node_offset = align8(sizeof(ImageHeader));
  h.record_offset = align8(h.node_offset + tree.nodes.size());
  if (f.prim_layout == 2)  // clusters start on 64-byte lines of the image
    h.record_offset = (h.record_offset + kClusterLineBytes - 1) / kClusterLineBytes * kClusterLineBytes;
  h.plane_offset = align8(h.record_offset + tree.prims.size());
  h.total_bytes = align8(h.plane_offset + plane_count * sizeof(PlaneRecord));
  return h;
}

}  // namespace

DeviceImage ImageWriter::write(Encoder& enc, const Geometry& g, const FixedFormat& f, const Bvh* bvh,
                               uint32_t flags) {
  PackedTree tree;  // the node and primitive sections (and, packed, their expected decoding)
  const bool packed = f.node_layout != 0;
  const NodeKindId kind = f.node_kind == 1 ? NodeKindId::kOrientedAabb : NodeKindId::kQuantizedAabb;
  flags |= uint32_t(kind) << kImageNodeKindShift;
  if (kind == NodeKindId::kOrientedAabb)
    flags |= (uint32_t(f.rotations - 1) << kImageRotationsShift) | (uint32_t(f.rot_bits) << kImageRotBitsShift);
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
  if (packed || f.prim_layout != 0) {
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
