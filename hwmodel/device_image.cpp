#include "hwmodel/device_image.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

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
