// The test of the quantized AABB node kind (format/quantized_aabb.h): slab tests of each child's decoded box,
// conservative (docs/numerics.md), with the fast kernels of box_node.h.
#pragma once

#include "hwmodel/datapath/box_node.h"
#include "hwmodel/datapath/box_unit.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/datapath/node_test.h"
#include "hwmodel/format/quantized_aabb.h"

namespace rtu::hw {

template <int N, class Q>
struct NodeTest<QuantizedAabb<N, Q>> {
  using Node = QNode<N, Q>;
  using RayState = NodeRay;

  static NodeRay ray(const FixedRay& r, const FixedFormat& f) { return make_node_ray(r, f, int(sizeof(Q))); }

  static int fast(const NodeRay& nr, const Node& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                  int64_t dists[N]) {
    return box_node<N, Q>(nr, n, tmin, tlim, refs, dists);
  }

  // Child planes relative to the ray origin in grid.F: (origin << F) - o once per node and axis, then
  // + (q << (exp + F)) per child plane: the decode and the subtraction of box_test in one step.
  template <class Int, class OnChild>
  static int test(const NodeRay&, const FixedRay& r, const Node& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                  int64_t dists[N], OnChild&& on_child) {
    int64_t base[3];
    int sh[3];
    for (int a = 0; a < 3; ++a) {
      base[a] = (int64_t(n.origin[a]) << r.frac) - r.o[a];
      sh[a] = n.exp[a] + r.frac;
    }
    int k = 0;
    for (int i = 0; i < n.count; ++i) {
      int64_t dl[3], dh[3];
      for (int a = 0; a < 3; ++a) {
        dl[a] = base[a] + (int64_t(n.q[2 * a][i]) << sh[a]);
        dh[a] = base[a] + (int64_t(n.q[2 * a + 1][i]) << sh[a]);
      }
      int64_t t = 0;
      const bool hit = box_test_delta<Int>(r, dl, dh, tmin, tlim, t);
      on_child(i, hit);
      // Written unconditionally, kept when hit: whether a child is hit varies from child to child.
      refs[k] = n.child[i];
      dists[k] = t;
      k += int(hit);
    }
    return k;
  }

  static BoxUnitNode unit_input(const NodeRay&, const FixedRay& r, const Node& n) {
    BoxUnitNode in{};
    for (int a = 0; a < 3; ++a) {
      in.base[a] = (int64_t(n.origin[a]) << r.frac) - r.o[a];
      in.sh[a] = n.exp[a] + r.frac;
    }
    for (int row = 0; row < 6; ++row)
      for (int i = 0; i < N; ++i) in.q[row][i] = uint16_t(n.q[row][i]);
    in.count = n.count;
    return in;
  }

  static bool exact(const NodeRay&, const FixedRay& r, const Node& n, int i, int64_t tmin, int64_t tlim) {
    int64_t lo[3], hi[3];
    QuantizedAabb<N, Q>::child_box(n, i, lo, hi);
    return box_test_exact(r, lo, hi, tmin, tlim);
  }
};

}  // namespace rtu::hw
