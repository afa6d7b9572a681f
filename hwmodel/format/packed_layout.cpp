#include "hwmodel/format/packed_layout.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <map>
#include <stdexcept>

#include "hwmodel/format/hw_format.h"

namespace rtu::hw {

uint64_t NodeFields::bits() const {
  return 3 * uint64_t(origin + exp) + uint64_t(count + rot + node_base + prim_base) +
         uint64_t(width) * (1 + group) + 6 * uint64_t(width) * uint64_t(q);
}

uint64_t NodeFields::bytes(int align) const {
  const uint64_t b = (bits() + 7) / 8, a = uint64_t(align < 1 ? 1 : align);
  return (b + a - 1) / a * a;
}

NodeFields node_fields(const FixedFormat& f, int base_bits, int prim_bits, int group_bits) {
  NodeFields n;
  n.width = f.width;
  const bool oriented = f.node_kind_id() == NodeKindId::kOrientedAabb;
  n.origin_bias = oriented ? f.coord_bits + 2 : f.coord_bits;
  if (f.node_layout_id() == NodeLayout::kCompressedWide) {
    n.origin = 32;
    n.exp = 8;
    n.count = 8;
    n.rot = oriented ? 16 : 0;
    n.node_base = 32;
    n.prim_base = 32;
    n.group = 7;
    n.q = 8 * f.offset_bytes();
    return n;
  }
  // Origins lie in [-2^B, 2^(B+1)] (DeviceImage's check), stored plus 2^B; an oriented node's in [-2^(B+2),
  // 2^(B+2)], stored plus 2^(B+2); scales up to B+1 (B+3 oriented).
  n.origin = oriented ? f.coord_bits + 4 : f.coord_bits + 2;
  n.exp = bits_for(uint64_t(f.coord_bits) + (oriented ? 3 : 1));
  n.rot = oriented ? bits_for(uint64_t(f.rotations) - 1) : 0;
  n.count = bits_for(uint64_t(f.width) - 1);
  n.node_base = base_bits;
  n.prim_base = prim_bits;
  n.group = group_bits;
  n.q = f.child_bits;
  return n;
}

void BitWriter::put(uint64_t v, int bits) {
  if (bits < 64 && (v >> bits) != 0) throw std::logic_error("packed layout: a value wider than its field");
  for (int i = 0; i < bits; ++i, ++m_bits) {
    const uint64_t byte = m_start + m_bits / 8;
    if (byte >= m_out.size()) m_out.push_back(0);
    m_out[byte] = uint8_t(m_out[byte] | (((v >> i) & 1u) << (m_bits % 8)));
  }
}

void BitWriter::pad_to(uint64_t bytes) {
  if (m_bits > bytes * 8) throw std::logic_error("packed layout: fields beyond the padded size");
  m_out.resize(m_start + bytes, 0);
  m_bits = bytes * 8;
}

uint64_t BitReader::get(int bits) {
  if (m_pos + uint64_t(bits) > m_n * 8) throw std::invalid_argument(m_what + ": truncated");
  uint64_t v = 0;
  for (int i = 0; i < bits; ++i, ++m_pos) v |= uint64_t((m_d[m_pos / 8] >> (m_pos % 8)) & 1u) << i;
  return v;
}

bool BitReader::zero_to(uint64_t bytes) const {
  for (uint64_t p = m_pos; p < bytes * 8 && p < m_n * 8; ++p)
    if ((m_d[p / 8] >> (p % 8)) & 1u) return false;
  return true;
}

void pack_node(const PackedNode& n, const NodeFields& f, uint64_t bytes, std::vector<uint8_t>& out) {
  BitWriter w(out);
  for (int a = 0; a < 3; ++a) w.put(uint64_t(int64_t(n.origin[a]) + (int64_t(1) << f.origin_bias)), f.origin);
  for (int a = 0; a < 3; ++a) w.put(uint64_t(n.exp[a]), f.exp);
  w.put(uint64_t(n.count - 1), f.count);
  w.put(n.rot, f.rot);
  w.put(n.node_base, f.node_base);
  w.put(n.prim_base, f.prim_base);
  for (int i = 0; i < f.width; ++i) {
    const bool used = i < n.count;
    w.put(used && n.leaf[i], 1);
    w.put(used && n.leaf[i] ? n.group[i] - 1 : 0, f.group);
  }
  for (int r = 0; r < 6; ++r)
    for (int i = 0; i < f.width; ++i) w.put(i < n.count ? n.q[r][i] : 0, f.q);
  w.pad_to(bytes);
}

PackedNode unpack_node(const uint8_t* data, uint64_t bytes, const NodeFields& f, const std::string& at) {
  BitReader r(data, bytes, at);
  PackedNode n;
  for (int a = 0; a < 3; ++a) n.origin[a] = int32_t(int64_t(r.get(f.origin)) - (int64_t(1) << f.origin_bias));
  for (int a = 0; a < 3; ++a) n.exp[a] = int(r.get(f.exp));
  n.count = int(r.get(f.count)) + 1;
  if (n.count > f.width) throw std::invalid_argument(at + ": child count beyond the node width");
  n.rot = uint32_t(r.get(f.rot));
  n.node_base = r.get(f.node_base);
  n.prim_base = r.get(f.prim_base);
  for (int i = 0; i < f.width; ++i) {
    const bool leaf = r.get(1) != 0;
    const uint64_t g = r.get(f.group);
    if (i >= n.count && (leaf || g != 0)) throw std::invalid_argument(at + ": an empty slot holds a child");
    if (!leaf && g != 0) throw std::invalid_argument(at + ": an inner child with a group size");
    n.leaf[i] = leaf;
    n.group[i] = leaf ? uint32_t(g) + 1 : 0;
  }
  for (int rr = 0; rr < 6; ++rr)
    for (int i = 0; i < f.width; ++i) {
      n.q[rr][i] = uint32_t(r.get(f.q));
      if (i >= n.count && n.q[rr][i] != 0) throw std::invalid_argument(at + ": an empty slot holds a box");
    }
  if (!r.zero_to(bytes)) throw std::invalid_argument(at + ": padding not zero");
  return n;
}

namespace {

constexpr int kKindBits = 1, kCountBits = 4, kVertBits = 6, kAxisBits = 5, kPrimOffBits = 5, kPrimBaseBits = 30;
constexpr int kMaxBlockVerts = 1 << kVertBits;

uint32_t granules(uint64_t bits) {
  return uint32_t((bits + 63) / 64);
}

}  // namespace

TriangleGroup group_triangles(const uint8_t* records, size_t count) {
  TriangleGroup g;
  std::map<std::array<int32_t, 3>, uint32_t> index;
  g.idx.resize(count);
  g.prims.resize(count);
  for (size_t i = 0; i < count; ++i) {
    TriangleRecord t;
    std::memcpy(&t, records + i * kRecordBytes, sizeof t);
    g.prims[i] = t.prim & kRecordPrimMask;
    g.pmin = std::min(g.pmin, g.prims[i]);
    g.pmax = std::max(g.pmax, g.prims[i]);
    for (int k = 0; k < 3; ++k) {
      const std::array<int32_t, 3> v = {t.v[k][0], t.v[k][1], t.v[k][2]};
      const auto [it, added] = index.emplace(v, uint32_t(g.verts.size()));
      if (added) g.verts.push_back(v);
      g.idx[i][size_t(k)] = it->second;
      for (int a = 0; a < 3; ++a) {
        g.lo[a] = std::min<int64_t>(g.lo[a], v[size_t(a)]);
        g.hi[a] = std::max<int64_t>(g.hi[a], v[size_t(a)]);
      }
    }
  }
  return g;
}

void TriangleGroup::put_body(BitWriter& w, const int axis[3], int off_bits, int base_bits) const {
  const int pbits = prim_bits(), ibits = index_bits();
  w.put(uint64_t(pbits), off_bits);
  w.put(pmin, base_bits);
  for (uint32_t p : prims) w.put(p - pmin, pbits);
  for (const auto& v : verts)
    for (int a = 0; a < 3; ++a) w.put(uint64_t(v[size_t(a)] - lo[a]), axis[a]);
  for (const auto& t : idx)
    for (uint32_t k : t) w.put(k, ibits);
}

uint32_t encode_block(const uint8_t* records, int count, int B, std::vector<uint8_t>& out) {
  if (count < 1 || count > (1 << kCountBits)) throw std::logic_error("encode_block: group size out of range");
  const uint32_t raw = 1 + uint32_t(count) * uint32_t(kRecordBytes / kGranuleBytes);
  bool triangles = true;
  // Compressed blocks hold opaque triangles only; a block with a sphere or a non-opaque triangle stays raw.
  for (int i = 0; i < count; ++i) {
    uint32_t word;
    std::memcpy(&word, records + i * kRecordBytes + 36, 4);
    triangles = triangles && record_kind(records + i * kRecordBytes) == RecordKind::kTriangle &&
                !(word & kRecordNonOpaque);
  }
  const TriangleGroup g = triangles ? group_triangles(records, size_t(count)) : TriangleGroup{};
  int axis[3] = {0, 0, 0};
  const int nv = int(g.verts.size());
  const int ibits = g.index_bits(), pbits = g.prim_bits();
  uint64_t bits = 0;
  if (triangles) {
    for (int a = 0; a < 3; ++a) axis[a] = bits_for(uint64_t(g.hi[a] - g.lo[a]));
    bits = kKindBits + kCountBits + kVertBits + 3 * kAxisBits + 3 * uint64_t(B) + kPrimOffBits + kPrimBaseBits +
           uint64_t(count) * uint64_t(pbits) + uint64_t(nv) * uint64_t(axis[0] + axis[1] + axis[2]) +
           3 * uint64_t(count) * uint64_t(ibits);
  }
  BitWriter w(out);
  if (!triangles || nv > kMaxBlockVerts || granules(bits) >= raw) {
    w.put(0, kKindBits);
    w.put(uint64_t(count - 1), kCountBits);
    w.pad_to(kGranuleBytes);
    out.insert(out.end(), records, records + size_t(count) * kRecordBytes);
    return raw;
  }
  w.put(1, kKindBits);
  w.put(uint64_t(count - 1), kCountBits);
  w.put(uint64_t(nv - 1), kVertBits);
  for (int a = 0; a < 3; ++a) w.put(uint64_t(axis[a]), kAxisBits);
  for (int a = 0; a < 3; ++a) w.put(uint64_t(g.lo[a]), B);
  g.put_body(w, axis, kPrimOffBits, kPrimBaseBits);
  w.pad_to(uint64_t(granules(bits)) * kGranuleBytes);
  return granules(bits);
}

uint32_t decode_block(const uint8_t* data, uint64_t bytes, int B, std::vector<uint8_t>& records,
                      const std::string& at) {
  BitReader r(data, bytes, at);
  const bool triangles = r.get(kKindBits) != 0;
  const int count = int(r.get(kCountBits)) + 1;
  if (!triangles) {
    const uint32_t size = 1 + uint32_t(count) * uint32_t(kRecordBytes / kGranuleBytes);
    if (!r.zero_to(kGranuleBytes)) throw std::invalid_argument(at + ": raw block header not zero after its count");
    if (uint64_t(size) * kGranuleBytes > bytes) throw std::invalid_argument(at + ": truncated");
    records.insert(records.end(), data + kGranuleBytes, data + kGranuleBytes + size_t(count) * kRecordBytes);
    return size;
  }
  const int nv = int(r.get(kVertBits)) + 1;
  if (nv > 3 * count) throw std::invalid_argument(at + ": more vertices than its triangles have");
  int axis[3];
  for (int& a : axis) {
    a = int(r.get(kAxisBits));
    if (a > B) throw std::invalid_argument(at + ": vertex offsets wider than coord_bits");
  }
  int64_t anchor[3];
  for (int64_t& a : anchor) a = int64_t(r.get(B));
  const int pbits = int(r.get(kPrimOffBits));
  if (pbits > kPrimBaseBits) throw std::invalid_argument(at + ": primitive offsets wider than 30 bits");
  const uint64_t pbase = r.get(kPrimBaseBits);
  std::vector<uint64_t> prims(static_cast<size_t>(count));
  for (uint64_t& p : prims) {
    p = pbase + r.get(pbits);
    if (p > kRecordPrimMask) throw std::invalid_argument(at + ": primitive index beyond 27 bits");
  }
  std::vector<std::array<int64_t, 3>> verts(static_cast<size_t>(nv));
  for (auto& v : verts)
    for (int a = 0; a < 3; ++a) v[size_t(a)] = anchor[a] + int64_t(r.get(axis[a]));
  const int ibits = bits_for(uint64_t(nv - 1));
  const size_t first = records.size();
  records.resize(first + size_t(count) * kRecordBytes);
  for (int i = 0; i < count; ++i) {
    TriangleRecord t{};
    for (int k = 0; k < 3; ++k) {
      const uint64_t j = r.get(ibits);
      if (j >= uint64_t(nv)) throw std::invalid_argument(at + ": vertex index beyond its vertices");
      for (int a = 0; a < 3; ++a) {
        const int64_t c = verts[j][size_t(a)];
        // Below 2^31 (anchor and offset below 2^30 each); the grid range is the caller's check.
        t.v[k][a] = int32_t(c);
      }
    }
    t.prim = record_word(RecordKind::kTriangle, uint32_t(prims[size_t(i)]));
    std::memcpy(records.data() + first + size_t(i) * kRecordBytes, &t, sizeof t);
  }
  const uint32_t size = granules(r.pos());
  if (uint64_t(size) * kGranuleBytes > bytes) throw std::invalid_argument(at + ": truncated");
  if (!r.zero_to(uint64_t(size) * kGranuleBytes)) throw std::invalid_argument(at + ": padding not zero");
  return size;
}

}  // namespace rtu::hw
