// Building a kind's nodes over the float BVH (node_kind.h: each kind's `build` hook). The generic half: NodeBuild,
// what the encoder hands a kind (the records in leaf order with their grid boxes, the format, the frame), with the
// outward rounding of a float box and the encoding of one node checked to contain its children's boxes; and the
// two builds the kinds so far use: axis-aligned (build_axis_aligned) and oriented (build_oriented: each node in
// the rotation of the format's table whose children's boxes have the least summed surface area, after DOBB-BVH,
// Kern et al., HPG 2025).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include "hwmodel/format/node_kind.h"
#include "hwmodel/format/prim_kinds.h"
#include "hwmodel/format/rotation_table.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::hw {

// Encodes one node of kind K and checks that every decoded child box contains its grid box and its float box.
template <class K>
void encode_checked(const NodeBuild& b, typename K::Node& node, const GridBox* boxes, const Aabb* float_boxes,
                    const uint32_t* refs, int count) {
  K::encode(node, boxes, refs, count, b.f);
  for (int i = 0; i < count; ++i) {
    int64_t dlo[3], dhi[3];
    K::child_box(node, i, dlo, dhi);
    for (int a = 0; a < 3; ++a) {
      const bool ok = dlo[a] <= boxes[i].lo[a] && dhi[a] >= boxes[i].hi[a] &&
                      b.frame.to_world(dlo[a], a) <= double(float_boxes[i].lo[a]) &&
                      b.frame.to_world(dhi[a], a) >= double(float_boxes[i].hi[a]);
      if (!ok) throw std::logic_error("encoder: a quantized child box does not contain its exact box");
    }
  }
}

// Axis-aligned nodes: each child's box is the grid boxes of what lies below it joined with its float box rounded
// outward. Encodes the subtree at ref into nodes and returns its grid box.
template <class K>
GridBox build_axis_aligned(const NodeBuild& b, const WideBvh<K::kWidth>& t, typename K::Node* nodes,
                           uint32_t ref) {
  constexpr int N = K::kWidth;
  GridBox all;
  if (is_leaf(ref)) {
    for (uint32_t i = leaf_first(ref); i < leaf_first(ref) + leaf_count(ref); ++i) all.extend(b.record_boxes[i]);
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
    boxes[count] = build_axis_aligned<K>(b, t, nodes, fn.child[i]);
    boxes[count].extend(b.outward(fboxes[count]));
    refs[count] = fn.child[i];
    all.extend(boxes[count]);
    ++count;
  }
  encode_checked<K>(b, nodes[ref], boxes, fboxes, refs, count);
  return all;
}

// Oriented nodes. What lies below a subtree, as the extents of its points along each rotation's axes: element
// 6k + 2a is the least (M_k p)_a over its points p (grid integers times the table's integers: exact), 6k + 2a + 1
// the greatest. A record's points are its primitive kind's (orient_points: a triangle's vertices, a curve
// segment's end points widened by its radius, a sphere's grid box corners); an instance's are its grid box's
// corners.
using OrientExtents = std::vector<int64_t>;

inline OrientExtents record_extents(const NodeBuild& b, const std::vector<Rotation>& rot, uint32_t i) {
  OrientExtents e(6 * rot.size());
  for (size_t k = 0; k < rot.size(); ++k)
    for (int a = 0; a < 3; ++a) {
      e[6 * k + 2 * a] = INT64_MAX;
      e[6 * k + 2 * a + 1] = INT64_MIN;
    }
  const uint8_t* rec = b.records + size_t(i) * kRecordBytes;
  OrientPoints pts;
  if (!with_record_prim(record_kind(rec),
                        [&](auto k) { decltype(k)::orient_points(rec, b.record_boxes[i], b.f, pts); }))
    pts.corners(b.record_boxes[i]);
  for (size_t k = 0; k < rot.size(); ++k)
    for (int a = 0; a < 3; ++a) {
      const int32_t* m = rot[k].m[a];
      int64_t& lo = e[6 * k + 2 * a];
      int64_t& hi = e[6 * k + 2 * a + 1];
      // The row's length, rounded up: a sphere of radius r spans r |m| along it.
      const int64_t len =
          pts.pad == 0
              ? 0
              : int64_t(isqrt_round(Wide(m[0]) * m[0] + Wide(m[1]) * m[1] + Wide(m[2]) * m[2], Round::kUp));
      for (int p = 0; p < pts.n; ++p) {
        const int64_t v = m[0] * pts.p[p][0] + m[1] * pts.p[p][1] + m[2] * pts.p[p][2];
        lo = std::min(lo, v - pts.pad * len);
        hi = std::max(hi, v + pts.pad * len);
      }
    }
  return e;
}

inline void merge_extents(OrientExtents& into, const OrientExtents& e) {
  for (size_t j = 0; j < into.size(); j += 2) {
    into[j] = std::min(into[j], e[j]);
    into[j + 1] = std::max(into[j + 1], e[j + 1]);
  }
}

// Encodes the subtree's nodes, each in the rotation whose children's boxes have the least summed surface area
// (the first such: the identity on a tie with it), through K::encode_rotated, and returns the subtree's extents.
template <class K>
OrientExtents build_oriented(const NodeBuild& b, const std::vector<Rotation>& rot, const WideBvh<K::kWidth>& t,
                             typename K::Node* nodes, uint32_t ref) {
  constexpr int N = K::kWidth;
  if (is_leaf(ref)) {
    OrientExtents all = record_extents(b, rot, leaf_first(ref));
    for (uint32_t i = leaf_first(ref) + 1; i < leaf_first(ref) + leaf_count(ref); ++i)
      merge_extents(all, record_extents(b, rot, i));
    return all;
  }
  const WideNode<N>& fn = t.nodes[ref];
  OrientExtents ext[N];
  uint32_t refs[N];
  int count = 0;
  for (int i = 0; i < N; ++i) {
    if (fn.child[i] == kEmptyChild) continue;
    ext[count] = build_oriented<K>(b, rot, t, nodes, fn.child[i]);
    refs[count] = fn.child[i];
    ++count;
  }
  const size_t R = rot.size();
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
  const int rb = b.f.rot_bits;
  GridBox boxes[N];
  for (int i = 0; i < count; ++i)
    for (int a = 0; a < 3; ++a) {
      boxes[i].lo[a] = round_shift64(ext[i][6 * best + 2 * a], rb, Round::kDown);
      boxes[i].hi[a] = round_shift64(ext[i][6 * best + 2 * a + 1], rb, Round::kUp);
    }
  typename K::Node& node = nodes[ref];
  K::encode_rotated(node, int(best), boxes, refs, count, b.f);
  for (int i = 0; i < count; ++i) {
    int64_t lo[3], hi[3];
    K::child_box(node, i, lo, hi);
    for (int a = 0; a < 3; ++a)
      if ((lo[a] << rb) > ext[i][6 * best + 2 * a] || (hi[a] << rb) < ext[i][6 * best + 2 * a + 1])
        throw std::logic_error("encoder: an oriented child box does not contain its points");
  }
  OrientExtents all = std::move(ext[0]);
  for (int i = 1; i < count; ++i) merge_extents(all, ext[i]);
  return all;
}

}  // namespace rtu::hw
