// The fixed datapath's fast paths against the code they replace, bit for bit:
// - ray setup (float -> grid without 128-bit arithmetic, the double quotient with an exact integer correction
//   in set_direction, ilogb from the bits) against reference copies of the exact 128-bit/division code, on
//   millions of random floats with subnormals, powers of two, +-0, huge and tiny magnitudes;
// - round_shift64 against round_shift;
// - the triangle test's 64-bit q x d edge functions against the 128-bit d . (p x q) code, on triangles of every
//   size with rays exactly through their vertices and edges, from origins near and far (both paths);
// - the node kernels of box_node.h (scalar and, where the CPU has it, AVX-512) against box_test child by child
//   on random nodes and rays: ties, origins on planes, zero and tiny direction components, every width and both
//   offset types.
#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "hwmodel/datapath/box_node.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/quant_frame.h"
#include "hwmodel/numeric/fixed_format.h"

using namespace rtu::hw;

namespace {

// ---- Reference copies of the exact code the fast paths replaced ----

int64_t to_grid_ref(const QuantFrame& fr, float x, int axis, Round r, int frac_bits) {
  if (std::isnan(x)) {
    ++saturation_counter();
    return 0;
  }
  if (std::isinf(x)) {
    ++saturation_counter();
    return x > 0 ? QuantFrame::kGridLimit : -QuantFrame::kGridLimit;
  }
  int64_t m;
  int k;
  split_float(x, m, k);
  const int sh = k - fr.step_exp + frac_bits;
  const Wide o = Wide(fr.origin[axis]) << frac_bits;
  Wide g;
  const Wide beyond = Wide(QuantFrame::kGridLimit) + 1;
  if (sh >= 0) {
    g = sh > 64 ? (m > 0 ? beyond : -beyond) : (Wide(m) << sh) - o;
  } else if (-sh <= 40) {
    g = round_shift(Wide(m) - (o << -sh), -sh, r);
  } else {
    g = -o;
    if (m > 0 && r == Round::kUp) g += 1;
    if (m < 0 && r == Round::kDown) g -= 1;
  }
  if (g > QuantFrame::kGridLimit || g < -QuantFrame::kGridLimit) {
    ++saturation_counter();
    return g > 0 ? QuantFrame::kGridLimit : -QuantFrame::kGridLimit;
  }
  return int64_t(g);
}

Wide scaled_round_ref(float x, int e, Round r) {
  if (x == 0.0f) return 0;
  int64_t m;
  int k;
  split_float(x, m, k);
  const int sh = k + e;
  if (sh >= 0) {
    if (sh > 46) return m > 0 ? (Wide(1) << 70) : -(Wide(1) << 70);
    return Wide(m) << sh;
  }
  if (-sh > 100) {
    if (m > 0 && r == Round::kUp) return 1;
    if (m < 0 && r == Round::kDown) return -1;
    return 0;
  }
  return round_shift(Wide(m), -sh, r);
}

void set_direction_ref(FixedRay& r, const int64_t d[3], const FixedFormat& f) {
  const int64_t one = int64_t(1) << (f.dir_bits + f.rcp_bits);
  for (int a = 0; a < 3; ++a) {
    r.d[a] = d[a];
    r.zero[a] = d[a] == 0;
    if (r.zero[a]) {
      r.rcp_dn[a] = r.rcp_up[a] = r.rcpm_dn[a] = r.rcpm_up[a] = 0;
      r.rcp_sh[a] = 0;
      continue;
    }
    const int64_t q = one / d[a], rem = one % d[a];
    r.rcp_dn[a] = rem != 0 && d[a] < 0 ? q - 1 : q;
    r.rcp_up[a] = rem != 0 && d[a] > 0 ? q + 1 : q;
    const uint64_t mag = uint64_t(std::max(std::abs(r.rcp_dn[a]), std::abs(r.rcp_up[a])));
    const int bits = 64 - __builtin_clzll(mag);
    const int e = std::max(0, bits - (f.rcp_bits + 1));
    r.rcpm_dn[a] = int64_t(round_shift(r.rcp_dn[a], e, Round::kDown));
    r.rcpm_up[a] = int64_t(round_shift(r.rcp_up[a], e, Round::kUp));
    r.rcp_sh[a] = f.frac_bits + f.rcp_bits - f.t_frac_bits - e;
  }
  r.narrow = f.translated_bits() + f.rcp_bits + 2 <= 63 && f.frac_bits + f.rcp_bits - f.t_frac_bits <= 61;
}

RayStatus setup_ray_ref(const Ray& r, const QuantFrame& frame, const FixedFormat& f, FixedRay& out) {
  const RayStatus st = validate_ray(r);
  if (st != RayStatus::kOk) return st;
  out.frac = f.frac_bits;
  out.dir_bits = f.dir_bits;
  out.box_shift = f.frac_bits + f.rcp_bits - f.t_frac_bits;
  out.t_shift = f.t_shift();
  out.t_limit = int64_t((uint64_t(1) << f.t_bits) - 1);
  const int range_exp = f.coord_bits + f.guard_bits;
  const int64_t olim = int64_t(1) << (range_exp + f.frac_bits);
  for (int a = 0; a < 3; ++a) {
    const double rel = double(r.origin[a]) - double(frame.origin[a]) * pow2(frame.step_exp);
    if (std::abs(rel) > pow2(range_exp + 1 + frame.step_exp)) return RayStatus::kOutOfFrame;
    out.o[a] = to_grid_ref(frame, r.origin[a], a, Round::kNearestEven, f.frac_bits);
    if (out.o[a] >= olim || out.o[a] <= -olim) return RayStatus::kOutOfFrame;
  }
  const float m = std::max({std::abs(r.dir.x), std::abs(r.dir.y), std::abs(r.dir.z)});
  const int E = std::ilogb(m);
  int64_t d[3];
  for (int a = 0; a < 3; ++a) d[a] = int64_t(scaled_round_ref(r.dir[a], f.dir_bits - E - 1, Round::kNearestEven));
  set_direction_ref(out, d, f);
  const int k = E + 1 - frame.step_exp;
  out.t_exp = f.t_frac_bits + k;
  out.tmin = clamp_t(scaled_round_ref(r.tmin, out.t_exp, Round::kDown), out.t_limit);
  out.tmax = std::isinf(r.tmax) ? (r.tmax > 0 ? out.t_limit : -out.t_limit)
                                : clamp_t(scaled_round_ref(r.tmax, out.t_exp, Round::kUp), out.t_limit);
  return RayStatus::kOk;
}

// triangle_test with every edge function as d . (p x q) in 128 bits (before the 64-bit q x d path).
bool triangle_test_ref(const FixedRay& r, const int32_t v[3][3], int64_t tmin, int64_t tlim, FixedPrimHit& out) {
  int64_t A[3][3];
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a) A[i][a] = (int64_t(v[i][a]) << r.frac) - r.o[a];
  auto edge = [&](const int64_t* p, const int64_t* q) {
    const Wide cx = Wide(p[1]) * q[2] - Wide(p[2]) * q[1];
    const Wide cy = Wide(p[2]) * q[0] - Wide(p[0]) * q[2];
    const Wide cz = Wide(p[0]) * q[1] - Wide(p[1]) * q[0];
    return cx * r.d[0] + cy * r.d[1] + cz * r.d[2];
  };
  const Wide e0 = edge(A[1], A[2]), e1 = edge(A[2], A[0]);
  if ((e0 < 0 && e1 > 0) || (e0 > 0 && e1 < 0)) return false;
  const Wide e2 = edge(A[0], A[1]);
  if ((e0 < 0 || e1 < 0 || e2 < 0) && (e0 > 0 || e1 > 0 || e2 > 0)) return false;
  const Wide det = e0 + e1 + e2;
  if (det == 0) return false;
  int64_t t;
  if (!triangle_plane_t(r, v, A[0], t)) return false;
  if (t < tmin || t > tlim || !in_register(t, r)) return false;
  out.t = t;
  triangle_barycentrics(e1, e2, det, out.u, out.v);
  return true;
}

// ---- Helpers ----

bool same_direction(const FixedRay& a, const FixedRay& b) {
  for (int i = 0; i < 3; ++i) {
    if (a.d[i] != b.d[i] || a.zero[i] != b.zero[i] || a.rcp_dn[i] != b.rcp_dn[i] || a.rcp_up[i] != b.rcp_up[i] ||
        a.rcpm_dn[i] != b.rcpm_dn[i] || a.rcpm_up[i] != b.rcpm_up[i] || a.rcp_sh[i] != b.rcp_sh[i])
      return false;
  }
  return a.narrow == b.narrow;
}

bool same_ray(const FixedRay& a, const FixedRay& b) {
  for (int i = 0; i < 3; ++i)
    if (a.o[i] != b.o[i]) return false;
  return same_direction(a, b) && a.tmin == b.tmin && a.tmax == b.tmax && a.t_exp == b.t_exp && a.frac == b.frac &&
         a.dir_bits == b.dir_bits && a.box_shift == b.box_shift && a.t_shift == b.t_shift &&
         a.t_limit == b.t_limit;
}

// A float of every kind: +-0, subnormal, powers of two and their neighbours, tiny to huge, or plain random.
float odd_float(std::mt19937_64& rng) {
  const uint32_t kind = uint32_t(rng() % 10);
  const float sign = (rng() & 1) ? -1.0f : 1.0f;
  switch (kind) {
    case 0:
      return sign * 0.0f;
    case 1:  // subnormal
      return std::bit_cast<float>(uint32_t(rng() % 0x7FFFFFu + 1) | ((rng() & 1) ? 0x80000000u : 0u));
    case 2:  // a power of two, any exponent
      return sign * std::ldexp(1.0f, int(rng() % 254) - 126);
    case 3: {  // next to a power of two
      const float p = std::ldexp(1.0f, int(rng() % 120) - 60);
      return sign * ((rng() & 1) ? std::nextafter(p, 0.0f) : std::nextafter(p, 1e30f));
    }
    case 4:  // any finite float by its bits
      for (;;) {
        const float x = std::bit_cast<float>(uint32_t(rng()));
        if (std::isfinite(x)) return x;
      }
    default:  // moderate magnitudes, random mantissa
      return sign * std::ldexp(1.0f + float(rng() % (1u << 23)) / float(1u << 23), int(rng() % 40) - 20);
  }
}

}  // namespace

TEST_CASE("round_shift64 equals round_shift on 64-bit values", "[fixed][fast]") {
  std::mt19937_64 rng(7);
  const Round modes[] = {Round::kDown, Round::kUp, Round::kNearestEven};
  for (int i = 0; i < 1000000; ++i) {
    int64_t x = int64_t(rng());
    const int s = int(rng() % 63);
    if (i % 4 == 1) x >>= rng() % 63;                                                          // small magnitudes
    if (i % 4 == 2) x = (x >> s << s) | (int64_t(1) << s >> 1);                                // exact halves
    if (i % 4 == 3) x = (int64_t(1) << 62) * ((rng() & 1) ? 1 : -1) + int64_t(rng() % 5) - 2;  // near +-2^62
    for (Round r : modes) {
      if (round_shift64(x, s, r) != int64_t(round_shift(x, s, r))) {
        INFO("x " << x << " s " << s << " mode " << int(r));
        REQUIRE(round_shift64(x, s, r) == int64_t(round_shift(x, s, r)));
      }
    }
  }
}

TEST_CASE("set_direction: the double quotient with integer correction equals the 64-bit division",
          "[fixed][fast][setup][scale]") {
  std::mt19937_64 rng(11);
  uint64_t cases = 0;
  for (const FixedFormat& f : format_presets()) {
    const int64_t dmax = int64_t(1) << f.dir_bits;
    for (int i = 0; i < 500000; ++i) {
      int64_t d[3];
      for (int a = 0; a < 3; ++a) {
        const uint32_t kind = uint32_t(rng() % 8);
        int64_t v;
        if (kind == 0) {
          v = int64_t(rng() % 8);  // 0 .. 7
        } else if (kind == 1) {
          v = int64_t(1) << (rng() % (f.dir_bits + 1));  // powers of two up to 2^D
        } else if (kind == 2) {
          v = (int64_t(1) << (rng() % (f.dir_bits + 1))) + int64_t(rng() % 3) - 1;  // their neighbours
        } else if (kind == 3) {
          v = dmax - int64_t(rng() % 4);
        } else if (kind == 4) {
          v = int64_t(rng() % uint64_t(dmax)) >> (rng() % f.dir_bits);  // any magnitude
        } else {
          v = int64_t(rng() % uint64_t(dmax + 1));
        }
        v = std::clamp<int64_t>(v, 0, dmax);
        d[a] = (rng() & 1) ? -v : v;
      }
      FixedRay got{}, want{};
      set_direction(got, d, f);
      set_direction_ref(want, d, f);
      if (!same_direction(got, want)) {
        INFO(f.name << " d " << d[0] << " " << d[1] << " " << d[2]);
        REQUIRE(same_direction(got, want));
      }
      ++cases;
    }
    // Every magnitude 1 .. 2^16 exactly, and the top of the range.
    for (int64_t v = 1; v <= (int64_t(1) << 16) && v <= dmax; ++v) {
      for (int64_t w : {v, -v, dmax - v + 1, -(dmax - v + 1)}) {
        const int64_t d[3] = {w, dmax, -w};
        FixedRay got{}, want{};
        set_direction(got, d, f);
        set_direction_ref(want, d, f);
        if (!same_direction(got, want)) {
          INFO(f.name << " d " << w);
          REQUIRE(same_direction(got, want));
        }
        ++cases;
      }
    }
  }
  CHECK(cases > 2500000);
}

TEST_CASE("ray setup: the 64-bit fast paths equal the exact 128-bit code on odd floats",
          "[fixed][fast][setup][scale]") {
  std::mt19937_64 rng(13);
  uint64_t ok = 0, rejected = 0, saturated = 0;  // (the coarse range test keeps to_grid from saturating)
  for (const FixedFormat& f : format_presets()) {
    for (int fi = 0; fi < 40; ++fi) {
      // Frames of every scale and position: origins near and far from world 0.
      QuantFrame frame;
      frame.bits = f.coord_bits;
      frame.step_exp = int(rng() % 80) - 50;
      for (int a = 0; a < 3; ++a) {
        const int mag = int(rng() % 52);
        frame.origin[a] = int64_t(rng() % (uint64_t(1) << mag)) * ((rng() & 1) ? -1 : 1);
      }
      const double step = std::ldexp(1.0, frame.step_exp);
      const RaySetup setup(frame, f);  // the tracers' setup: its own fast path for frames near world 0
      for (int i = 0; i < 10000; ++i) {
        Ray r;
        for (int a = 0; a < 3; ++a) {
          // Origins in or near the frame (most), or any float.
          if (rng() % 4 != 0) {
            const double g =
                (double(int64_t(rng() % (uint64_t(1) << 40))) / double(uint64_t(1) << 40) * 1.5 - 0.25) *
                std::ldexp(1.0, f.coord_bits + int(rng() % (f.guard_bits + 2)));
            r.origin[a] = float(double(frame.origin[a]) * step + g * step);
          } else {
            r.origin[a] = odd_float(rng);
          }
          r.dir[a] = odd_float(rng);
        }
        r.tmin = (rng() % 3 == 0) ? std::abs(odd_float(rng)) : 0.0f;
        r.tmax = (rng() % 3 == 0) ? std::abs(odd_float(rng)) : std::numeric_limits<float>::infinity();
        FixedRay got{}, want{};
        const uint64_t s0 = saturation_count();
        const RayStatus sw = setup_ray_ref(r, frame, f, want);
        const uint64_t s1 = saturation_count();
        const RayStatus sg = setup_ray(r, frame, f, got);
        const uint64_t s2 = saturation_count();
        FixedRay got2{};
        const RayStatus sg2 = setup(r, got2);
        const uint64_t s3 = saturation_count();
        const bool same = sg == sw && s2 - s1 == s1 - s0 && (sw != RayStatus::kOk || same_ray(got, want)) &&
                          sg2 == sw && s3 - s2 == s1 - s0 && (sw != RayStatus::kOk || same_ray(got2, want));
        if (!same) {  // (INFO only here: building its message for every case would dominate the run time)
          INFO(f.name << " frame " << frame.step_exp << " " << frame.origin[0] << " " << frame.origin[1] << " "
                      << frame.origin[2] << " origin " << r.origin.x << " " << r.origin.y << " " << r.origin.z
                      << " dir " << r.dir.x << " " << r.dir.y << " " << r.dir.z << " t " << r.tmin << " "
                      << r.tmax);
          REQUIRE(sg == sw);
          REQUIRE(s2 - s1 == s1 - s0);
          REQUIRE(same_ray(got, want));
          REQUIRE(sg2 == sw);
          REQUIRE(s3 - s2 == s1 - s0);
          REQUIRE(same_ray(got2, want));
        }
        saturated += s1 - s0;
        ok += uint64_t(sw == RayStatus::kOk);
        rejected += uint64_t(sw != RayStatus::kOk);
      }
    }
  }
  CHECK(ok > 900000);
  CHECK(rejected > 10000);
  CHECK(saturated == 0);
}

TEST_CASE("quantization frame: to_grid's 64-bit path equals the 128-bit code, every mode and frac",
          "[fixed][fast]") {
  std::mt19937_64 rng(17);
  const Round modes[] = {Round::kDown, Round::kUp, Round::kNearestEven};
  uint64_t sats = 0;
  for (int fi = 0; fi < 2000; ++fi) {
    QuantFrame frame;
    frame.bits = 24;
    frame.step_exp = int(rng() % 300) - 150;
    for (int a = 0; a < 3; ++a) {
      const int mag = int(rng() % 52);
      frame.origin[a] = int64_t(rng() % (uint64_t(1) << mag)) * ((rng() & 1) ? -1 : 1);
    }
    for (int i = 0; i < 1000; ++i) {
      float x = odd_float(rng);
      if (i % 3 == 0)
        x = float(double(frame.origin[0]) * std::ldexp(1.0, frame.step_exp) * (1.0 + double(x) * 1e-3));
      if (i % 50 == 0) x = std::numeric_limits<float>::infinity() * ((rng() & 1) ? 1.0f : -1.0f);
      const int frac = int(rng() % 25);
      for (Round r : modes) {
        const uint64_t s0 = saturation_count();
        const int64_t want = to_grid_ref(frame, x, 0, r, frac);
        const uint64_t s1 = saturation_count();
        const int64_t got = frame.to_grid(x, 0, r, frac);
        const uint64_t s2 = saturation_count();
        if (got != want || s2 - s1 != s1 - s0) {
          INFO("step_exp " << frame.step_exp << " origin " << frame.origin[0] << " x " << x << " frac " << frac);
          REQUIRE(got == want);
          REQUIRE(s2 - s1 == s1 - s0);
        }
        sats += s1 - s0;
      }
    }
  }
  CHECK(sats > 1000);  // saturating values (beyond 2^61, infinities) were among them
}

namespace {

// A random node of N children with offsets of type Q and a ray in format f; checks each kernel the CPU runs
// against box_test child by child. Returns false when the kernels declined the node (-1).
template <int N, class Q>
void check_node_kernels(const FixedFormat& f, std::mt19937_64& rng, uint64_t& nodes, uint64_t& declined,
                        uint64_t& accepted, uint64_t (&simd_nodes)[3]) {
  const int B = f.coord_bits, k = std::min<int>(f.child_bits, 8 * int(sizeof(Q)));
  const int64_t qmax = (int64_t(1) << k) - 1;
  auto rint = [&](int64_t lo, int64_t hi) { return lo + int64_t(rng() % uint64_t(hi - lo + 1)); };
  // The ray: an origin on the grid.F (sometimes exactly on a child plane), a direction of D fraction bits.
  QNode<N, Q> n{};
  n.count = uint8_t(rint(1, N));
  for (int a = 0; a < 3; ++a) {
    n.exp[a] = int8_t(rint(0, std::max(0, B + 1 - k)));
    const int64_t span = qmax << n.exp[a];
    n.origin[a] = int32_t(rint(0, std::max<int64_t>(0, (int64_t(1) << B) - span)));
  }
  for (int i = 0; i < N; ++i) {
    n.child[i] = uint32_t(rng());
    for (int a = 0; a < 3; ++a) {
      int64_t lo = rint(0, qmax), hi = rint(0, qmax);
      if (lo > hi) std::swap(lo, hi);
      if (rng() % 8 == 0) hi = lo;  // flat box
      n.q[2 * a][i] = Q(lo);
      n.q[2 * a + 1][i] = Q(hi);
    }
  }
  FixedRay r{};
  set_format_fields(r, f);
  r.t_exp = f.t_frac_bits;
  const int64_t glim = (int64_t(1) << (B + f.guard_bits + f.frac_bits)) - 1;
  for (int a = 0; a < 3; ++a) {
    const int kind = int(rng() % 4);
    if (kind == 0) {  // exactly on a child plane
      const int i = int(rng() % n.count);
      r.o[a] = (int64_t(n.origin[a]) + (int64_t(n.q[2 * a + (rng() & 1)][i]) << n.exp[a])) << f.frac_bits;
    } else if (kind == 1) {  // anywhere in the guard range
      r.o[a] = rint(-glim, glim);
    } else {  // near the node
      r.o[a] = ((int64_t(n.origin[a]) + rint(-(qmax << n.exp[a]), 2 * (qmax << n.exp[a]))) << f.frac_bits) +
               rint(0, (int64_t(1) << f.frac_bits) - 1);
    }
  }
  // The direction: aimed at a point of a child box (most), or random; some components zero or tiny.
  int64_t d[3];
  const int64_t dmax = int64_t(1) << f.dir_bits;
  if (rng() % 4 != 0) {
    const int i = int(rng() % n.count);
    int64_t delta[3], m = 0;
    for (int a = 0; a < 3; ++a) {
      const int64_t lo = int64_t(n.origin[a]) + (int64_t(n.q[2 * a][i]) << n.exp[a]);
      const int64_t hi = int64_t(n.origin[a]) + (int64_t(n.q[2 * a + 1][i]) << n.exp[a]);
      delta[a] = (rint(lo, hi) << f.frac_bits) - r.o[a];
      m = std::max(m, std::abs(delta[a]));
    }
    for (int a = 0; a < 3; ++a) d[a] = m == 0 ? dmax : int64_t(Wide(delta[a]) * dmax / m);
  } else {
    const int big = int(rng() % 3);
    for (int a = 0; a < 3; ++a) {
      const int64_t v = a == big ? rint(dmax / 2, dmax) : rint(1, dmax) >> (rng() % 14);
      d[a] = (rng() & 1) ? -v : v;
    }
  }
  for (int a = 0; a < 3; ++a) {
    const uint32_t kind = uint32_t(rng() % 16);
    if (kind == 0 && std::abs(d[a]) < dmax / 2) d[a] = 0;
    if (kind == 1 && std::abs(d[a]) < dmax / 2) d[a] = int64_t(rng() % 64) * ((rng() & 1) ? -1 : 1);
  }
  if (d[0] == 0 && d[1] == 0 && d[2] == 0) d[0] = dmax;
  set_direction(r, d, f);
  int64_t tmin = 0, tlim = r.t_limit;
  if (rng() % 3 == 0) tmin = rint(0, int64_t(1) << (f.t_frac_bits + B));
  if (rng() % 3 == 0) tlim = rint(0, int64_t(1) << (f.t_frac_bits + B + 2));
  r.tmin = tmin;
  r.tmax = tlim;

  uint32_t want_refs[N];
  int64_t want_dists[N];
  int want = 0;
  for (int i = 0; i < n.count; ++i) {
    int64_t lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = int64_t(n.origin[a]) + (int64_t(n.q[2 * a][i]) << n.exp[a]);
      hi[a] = int64_t(n.origin[a]) + (int64_t(n.q[2 * a + 1][i]) << n.exp[a]);
    }
    int64_t t = 0;
    if (box_test(r, lo, hi, tmin, tlim, t)) {
      want_refs[want] = n.child[i];
      want_dists[want] = t;
      ++want;
    }
  }
  ++nodes;
  accepted += uint64_t(want);
  // Each kernel the CPU runs: scalar, AVX2, AVX-512 (box_node() picks the one NodeRay::simd names).
  for (uint8_t level : {rtu::hw::kNodeScalar, rtu::hw::kNodeAvx2, rtu::hw::kNodeAvx512}) {
    const NodeRay nr = make_node_ray(r, f, int(sizeof(Q)), level);
    if (!nr.fast) {
      ++declined;
      return;
    }
    if (nr.simd != level) continue;  // the CPU lacks it, or the ray is not for the vector kernels
    uint32_t refs[N];
    int64_t dists[N];
    const int got = box_node<N, Q>(nr, n, tmin, tlim, refs, dists);
    if (got < 0) {  // every kernel declines the same nodes: counted once
      declined += uint64_t(level == rtu::hw::kNodeScalar);
      continue;
    }
    simd_nodes[level] += 1;
    INFO(f.name << " N " << N << " q bytes " << sizeof(Q) << " kernel " << int(level) << " d " << d[0] << " "
                << d[1] << " " << d[2] << " o " << r.o[0] << " " << r.o[1] << " " << r.o[2] << " t " << tmin << " "
                << tlim);
    REQUIRE(got == want);
    for (int j = 0; j < got; ++j) {
      REQUIRE(refs[j] == want_refs[j]);
      REQUIRE(dists[j] == want_dists[j]);
    }
  }
}

}  // namespace

TEST_CASE("node kernels: scalar, AVX2 and AVX-512 equal box_test child by child (random nodes, every width)",
          "[fixed][fast][box][scale]") {
  std::mt19937_64 rng(19);
  uint64_t nodes = 0, declined = 0, accepted = 0, simd_nodes[3] = {0, 0, 0};
  std::vector<FixedFormat> formats;
  for (const FixedFormat& f : format_presets())
    if (f.translated_bits() + f.rcp_bits + 2 <= 63) formats.push_back(f);  // the narrow ones
  REQUIRE(formats.size() >= 2);
  for (const FixedFormat& f : formats) {
    for (int i = 0; i < 50000; ++i) {
      check_node_kernels<2, uint8_t>(f, rng, nodes, declined, accepted, simd_nodes);
      check_node_kernels<4, uint8_t>(f, rng, nodes, declined, accepted, simd_nodes);
      check_node_kernels<6, uint8_t>(f, rng, nodes, declined, accepted, simd_nodes);
      check_node_kernels<8, uint8_t>(f, rng, nodes, declined, accepted, simd_nodes);
      check_node_kernels<2, uint16_t>(f, rng, nodes, declined, accepted, simd_nodes);
      check_node_kernels<4, uint16_t>(f, rng, nodes, declined, accepted, simd_nodes);
      check_node_kernels<6, uint16_t>(f, rng, nodes, declined, accepted, simd_nodes);
      check_node_kernels<8, uint16_t>(f, rng, nodes, declined, accepted, simd_nodes);
    }
  }
  INFO("nodes " << nodes << " declined " << declined << " accepted children " << accepted << " simd "
                << simd_nodes[1] << " avx2, " << simd_nodes[2] << " avx512");
  CHECK(accepted > nodes / 4);  // the random nodes are hit often enough to compare distances
  CHECK(declined < nodes / 2);
  // Each vector kernel the CPU has took most nodes (the others' rays have a zero direction component).
  if (rtu::hw::node_simd_level() >= rtu::hw::kNodeAvx2) CHECK(simd_nodes[1] > nodes / 4);
  if (rtu::hw::node_simd_level() >= rtu::hw::kNodeAvx512) CHECK(simd_nodes[2] > nodes / 4);
}

TEST_CASE("triangle test: the 64-bit q x d edge functions equal the 128-bit code, through vertices and edges",
          "[fixed][fast][triangle][scale]") {
  std::mt19937_64 rng(23);
  auto rint = [&](int64_t lo, int64_t hi) { return lo + int64_t(rng() % uint64_t(hi - lo + 1)); };
  uint64_t cases = 0, hits = 0, through = 0, short_path = 0, long_path = 0, known = 0;
  for (const FixedFormat& f : format_presets()) {
    FixedRay proto{};
    set_format_fields(proto, f);
    const int B = f.coord_bits, F = f.frac_bits;
    const int64_t gmax = (int64_t(1) << B) - 1, dmax = int64_t(1) << f.dir_bits;
    const int64_t olim = (int64_t(1) << (B + f.guard_bits + F)) - 1;
    const uint64_t short_lim = uint64_t(1) << (62 - f.dir_bits);
    for (int i = 0; i < 200000; ++i) {
      // Vertices anywhere on the grid, clustered (small triangles), or collinear.
      int32_t v[3][3];
      const int kind = int(rng() % 4);
      const int64_t span = kind == 0 ? gmax : (int64_t(1) << (rng() % B));
      int64_t base[3];
      for (int a = 0; a < 3; ++a) base[a] = rint(0, gmax - std::min(span, gmax));
      for (int j = 0; j < 3; ++j)
        for (int a = 0; a < 3; ++a) v[j][a] = int32_t(base[a] + rint(0, std::min(span, gmax)));
      if (kind == 3)
        for (int a = 0; a < 3; ++a) v[2][a] = int32_t((int64_t(v[0][a]) + v[1][a]) / 2);
      // A point: a vertex, the midpoint of an edge (exactly on it, F >= 1), inside, or anywhere.
      int64_t p[3];
      const int aim = int(rng() % 4);
      const int j0 = int(rng() % 3), j1 = (j0 + 1) % 3;
      for (int a = 0; a < 3; ++a) {
        const int64_t v0 = int64_t(v[j0][a]) << F, v1 = int64_t(v[j1][a]) << F;
        if (aim == 0)
          p[a] = v0;
        else if (aim == 1)
          p[a] = (v0 + v1) / 2;
        else if (aim == 2)
          p[a] = (v0 + v1 + (int64_t(v[3 - j0 - j1][a]) << F)) / 3;
        else
          p[a] = rint(0, gmax) << F;
      }
      // The ray passes exactly through p: origin p - d * 2^s (or just off it), s up to the guard range.
      int64_t d[3], m = 0;
      for (int a = 0; a < 3; ++a) {
        d[a] = rint(-dmax, dmax) >> (rng() % 4 == 0 ? rng() % 20 : 0);
        if (rng() % 12 == 0) d[a] = 0;
        m = std::max(m, std::abs(d[a]));
      }
      if (m < dmax / 2) d[rng() % 3] = (rng() & 1) ? dmax : -dmax;
      const int s = int(rng() % uint64_t(B + f.guard_bits + F - f.dir_bits + 1));
      FixedRay r = proto;
      bool in_range = true;
      for (int a = 0; a < 3; ++a) {
        r.o[a] = p[a] - d[a] * (int64_t(1) << s);
        if (rng() % 8 == 0) r.o[a] += rint(-3, 3);
        in_range = in_range && r.o[a] > -olim && r.o[a] < olim;
      }
      if (!in_range) continue;
      set_direction(r, d, f);
      const int64_t tlim = (rng() % 4 == 0) ? rint(0, r.t_limit) : r.t_limit;
      FixedPrimHit hg{}, hw{};
      const bool got = triangle_test(r, v, 0, tlim, hg);
      const bool want = triangle_test_ref(r, v, 0, tlim, hw);
      if (got != want || (got && (hg.t != hw.t || hg.u != hw.u || hg.v != hw.v))) {
        INFO(f.name << " v " << v[0][0] << " " << v[0][1] << " " << v[0][2] << " / " << v[1][0] << " " << v[1][1]
                    << " " << v[1][2] << " / " << v[2][0] << " " << v[2][1] << " " << v[2][2] << " o " << r.o[0]
                    << " " << r.o[1] << " " << r.o[2] << " d " << d[0] << " " << d[1] << " " << d[2]);
        REQUIRE(got == want);
        REQUIRE(hg.t == hw.t);
        REQUIRE(hg.u == hw.u);
        REQUIRE(hg.v == hw.v);
      }
      uint64_t mag = 0;
      for (int j = 0; j < 3; ++j)
        for (int a = 0; a < 3; ++a) mag |= uint64_t(std::abs((int64_t(v[j][a]) << F) - r.o[a]));
      (mag < short_lim ? short_path : long_path) += 1;
      // The per-ray bound the tracer uses (every grid vertex): when it holds, this triangle's |A| are below it too
      // and the test without its own magnitude check gives the same answer.
      if (short_edges_known(r, B)) {
        ++known;
        REQUIRE(mag < short_lim);
        FixedPrimHit hk{};
        const bool got_k = triangle_test(r, v, 0, tlim, hk, true);
        REQUIRE(got_k == want);
        if (want) REQUIRE((hk.t == hw.t && hk.u == hw.u && hk.v == hw.v));
      }
      ++cases;
      hits += uint64_t(want);
      through += uint64_t(want && aim <= 1);
    }
  }
  INFO("cases " << cases << " hits " << hits << " through vertices and edges " << through << " 64-bit path "
                << short_path << " 128-bit path " << long_path);
  CHECK(cases > 700000);
  CHECK(hits > cases / 10);
  CHECK(through > cases / 20);    // exact zeros of the edge functions
  CHECK(short_path > cases / 2);  // both paths
  CHECK(long_path > cases / 100);
  CHECK(known > cases / 4);  // the per-ray bound holds for origins near the grid, not for those far into the guard
  CHECK(known < short_path);
}
