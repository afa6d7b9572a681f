// The test of the oriented node kind (format/oriented_aabb.h): the ray turned into the node's frame with the
// rotation table's integers, then the slab tests of the axis-aligned kind there.
//
// Exact rotation: o' = M o and d' = M d are integer products (o with F fraction bits, d with D, M with rb), so o'
// has F + rb fraction bits and d' has D + rb, and a child's region { p : lo <= (M p) / 2^rb <= hi } meets the ray
// o + t d exactly where the slabs [lo, hi] meet o' + t d' (the same t). The reciprocals of d' are rounded down and
// up at R + 1 significant bits as the ray's own (set_direction), and box_test_delta rounds each slab's near
// distance down and its far one up: conservative as the axis-aligned test is (docs/numerics.md). The exact
// oracle is box_test_exact on the rotated ray: rational comparisons, no reciprocal. Products are 128-bit
// (FixedFormat::rotated_translated_bits; validate() proves the widths).
#pragma once

#include "hwmodel/datapath/box_unit.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/datapath/node_test.h"
#include "hwmodel/format/oriented_aabb.h"
#include "hwmodel/format/rotation_table.h"

namespace rtu::hw {

struct OrientedRay {
  bool fast = false;  // no fast kernel: every node takes the reference path
  const Rotation* table = nullptr;
  FixedFormat rotated;  // the format of the rotated frame: F + rb and D + rb fraction bits
};

// The ray in the frame of rotation m: origin and direction multiplied by m exactly, reciprocals of the rotated
// direction, the ray's interval kept.
inline FixedRay rotate_ray(const FixedRay& r, const Rotation& m, const FixedFormat& rotated) {
  FixedRay out = r;
  set_format_fields(out, rotated);
  int64_t d[3];
  for (int a = 0; a < 3; ++a) {
    out.o[a] = m.m[a][0] * r.o[0] + m.m[a][1] * r.o[1] + m.m[a][2] * r.o[2];
    d[a] = m.m[a][0] * r.d[0] + m.m[a][1] * r.d[1] + m.m[a][2] * r.d[2];
  }
  set_direction(out, d, rotated);
  out.narrow = false;
  return out;
}

template <int N, class Q>
struct NodeTest<OrientedAabb<N, Q>> {
  using Node = ONode<N, Q>;
  using RayState = OrientedRay;

  static OrientedRay ray(const FixedRay&, const FixedFormat& f) {
    OrientedRay s;
    s.table = rotation_table(f.rotations, f.rot_bits).data();
    s.rotated = f;
    s.rotated.frac_bits += f.rot_bits;
    s.rotated.dir_bits += f.rot_bits;
    return s;
  }

  static int fast(const OrientedRay&, const Node&, int64_t, int64_t, uint32_t[N], int64_t[N]) { return -1; }

  template <class Int, class OnChild>
  static int test(const OrientedRay& s, const FixedRay& r, const Node& n, int64_t tmin, int64_t tlim,
                  uint32_t refs[N], int64_t dists[N], OnChild&& on_child) {
    const FixedRay rr = rotate_ray(r, s.table[n.rot], s.rotated);
    int k = 0;
    for (int i = 0; i < n.count; ++i) {
      int64_t lo[3], hi[3];
      OrientedAabb<N, Q>::child_box(n, i, lo, hi);
      int64_t t = 0;
      const bool hit = box_test_impl<Wide>(rr, lo, hi, tmin, tlim, t);
      on_child(i, hit);
      refs[k] = n.child[i];
      dists[k] = t;
      k += int(hit);
    }
    return k;
  }

  static BoxUnitNode unit_input(const OrientedRay&, const FixedRay&, const Node&) {
    throw std::invalid_argument(
        "an attached box unit tests axis-aligned nodes; this image's nodes are oriented (node_kind 1)");
  }

  static bool exact(const OrientedRay& s, const FixedRay& r, const Node& n, int i, int64_t tmin, int64_t tlim) {
    int64_t lo[3], hi[3];
    OrientedAabb<N, Q>::child_box(n, i, lo, hi);
    return box_test_exact(rotate_ray(r, s.table[n.rot], s.rotated), lo, hi, tmin, tlim);
  }
};

}  // namespace rtu::hw
