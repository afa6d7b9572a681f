#include "hwmodel/datapath/box_node.h"

#include <cstdlib>
#include <cstring>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define RTU_NODE_SIMD 1
#endif

namespace rtu::hw {

bool node_simd_available() {
#ifdef RTU_NODE_SIMD
  // RTU_NO_SIMD=1 in the environment keeps the scalar kernel (to compare the two).
  static const bool ok = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
                         !(std::getenv("RTU_NO_SIMD") && std::getenv("RTU_NO_SIMD")[0] == '1');
  return ok;
#else
  return false;
#endif
}

#ifdef RTU_NODE_SIMD

// Everything from here to the instantiations is compiled for AVX-512F/DQ; it runs only when
// node_simd_available() (make_node_ray sets NodeRay::simd by it).
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f,avx512dq"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx512f,avx512dq")
// GCC 12's AVX-512 intrinsics start from an "undefined" vector that -Wmaybe-uninitialized reports.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace {

// One row of N offsets, zero-extended to eight 64-bit lanes (lanes >= N are 0). Exactly the row's N * sizeof(Q)
// bytes are read: for N = 6 (6 or 12 bytes, not a power of two) as 4 + 2 or 8 + 4 bytes, the upper lanes zero.
template <int N, class Q>
inline __m512i load_row(const Q* row) {
  constexpr int kBytes = N * int(sizeof(Q));
  __m128i v;
  if constexpr (kBytes == 2) {
    uint16_t x;
    std::memcpy(&x, row, 2);
    v = _mm_cvtsi32_si128(int(x));
  } else if constexpr (kBytes == 4) {
    uint32_t x;
    std::memcpy(&x, row, 4);
    v = _mm_cvtsi32_si128(int(x));
  } else if constexpr (kBytes == 6) {
    uint64_t x = 0;
    std::memcpy(&x, row, 6);
    v = _mm_cvtsi64_si128(int64_t(x));
  } else if constexpr (kBytes == 8) {
    v = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(row));
  } else if constexpr (kBytes == 12) {
    uint64_t lo;
    uint32_t hi;
    std::memcpy(&lo, row, 8);
    std::memcpy(&hi, reinterpret_cast<const unsigned char*>(row) + 8, 4);
    v = _mm_insert_epi32(_mm_cvtsi64_si128(int64_t(lo)), int(hi), 2);
  } else {
    static_assert(kBytes == 16);
    v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row));
  }
  if constexpr (sizeof(Q) == 1) return _mm512_cvtepu8_epi64(v);
  return _mm512_cvtepu16_epi64(v);
}

}  // namespace

// Lanes are child slots. Per axis: the near and far planes' two products (exact, every value below 2^63),
// min / max, the floor / ceil shift, then the running max of entries and min of exits.
template <int N, class Q>
int box_node_simd(const NodeRay& nr, const QNode<N, Q>& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                  int64_t dists[N]) {
  __m512i t0 = _mm512_set1_epi64(tmin), t1 = _mm512_set1_epi64(tlim);
  for (int a = 0; a < 3; ++a) {
    const int64_t base = (int64_t(n.origin[a]) << nr.frac) - nr.o[a];
    const int s = n.exp[a] + nr.frac;
    if (s > nr.smax || base >= nr.blim || base <= -nr.blim) return -1;
    const __m512i blo = _mm512_set1_epi64(base * nr.mlo[a]), bhi = _mm512_set1_epi64(base * nr.mhi[a]);
    // q * (m << s) as (q * m) << s: q < 2^16 and |m| <= 2^(R+1) <= 2^31 are 32-bit values, so vpmuldq (32 x 32
    // -> 64 bits, signed) gives q * m exactly, and the shift is exact (the result is below 2^62).
    const __m512i mlo = _mm512_set1_epi64(nr.mlo[a]), mhi = _mm512_set1_epi64(nr.mhi[a]);
    const __m128i ss = _mm_cvtsi32_si128(s);
    const __m512i qn = load_row<N, Q>(n.q[nr.near[a]]), qf = load_row<N, Q>(n.q[nr.near[a] ^ 1]);
    const __m512i pn = _mm512_min_epi64(_mm512_add_epi64(blo, _mm512_sll_epi64(_mm512_mul_epi32(qn, mlo), ss)),
                                        _mm512_add_epi64(bhi, _mm512_sll_epi64(_mm512_mul_epi32(qn, mhi), ss)));
    const __m512i pf = _mm512_max_epi64(_mm512_add_epi64(blo, _mm512_sll_epi64(_mm512_mul_epi32(qf, mlo), ss)),
                                        _mm512_add_epi64(bhi, _mm512_sll_epi64(_mm512_mul_epi32(qf, mhi), ss)));
    const __m128i sh = _mm_cvtsi32_si128(nr.sh[a]);
    t0 = _mm512_max_epi64(t0, _mm512_sra_epi64(pn, sh));
    t1 = _mm512_min_epi64(t1, _mm512_sra_epi64(_mm512_add_epi64(pf, _mm512_set1_epi64(nr.rnd[a])), sh));
  }
  // Lanes >= N hold no child (their offsets were loaded as 0) and slots >= count are empty: both masked off.
  constexpr unsigned kLanes = (1u << N) - 1u;
  unsigned hit = unsigned(_mm512_cmple_epi64_mask(t0, t1)) & ((1u << n.count) - 1u) & kLanes;
  alignas(64) int64_t tv[8];
  _mm512_store_si512(tv, t0);
  int k = 0;
  while (hit) {
    const int i = __builtin_ctz(hit);
    hit &= hit - 1;
    refs[k] = n.child[i];
    dists[k] = tv[i];
    ++k;
  }
  return k;
}

#else  // no AVX-512 kernel on this target: never chosen (node_simd_available() is false)

template <int N, class Q>
int box_node_simd(const NodeRay& nr, const QNode<N, Q>& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                  int64_t dists[N]) {
  return box_node_scalar<N, Q>(nr, n, tmin, tlim, refs, dists);
}

#endif

#define RTU_BOX_NODE_SIMD(N, Q) \
  template int box_node_simd<N, Q>(const NodeRay&, const QNode<N, Q>&, int64_t, int64_t, uint32_t[N], int64_t[N]);
RTU_BOX_NODE_SIMD(2, uint8_t)
RTU_BOX_NODE_SIMD(4, uint8_t)
RTU_BOX_NODE_SIMD(6, uint8_t)
RTU_BOX_NODE_SIMD(8, uint8_t)
RTU_BOX_NODE_SIMD(2, uint16_t)
RTU_BOX_NODE_SIMD(4, uint16_t)
RTU_BOX_NODE_SIMD(6, uint16_t)
RTU_BOX_NODE_SIMD(8, uint16_t)
#undef RTU_BOX_NODE_SIMD

#ifdef RTU_NODE_SIMD
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif
#endif

}  // namespace rtu::hw
