#include "rtl_sim/tb/tri_vectors.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "host/scene/scene.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/rng.h"

namespace rtu::rtl {

using hw::FixedFormat;
using hw::FixedRay;
using hw::Pcg32;
using hw::Wide;

std::string to_string(Wide x) {
  if (x == 0) return "0";
  const bool neg = x < 0;
  unsigned __int128 u = neg ? (unsigned __int128)(-(x + 1)) + 1 : (unsigned __int128)x;
  std::string s;
  while (u) {
    s += char('0' + int(u % 10));
    u /= 10;
  }
  if (neg) s += '-';
  return std::string(s.rbegin(), s.rend());
}

TriExpect expected(const TriSet& s, const TriCase& c) {
  const FixedRay& r = s.rays[c.ray];
  TriExpect e;
  hw::FixedPrimHit h;
  e.hit = hw::triangle_test(r, c.v, c.tmin, c.tlim, h);
  if (e.hit) {
    e.t = h.t;
    e.u = h.u;
    e.v = h.v;
  }
  Wide A[3][3];
  for (int i = 0; i < 3; ++i)
    for (int a = 0; a < 3; ++a) A[i][a] = (Wide(c.v[i][a]) << r.frac) - r.o[a];
  auto edge = [&](const Wide* p, const Wide* q) {  // d . (p x q), the general path
    const Wide cx = p[1] * q[2] - p[2] * q[1], cy = p[2] * q[0] - p[0] * q[2], cz = p[0] * q[1] - p[1] * q[0];
    return cx * r.d[0] + cy * r.d[1] + cz * r.d[2];
  };
  e.e0 = edge(A[1], A[2]);
  e.e1 = edge(A[2], A[0]);
  e.e2 = edge(A[0], A[1]);
  e.det = e.e0 + e.e1 + e.e2;
  Wide ea[3], eb[3];
  for (int a = 0; a < 3; ++a) {
    ea[a] = Wide(c.v[1][a]) - c.v[0][a];
    eb[a] = Wide(c.v[2][a]) - c.v[0][a];
  }
  const Wide n[3] = {ea[1] * eb[2] - ea[2] * eb[1], ea[2] * eb[0] - ea[0] * eb[2], ea[0] * eb[1] - ea[1] * eb[0]};
  e.num = n[0] * A[0][0] + n[1] * A[0][1] + n[2] * A[0][2];
  e.den = n[0] * r.d[0] + n[1] * r.d[1] + n[2] * r.d[2];
  if (e.den != 0) e.t_div = hw::div_shift(e.num, e.den, r.t_shift, hw::Round::kNearestEven, r.t_limit);
  return e;
}

namespace {

struct Limits {
  int64_t grid_max, olim, dmax;  // 2^B - 1, 2^(B+G+F) - 1 (largest |o|), 2^D
};
Limits limits(const FixedFormat& f) {
  return {(int64_t(1) << f.coord_bits) - 1, (int64_t(1) << (f.coord_bits + f.guard_bits + f.frac_bits)) - 1,
          int64_t(1) << f.dir_bits};
}

// A direction from a non-zero displacement (grid.F): scaled by a power of two so that the largest component
// lands in (2^(D-1), 2^D]; exact when scaled up (then the ray passes exactly through origin + delta), rounded
// toward zero when scaled down.
void direction_from(const FixedFormat& f, const int64_t delta[3], int64_t d[3]) {
  int64_t m = 0;
  for (int a = 0; a < 3; ++a) m = std::max(m, std::abs(delta[a]));
  const int64_t top = int64_t(1) << f.dir_bits;
  int up = 0, down = 0;
  while ((m << (up + 1)) <= top && up < 62) ++up;
  while ((m >> down) > top) ++down;
  for (int a = 0; a < 3; ++a)
    d[a] = down ? (delta[a] < 0 ? -((-delta[a]) >> down) : delta[a] >> down) : delta[a] << up;
}

// Intervals around the hit distance t of the case (when there is one): the comparators' edge cases.
void add_interval_variants(TriSet& s, TriCase c) {
  const FixedRay& r = s.rays[c.ray];
  c.tmin = 0;
  c.tlim = r.t_limit;
  const TriExpect e = expected(s, c);
  const int64_t L = r.t_limit, t = e.den != 0 ? e.t_div : 0;
  auto cl = [&](int64_t x) { return std::clamp(x, -L, L); };
  const int64_t pairs[][2] = {{0, L}, {-L, L},    {t, L}, {t + 1, L}, {t - 1, L}, {0, t},  {0, t - 1}, {0, t + 1},
                              {t, t}, {t + 1, t}, {5, 4}, {L, L},     {-L, -L},   {-L, 0}, {-L, t},    {L, -L}};
  for (const auto& p : pairs) {
    TriCase v = c;
    v.tmin = cl(p[0]);
    v.tlim = cl(p[1]);
    s.cases.push_back(v);
  }
}

}  // namespace

// ---- directed ----------------------------------------------------------------------------------------------

TriSet tri_directed_cases(const FixedFormat& f) {
  TriSet s;
  s.name = "directed";
  s.format = f;
  const Limits L = limits(f);
  const int F = f.frac_bits;
  const int64_t gm = L.grid_max, mid = gm / 2;
  auto add_ray = [&](const int64_t o[3], const int64_t d[3]) {
    s.rays.push_back(grid_ray(f, o, d));
    return uint32_t(s.rays.size() - 1);
  };
  // Triangles: ordinary, both windings, degenerate (repeated, collinear, a point), at the grid's ends, huge.
  std::vector<std::array<std::array<int32_t, 3>, 3>> tris;
  auto tri = [&](int64_t a0, int64_t a1, int64_t a2, int64_t b0, int64_t b1, int64_t b2, int64_t c0, int64_t c1,
                 int64_t c2) {
    tris.push_back({{{int32_t(a0), int32_t(a1), int32_t(a2)},
                     {int32_t(b0), int32_t(b1), int32_t(b2)},
                     {int32_t(c0), int32_t(c1), int32_t(c2)}}});
  };
  const int64_t m = mid, k = std::min<int64_t>(1000, mid);
  tri(m - k, m - k, m, m + k, m - k, m, m, m + k, m);          // in the plane z = m
  tri(m - k, m - k, m, m, m + k, m, m + k, m - k, m);          // the other winding
  tri(m - k, m, m - k, m + k, m, m - k, m, m, m + k);          // y = m
  tri(m, m - k, m - k, m, m + k, m - k, m, m, m + k);          // x = m
  tri(m - k, m - k, m - k, m + k, m - k, m + k, m, m + k, m);  // slanted
  tri(m, m, m, m, m, m, m + k, m, m);                          // two vertices equal
  tri(m, m, m, m, m, m, m, m, m);                              // a point
  tri(m - k, m - k, m, m, m, m, m + k, m + k, m);              // collinear
  tri(m - k, m, m, m + k, m, m, m, m, m);                      // collinear, on an axis
  tri(0, 0, 0, gm, 0, 0, 0, gm, 0);                            // the grid's ends
  tri(gm, gm, gm, 0, gm, gm, gm, 0, gm);
  tri(0, 0, m, gm, 0, m, 0, gm, m);
  tri(0, 0, 0, gm, gm, gm, 0, gm, gm);
  tri(0, gm, 0, gm, 0, gm, gm, gm, 0);
  tri(gm, 0, 0, 0, gm, 0, 0, 0, gm);  // the largest slanted
  tri(0, 0, 0, 0, 0, 1, 0, 1, 0);     // the smallest
  tri(gm, gm, gm, gm, gm, gm - 1, gm, gm - 1, gm);
  // Rays: through the triangle's centroid, vertices and edge midpoints (exact: origin = target - delta), from
  // near and from the guard range's edge, with zero components; and fixed directions.
  for (const auto& t : tris) {
    int64_t pts[7][3];
    for (int a = 0; a < 3; ++a) {
      const int64_t v0 = int64_t(t[0][a]) << F, v1 = int64_t(t[1][a]) << F, v2 = int64_t(t[2][a]) << F;
      pts[0][a] = (v0 + v1 + v2) / 3;
      pts[1][a] = v0;
      pts[2][a] = v1;
      pts[3][a] = v2;
      pts[4][a] = (v0 + v1) / 2;
      pts[5][a] = (v1 + v2) / 2;
      pts[6][a] = (v2 + v0) / 2;
    }
    const int64_t deltas[][3] = {{0, 0, 1}, {0, 0, -1}, {1, 0, 0}, {0, -1, 0},   {1, 1, 0},     {0, 1, -1},
                                 {3, 5, 7}, {-7, 2, 9}, {1, 1, 1}, {-1, -1, -1}, {1000, -3, 77}};
    for (const auto& p : pts) {
      for (const auto& dl : deltas) {
        for (int far = 0; far < 3; ++far) {
          int64_t delta[3], o[3], d[3];
          // near: a small displacement; far: as long as the guard range allows (scaled to reach its edge)
          int64_t dm = 0;
          for (int a = 0; a < 3; ++a) dm = std::max(dm, std::abs(dl[a]));
          int64_t scale =
              far == 0 ? (int64_t(1) << (F + 3)) : (far == 1 ? (int64_t(1) << (F + f.coord_bits / 2)) : 0);
          if (far == 2) {  // the largest scale keeping |o| < 2^(B+G+F) on every axis
            scale = L.olim;
            for (int a = 0; a < 3; ++a)
              if (dl[a] != 0)
                scale = std::min(scale, (dl[a] > 0 ? L.olim + p[a] : L.olim - p[a]) / std::abs(dl[a]));
          }
          for (int a = 0; a < 3; ++a) {
            delta[a] = dl[a] * scale;
            o[a] = p[a] - delta[a];
          }
          bool ok = scale > 0;
          for (int a = 0; a < 3; ++a) ok = ok && std::abs(o[a]) <= L.olim;
          if (!ok) continue;
          direction_from(f, delta, d);
          const uint32_t ri = add_ray(o, d);
          TriCase c;
          c.ray = ri;
          std::memcpy(c.v, t.data(), sizeof c.v);
          add_interval_variants(s, c);
          TriCase rev = c;  // the other winding
          std::swap(rev.v[1], rev.v[2]);
          rev.tmin = 0;
          rev.tlim = s.rays[ri].t_limit;
          s.cases.push_back(rev);
        }
      }
    }
    // Grazing rays: nearly parallel to the plane (N . d tiny), from near and far origins, so that the quotient
    // saturates at +-t_limit (and the in-register test rejects it).
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        if (a == b) continue;
        for (const int64_t sg : {int64_t(1), int64_t(-1)})
          for (const int64_t off : {int64_t(1) << F, L.olim / 2, L.olim}) {
            int64_t o[3], d[3] = {0, 0, 0};
            for (int x = 0; x < 3; ++x) o[x] = std::clamp((int64_t(t[0][x]) << F) - off, -L.olim, L.olim);
            d[a] = L.dmax;
            d[b] = sg;
            TriCase c;
            c.ray = add_ray(o, d);
            std::memcpy(c.v, t.data(), sizeof c.v);
            add_interval_variants(s, c);
          }
      }
    // The largest direction d = 2^D on one axis and the most negative origin.
    for (int a = 0; a < 3; ++a) {
      int64_t o[3] = {-L.olim, -L.olim, -L.olim}, d[3] = {0, 0, 0};
      d[a] = L.dmax;
      TriCase c;
      c.ray = add_ray(o, d);
      std::memcpy(c.v, t.data(), sizeof c.v);
      add_interval_variants(s, c);
      o[0] = o[1] = o[2] = L.olim;
      d[a] = -L.dmax;
      c.ray = add_ray(o, d);
      add_interval_variants(s, c);
    }
  }
  return s;
}

// ---- random --------------------------------------------------------------------------------------------------

TriSet tri_random_cases(const FixedFormat& f, uint64_t seed, size_t n) {
  TriSet s;
  s.name = "random";
  s.format = f;
  const Limits L = limits(f);
  const int F = f.frac_bits, B = f.coord_bits;
  Pcg32 rng(seed);
  while (s.cases.size() < n) {
    // A triangle.
    TriCase c;
    const int kind = int(rng.next_u32() % 8);
    int64_t center[3];
    for (int a = 0; a < 3; ++a) center[a] = rand_int(rng, 0, L.grid_max);
    const int64_t size = rand_mag(rng, B);
    for (int i = 0; i < 3; ++i)
      for (int a = 0; a < 3; ++a) {
        int64_t x;
        if (kind == 0)
          x = rand_int(rng, 0, L.grid_max);  // anywhere
        else if (kind == 1)
          x = one_in(rng, 2) ? 0 : L.grid_max;  // at the grid's ends
        else if (kind == 2)
          x = one_in(rng, 3) ? (one_in(rng, 2) ? 0 : L.grid_max) : rand_int(rng, 0, L.grid_max);
        else
          x = center[a] + rand_int(rng, -size, size);  // around a point
        c.v[i][a] = int32_t(std::clamp<int64_t>(x, 0, L.grid_max));
      }
    if (kind == 7) {  // degenerate: a repeated vertex, or the third on the line of the first two
      const int k = int(rng.next_u32() % 3);
      if (one_in(rng, 2)) {
        std::memcpy(c.v[k], c.v[(k + 1) % 3], sizeof c.v[k]);
      } else {
        for (int a = 0; a < 3; ++a)
          c.v[2][a] = int32_t(std::clamp<int64_t>(2 * int64_t(c.v[1][a]) - c.v[0][a], 0, L.grid_max));
      }
    }
    // A ray: aimed exactly at a point of the triangle (a vertex, an edge point, an inside point) from a random
    // displacement, or a random direction, with zero components sometimes.
    int64_t o[3], d[3];
    const int rk = int(rng.next_u32() % 4);
    if (rk < 3) {
      int64_t target[3];
      const uint32_t w0 = rng.next_u32() % 4, w1 = rng.next_u32() % 4, w2 = rk == 0 ? 0 : rng.next_u32() % 4;
      const int64_t ws = int64_t(w0 + w1 + w2) == 0 ? 1 : int64_t(w0 + w1 + w2);
      for (int a = 0; a < 3; ++a)
        target[a] = ((int64_t(c.v[0][a]) * w0 + int64_t(c.v[1][a]) * w1 + int64_t(c.v[2][a]) * w2) << F) / ws;
      int64_t delta[3];
      const int bits = int(rand_int(rng, 0, std::min(f.dir_bits, f.coord_bits + F)));
      bool nz = false;
      for (int a = 0; a < 3; ++a) {
        delta[a] = one_in(rng, 5) ? 0 : rand_int(rng, -(int64_t(1) << bits), int64_t(1) << bits);
        nz = nz || delta[a] != 0;
      }
      if (!nz) delta[rng.next_u32() % 3] = 1;
      for (int a = 0; a < 3; ++a) o[a] = std::clamp(target[a] - delta[a], -L.olim, L.olim);
      for (int a = 0; a < 3; ++a) delta[a] = target[a] - o[a];
      nz = false;
      for (int a = 0; a < 3; ++a) nz = nz || delta[a] != 0;
      if (!nz) delta[0] = 1;
      direction_from(f, delta, d);
    } else {
      const int ob = int(rand_int(rng, 0, f.coord_bits + f.guard_bits + F));
      for (int a = 0; a < 3; ++a)
        o[a] = std::clamp(rand_int(rng, -(int64_t(1) << ob), int64_t(1) << ob), -L.olim, L.olim);
      int64_t delta[3];
      for (int a = 0; a < 3; ++a) delta[a] = one_in(rng, 4) ? 0 : rand_int(rng, -L.dmax, L.dmax);
      if (delta[0] == 0 && delta[1] == 0 && delta[2] == 0) delta[rng.next_u32() % 3] = 1;
      direction_from(f, delta, d);
    }
    s.rays.push_back(grid_ray(f, o, d));
    c.ray = uint32_t(s.rays.size() - 1);
    // The interval: the ray's own; random; or ending at (or one beside) the hit distance.
    const FixedRay& r = s.rays.back();
    c.tmin = 0;
    c.tlim = r.t_limit;
    const int ik = int(rng.next_u32() % 6);
    if (ik == 1) {
      auto rt = [&]() {
        const int64_t v = rand_mag(rng, f.t_bits);
        return std::clamp(one_in(rng, 3) ? -v : v, -r.t_limit, r.t_limit);
      };
      c.tmin = rt();
      c.tlim = rt();
    } else if (ik >= 2) {
      const TriExpect e = expected(s, c);
      const int64_t t = e.den != 0 ? e.t_div : 0, off = rand_int(rng, -1, 1);
      if (ik == 2)
        c.tlim = std::clamp(t + off, -r.t_limit, r.t_limit);
      else if (ik == 3)
        c.tmin = std::clamp(t + off, -r.t_limit, r.t_limit);
      else
        c.tmin = -r.t_limit;
    }
    s.cases.push_back(c);
  }
  return s;
}

// ---- watertight ------------------------------------------------------------------------------------------------

TriSet tri_watertight_cases(const std::string& scene, const FixedFormat& f, uint64_t seed, size_t n) {
  TriSet s;
  s.name = "watertight " + scene;
  s.format = f;
  const host::Scene sc = host::load_scene(scene);
  hw::BvhBuildParams bp;
  bp.width = f.width;
  const hw::Bvh bvh = hw::Bvh::build(sc.geometry, bp);
  const hw::DeviceImage img = hw::encode_scene(sc.geometry, f, &bvh);
  const uint32_t n_rec = img.header().record_count;
  std::vector<hw::TriangleRecord> recs(n_rec);
  for (uint32_t i = 0; i < n_rec; ++i) std::memcpy(&recs[i], img.record(i), sizeof recs[i]);
  // The triangles around each grid vertex.
  std::map<std::array<int32_t, 3>, std::vector<uint32_t>> around;
  for (uint32_t i = 0; i < n_rec; ++i)
    for (int k = 0; k < 3; ++k) around[{recs[i].v[k][0], recs[i].v[k][1], recs[i].v[k][2]}].push_back(i);
  const int F = f.frac_bits;
  const Limits L = limits(f);
  Pcg32 rng(seed);
  while (s.cases.size() < n) {
    const hw::TriangleRecord& rec = recs[rng.next_u32() % n_rec];
    const int k = int(rng.next_u32() % 3);
    const int32_t* a = rec.v[k];
    const int32_t* c = rec.v[(k + 1) % 3];
    // A vertex (j = 0) or a point a + (c - a) j / 2^F of the edge, exact in grid.F.
    const int64_t j = one_in(rng, 2) ? 0 : int64_t(rng.next_u32() % ((1u << F) + 1));
    int64_t target[3], delta[3], o[3], d[3];
    bool nz = false;
    const int bits = int(rand_int(rng, 4, std::min(f.dir_bits, f.coord_bits + F - 2)));
    for (int ax = 0; ax < 3; ++ax) {
      target[ax] = (int64_t(a[ax]) << F) + (int64_t(c[ax]) - a[ax]) * j;
      delta[ax] = rand_int(rng, -(int64_t(1) << bits), int64_t(1) << bits);
      nz = nz || delta[ax] != 0;
    }
    if (!nz) delta[0] = 1;
    for (int ax = 0; ax < 3; ++ax) o[ax] = std::clamp(target[ax] - delta[ax], -L.olim, L.olim);
    for (int ax = 0; ax < 3; ++ax) delta[ax] = target[ax] - o[ax];
    direction_from(f, delta, d);
    s.rays.push_back(grid_ray(f, o, d));
    const uint32_t ri = uint32_t(s.rays.size() - 1);
    // Every triangle through the vertex a (j = 0, j = 2^F: c), or holding the edge a-c.
    const int32_t* at = j == (int64_t(1) << F) ? c : a;
    const std::vector<uint32_t>& va = around[{at[0], at[1], at[2]}];
    const std::vector<uint32_t>& vc = around[{c[0], c[1], c[2]}];
    const uint32_t group = s.groups++;
    for (uint32_t t : va) {
      if (j != 0 && j != (int64_t(1) << F) && std::find(vc.begin(), vc.end(), t) == vc.end()) continue;
      TriCase tc;
      tc.ray = ri;
      std::memcpy(tc.v, recs[t].v, sizeof tc.v);
      tc.tmin = 0;
      tc.tlim = s.rays[ri].t_limit;
      tc.group = group;
      s.cases.push_back(tc);
    }
  }
  return s;
}

// ---- traversal ---------------------------------------------------------------------------------------------

TriSet tri_traversal_cases(const std::string& scene, const FixedFormat& f, size_t max_cases, uint64_t seed) {
  TriSet s;
  s.format = f;
  // Every triangle a traversal tests, with the closest hit so far as its limit.
  capture_traversals(
      s, scene, seed, [&] { return s.cases.size() >= max_cases; },
      [&](const hw::DeviceImage& img, const hw::TraceEvent& e, uint32_t ray, int64_t closest) {
        if (e.kind != hw::TraceEvent::kPrim || s.cases.size() >= max_cases) return;
        const uint8_t* rec = img.record(e.index);
        if (hw::record_kind(rec) != hw::RecordKind::kTriangle) return;
        hw::TriangleRecord t;
        std::memcpy(&t, rec, sizeof t);
        TriCase c;
        c.ray = ray;
        std::memcpy(c.v, t.v, sizeof c.v);
        c.tmin = s.rays[ray].tmin;
        c.tlim = closest;
        s.cases.push_back(c);
      });
  return s;
}

std::string describe(const TriSet& s, const TriCase& c) {
  const FixedRay& r = s.rays[c.ray];
  const TriExpect e = expected(s, c);
  std::ostringstream o;
  o << s.name << " | ray o (" << r.o[0] << ", " << r.o[1] << ", " << r.o[2] << ") d (" << r.d[0] << ", " << r.d[1]
    << ", " << r.d[2] << ") | v0 (" << c.v[0][0] << ", " << c.v[0][1] << ", " << c.v[0][2] << ") v1 (" << c.v[1][0]
    << ", " << c.v[1][1] << ", " << c.v[1][2] << ") v2 (" << c.v[2][0] << ", " << c.v[2][1] << ", " << c.v[2][2]
    << ") | tmin " << c.tmin << " tlim " << c.tlim << "\n  model: hit " << e.hit << " t " << e.t << " u " << e.u
    << " v " << e.v << " e0 " << to_string(e.e0) << " e1 " << to_string(e.e1) << " e2 " << to_string(e.e2)
    << " det " << to_string(e.det) << " num " << to_string(e.num) << " den " << to_string(e.den) << " t_div "
    << e.t_div << "\n";
  return o.str();
}

}  // namespace rtu::rtl
