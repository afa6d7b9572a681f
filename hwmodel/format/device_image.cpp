#include "hwmodel/format/device_image.h"
#include "hwmodel/scene/bvh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "hwmodel/format/cluster_layout.h"
#include "hwmodel/format/node_kinds.h"
#include "hwmodel/format/packed_layout.h"
#include "hwmodel/format/rotation_table.h"

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
  if (node_kind(h) == NodeKindId::kOrientedAabb) {
    f.node_kind = 1;
    f.rotations = int((h.flags & kImageRotationsMask) >> kImageRotationsShift) + 1;
    f.rot_bits = int((h.flags & kImageRotBitsMask) >> kImageRotBitsShift);
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
      rec.prim = (uint32_t(RecordKind::kInstance) << 30) | (*m_ids)[p];
      std::memcpy(out, &rec, sizeof rec);
    } else if (p < m_g.triangles.size()) {
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
      rec.prim = (uint32_t(RecordKind::kTriangle) << 30) | (m_g.opaque(p) ? 0u : kRecordNonOpaque) | p;
      std::memcpy(out, &rec, sizeof rec);
    } else if (m_g.kind(p) == PrimKind::kCurve) {
      const CurveSegment& cs = m_g.curve(p);
      CurveRecord rec{};
      const int F = m_f.frac_bits;
      const Vec3* ends[2] = {&cs.p0, &cs.p1};
      const float radii[2] = {cs.r0, cs.r1};
      uint32_t* stored[2] = {&rec.r0, &rec.r1};
      int32_t* points[2] = {rec.p0, rec.p1};
      for (int i = 0; i < 2; ++i) {
        // Radius in grid.F units, rounded up (exact in double, as a sphere's), then to the field's 27 significant
        // bits, up. The frame holds the segment's spheres, so a radius is below 2^(B+F).
        const double rs = std::ceil(std::ldexp(double(radii[i]), F - m_frame.step_exp));
        if (!(rs < std::ldexp(1.0, 58)))
          throw std::invalid_argument("curve segment " +
                                      std::to_string(p - m_g.triangles.size() - m_g.spheres.size()) +
                                      ": radius beyond the record's range");
        *stored[i] = curve_radius_field(int64_t(rs));
        const int64_t r = curve_radius(*stored[i]);
        for (int a = 0; a < 3; ++a) {
          const int64_t g = m_frame.to_grid((*ends[i])[a], a, Round::kNearestEven);
          points[i][a] = int32_t(g);  // in [0, 2^B - 1]: the end point lies inside the frame's bounds
          box.lo[a] = std::min(box.lo[a], floor_shift((g << F) - r, F));
          box.hi[a] = std::max(box.hi[a], ceil_shift((g << F) + r, F));
        }
      }
      rec.round = kRoundCurve | ((cs.flags & kCurveCapStart) ? kRoundCapStart : 0u);
      rec.prim = (uint32_t(RecordKind::kSphere) << 30) | p;
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
      ta.prim = (ta.prim & ~(3u << 30)) | (uint32_t(RecordKind::kTrianglePair) << 30);
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

// A tree in a packed layout: the node and primitive sections, and what the image must decode them to.
struct PackedTree {
  std::vector<uint8_t> nodes, prims;
  std::vector<uint8_t> qnodes, records;  // the expected decoding: QNodes, 40-byte records, in the new order
  uint32_t root = kEmptyChild, node_count = 0;
  uint64_t node_bytes = 0;
  int base_bits = 0, prim_bits = 0, group_bits = 0;
};

// The cluster of the subtree at inner node `root` (cluster_layout.h): its nodes breadth first with their leaf
// groups, its records in leaf order; and, when `decoded` is not null, the nodes as the image decodes them, with
// references from node `node_base` and record `record_base`.
template <NodeKind K>
void gather_cluster(const std::vector<typename K::Node>& nodes, const std::vector<uint8_t>& records, uint32_t root,
                    Cluster& c, std::vector<typename K::Node>* decoded, uint32_t node_base, uint32_t record_base) {
  std::vector<uint32_t> order{root};
  uint32_t next_node = 1, next_record = 0;
  for (size_t k = 0; k < order.size(); ++k) {
    typename K::Node n = nodes[order[k]];
    PackedNode pn;
    K::to_packed(n, pn);
    for (int i = 0; i < K::count(n); ++i) {
      const uint32_t ref = K::child(n, i);
      if (is_leaf(ref)) {
        const uint8_t* rec = records.data() + size_t(leaf_first(ref)) * kRecordBytes;
        c.records.insert(c.records.end(), rec, rec + size_t(leaf_count(ref)) * kRecordBytes);
        pn.leaf[i] = true;
        pn.group[i] = leaf_count(ref);
        K::set_child(n, i, make_leaf(record_base + next_record, leaf_count(ref)));
        next_record += leaf_count(ref);
      } else {
        order.push_back(ref);
        K::set_child(n, i, node_base + next_node++);
      }
    }
    c.nodes.push_back(pn);
    if (decoded) decoded->push_back(n);
  }
}

// Triangle clusters (prim_layout 2): the inner nodes below the root that root a cluster, each with its encoded
// bytes. Top down, a subtree becomes a cluster when it holds only opaque triangles, at most cluster_tris of them
// and at most kMaxClusterNodes nodes, and its cluster fits the format (kMaxClusterLines); else its children are
// tried. The root stays a node of the top tree.
template <NodeKind K>
std::vector<std::vector<uint8_t>> choose_clusters(const FixedFormat& f, const std::vector<typename K::Node>& nodes,
                                                  const std::vector<uint8_t>& records, uint32_t root) {
  std::vector<std::vector<uint8_t>> bytes(nodes.size());
  if (root == kEmptyChild || is_leaf(root)) return bytes;
  // Below each node: triangles, nodes, and whether all are opaque triangles. Children follow their parents.
  std::vector<uint32_t> tris(nodes.size(), 0), inner(nodes.size(), 1);
  std::vector<uint8_t> ok(nodes.size(), 1);
  for (size_t n = nodes.size(); n-- > 0;) {
    for (int i = 0; i < K::count(nodes[n]); ++i) {
      const uint32_t ref = K::child(nodes[n], i);
      if (is_leaf(ref)) {
        tris[n] += leaf_count(ref);
        ok[n] &= uint8_t(clusterable(records.data() + size_t(leaf_first(ref)) * kRecordBytes, leaf_count(ref)));
      } else {
        if (ref <= n) throw std::logic_error("encoder: a child node before its parent");
        tris[n] += tris[ref];
        inner[n] += inner[ref];
        ok[n] &= ok[ref];
      }
    }
  }
  std::vector<uint32_t> todo;
  auto children = [&](uint32_t n) {
    for (int i = 0; i < K::count(nodes[n]); ++i)
      if (!is_leaf(K::child(nodes[n], i))) todo.push_back(K::child(nodes[n], i));
  };
  children(root);
  while (!todo.empty()) {
    const uint32_t n = todo.back();
    todo.pop_back();
    if (ok[n] && tris[n] <= uint32_t(f.cluster_tris) && inner[n] <= uint32_t(kMaxClusterNodes)) {
      Cluster c;
      gather_cluster<K>(nodes, records, n, c, nullptr, 0, 0);
      if (encode_cluster(c, f, bytes[n]) > 0) continue;
    }
    children(n);
  }
  return bytes;
}

// Numbers nodes breadth first, each node's inner children consecutive, and stores each node's leaf groups
// consecutively (packed_layout.h): the nodes' values are unchanged, their references follow the new order. With
// clusters (prim_layout 2) a cluster's subtree is a leaf group of the top tree: its nodes are decoded after the
// top tree's, cluster by cluster in the order of the primitive section.
template <NodeKind K>
PackedTree pack_tree(const FixedFormat& f, const std::vector<typename K::Node>& nodes,
                     const std::vector<uint8_t>& records, uint32_t root) {
  PackedTree p;
  const bool blocks = f.prim_layout == 1, clusters = f.prim_layout == 2;
  std::vector<std::vector<uint8_t>> cluster_bytes;  // clusters: a cluster root's encoded cluster, else empty
  if (clusters) cluster_bytes = choose_clusters<K>(f, nodes, records, root);
  auto cluster_root = [&](uint32_t ref) { return clusters && !is_leaf(ref) && !cluster_bytes[ref].empty(); };
  std::vector<uint32_t> order;  // new index -> old
  if (root != kEmptyChild && !is_leaf(root)) order.push_back(root);
  for (size_t k = 0; k < order.size(); ++k) {
    const typename K::Node& n = nodes[order[k]];
    for (int i = 0; i < K::count(n); ++i)
      if (!is_leaf(K::child(n, i)) && !cluster_root(K::child(n, i))) order.push_back(K::child(n, i));
  }
  uint64_t units = 0;  // primitive section so far: records, or granules of blocks, or lines of clusters
  uint32_t next_record = 0;
  std::vector<typename K::Node> cluster_nodes;  // clusters: their nodes as decoded, after the top tree's
  // Appends the cluster rooted at inner node `ref`; returns its size in lines and its decoded reference.
  auto cluster = [&](uint32_t ref, uint32_t& size) {
    Cluster c;
    const uint32_t at = uint32_t(order.size() + cluster_nodes.size());
    gather_cluster<K>(nodes, records, ref, c, &cluster_nodes, at, next_record);
    p.prims.insert(p.prims.end(), cluster_bytes[ref].begin(), cluster_bytes[ref].end());
    p.records.insert(p.records.end(), c.records.begin(), c.records.end());
    size = uint32_t(cluster_bytes[ref].size() / kClusterLineBytes);
    units += size;
    next_record += uint32_t(c.records.size() / kRecordBytes);
    return at;
  };
  // Appends leaf `ref`'s group; returns its size in units and the leaf's reference in the new record order.
  auto group = [&](uint32_t ref, uint32_t& size) {
    const uint8_t* rec = records.data() + size_t(leaf_first(ref)) * kRecordBytes;
    const uint32_t count = leaf_count(ref);
    if (clusters && clusterable(rec, count)) {
      Cluster c;
      c.records.assign(rec, rec + size_t(count) * kRecordBytes);
      size = encode_cluster(c, f, p.prims);
      if (size == 0) throw std::logic_error("encoder: a leaf that fits no cluster");
    } else if (clusters) {
      size = encode_raw_unit(rec, int(count), f, p.prims);
    } else if (blocks) {
      size = encode_block(rec, int(count), f.coord_bits, p.prims);
    } else {
      p.prims.insert(p.prims.end(), rec, rec + size_t(count) * kRecordBytes);
      size = count;
    }
    p.records.insert(p.records.end(), rec, rec + size_t(count) * kRecordBytes);
    units += size;
    const uint32_t r = make_leaf(next_record, count);
    next_record += count;
    return r;
  };
  std::vector<PackedNode> packed(order.size());
  uint64_t max_base = 0, max_prim = 0, max_group = 0;
  uint32_t next_node = 1;
  for (size_t k = 0; k < order.size(); ++k) {
    typename K::Node n = nodes[order[k]];
    PackedNode& pn = packed[k];
    K::to_packed(n, pn);
    pn.node_base = next_node;
    pn.prim_base = units;
    bool any_inner = false, any_leaf = false;
    for (int i = 0; i < K::count(n); ++i) {
      const uint32_t ref = K::child(n, i);
      if (is_leaf(ref) || cluster_root(ref)) {
        pn.leaf[i] = true;
        K::set_child(n, i, is_leaf(ref) ? group(ref, pn.group[i]) : cluster(ref, pn.group[i]));
        max_group = std::max<uint64_t>(max_group, pn.group[i] - 1);
        any_leaf = true;
      } else {
        K::set_child(n, i, next_node++);
        any_inner = true;
      }
    }
    if (!any_inner) pn.node_base = 0;  // unused: zero, so it costs no base bits
    if (!any_leaf) pn.prim_base = 0;
    max_base = std::max(max_base, pn.node_base);
    max_prim = std::max(max_prim, pn.prim_base);
    const auto* b = reinterpret_cast<const uint8_t*>(&n);
    p.qnodes.insert(p.qnodes.end(), b, b + sizeof n);
  }
  if (root != kEmptyChild && is_leaf(root)) {
    uint32_t size = 0;
    p.root = group(root, size);
  } else {
    p.root = order.empty() ? kEmptyChild : 0;
  }
  for (const typename K::Node& n : cluster_nodes) {
    const auto* b = reinterpret_cast<const uint8_t*>(&n);
    p.qnodes.insert(p.qnodes.end(), b, b + sizeof n);
  }
  if (next_record * kRecordBytes != records.size())
    throw std::logic_error("encoder: packed layout did not place every record once");
  p.base_bits = bits_for(max_base);
  p.prim_bits = bits_for(max_prim);
  p.group_bits = bits_for(max_group);
  const NodeFields fields = node_fields(f, p.base_bits, p.prim_bits, p.group_bits);
  p.node_bytes = fields.bytes(f.node_align);
  if (p.node_bytes > 0xFFFF) throw std::invalid_argument("encode_scene: a packed node above 65535 bytes");
  for (const PackedNode& pn : packed) pack_node(pn, fields, p.node_bytes, p.nodes);
  p.node_count = uint32_t(order.size());
  return p;
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
    if (id > kRecordPrimMask) throw std::invalid_argument("encode_top_level: instance index beyond 2^29 - 1");
  FixedFormat f = format;
  f.prim_layout = 0;
  Encoder enc(boxes, ids, flat, f);
  return ImageWriter::write(enc, flat, f, &bvh, kImageTopLevel);
}

DeviceImage ImageWriter::write(Encoder& enc, const Geometry& g, const FixedFormat& f, const Bvh* bvh,
                               uint32_t flags) {
  PackedTree tree;  // the node and primitive sections (and, packed, their expected decoding)
  const int q_bytes = f.offset_bytes();
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
    bvh->visit([&](const auto& t) {
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
  } else {
    flags |= kImageNoBvh;
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
  h.root_ref = tree.root;
  h.node_count = tree.node_count;
  h.record_count = enc.record_count();
  h.plane_count = uint32_t(planes.size());
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
  h.total_bytes = align8(h.plane_offset + planes.size() * sizeof(PlaneRecord));

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

namespace rtu::hw {

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
  if (!find_node_kind(uint32_t(node_kind(h)))) bad_image("unknown node kind " + std::to_string(int(node_kind(h))));
  if (node_kind(h) != NodeKindId::kOrientedAabb && (h.flags & (kImageRotationsMask | kImageRotBitsMask)))
    bad_image("rotation table fields in an image of axis-aligned nodes");
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
  if (h.node_layout != 0) {
    if (h.base_bits > 32 || h.prim_bits > 32 || h.group_bits > 7)
      bad_image("node field widths out of range (base_bits, prim_bits <= 32, group_bits <= 7)");
    if (h.node_layout == 2 && (h.base_bits | h.prim_bits | h.group_bits) != 0)
      bad_image("node field widths given for compressed-wide nodes (their fields are bytes)");
    fields = node_fields(f, h.base_bits, h.prim_bits, h.group_bits);
    if (h.node_bytes != fields.bytes(f.node_align))
      bad_image("node_bytes " + std::to_string(h.node_bytes) + " differs from the layout's " +
                std::to_string(fields.bytes(f.node_align)));
  } else if (h.node_bytes != struct_bytes || (h.base_bits | h.prim_bits | h.group_bits) != 0) {
    bad_image("node_bytes or node field widths differ from the struct layout's");
  }
  if (h.prim_layout == 0 && h.record_bytes != uint64_t(h.record_count) * kRecordBytes)
    bad_image("record_bytes differs from record_count 40-byte records");
  if (h.prim_layout == 2 && (h.record_offset % kClusterLineBytes != 0 || h.record_bytes % kClusterLineBytes != 0))
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
  if (num_bounded + h.plane_count >= kRecordPrimMask) bad_image("too many primitives");
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
  if (h.prim_layout == 2) {
    const uint64_t end = h.record_bytes / kClusterLineBytes;
    const auto it = std::lower_bound(block_at.begin(), block_at.end(), std::make_pair(unit, uint32_t(0)));
    if (it == block_at.end() || it->first != unit)
      bad_image(at + ": leaf child " + std::to_string(i) + " does not point at the start of a cluster");
    if ((it + 1 == block_at.end() ? end : (it + 1)->first) - unit != group)
      bad_image(at + ": leaf child " + std::to_string(i) + "'s group size differs from its cluster's");
    return cd.unit_ref[size_t(it - block_at.begin())];
  }
  if (h.prim_layout != 0) {
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

// Records: kind and index agree, coordinates inside the ranges validate() proves the datapath for.
void check_records(const DeviceImage& img, const FixedFormat& f) {
  const ImageHeader& h = img.header();
  const bool top = h.flags & kImageTopLevel;
  const uint64_t num_bounded = uint64_t(h.num_triangles) + h.num_spheres;
  const int B = f.coord_bits, F = f.frac_bits;
  const int64_t grid_max = (int64_t(1) << B) - 1;
  const int64_t center_lim = int64_t(1) << (B + f.guard_bits + F);  // like a ray origin
  for (uint32_t i = 0; i < h.record_count; ++i) {
    const uint8_t* rec = img.record(i);
    uint32_t word;
    std::memcpy(&word, rec + 36, 4);
    const uint32_t p = word & kRecordPrimMask;
    const uint32_t kind = word >> 30;
    const bool triangle = is_triangle(RecordKind(kind));
    if ((word & kRecordNonOpaque) && !triangle)
      bad_image("record " + std::to_string(i) + ": a sphere or instance marked non-opaque");
    if (top != (kind == uint32_t(RecordKind::kInstance)))
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
    } else if (triangle) {
      if (p >= h.num_triangles) bad_image("record " + std::to_string(i) + ": triangle index out of range");
      TriangleRecord t;
      std::memcpy(&t, rec, sizeof t);
      for (const auto& v : t.v)
        for (int32_t c : v)
          if (c < 0 || c > grid_max) bad_image("record " + std::to_string(i) + ": vertex outside the grid");
      if (kind == uint32_t(RecordKind::kTrianglePair)) {
        // Its second: the next record, a single triangle sharing an edge with it.
        TriangleRecord second;
        if (i + 1 >= h.record_count || record_kind(img.record(i + 1)) != RecordKind::kTriangle)
          bad_image("record " + std::to_string(i) + ": a triangle pair without its second triangle");
        std::memcpy(&second, img.record(i + 1), sizeof second);
        if (!share_edge(t, second))
          bad_image("record " + std::to_string(i) + ": a triangle pair whose triangles share no edge");
      }
    } else if (kind == uint32_t(RecordKind::kSphere) && is_curve_record(rec)) {
      if (p < h.num_triangles || p >= num_bounded)
        bad_image("record " + std::to_string(i) + ": curve segment index out of range");
      if (!(h.flags & kImageCurveBitsMask))
        bad_image("record " + std::to_string(i) + ": a curve segment in an image without curve_bits");
      CurveRecord c;
      std::memcpy(&c, rec, sizeof c);
      for (int e = 0; e < 3; ++e)
        if (c.p0[e] < 0 || c.p0[e] > grid_max || c.p1[e] < 0 || c.p1[e] > grid_max)
          bad_image("record " + std::to_string(i) + ": curve end point outside the grid");
      if (curve_radius(c.r0) > (int64_t(1) << (B + F + 1)) || curve_radius(c.r1) > (int64_t(1) << (B + F + 1)))
        bad_image("record " + std::to_string(i) + ": curve radius out of range");
      if (c.round & ~(kRoundCurve | kRoundCapStart))
        bad_image("record " + std::to_string(i) + ": unknown round-primitive bits");
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
}

// Planes: a non-zero normal and an offset in range, in primitive order after the bounded primitives.
void check_planes(const DeviceImage& img, const FixedFormat& f) {
  const ImageHeader& h = img.header();
  const uint64_t num_bounded = uint64_t(h.num_triangles) + h.num_spheres;
  const PlaneRecord* pl = img.planes();
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
  if (h.prim_layout == 2)
    block_at = decode_clusters(data(), h, f, m_records, m_spans, m_cluster_spans, m_record_flags, cd);
  else if (h.prim_layout != 0)
    block_at = decode_blocks(data(), h, f, m_records, m_spans);
  check_records(*this, f);
  check_planes(*this, f);
  if (!check_root(h)) {
    if (!cd.nodes.empty()) bad_image("cluster nodes without a tree of nodes to reach them");
    return;
  }
  with_node_kind(kind, h.width, h.q_bytes, [&](auto k) {
    using K = decltype(k);
    if (h.node_layout != 0) decode_packed_nodes<K>(data(), h, fields, block_at, cd, m_nodes);
    check_tree<K>(reinterpret_cast<const uint8_t*>(this->nodes<uint8_t>()), node_total(), h, f);
  });
}

}  // namespace rtu::hw
