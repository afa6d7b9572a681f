// The box tests of one node's children, fast: the same function as box_test_delta<int64_t> applied child by
// child (as FixedPolicy::expand_impl does), restructured for speed. Bit for bit the same accepted children (in
// slot order) and entry distances; tests/hwmodel/test_fast_paths.cpp compares them on random and edge-case nodes.
//
// Per node and axis the plane of child i, minus the ray origin, is base + (q_i << s) (base = (origin << F) - o,
// s = exp + F), and box_test_delta's product is (base + (q_i << s)) * m = base * m + q_i * (m << s) exactly:
// base * m and m << s once per node, then one small product and an add per child plane. The reciprocal that
// gives the lower bound of a near plane's distance is the one with the smaller product (rcpm_dn <= rcpm_up:
// box_test_delta picks it by the plane's sign), the upper bound of a far plane's the larger: min and max of the
// two products instead of a select by sign, the same value. Every term stays below 2^62 in magnitude when the
// format is narrow and the node passes two checks (node shift, |base|); a node that does not is left to the
// reference path (the kernels return -1).
//
// Three kernels: portable scalar code; AVX-512F/DQ (all children and both planes of an axis in one vector); AVX2
// (four children a vector, for CPUs without AVX-512). The best the CPU has is chosen at run time (x86-64 only).
#pragma once

#include <algorithm>
#include <cstdint>

#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/hw_format.h"
#include "hwmodel/numeric/fixed_format.h"

namespace rtu::hw {

// The ray's constants for the node kernels.
struct NodeRay {
  bool fast = false;       // the kernels apply: narrow format, every rcp_sh >= 0
  uint8_t simd = 0;        // and a vector kernel is used (a NodeSimd level): the CPU has it, no component d is 0
  bool zero[3];            // d[a] == 0
  int frac;                // F
  int smax;                // largest node shift s = exp + F with q * (m << s) below 2^62
  int64_t blim;            // |base| below this keeps base * m below 2^62
  int near[3];             // q row of the near plane of axis a (2a or 2a + 1); the far plane is near ^ 1
  int64_t o[3];            // ray origin, grid.F
  int64_t mlo[3], mhi[3];  // rcpm_dn, rcpm_up (mlo <= mhi)
  int sh[3];               // rcp_sh (>= 0 when fast)
  int64_t rnd[3];          // 2^sh - 1: ceil of the far planes' shift
};

// The node kernels' vector levels.
enum NodeSimd : uint8_t { kNodeScalar = 0, kNodeAvx2 = 1, kNodeAvx512 = 2 };

// The best level the CPU runs: AVX-512 with AVX-512F and DQ, AVX2 with AVX2, else scalar (any other target).
// RTU_NO_SIMD=1 in the environment keeps the scalar kernel, RTU_SIMD=avx2 at most the AVX2 one (to compare them).
uint8_t node_simd_level();
inline bool node_simd_available() {
  return node_simd_level() != kNodeScalar;
}

// q_bytes: 1 or 2 (the node's offset type). max_simd caps the kernel (kNodeScalar forces the scalar one, for
// tests). Inline: built once per ray, in place.
inline NodeRay make_node_ray(const FixedRay& r, const FixedFormat& f, int q_bytes,
                             uint8_t max_simd = kNodeAvx512) {
  NodeRay nr;
  nr.fast = r.narrow;
  bool any_zero = false;
  for (int a = 0; a < 3; ++a) {
    nr.fast = nr.fast && r.rcp_sh[a] >= 0;
    nr.zero[a] = r.zero[a];
    any_zero = any_zero || r.zero[a];
    nr.near[a] = r.d[a] > 0 ? 2 * a : 2 * a + 1;
    nr.o[a] = r.o[a];
    nr.mlo[a] = r.rcpm_dn[a];
    nr.mhi[a] = r.rcpm_up[a];
    nr.sh[a] = r.rcp_sh[a];
    nr.rnd[a] = r.rcp_sh[a] > 0 && r.rcp_sh[a] < 63 ? (int64_t(1) << r.rcp_sh[a]) - 1 : 0;
  }
  nr.frac = r.frac;
  // |m| <= 2^(R+1) and q < 2^(8 q_bytes): q * (m << s) < 2^62 when s <= 61 - 8 q_bytes - R; base * m < 2^62
  // when |base| < 2^(61 - R).
  nr.smax = 61 - 8 * q_bytes - f.rcp_bits;
  nr.blim = int64_t(1) << (61 - f.rcp_bits);
  // The vector kernels multiply 32-bit halves: |m| <= 2^(R+1) must fit 32 signed bits.
  nr.simd =
      nr.fast && !any_zero && f.rcp_bits <= 30 ? std::min(max_simd, node_simd_level()) : uint8_t(kNodeScalar);
  return nr;
}

// Both kernels: tests the occupied children of n against [tmin, tlim]; writes the accepted ones (slot order)
// and their entry distances; returns how many, or -1 when the node is outside the kernels' bounds (then
// nothing is decided: use box_test_delta).
template <int N, class Q>
inline int box_node_scalar(const NodeRay& nr, const QNode<N, Q>& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                           int64_t dists[N]) {
  int64_t base[3], blo[3], bhi[3], mlo[3], mhi[3];
  int s[3];
  const Q* qn[3];
  const Q* qf[3];
  for (int a = 0; a < 3; ++a) {
    base[a] = (int64_t(n.origin[a]) << nr.frac) - nr.o[a];
    s[a] = n.exp[a] + nr.frac;
    if (s[a] > nr.smax || base[a] >= nr.blim || base[a] <= -nr.blim) return -1;
    blo[a] = base[a] * nr.mlo[a];
    bhi[a] = base[a] * nr.mhi[a];
    mlo[a] = int64_t(uint64_t(nr.mlo[a]) << s[a]);
    mhi[a] = int64_t(uint64_t(nr.mhi[a]) << s[a]);
    qn[a] = n.q[nr.near[a]];
    qf[a] = n.q[nr.near[a] ^ 1];
  }
  const int cnt = n.count;
  int k = 0;
  for (int i = 0; i < cnt; ++i) {
    int64_t t0 = tmin, t1 = tlim;
    bool out = false;
    for (int a = 0; a < 3; ++a) {
      if (nr.zero[a]) {  // the same for every child and node of the ray: predictable
        const int64_t dl = base[a] + (int64_t(n.q[2 * a][i]) << s[a]);
        const int64_t dh = base[a] + (int64_t(n.q[2 * a + 1][i]) << s[a]);
        out |= dl > 0 || dh < 0;
        continue;
      }
      const int64_t an = qn[a][i], af = qf[a][i];
      const int64_t pn1 = blo[a] + an * mlo[a], pn2 = bhi[a] + an * mhi[a];
      const int64_t pf1 = blo[a] + af * mlo[a], pf2 = bhi[a] + af * mhi[a];
      const int64_t tn = (pn1 < pn2 ? pn1 : pn2) >> nr.sh[a];
      const int64_t tf = ((pf1 > pf2 ? pf1 : pf2) + nr.rnd[a]) >> nr.sh[a];
      t0 = tn > t0 ? tn : t0;
      t1 = tf < t1 ? tf : t1;
    }
    refs[k] = n.child[i];
    dists[k] = t0;
    k += int(!out && t0 <= t1);
  }
  return k;
}

// The vector kernels (nr.simd at least their level); explicitly instantiated for the eight node types (widths 2,
// 4, 6, 8; 8- and 16-bit offsets).
template <int N, class Q>
int box_node_simd(const NodeRay& nr, const QNode<N, Q>& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                  int64_t dists[N]);
template <int N, class Q>
int box_node_avx2(const NodeRay& nr, const QNode<N, Q>& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                  int64_t dists[N]);

template <int N, class Q>
inline int box_node(const NodeRay& nr, const QNode<N, Q>& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                    int64_t dists[N]) {
  if (nr.simd == kNodeAvx512) return box_node_simd<N, Q>(nr, n, tmin, tlim, refs, dists);
  if (nr.simd == kNodeAvx2) return box_node_avx2<N, Q>(nr, n, tmin, tlim, refs, dists);
  return box_node_scalar<N, Q>(nr, n, tmin, tlim, refs, dists);
}

}  // namespace rtu::hw
