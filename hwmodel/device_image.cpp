#include "hwmodel/device_image.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "hwmodel/traverse.h"

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

size_t DeviceImage::node_bytes() const {
  return qnode_bytes(header().width, header().q_bytes);
}

namespace {

// A box on the grid, exact integers.
struct GridBox {
  int64_t lo[3] = {INT64_MAX, INT64_MAX, INT64_MAX};
  int64_t hi[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
  void extend(const GridBox& b) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], b.lo[a]);
      hi[a] = std::max(hi[a], b.hi[a]);
    }
  }
};

int64_t floor_shift(int64_t x, int s) {
  return int64_t(round_shift(x, s, Round::kDown));
}
int64_t ceil_shift(int64_t x, int s) {
  return int64_t(round_shift(x, s, Round::kUp));
}

class Encoder {
 public:
  Encoder(const Geometry& g, const FixedFormat& f) : m_g(g), m_f(f) {
    Aabb b = g.bounds();
    if (b.empty()) b = Aabb{Vec3(-1.0f), Vec3(1.0f)};  // planes only: any frame will do
    m_frame = QuantFrame::fit(b, f.coord_bits);
  }

  const QuantFrame& frame() const { return m_frame; }

  // The record of bounded primitive p and its grid bounds.
  void make_record(uint32_t p, uint8_t* out, GridBox& box) const {
    if (p < m_g.triangles.size()) {
      const Triangle& t = m_g.triangles[p];
      TriangleRecord rec{};
      const Vec3* v[3] = {&t.v0, &t.v1, &t.v2};
      for (int i = 0; i < 3; ++i) {
        for (int a = 0; a < 3; ++a) {
          const int64_t g = m_frame.to_grid((*v[i])[a], a, Round::kNearestEven);
          rec.v[i][a] = int32_t(g);  // in [0, 2^B - 1]: the vertex lies inside the frame's bounds
          box.lo[a] = std::min(box.lo[a], g);
          box.hi[a] = std::max(box.hi[a], g);
        }
      }
      rec.prim = (uint32_t(RecordKind::kTriangle) << 30) | p;
      std::memcpy(out, &rec, sizeof rec);
    } else {
      const Sphere& s = m_g.spheres[p - m_g.triangles.size()];
      SphereRecord rec{};
      const int F = m_f.frac_bits;
      // Radius in grid.F units, rounded up: r * 2^(F - step_exp) is exact in double (a float times a power of
      // two), and at least one unit so a sphere never vanishes.
      const double rs = std::ldexp(double(s.radius), F - m_frame.step_exp);
      rec.radius = std::max<int64_t>(1, int64_t(std::ceil(rs)));
      for (int a = 0; a < 3; ++a) {
        rec.center[a] = m_frame.to_grid(s.center[a], a, Round::kNearestEven, F);
        box.lo[a] = std::min(box.lo[a], floor_shift(rec.center[a] - rec.radius, F));
        box.hi[a] = std::max(box.hi[a], ceil_shift(rec.center[a] + rec.radius, F));
      }
      rec.prim = (uint32_t(RecordKind::kSphere) << 30) | p;
      std::memcpy(out, &rec, sizeof rec);
    }
  }

  PlaneRecord make_plane(uint32_t i) const {
    const Plane& pl = m_g.planes[i];
    PlaneRecord rec{};
    rec.prim = m_g.plane_prim(i);
    // n . x_world = c with x_world = O + step * x_grid:  n . x_grid = (c - n . O) / step. Scale by 2^-(E+1)
    // so the largest normal component is in [1/2, 1); D fraction bits for n, F for the offset, nearest.
    const float m = std::max({std::abs(pl.normal.x), std::abs(pl.normal.y), std::abs(pl.normal.z)});
    if (!(m > 0.0f) || !std::isfinite(m) || !std::isfinite(pl.offset))
      throw std::invalid_argument("plane " + std::to_string(i) + ": zero or non-finite normal or offset");
    const int E = std::ilogb(m);
    double no = 0.0;
    for (int a = 0; a < 3; ++a) {
      rec.normal[a] = int32_t(std::nearbyint(std::ldexp(double(pl.normal[a]), m_f.dir_bits - E - 1)));
      no += double(pl.normal[a]) * std::ldexp(double(m_frame.origin[a]), m_frame.step_exp);
    }
    const double w = std::ldexp(double(pl.offset) - no, m_f.frac_bits - m_frame.step_exp - E - 1);
    const double wmax = std::ldexp(1.0, m_f.translated_bits());
    if (std::abs(w) >= wmax) {
      ++saturation_counter();  // a plane beyond the guard range: moved to its edge
      rec.offset = w > 0 ? int64_t(wmax) - 1 : 1 - int64_t(wmax);
    } else {
      rec.offset = int64_t(std::nearbyint(w));
    }
    return rec;
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

  // Quantizes the children's grid boxes relative to their common low corner, lows down and highs up, and checks
  // that every decoded box contains its grid box and its float box.
  template <int N, class Q>
  void encode_node(QNode<N, Q>& node, const GridBox* boxes, const Aabb* float_boxes, const uint32_t* refs,
                   int count) const {
    const int64_t qmax = (int64_t(1) << m_f.child_bits) - 1;
    std::memset(&node, 0, sizeof node);
    node.count = uint8_t(count);
    for (int a = 0; a < 3; ++a) {
      int64_t lo = INT64_MAX, hi = INT64_MIN;
      for (int i = 0; i < count; ++i) {
        lo = std::min(lo, boxes[i].lo[a]);
        hi = std::max(hi, boxes[i].hi[a]);
      }
      int e = 0;
      while (ceil_shift(hi - lo, e) > qmax) ++e;
      node.origin[a] = int32_t(lo);
      node.exp[a] = int8_t(e);
      for (int i = 0; i < count; ++i) {
        node.q[2 * a][i] = Q(floor_shift(boxes[i].lo[a] - lo, e));
        node.q[2 * a + 1][i] = Q(ceil_shift(boxes[i].hi[a] - lo, e));
      }
    }
    for (int i = 0; i < N; ++i) {
      node.child[i] = i < count ? refs[i] : kEmptyChild;
      if (i >= count) continue;
      for (int a = 0; a < 3; ++a) {
        const int64_t dlo = int64_t(node.origin[a]) + (int64_t(node.q[2 * a][i]) << node.exp[a]);
        const int64_t dhi = int64_t(node.origin[a]) + (int64_t(node.q[2 * a + 1][i]) << node.exp[a]);
        const bool ok = dlo <= boxes[i].lo[a] && dhi >= boxes[i].hi[a] &&
                        m_frame.to_world(dlo, a) <= double(float_boxes[i].lo[a]) &&
                        m_frame.to_world(dhi, a) >= double(float_boxes[i].hi[a]);
        if (!ok) throw std::logic_error("encoder: a quantized child box does not contain its exact box");
      }
    }
  }

  template <int N, class Q>
  void encode_tree(const WideBvh<N>& t, std::vector<QNode<N, Q>>& nodes, std::vector<uint8_t>& records) {
    records.assign(t.prim_ids.size() * kRecordBytes, 0);
    m_record_boxes.assign(t.prim_ids.size(), GridBox{});
    for (size_t i = 0; i < t.prim_ids.size(); ++i)
      make_record(t.prim_ids[i], records.data() + i * kRecordBytes, m_record_boxes[i]);
    nodes.resize(t.nodes.size());
    if (!is_leaf(t.root_ref) && t.root_ref != kEmptyChild) subtree(t, nodes, t.root_ref);
  }

 private:
  template <int N, class Q>
  GridBox subtree(const WideBvh<N>& t, std::vector<QNode<N, Q>>& nodes, uint32_t ref) {
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
      boxes[count] = subtree(t, nodes, fn.child[i]);
      boxes[count].extend(outward(fboxes[count]));
      refs[count] = fn.child[i];
      all.extend(boxes[count]);
      ++count;
    }
    encode_node(nodes[ref], boxes, fboxes, refs, count);
    return all;
  }

  const Geometry& m_g;
  const FixedFormat& m_f;
  QuantFrame m_frame;
  std::vector<GridBox> m_record_boxes;
};

size_t align8(size_t x) {
  return (x + 7) & ~size_t(7);
}

}  // namespace

DeviceImage encode_scene(const Geometry& g, const FixedFormat& f, const Bvh* bvh) {
  f.validate();
  if (bvh && bvh->width() != f.width)
    throw std::invalid_argument("encode_scene: BVH width " + std::to_string(bvh->width()) +
                                " differs from the format's width " + std::to_string(f.width));
  Encoder enc(g, f);
  std::vector<uint8_t> node_bytes, records;
  uint32_t root = kEmptyChild, node_count = 0, flags = 0;
  const int q_bytes = f.offset_bytes();
  if (bvh) {
    bvh->visit([&](const auto& t) {
      constexpr int N = std::decay_t<decltype(t)>::kWidth;
      auto run = [&](auto q_tag) {
        using Q = decltype(q_tag);
        std::vector<QNode<N, Q>> nodes;
        enc.encode_tree(t, nodes, records);
        node_bytes.resize(nodes.size() * sizeof(QNode<N, Q>));
        if (!nodes.empty()) std::memcpy(node_bytes.data(), nodes.data(), node_bytes.size());
        node_count = uint32_t(nodes.size());
      };
      if (q_bytes == 1)
        run(uint8_t{});
      else
        run(uint16_t{});
      root = t.root_ref;
    });
  } else {
    flags |= kImageNoBvh;
    const uint32_t n = g.num_bounded();
    records.assign(size_t(n) * kRecordBytes, 0);
    for (uint32_t p = 0; p < n; ++p) {
      GridBox unused;
      enc.make_record(p, records.data() + size_t(p) * kRecordBytes, unused);
    }
  }
  std::vector<PlaneRecord> planes;
  for (uint32_t i = 0; i < g.planes.size(); ++i) planes.push_back(enc.make_plane(i));

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
  h.root_ref = root;
  h.node_count = node_count;
  h.record_count = uint32_t(records.size() / kRecordBytes);
  h.plane_count = uint32_t(planes.size());
  h.num_triangles = uint32_t(g.triangles.size());
  h.num_spheres = uint32_t(g.spheres.size());
  h.node_offset = align8(sizeof(ImageHeader));
  h.record_offset = align8(h.node_offset + node_bytes.size());
  h.plane_offset = align8(h.record_offset + records.size());
  h.total_bytes = align8(h.plane_offset + planes.size() * sizeof(PlaneRecord));

  DeviceImage img;
  img.m_words.assign(h.total_bytes / 8, 0);
  uint8_t* base = reinterpret_cast<uint8_t*>(img.m_words.data());
  std::memcpy(base, &h, sizeof h);
  if (!node_bytes.empty()) std::memcpy(base + h.node_offset, node_bytes.data(), node_bytes.size());
  if (!records.empty()) std::memcpy(base + h.record_offset, records.data(), records.size());
  if (!planes.empty()) std::memcpy(base + h.plane_offset, planes.data(), planes.size() * sizeof(PlaneRecord));
  return img;
}

}  // namespace rtu::hw

namespace rtu::hw {

namespace {

[[noreturn]] void bad_image(const std::string& why) {
  throw std::invalid_argument("scene image: " + why);
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

void DeviceImage::check() const {
  const ImageHeader& h = header();
  const uint64_t bytes = uint64_t(m_words.size()) * 8;
  if (h.magic != kImageMagic) bad_image("bad magic");
  if (h.version != kImageVersion) bad_image("unsupported version " + std::to_string(h.version));
  if (h.total_bytes != bytes) bad_image("total_bytes differs from the bound size");
  const FixedFormat f = format();
  try {
    f.validate();
  } catch (const std::invalid_argument& e) {
    bad_image(std::string("format: ") + e.what());
  }
  if (h.q_bytes != f.offset_bytes()) bad_image("offset bytes do not match child_bits");
  if (h.flags & ~kImageNoBvh) bad_image("unknown flag bits");
  // The frame: grid -> world must stay exact in double (quant_frame.h) and finite.
  if (h.step_exp < -1000 || h.step_exp > 1000) bad_image("frame step exponent out of range");
  for (int a = 0; a < 3; ++a)
    if (h.frame_origin[a] <= -(int64_t(1) << 52) || h.frame_origin[a] >= (int64_t(1) << 52))
      bad_image("frame origin out of range");
  // Sections inside the image, aligned, not overlapping the header or each other.
  const uint64_t nb = uint64_t(h.node_count) * node_bytes(), rb = uint64_t(h.record_count) * kRecordBytes,
                 pb = uint64_t(h.plane_count) * sizeof(PlaneRecord);
  auto section = [&](uint64_t off, uint64_t size, uint64_t after, const char* what) {
    if (off % 8 != 0 || off < after || off > bytes || size > bytes - off)
      bad_image(std::string(what) + " section outside the image or misaligned");
  };
  section(h.node_offset, nb, sizeof(ImageHeader), "node");
  section(h.record_offset, rb, h.node_offset + nb, "record");
  section(h.plane_offset, pb, h.record_offset + rb, "plane");
  const uint64_t num_bounded = uint64_t(h.num_triangles) + h.num_spheres;
  if (num_bounded + h.plane_count >= kRecordPrimMask) bad_image("too many primitives");
  if (h.record_count != num_bounded) bad_image("record count differs from the primitive counts");

  // Records: kind and index agree, coordinates inside the ranges validate() proves the datapath for.
  const int B = f.coord_bits, F = f.frac_bits;
  const int64_t grid_max = (int64_t(1) << B) - 1;
  const int64_t center_lim = int64_t(1) << (B + f.guard_bits + F);  // like a ray origin
  for (uint32_t i = 0; i < h.record_count; ++i) {
    const uint8_t* rec = record(i);
    uint32_t word;
    std::memcpy(&word, rec + 36, 4);
    const uint32_t p = word & kRecordPrimMask;
    const uint32_t kind = word >> 30;
    if (kind == uint32_t(RecordKind::kTriangle)) {
      if (p >= h.num_triangles) bad_image("record " + std::to_string(i) + ": triangle index out of range");
      TriangleRecord t;
      std::memcpy(&t, rec, sizeof t);
      for (const auto& v : t.v)
        for (int32_t c : v)
          if (c < 0 || c > grid_max) bad_image("record " + std::to_string(i) + ": vertex outside the grid");
    } else if (kind == uint32_t(RecordKind::kSphere)) {
      if (p < h.num_triangles || p >= num_bounded)
        bad_image("record " + std::to_string(i) + ": sphere index out of range");
      SphereRecord s;
      std::memcpy(&s, rec, sizeof s);
      for (int64_t c : s.center)
        if (c <= -center_lim || c >= center_lim)
          bad_image("record " + std::to_string(i) + ": center out of range");
      if (s.radius <= 0 || s.radius > (int64_t(1) << (B + F + 1)) || s.reserved != 0)
        bad_image("record " + std::to_string(i) + ": radius out of range");
    } else {
      bad_image("record " + std::to_string(i) + ": unknown kind");
    }
  }
  const PlaneRecord* pl = planes();
  const int64_t wmax = int64_t(1) << f.translated_bits();
  for (uint32_t i = 0; i < h.plane_count; ++i) {
    bool zero = true;
    for (int32_t c : pl[i].normal) {
      if (c < -(int64_t(1) << f.dir_bits) || c > (int64_t(1) << f.dir_bits))
        bad_image("plane normal out of range");
      zero = zero && c == 0;
    }
    if (zero || pl[i].offset <= -wmax || pl[i].offset >= wmax)
      bad_image("plane " + std::to_string(i) + " invalid");
    if (pl[i].prim != num_bounded + i) bad_image("plane " + std::to_string(i) + ": index out of order");
  }

  // Tree: leaves inside the records, children after their parent (so no cycles), one parent per node (so no
  // shared subtrees: a ray visits each node at most once), and no path deeper than the traversal stack holds.
  auto leaf_ok = [&](uint32_t ref) { return uint64_t(leaf_first(ref)) + leaf_count(ref) <= h.record_count; };
  if (h.flags & kImageNoBvh) {
    if (h.node_count != 0) bad_image("nodes in an image without a BVH");
    return;
  }
  if (h.root_ref == kEmptyChild) {
    if (h.record_count != 0 || h.node_count != 0) bad_image("empty root with primitives");
    return;
  }
  if (is_leaf(h.root_ref)) {
    if (!leaf_ok(h.root_ref)) bad_image("root leaf outside the records");
    return;
  }
  if (h.root_ref != 0 || h.node_count == 0) bad_image("root must be node 0");
  const int N = h.width;
  const int64_t qlim = int64_t(1) << f.child_bits;
  std::vector<uint32_t> depth(h.node_count, 0);
  const uint8_t* nodes = data() + h.node_offset;
  const size_t nbytes = node_bytes();
  for (uint32_t n = 0; n < h.node_count; ++n) {
    const uint8_t* nd = nodes + size_t(n) * nbytes;
    int32_t origin[3];
    int8_t exp[3];
    std::memcpy(origin, nd, 12);
    std::memcpy(exp, nd + 12, 3);
    const uint8_t count = nd[15];
    const std::string at = "node " + std::to_string(n) + ": ";
    if (count < 1 || count > N) bad_image(at + "child count out of range");
    for (int a = 0; a < 3; ++a)
      if (exp[a] < 0 || exp[a] > B + 1) bad_image(at + "scale out of range");
    // Decoded planes within [-2^B, 2^(B+1)] grid units: minus any valid ray origin they stay below 2^(B+G+1),
    // the translated range the box unit's widths are derived for (G >= 1).
    for (int r = 0; r < 6; ++r) {
      for (int i = 0; i < N; ++i) {
        uint32_t q = 0;
        std::memcpy(&q, nd + 16 + size_t(r * N + i) * h.q_bytes, h.q_bytes);
        if (int64_t(q) >= qlim) bad_image(at + "child offset wider than child_bits");
        const int64_t plane = int64_t(origin[r / 2]) + (int64_t(q) << exp[r / 2]);
        if (plane < -(int64_t(1) << B) || plane > (int64_t(1) << (B + 1))) bad_image(at + "box outside the grid");
      }
    }
    const uint8_t* child = nd + 16 + size_t(6 * N) * h.q_bytes;
    for (int i = 0; i < N; ++i) {
      uint32_t ref;
      std::memcpy(&ref, child + 4 * i, 4);
      if (i >= count) {
        if (ref != kEmptyChild) bad_image(at + "an empty slot holds a child");
        continue;
      }
      if (is_leaf(ref)) {
        if (!leaf_ok(ref)) bad_image(at + "leaf outside the records");
      } else if (ref <= n || ref >= h.node_count) {
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

}  // namespace rtu::hw
