#include "hwmodel/format/cluster_layout.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <stdexcept>

#include "hwmodel/format/hw_format.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

namespace {

constexpr int kTriBits = 8, kNodeBits = 8, kVertBits = 10, kAxisBits = 6, kPrimOffBits = 5, kPrimBaseBits = 30;
constexpr int kGroupBits = 4;  // a leaf's triangles - 1: sub-groups of at most 16, the BVH's leaves
static_assert((1 << kTriBits) == kMaxClusterTris && (1 << kNodeBits) - 1 == kMaxClusterNodes &&
              (1 << kVertBits) == kMaxClusterVerts);

// The internal nodes' field widths: those of a bit-packed node (node_fields) whatever the top tree's layout.
NodeFields cluster_node_fields(const FixedFormat& f) {
  FixedFormat g = f;
  g.node_layout = 1;
  return node_fields(g, 0, 0, 0);
}

// The range a decoded node origin must lie in: the one DeviceImage's node check and packed_layout.h's origin field
// give ([-2^B, 2^(B+1)], oriented nodes [-2^(B+2), 2^(B+2)]), and inside int32 (QNode's field).
void origin_range(const FixedFormat& f, int64_t& lo, int64_t& hi) {
  const int B = f.coord_bits;
  const bool oriented = f.node_kind_id() == NodeKindId::kOrientedAabb;
  lo = oriented ? -(int64_t(1) << (B + 2)) : -(int64_t(1) << B);
  hi = oriented ? int64_t(1) << (B + 2) : int64_t(1) << (B + 1);
  lo = std::max<int64_t>(lo, INT32_MIN);
  hi = std::min<int64_t>(hi, INT32_MAX);
}

uint32_t lines_of(uint64_t bits) {
  return uint32_t((bits + 8 * kClusterLineBytes - 1) / (8 * kClusterLineBytes));
}

}  // namespace

bool clusterable(const uint8_t* records, uint32_t count) {
  for (uint32_t i = 0; i < count; ++i) {
    uint32_t word;
    std::memcpy(&word, records + size_t(i) * kRecordBytes + 36, 4);
    if (record_kind(records + size_t(i) * kRecordBytes) != RecordKind::kTriangle || (word & kRecordNonOpaque))
      return false;
  }
  return count > 0;
}

uint32_t encode_cluster(const Cluster& c, const FixedFormat& f, std::vector<uint8_t>& out) {
  const size_t count = c.records.size() / kRecordBytes;
  if (count < 1 || count > size_t(kMaxClusterTris) || c.records.size() % kRecordBytes != 0)
    throw std::logic_error("encode_cluster: a cluster of 1 to 256 triangles");
  if (!clusterable(c.records.data(), uint32_t(count)))
    throw std::logic_error("encode_cluster: a cluster holds opaque triangles only");
  if (c.nodes.empty() && count > size_t(kMaxLeafSize))
    throw std::logic_error("encode_cluster: a cluster without internal nodes is one leaf of at most 16");
  if (c.nodes.size() > size_t(kMaxClusterNodes)) return 0;
  const NodeFields nf = cluster_node_fields(f);
  // The distinct vertices in order of first use; the anchor bounds the vertices and the node origins.
  TriangleGroup g = group_triangles(c.records.data(), count);
  int64_t(&lo)[3] = g.lo;
  int64_t(&hi)[3] = g.hi;
  for (const PackedNode& n : c.nodes)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min<int64_t>(lo[a], n.origin[a]);
      hi[a] = std::max<int64_t>(hi[a], n.origin[a]);
    }
  if (g.verts.size() > size_t(kMaxClusterVerts)) return 0;
  int axis[3];
  for (int a = 0; a < 3; ++a) {
    axis[a] = bits_for(uint64_t(hi[a] - lo[a]));
    if (axis[a] > nf.origin || lo[a] + (int64_t(1) << nf.origin_bias) < 0)
      throw std::logic_error("encode_cluster: an anchor or offset beyond the origin field");
  }

  std::vector<uint8_t> bytes;
  BitWriter w(bytes);
  w.put(1, 1);
  w.put(count - 1, kTriBits);
  w.put(c.nodes.size(), kNodeBits);
  w.put(g.verts.size() - 1, kVertBits);
  for (int a = 0; a < 3; ++a) w.put(uint64_t(axis[a]), kAxisBits);
  for (int a = 0; a < 3; ++a) w.put(uint64_t(lo[a] + (int64_t(1) << nf.origin_bias)), nf.origin);
  g.put_body(w, axis, kPrimOffBits, kPrimBaseBits);
  for (const PackedNode& n : c.nodes) {
    if (n.count < 1 || n.count > f.width)
      throw std::logic_error("encode_cluster: a node's count beyond its width");
    for (int a = 0; a < 3; ++a) w.put(uint64_t(n.origin[a] - lo[a]), axis[a]);
    for (int a = 0; a < 3; ++a) w.put(uint64_t(n.exp[a]), nf.exp);
    w.put(uint64_t(n.count - 1), nf.count);
    w.put(n.rot, nf.rot);
    for (int i = 0; i < f.width; ++i) {
      const bool leaf = i < n.count && n.leaf[i];
      if (leaf && (n.group[i] < 1 || n.group[i] > uint32_t(kMaxLeafSize)))
        throw std::logic_error("encode_cluster: a leaf of 1 to 16 triangles");
      w.put(leaf, 1);
      w.put(leaf ? n.group[i] - 1 : 0, kGroupBits);
    }
    for (int r = 0; r < 6; ++r)
      for (int i = 0; i < f.width; ++i) w.put(i < n.count ? n.q[r][i] : 0, nf.q);
  }
  const uint32_t lines = lines_of(w.bits());
  if (lines > kMaxClusterLines) return 0;
  w.pad_to(uint64_t(lines) * kClusterLineBytes);
  out.insert(out.end(), bytes.begin(), bytes.end());
  return lines;
}

uint32_t encode_raw_unit(const uint8_t* records, int count, const FixedFormat& f, std::vector<uint8_t>& out) {
  if (clusterable(records, uint32_t(count)))
    throw std::logic_error("encode_raw_unit: opaque triangles go into clusters");
  const size_t start = out.size();
  const uint32_t granules = encode_block(records, count, f.coord_bits, out);  // raw: not all opaque triangles
  const uint32_t lines = lines_of(uint64_t(granules) * kGranuleBytes * 8);
  out.resize(start + size_t(lines) * kClusterLineBytes, 0);
  return lines;
}

uint32_t decode_cluster_unit(const uint8_t* data, uint64_t bytes, const FixedFormat& f, Cluster& out,
                             const std::string& at) {
  out.nodes.clear();
  out.records.clear();
  if (bytes == 0) throw std::invalid_argument(at + ": truncated");
  if ((data[0] & 1u) == 0) {  // a raw block, padded to its line
    const uint32_t granules = decode_block(data, bytes, f.coord_bits, out.records, at);
    const uint32_t lines = lines_of(uint64_t(granules) * kGranuleBytes * 8);
    if (uint64_t(lines) * kClusterLineBytes > bytes) throw std::invalid_argument(at + ": truncated");
    for (uint64_t b = uint64_t(granules) * kGranuleBytes; b < uint64_t(lines) * kClusterLineBytes; ++b)
      if (data[b] != 0) throw std::invalid_argument(at + ": padding not zero");
    return lines;
  }
  const NodeFields nf = cluster_node_fields(f);
  const int B = f.coord_bits;
  BitReader r(data, bytes, at);
  r.get(1);
  const int count = int(r.get(kTriBits)) + 1;
  const int nn = int(r.get(kNodeBits));
  const int nv = int(r.get(kVertBits)) + 1;
  if (nn == 0 && count > kMaxLeafSize)
    throw std::invalid_argument(at + ": a cluster without internal nodes of more than 16 triangles");
  if (nv > 3 * count) throw std::invalid_argument(at + ": more vertices than its triangles have");
  int axis[3];
  for (int& a : axis) {
    a = int(r.get(kAxisBits));
    if (a > nf.origin) throw std::invalid_argument(at + ": vertex offsets wider than the anchor's field");
  }
  int64_t anchor[3];
  for (int64_t& a : anchor) a = int64_t(r.get(nf.origin)) - (int64_t(1) << nf.origin_bias);
  const int pbits = int(r.get(kPrimOffBits));
  if (pbits > kPrimBaseBits) throw std::invalid_argument(at + ": primitive offsets wider than 30 bits");
  const uint64_t pbase = r.get(kPrimBaseBits);
  std::vector<uint32_t> prims(static_cast<size_t>(count));
  for (uint32_t& p : prims) {
    const uint64_t v = pbase + r.get(pbits);
    if (v > kRecordPrimMask) throw std::invalid_argument(at + ": primitive index beyond 27 bits");
    p = uint32_t(v);
  }
  const int64_t grid_max = (int64_t(1) << B) - 1;
  std::vector<std::array<int32_t, 3>> verts(static_cast<size_t>(nv));
  for (auto& v : verts)
    for (int a = 0; a < 3; ++a) {
      const int64_t c = anchor[a] + int64_t(r.get(axis[a]));
      if (c < 0 || c > grid_max) throw std::invalid_argument(at + ": vertex outside the grid");
      v[size_t(a)] = int32_t(c);
    }
  const int ibits = bits_for(uint64_t(nv - 1));
  out.records.resize(size_t(count) * kRecordBytes);
  for (int i = 0; i < count; ++i) {
    TriangleRecord t{};
    for (int k = 0; k < 3; ++k) {
      const uint64_t j = r.get(ibits);
      if (j >= uint64_t(nv)) throw std::invalid_argument(at + ": vertex index beyond its vertices");
      for (int a = 0; a < 3; ++a) t.v[k][a] = verts[j][size_t(a)];
    }
    t.prim = record_word(RecordKind::kTriangle, prims[size_t(i)]);
    std::memcpy(out.records.data() + size_t(i) * kRecordBytes, &t, sizeof t);
  }
  int64_t olo, ohi;
  origin_range(f, olo, ohi);
  out.nodes.resize(size_t(nn));
  int next = 1, tris = 0;  // the next node an inner child numbers; triangles the leaves so far hold
  for (int j = 0; j < nn; ++j) {
    const std::string node_at = at + ", internal node " + std::to_string(j);
    if (j >= next) throw std::invalid_argument(node_at + ": no earlier node's child");
    PackedNode& n = out.nodes[size_t(j)];
    for (int a = 0; a < 3; ++a) {
      const int64_t o = anchor[a] + int64_t(r.get(axis[a]));
      if (o < olo || o > ohi) throw std::invalid_argument(node_at + ": origin out of range");
      n.origin[a] = int32_t(o);
    }
    for (int& e : n.exp) e = int(r.get(nf.exp));
    n.count = int(r.get(nf.count)) + 1;
    if (n.count > f.width) throw std::invalid_argument(node_at + ": child count beyond the node width");
    n.rot = uint32_t(r.get(nf.rot));
    for (int i = 0; i < f.width; ++i) {
      const bool leaf = r.get(1) != 0;
      const uint64_t g = r.get(kGroupBits);
      if (i >= n.count && (leaf || g != 0)) throw std::invalid_argument(node_at + ": an empty slot holds a child");
      if (!leaf && g != 0) throw std::invalid_argument(node_at + ": an inner child with a group size");
      n.leaf[i] = leaf;
      n.group[i] = leaf ? uint32_t(g) + 1 : 0;
      if (i >= n.count) continue;
      if (leaf) {
        tris += int(n.group[i]);
      } else if (++next > nn) {
        throw std::invalid_argument(node_at + ": more inner children than the cluster's internal nodes");
      }
    }
    for (int rr = 0; rr < 6; ++rr)
      for (int i = 0; i < f.width; ++i) {
        n.q[rr][i] = uint32_t(r.get(nf.q));
        if (i >= n.count && n.q[rr][i] != 0) throw std::invalid_argument(node_at + ": an empty slot holds a box");
      }
  }
  if (nn > 0 && next != nn)
    throw std::invalid_argument(at + ": " + std::to_string(nn - next) + " internal nodes are no node's child");
  if (nn > 0 && tris != count)
    throw std::invalid_argument(at + ": its leaves hold " + std::to_string(tris) + " triangles, its count says " +
                                std::to_string(count));
  const uint32_t lines = lines_of(r.pos());
  if (uint64_t(lines) * kClusterLineBytes > bytes) throw std::invalid_argument(at + ": truncated");
  if (!r.zero_to(uint64_t(lines) * kClusterLineBytes)) throw std::invalid_argument(at + ": padding not zero");
  return lines;
}

}  // namespace rtu::hw
