#include "hwmodel/datapath/box_node.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define RTU_NODE_SIMD 1
#endif

namespace rtu::hw {

uint8_t node_simd_level() {
#ifdef RTU_NODE_SIMD
  static const uint8_t level = [] {
    const char* no = std::getenv("RTU_NO_SIMD");
    if (no && no[0] == '1') return uint8_t(kNodeScalar);
    uint8_t cap = kNodeAvx512;
    if (const char* want = std::getenv("RTU_SIMD")) {
      if (std::strcmp(want, "scalar") == 0)
        cap = kNodeScalar;
      else if (std::strcmp(want, "avx2") == 0)
        cap = kNodeAvx2;
      else if (std::strcmp(want, "avx512") != 0)
        std::fprintf(stderr, "rtusim: warning: RTU_SIMD=%s is none of scalar, avx2, avx512: ignored\n", want);
    }
    uint8_t have = kNodeScalar;
    if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq"))
      have = kNodeAvx512;
    else if (__builtin_cpu_supports("avx2"))
      have = kNodeAvx2;
    return std::min(cap, have);
  }();
  return level;
#else
  return kNodeScalar;
#endif
}

// Explicit instantiations of kernel K for the eight node types, inside K's target region (GCC compiles an
// instantiation for the target in force where it is instantiated).
#define RTU_BOX_NODE_INSTANCES(K)                                                                       \
  template int K<2, uint8_t>(const NodeRay&, const QNode<2, uint8_t>&, int64_t, int64_t, uint32_t[2],   \
                             int64_t[2]);                                                               \
  template int K<4, uint8_t>(const NodeRay&, const QNode<4, uint8_t>&, int64_t, int64_t, uint32_t[4],   \
                             int64_t[4]);                                                               \
  template int K<6, uint8_t>(const NodeRay&, const QNode<6, uint8_t>&, int64_t, int64_t, uint32_t[6],   \
                             int64_t[6]);                                                               \
  template int K<8, uint8_t>(const NodeRay&, const QNode<8, uint8_t>&, int64_t, int64_t, uint32_t[8],   \
                             int64_t[8]);                                                               \
  template int K<2, uint16_t>(const NodeRay&, const QNode<2, uint16_t>&, int64_t, int64_t, uint32_t[2], \
                              int64_t[2]);                                                              \
  template int K<4, uint16_t>(const NodeRay&, const QNode<4, uint16_t>&, int64_t, int64_t, uint32_t[4], \
                              int64_t[4]);                                                              \
  template int K<6, uint16_t>(const NodeRay&, const QNode<6, uint16_t>&, int64_t, int64_t, uint32_t[6], \
                              int64_t[6]);                                                              \
  template int K<8, uint16_t>(const NodeRay&, const QNode<8, uint16_t>&, int64_t, int64_t, uint32_t[8], \
                              int64_t[8]);

#ifdef RTU_NODE_SIMD

namespace {

// Both vector kernels' last step: the children whose bits are set in `hit`, in slot order, with their entry
// distances tv[i]. Plain code, inlined into either kernel's target.
template <int N>
inline int take_hits(unsigned hit, const uint32_t* child, const int64_t* tv, uint32_t refs[N], int64_t dists[N]) {
  int k = 0;
  while (hit) {
    const int i = __builtin_ctz(hit);
    hit &= hit - 1;
    refs[k] = child[i];
    dists[k] = tv[i];
    ++k;
  }
  return k;
}

}  // namespace

// Everything from here to the AVX2 kernel is compiled for AVX-512F/DQ, the AVX2 kernel for AVX2; each runs only
// where node_simd_level() is at least its level (make_node_ray sets NodeRay::simd by it).
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
  return take_hits<N>(hit, n.child, tv, refs, dists);
}
RTU_BOX_NODE_INSTANCES(box_node_simd)

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif

// The AVX2 kernel: the AVX-512 one's arithmetic, four children a vector (one or two vectors a node). AVX2 has no
// 64-bit min, max or arithmetic shift: min and max select by a compare, and x >> s (floor) is ~(~x >>> s) for
// negative x, (x ^ m) >>> s ^ m with m the sign mask: the same values.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

namespace {

// Offsets [4g, 4g + 4) of a row of N, zero-extended to four 64-bit lanes (those >= N are 0); reads only the row.
template <int N, class Q>
inline __m256i load_quad(const Q* row, int g) {
  const int first = 4 * g, count = std::min(4, N - first);
  uint64_t x = 0;
  std::memcpy(&x, row + first, size_t(count) * sizeof(Q));
  const __m128i v = _mm_cvtsi64_si128(int64_t(x));
  if constexpr (sizeof(Q) == 1) return _mm256_cvtepu8_epi64(v);
  return _mm256_cvtepu16_epi64(v);
}

inline __m256i min64(__m256i a, __m256i b) {
  return _mm256_blendv_epi8(a, b, _mm256_cmpgt_epi64(a, b));
}
inline __m256i max64(__m256i a, __m256i b) {
  return _mm256_blendv_epi8(b, a, _mm256_cmpgt_epi64(a, b));
}
inline __m256i sra64(__m256i x, __m128i s) {
  const __m256i m = _mm256_cmpgt_epi64(_mm256_setzero_si256(), x);
  return _mm256_xor_si256(_mm256_srl_epi64(_mm256_xor_si256(x, m), s), m);
}

}  // namespace

template <int N, class Q>
int box_node_avx2(const NodeRay& nr, const QNode<N, Q>& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                  int64_t dists[N]) {
  constexpr int G = (N + 3) / 4;
  __m256i t0[G], t1[G];
  for (int g = 0; g < G; ++g) {
    t0[g] = _mm256_set1_epi64x(tmin);
    t1[g] = _mm256_set1_epi64x(tlim);
  }
  for (int a = 0; a < 3; ++a) {
    const int64_t base = (int64_t(n.origin[a]) << nr.frac) - nr.o[a];
    const int s = n.exp[a] + nr.frac;
    if (s > nr.smax || base >= nr.blim || base <= -nr.blim) return -1;
    const __m256i blo = _mm256_set1_epi64x(base * nr.mlo[a]), bhi = _mm256_set1_epi64x(base * nr.mhi[a]);
    const __m256i mlo = _mm256_set1_epi64x(nr.mlo[a]), mhi = _mm256_set1_epi64x(nr.mhi[a]);
    const __m256i rnd = _mm256_set1_epi64x(nr.rnd[a]);
    const __m128i ss = _mm_cvtsi32_si128(s), sh = _mm_cvtsi32_si128(nr.sh[a]);
    for (int g = 0; g < G; ++g) {
      const __m256i qn = load_quad<N, Q>(n.q[nr.near[a]], g), qf = load_quad<N, Q>(n.q[nr.near[a] ^ 1], g);
      const __m256i pn = min64(_mm256_add_epi64(blo, _mm256_sll_epi64(_mm256_mul_epi32(qn, mlo), ss)),
                               _mm256_add_epi64(bhi, _mm256_sll_epi64(_mm256_mul_epi32(qn, mhi), ss)));
      const __m256i pf = max64(_mm256_add_epi64(blo, _mm256_sll_epi64(_mm256_mul_epi32(qf, mlo), ss)),
                               _mm256_add_epi64(bhi, _mm256_sll_epi64(_mm256_mul_epi32(qf, mhi), ss)));
      t0[g] = max64(t0[g], sra64(pn, sh));
      t1[g] = min64(t1[g], sra64(_mm256_add_epi64(pf, rnd), sh));
    }
  }
  constexpr unsigned kLanes = (1u << N) - 1u;
  alignas(32) int64_t tv[4 * G];
  unsigned hit = 0;
  for (int g = 0; g < G; ++g) {
    const __m256i out = _mm256_cmpgt_epi64(t0[g], t1[g]);  // t0 > t1: missed
    hit |= (unsigned(~_mm256_movemask_pd(_mm256_castsi256_pd(out))) & 0xFu) << (4 * g);
    _mm256_store_si256(reinterpret_cast<__m256i*>(tv + 4 * g), t0[g]);
  }
  hit &= ((1u << n.count) - 1u) & kLanes;
  return take_hits<N>(hit, n.child, tv, refs, dists);
}
RTU_BOX_NODE_INSTANCES(box_node_avx2)

#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif

#else  // no vector kernel on this target: never chosen (node_simd_level() is kNodeScalar)

template <int N, class Q>
int box_node_simd(const NodeRay& nr, const QNode<N, Q>& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                  int64_t dists[N]) {
  return box_node_scalar<N, Q>(nr, n, tmin, tlim, refs, dists);
}
template <int N, class Q>
int box_node_avx2(const NodeRay& nr, const QNode<N, Q>& n, int64_t tmin, int64_t tlim, uint32_t refs[N],
                  int64_t dists[N]) {
  return box_node_scalar<N, Q>(nr, n, tmin, tlim, refs, dists);
}
RTU_BOX_NODE_INSTANCES(box_node_simd)
RTU_BOX_NODE_INSTANCES(box_node_avx2)

#endif
#undef RTU_BOX_NODE_INSTANCES

}  // namespace rtu::hw
