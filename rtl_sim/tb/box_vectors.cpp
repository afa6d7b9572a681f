#include "rtl_sim/tb/box_vectors.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/node_kinds.h"
#include "hwmodel/numeric/rng.h"

namespace rtu::rtl {

using hw::FixedFormat;
using hw::FixedRay;
using hw::Pcg32;

uint64_t CaseSet::child_tests() const {
  uint64_t n = 0;
  for (const BoxCase& c : cases) n += c.count;
  return n;
}

namespace {

// The planes of slot i minus the ray origin, decoded as FixedPolicy::expand_impl does.
void child_deltas(const FixedRay& r, const BoxCase& c, int i, int64_t dl[3], int64_t dh[3]) {
  for (int a = 0; a < 3; ++a) {
    const int64_t base = (int64_t(c.origin[a]) << r.frac) - r.o[a];
    const int sh = c.exp[a] + r.frac;
    dl[a] = base + (int64_t(c.q[2 * a][i]) << sh);
    dh[a] = base + (int64_t(c.q[2 * a + 1][i]) << sh);
  }
}

// The slot's entry and exit distances as box_test_delta computes them, before the interval: for choosing
// intervals that end exactly on them. Zero axes are left out (their slab test does not give a distance).
void child_interval(const FixedRay& r, const BoxCase& c, int i, int64_t& t0, int64_t& t1) {
  int64_t dl[3], dh[3];
  child_deltas(r, c, i, dl, dh);
  t0 = -r.t_limit;
  t1 = r.t_limit;
  for (int a = 0; a < 3; ++a) {
    if (r.zero[a]) continue;
    const bool pos = r.d[a] > 0;
    const int64_t dn = pos ? dl[a] : dh[a], df = pos ? dh[a] : dl[a];
    const int64_t mn = dn >= 0 ? r.rcpm_dn[a] : r.rcpm_up[a], mf = df >= 0 ? r.rcpm_up[a] : r.rcpm_dn[a];
    t0 = std::max(t0, hw::box_product<int64_t>(dn, mn, r.rcp_sh[a], false));
    t1 = std::min(t1, hw::box_product<int64_t>(df, mf, r.rcp_sh[a], true));
  }
}

int64_t clamp_t(int64_t t, const FixedRay& r) {
  return std::clamp(t, -r.t_limit, r.t_limit);
}

// A node with every slot's offsets in range of the format: planes < 2^(B+1) (as the encoder guarantees).
struct NodeFrame {
  int64_t origin[3];
  int exp[3];
  int64_t qmax[3];  // largest offset per axis
};
NodeFrame node_frame(const FixedFormat& f, const int64_t origin[3], const int exp[3]) {
  NodeFrame n;
  const int64_t box_max = (int64_t(1) << (f.coord_bits + 1)) - 1;
  for (int a = 0; a < 3; ++a) {
    n.origin[a] = origin[a];
    n.exp[a] = exp[a];
    n.qmax[a] = std::min((int64_t(1) << f.child_bits) - 1, (box_max - origin[a]) >> exp[a]);
    if (origin[a] < 0 || origin[a] >= (int64_t(1) << f.coord_bits) || n.qmax[a] < 0)
      throw std::logic_error("box_vectors: node origin out of the grid");
  }
  return n;
}
BoxCase empty_case(const NodeFrame& n, uint32_t ray) {
  BoxCase c;
  c.ray = ray;
  for (int a = 0; a < 3; ++a) {
    c.origin[a] = int32_t(n.origin[a]);
    c.exp[a] = int8_t(n.exp[a]);
  }
  return c;
}
// Sets slot i to the grid box [lo, hi] (clamped to the node's range; lo and hi must be on its lattice).
void set_slot(BoxCase& c, const NodeFrame& n, int i, const int64_t lo[3], const int64_t hi[3]) {
  for (int a = 0; a < 3; ++a) {
    auto q = [&](int64_t v) {
      const int64_t k = std::clamp<int64_t>((v - n.origin[a]) >> n.exp[a], 0, n.qmax[a]);
      return uint16_t(k);
    };
    c.q[2 * a][i] = q(lo[a]);
    c.q[2 * a + 1][i] = q(hi[a]);
  }
}

// Adds copies of `c` with intervals at and around the exact entry/exit distances of slot `slot` (and a few
// fixed ones): the comparator's edge cases.
void add_interval_variants(CaseSet& s, const BoxCase& c, int slot) {
  const FixedRay& r = s.rays[c.ray];
  int64_t t0, t1;
  child_interval(r, c, slot, t0, t1);
  const int64_t L = r.t_limit;
  const int64_t pairs[][2] = {{0, L},      {-L, L},     {t0, L},  {t0 + 1, L}, {t0 - 1, L},     {0, t0},
                              {0, t0 - 1}, {0, t0 + 1}, {t1, L},  {t1 + 1, L}, {t1 - 1, L},     {-L, t1},
                              {t0, t1},    {t1, t0},    {t0, t0}, {t1, t1},    {5, 4},          {0, 0},
                              {L, L},      {L, -L},     {-L, -L}, {-L, 0},     {t0 - 1, t0 - 2}};
  for (const auto& p : pairs) {
    BoxCase v = c;
    v.tmin = clamp_t(p[0], r);
    v.tlim = clamp_t(p[1], r);
    s.cases.push_back(v);
  }
}

}  // namespace

BoxInputs unit_inputs(const CaseSet& s, const BoxCase& c) {
  const FixedRay& r = s.rays[c.ray];
  hw::BoxUnitNode n{};
  for (int a = 0; a < 3; ++a) {
    n.base[a] = (int64_t(c.origin[a]) << r.frac) - r.o[a];
    n.sh[a] = c.exp[a] + r.frac;
  }
  for (int row = 0; row < 6; ++row)
    for (int i = 0; i < kMaxWidth; ++i) n.q[row][i] = c.q[row][i];
  n.count = c.count;
  return unit_inputs(r, n, c.tmin, c.tlim);
}

void child_box(const BoxCase& c, int i, int64_t lo[3], int64_t hi[3]) {
  for (int a = 0; a < 3; ++a) {
    lo[a] = int64_t(c.origin[a]) + (int64_t(c.q[2 * a][i]) << c.exp[a]);
    hi[a] = int64_t(c.origin[a]) + (int64_t(c.q[2 * a + 1][i]) << c.exp[a]);
  }
}

BoxExpect expected(const CaseSet& s, const BoxCase& c) {
  const FixedRay& r = s.rays[c.ray];
  BoxExpect e;
  for (int i = 0; i < s.format.width; ++i) {
    int64_t dl[3], dh[3], lo[3], hi[3];
    child_deltas(r, c, i, dl, dh);
    child_box(c, i, lo, hi);
    constexpr int64_t kUnwritten = INT64_MIN;
    int64_t t = kUnwritten;
    e.c[i].hit = hw::box_test_delta<int64_t>(r, dl, dh, c.tmin, c.tlim, t);
    e.c[i].t_written = t != kUnwritten;
    e.c[i].t_near = t;
    e.c[i].exact = hw::box_test_exact(r, lo, hi, c.tmin, c.tlim);
  }
  return e;
}

// ---- directed ----------------------------------------------------------------------------------------------

CaseSet directed_cases(const FixedFormat& f) {
  CaseSet s;
  s.name = "directed";
  s.format = f;
  const int N = f.width, B = f.coord_bits, G = f.guard_bits, F = f.frac_bits, D = f.dir_bits, K = f.child_bits;
  const int64_t grid_max = (int64_t(1) << B) - 1;
  const int64_t side = std::min<int64_t>((int64_t(1) << K) - 1, 200);  // node extent in grid steps (exp 0)
  const int64_t c0 = std::min<int64_t>(grid_max / 2, 3000);            // a grid point well inside the frame
  const int64_t R = side / 2 - 1;  // reach of boxes around a node's center (99 for 8-bit offsets, 30 for 6)
  auto add_ray = [&](const FixedRay& r) {
    s.rays.push_back(r);
    return uint32_t(s.rays.size() - 1);
  };
  // Fills the slots of nodes with `boxes` (N per node), each node at `origin` with exp 0, then adds the node
  // with the ray's own interval and with the interval variants of its first slot.
  auto add_boxes = [&](uint32_t ray, const int64_t origin[3], const std::vector<std::array<int64_t, 6>>& boxes,
                       bool variants) {
    const int exp0[3] = {0, 0, 0};
    const NodeFrame n = node_frame(f, origin, exp0);
    for (size_t first = 0; first < boxes.size(); first += size_t(N)) {
      BoxCase c = empty_case(n, ray);
      c.count = uint8_t(std::min<size_t>(size_t(N), boxes.size() - first));
      for (int i = 0; i < c.count; ++i) {
        const auto& b = boxes[first + size_t(i)];
        const int64_t lo[3] = {b[0], b[2], b[4]}, hi[3] = {b[1], b[3], b[5]};
        set_slot(c, n, i, lo, hi);
      }
      c.tmin = s.rays[ray].tmin;
      c.tlim = s.rays[ray].tmax;
      s.cases.push_back(c);
      if (variants)
        for (int i = 0; i < c.count; ++i) add_interval_variants(s, c, i);
    }
  };

  // A. Zero direction components with +0 and -0, through ray setup (float rays on a frame whose grid is the
  // world: step 1, origin 0). On a zero axis the slab test is dl <= 0 <= dh: origins on a plane, inside, one
  // step (or half a step) outside.
  {
    hw::QuantFrame frame;
    frame.bits = B;
    frame.step_exp = 0;
    const float p = float(c0);
    const hw::Vec3 origins[] = {{p, p + 10.0f, p + 20.0f}, {p + 0.5f, p + 10.25f, p + 20.0f}};
    const hw::Vec3 dirs[] = {{+0.0f, +0.0f, 1.0f},  {-0.0f, +0.0f, -1.0f}, {1.0f, -0.0f, +0.0f},
                             {-0.0f, 1.0f, -0.0f},  {+0.0f, -1.0f, +0.0f}, {1.0f, 1.0f, -0.0f},
                             {-1.0f, -0.0f, -0.0f}, {-0.0f, 3.0f, -5.0f},  {0.25f, -0.0f, -0.75f}};
    for (const hw::Vec3& o : origins) {
      for (const hw::Vec3& d : dirs) {
        hw::Ray wr{o, 0.0f, d, std::numeric_limits<float>::infinity()};
        FixedRay r;
        if (hw::setup_ray(wr, frame, f, r) != hw::RayStatus::kOk) throw std::logic_error("directed: setup");
        const uint32_t ray = add_ray(r);
        int64_t og[3], org[3];
        for (int a = 0; a < 3; ++a) {
          og[a] = int64_t(std::floor(o[a]));
          org[a] = og[a] - side / 2;
        }
        // Zero-axis slab variants (relative to the origin's grid point) x a box ahead on the other axes.
        const int64_t slabs[][2] = {{0, 10}, {-10, 0}, {1, 10}, {-10, -1}, {0, 0}, {0, 1}, {-1, 0}, {-1, 1}};
        std::vector<std::array<int64_t, 6>> boxes;
        for (const auto& sl : slabs) {
          std::array<int64_t, 6> b{};
          for (int a = 0; a < 3; ++a) {
            int64_t lo, hi;
            if (r.zero[a]) {
              lo = og[a] + sl[0];
              hi = og[a] + sl[1];
            } else if (r.d[a] > 0) {
              lo = og[a] + 2;
              hi = og[a] + std::min<int64_t>(40, R);
            } else {
              lo = og[a] - std::min<int64_t>(40, R);
              hi = og[a] - 2;
            }
            b[size_t(2 * a)] = lo;
            b[size_t(2 * a + 1)] = hi;
          }
          boxes.push_back(b);
        }
        add_boxes(ray, org, boxes, false);
        // The same slabs behind the origin on the moving axes: a miss in [0, inf), a hit in [-inf, 0].
        for (auto& b : boxes)
          for (int a = 0; a < 3; ++a)
            if (!r.zero[a]) {
              const int64_t lo = 2 * og[a] - b[size_t(2 * a + 1)], hi = 2 * og[a] - b[size_t(2 * a)];
              b[size_t(2 * a)] = lo;
              b[size_t(2 * a + 1)] = hi;
            }
        add_boxes(ray, org, boxes, true);
      }
    }
  }

  // B/C. Grid rays exactly through a corner point c of boxes (directions delta * 2^j, exact): boxes in all 8
  // octants around c (the ray touches them at a corner, an edge or a face), one step away (just missed or
  // entered), flat and point boxes at c, inverted boxes (lo = hi + 1) and an all-zero slot (the node origin).
  {
    const int64_t deltas[][3] = {{1, 1, 1},     {1, -2, 3},    {-3, 5, -7},        {7, 0, 0},       {0, -5, 0},
                                 {0, 0, 9},     {4, 4, 0},     {0, -3, 3},         {-6, 0, 6},      {1000, 1, -1},
                                 {-1, 999, 17}, {3, -3, 1000}, {-100, -100, -100}, {12345, -678, 9}};
    for (const auto& dlt : deltas) {
      int64_t m = 0;
      for (int a = 0; a < 3; ++a) m = std::max(m, std::abs(dlt[a]));
      // Start far enough back that the box corners lie ahead at t > 0; d = delta * 2^j, largest component in
      // [2^(D-1), 2^D): the ray passes exactly through c.
      const int64_t back = std::max<int64_t>(1, 64 / m);
      const int j = D - 1 - (std::bit_width(uint64_t(m * back)) - 1);
      if (j < 0) throw std::logic_error("directed: direction too long for the format");
      int64_t c[3], og[3], o[3], d[3], org[3];
      for (int a = 0; a < 3; ++a) {
        c[a] = c0;
        og[a] = c[a] - dlt[a] * back;
        o[a] = og[a] << F;
        d[a] = (dlt[a] * back) << j;
      }
      const uint32_t ray = add_ray(grid_ray(f, o, d));
      for (int a = 0; a < 3; ++a) org[a] = c[a] - side / 2;
      std::vector<std::array<int64_t, 6>> boxes;
      for (int64_t ext : {int64_t(1), int64_t(7), std::min<int64_t>(60, R)}) {
        for (int oct = 0; oct < 8; ++oct) {
          std::array<int64_t, 6> b{};
          for (int a = 0; a < 3; ++a) {
            const bool up = (oct >> a) & 1;
            b[size_t(2 * a)] = up ? c[a] : c[a] - ext;
            b[size_t(2 * a + 1)] = up ? c[a] + ext : c[a];
          }
          boxes.push_back(b);
        }
      }
      for (int a = 0; a < 3; ++a) {
        for (int64_t sft : {int64_t(-1), int64_t(1)}) {  // a box with c on a face, moved one step off it
          std::array<int64_t, 6> b{};
          for (int x = 0; x < 3; ++x) {
            b[size_t(2 * x)] = c[x] - 5;
            b[size_t(2 * x + 1)] = c[x] + 5;
          }
          if (sft > 0) {
            b[size_t(2 * a)] = c[a] + 1;
            b[size_t(2 * a + 1)] = c[a] + 8;
          } else {
            b[size_t(2 * a)] = c[a] - 8;
            b[size_t(2 * a + 1)] = c[a] - 1;
          }
          boxes.push_back(b);
        }
      }
      boxes.push_back({c[0], c[0], c[1], c[1], c[2], c[2]});                          // a point at c
      boxes.push_back({c[0] - 3, c[0] + 3, c[1], c[1], c[2], c[2]});                  // a line through c
      boxes.push_back({c[0] - 3, c[0] + 3, c[1] - 3, c[1] + 3, c[2], c[2]});          // a flat box through c
      boxes.push_back({c[0], c[0] - 1, c[1] - 3, c[1] + 3, c[2] - 3, c[2] + 3});      // inverted on x
      boxes.push_back({c[0] - 3, c[0] + 3, c[1] + 1, c[1], c[2] - 3, c[2] + 3});      // inverted on y
      boxes.push_back({c[0] + 2, c[0] + 1, c[1] + 2, c[1] + 1, c[2] + 2, c[2] + 1});  // inverted everywhere
      boxes.push_back({org[0], org[0], org[1], org[1], org[2], org[2]});              // an all-zero slot
      add_boxes(ray, org, boxes, true);
    }
  }

  // D. Tiny direction components: rcp_sh < 0 (products shifted left, clamped at +-2^62 in the C++ and
  // saturated at +-2^TB in the RTL), near boxes (small exact t) and far ones (saturated t), both signs.
  {
    const int64_t tiny[] = {1, -1, 2, -3, 5, 100, -1000, 2047, -2049, 65535, int64_t(1) << (D / 2)};
    const int64_t big = int64_t(1) << D;
    for (int64_t t1 : tiny) {
      for (int64_t t2 : {int64_t(0), int64_t(1), int64_t(-7)}) {
        const int64_t d[3] = {t1, big - 1, t2};
        const int64_t og[3] = {c0, c0, c0};
        const int64_t o[3] = {(og[0] << F) + 3, og[1] << F, (og[2] << F) - 1};
        const uint32_t ray = add_ray(grid_ray(f, o, d));
        int64_t org[3] = {og[0] - side / 2, og[1] - side / 2, og[2] - side / 2};
        const int64_t r50 = std::min<int64_t>(50, R);
        std::vector<std::array<int64_t, 6>> boxes = {
            {og[0] - 2, og[0] + 2, og[1] + 1, og[1] + r50, og[2] - 2, og[2] + 2},
            {og[0] + 1, og[0] + 3, og[1] + 1, og[1] + r50, og[2] - 2, og[2] + 2},
            {og[0] - 3, og[0] - 1, og[1] + 1, og[1] + r50, og[2] - 1, og[2] + 0},
            {og[0], og[0], og[1], og[1] + R, og[2], og[2]},
            {og[0] + R - 9, og[0] + R, og[1] + 1, og[1] + 2, og[2] + R - 9, og[2] + R},
            {og[0] - R, og[0] - R + 9, og[1] - 2, og[1] - 1, og[2] - R, og[2] - R + 9}};
        add_boxes(ray, org, boxes, true);
        // Far boxes: the node at the grid's far corner with the largest scale.
        const int far_exp = B + 1 - K;
        const int exps[3] = {far_exp, far_exp, far_exp};
        const int64_t far_origin[3] = {0, 0, 0};
        const NodeFrame n = node_frame(f, far_origin, exps);
        BoxCase c = empty_case(n, ray);
        c.count = uint8_t(N);
        for (int i = 0; i < N; ++i)
          for (int a = 0; a < 3; ++a) {
            c.q[2 * a][i] = uint16_t(i % 2 == 0 ? n.qmax[a] - i : i);
            c.q[2 * a + 1][i] = uint16_t(n.qmax[a]);
          }
        c.tmin = -s.rays[ray].t_limit;
        c.tlim = s.rays[ray].t_limit;
        s.cases.push_back(c);
        add_interval_variants(s, c, 0);
      }
    }
  }

  // G. The largest magnitudes: origins at the edge of the guard range, nodes at the far corner of the grid with
  // the largest scale (planes up to 2^(B+1) - 1: |dl| close to 2^A), directions with the largest reciprocal
  // mantissa (d = +-2^(D-1): rcpm = +-2^M) and the exact d = 2^D.
  {
    const int64_t olim = (int64_t(1) << (B + G + F)) - 1;
    const int64_t dmin = int64_t(1) << (D - 1), dmax = int64_t(1) << D;
    const int64_t origins[][3] = {{-olim, -olim, -olim}, {olim, olim, olim}, {-olim, olim, 0}, {olim, -olim, 1}};
    const int64_t dirs[][3] = {{dmin, dmin, dmin},       {-dmin, -dmin, -dmin}, {dmax, 0, 0},    {0, -dmax, 1},
                               {dmin + 1, -dmin - 1, 1}, {-dmax, dmin, -dmin},  {dmin, -1, dmax}};
    const int max_exp = B + 1 - K;
    for (const auto& o : origins) {
      for (const auto& d : dirs) {
        const uint32_t ray = add_ray(grid_ray(f, o, d));
        for (int which = 0; which < 3; ++which) {
          int64_t org[3];
          int exps[3];
          for (int a = 0; a < 3; ++a) {
            org[a] = which == 0 ? 0 : (which == 1 ? grid_max : grid_max / 3);
            exps[a] = which == 1 ? 0 : max_exp;
          }
          const NodeFrame n = node_frame(f, org, exps);
          BoxCase c = empty_case(n, ray);
          c.count = uint8_t(N);
          for (int i = 0; i < N; ++i)
            for (int a = 0; a < 3; ++a) {
              c.q[2 * a][i] = uint16_t(i == 0 ? 0 : (i == 1 ? n.qmax[a] : n.qmax[a] / 2));
              c.q[2 * a + 1][i] = uint16_t(i == 2 ? n.qmax[a] / 2 : n.qmax[a]);
            }
          c.tmin = -s.rays[ray].t_limit;
          c.tlim = s.rays[ray].t_limit;
          s.cases.push_back(c);
          add_interval_variants(s, c, 1 % N);
        }
      }
    }
  }

  // F. count < N: every count from 0 to N over nodes whose every slot (occupied or not) the ray hits.
  {
    const int64_t o[3] = {(c0 - 50) << F, (c0 - 50) << F, (c0 - 50) << F};
    const int64_t d[3] = {int64_t(1) << (D - 1), int64_t(1) << (D - 1), (int64_t(1) << (D - 1)) - 12345};
    const uint32_t ray = add_ray(grid_ray(f, o, d));
    const int64_t org[3] = {c0 - side / 2, c0 - side / 2, c0 - side / 2};
    const int exp0[3] = {0, 0, 0};
    const NodeFrame n = node_frame(f, org, exp0);
    for (int count = 0; count <= N; ++count) {
      BoxCase c = empty_case(n, ray);
      c.count = uint8_t(count);
      for (int i = 0; i < N; ++i) {
        const int64_t lo[3] = {c0 - 10 - i, c0 - 10 - i, c0 - 10 - i},
                      hi[3] = {c0 + 10 + i, c0 + 10 + i, c0 + 10 + i};
        set_slot(c, n, i, lo, hi);
      }
      c.tmin = 0;
      c.tlim = s.rays[ray].t_limit;
      s.cases.push_back(c);
      add_interval_variants(s, c, 0);
    }
  }
  return s;
}

// ---- random ------------------------------------------------------------------------------------------------

CaseSet random_cases(const FixedFormat& f, uint64_t seed, size_t nodes) {
  CaseSet s;
  s.name = "random";
  s.format = f;
  Pcg32 rng(seed);
  const int N = f.width, B = f.coord_bits, G = f.guard_bits, F = f.frac_bits, D = f.dir_bits, K = f.child_bits;
  const int64_t grid_max = (int64_t(1) << B) - 1;
  const int64_t olim = (int64_t(1) << (B + G + F)) - 1;
  constexpr int kNodesPerRay = 8;
  s.cases.reserve(nodes);
  while (s.cases.size() < nodes) {
    // The ray: aimed exactly at a grid point c from a grid origin (2/3), or a random direction with zero and
    // tiny components from any origin (1/3).
    int64_t o[3], d[3], c[3];
    bool aimed = !one_in(rng, 3);
    for (int a = 0; a < 3; ++a) c[a] = rand_int(rng, 0, grid_max);
    if (aimed) {
      const int m = int(rand_int(rng, 0, std::min(D - 1, B)));
      int64_t delta[3], dm = 0;
      for (int a = 0; a < 3; ++a) {
        delta[a] = one_in(rng, 6) ? 0 : rand_int(rng, -(int64_t(1) << m), int64_t(1) << m);
        dm = std::max(dm, std::abs(delta[a]));
      }
      if (dm == 0 || dm >= (int64_t(1) << D)) continue;
      const int j = D - 1 - (std::bit_width(uint64_t(dm)) - 1);
      for (int a = 0; a < 3; ++a) {
        o[a] = (c[a] - delta[a]) << F;
        d[a] = delta[a] << j;
      }
    } else {
      const int main_axis = int(rng.next_u32() % 3);
      for (int a = 0; a < 3; ++a) {
        if (a == main_axis)
          d[a] = rand_int(rng, int64_t(1) << (D - 1), int64_t(1) << D);
        else if (one_in(rng, 4))
          d[a] = 0;
        else
          d[a] = rand_mag(rng, D);
        if (one_in(rng, 2)) d[a] = -d[a];
        if (one_in(rng, 8))  // anywhere in the guard range
          o[a] = rand_int(rng, -olim, olim);
        else  // near the point c, with a fraction
          o[a] = std::clamp<int64_t>(
              (c[a] << F) + rand_int(rng, -(int64_t(1) << (F + B / 2)), int64_t(1) << (F + B / 2)), -olim, olim);
      }
    }
    s.rays.push_back(grid_ray(f, o, d));
    const uint32_t ray = uint32_t(s.rays.size() - 1);
    const FixedRay& r = s.rays.back();

    for (int ni = 0; ni < kNodesPerRay && s.cases.size() < nodes; ++ni) {
      // The node: small scales mostly, any scale sometimes; around c (c on its lattice) or anywhere.
      int exps[3];
      int64_t org[3], m[3];
      for (int a = 0; a < 3; ++a) {
        exps[a] = one_in(rng, 4) ? int(rand_int(rng, 0, B + 1)) : int(rand_int(rng, 0, std::max(0, B / 2 - K)));
        if (one_in(rng, 5)) {
          org[a] = rand_int(rng, 0, grid_max);
          m[a] = -1;
        } else {
          m[a] = rand_int(rng, 0, std::min((int64_t(1) << K) - 1, c[a] >> exps[a]));
          org[a] = c[a] - (m[a] << exps[a]);
        }
      }
      const NodeFrame n = node_frame(f, org, exps);
      BoxCase bc = empty_case(n, ray);
      bc.count = one_in(rng, 6) ? uint8_t(rand_int(rng, 0, N)) : uint8_t(N);
      for (int i = 0; i < N; ++i) {
        const int kind = int(rng.next_u32() % 8);
        for (int a = 0; a < 3; ++a) {
          const int64_t qm = n.qmax[a];
          int64_t lo = rand_int(rng, 0, qm), hi = rand_int(rng, 0, qm);
          if (lo > hi) std::swap(lo, hi);
          const int64_t mc = m[a] >= 0 ? std::min(m[a], qm) : qm / 2;
          switch (kind) {
            case 0:  // c on the low plane
              lo = mc;
              hi = std::max(hi, mc);
              break;
            case 1:  // c on the high plane
              hi = mc;
              lo = std::min(lo, mc);
              break;
            case 2:  // c inside, small box
              lo = std::max<int64_t>(0, mc - rand_int(rng, 0, 3));
              hi = std::min(qm, mc + rand_int(rng, 0, 3));
              break;
            case 3:  // flat at c on a random axis set, else around c
              lo = hi = one_in(rng, 2) ? mc : lo;
              break;
            case 4:  // just off c by one step
              if (one_in(rng, 2)) {
                lo = std::min(qm, mc + 1);
                hi = std::max(hi, lo);
              } else {
                hi = std::max<int64_t>(0, mc - 1);
                lo = std::min(lo, hi);
              }
              break;
            case 5:  // inverted by one step
              if (hi < qm) {
                lo = hi + 1;
              }
              break;
            default:  // anywhere
              break;
          }
          bc.q[2 * a][i] = uint16_t(lo);
          bc.q[2 * a + 1][i] = uint16_t(hi);
        }
      }
      // The interval: the ray's own; random; or ending exactly at (or one unit beside) a slot's entry or exit.
      const int ik = int(rng.next_u32() % 6);
      bc.tmin = 0;
      bc.tlim = r.t_limit;
      if (ik == 1) {
        auto rand_t = [&]() {
          const int64_t v = rand_mag(rng, f.t_bits);
          return clamp_t(one_in(rng, 3) ? -v : v, r);
        };
        bc.tmin = rand_t();
        bc.tlim = rand_t();
      } else if (ik >= 2) {
        const int slot = int(rand_int(rng, 0, N - 1));
        int64_t t0, t1;
        child_interval(r, bc, slot, t0, t1);
        const int64_t off = rand_int(rng, -1, 1);
        if (ik == 2)
          bc.tlim = clamp_t(t0 + off, r);
        else if (ik == 3)
          bc.tmin = clamp_t(t1 + off, r);
        else if (ik == 4) {
          bc.tmin = clamp_t(t0 + off, r);
          bc.tlim = clamp_t(t1 + rand_int(rng, -1, 1), r);
        } else {
          bc.tmin = -r.t_limit;
          bc.tlim = clamp_t(t0 + off, r);
        }
      }
      s.cases.push_back(bc);
    }
  }
  return s;
}

// ---- traversal ---------------------------------------------------------------------------------------------

namespace {

template <int N, class Q>
void copy_node(const hw::DeviceImage& img, uint32_t index, BoxCase& c) {
  const hw::QNode<N, Q>& n = img.nodes<hw::QNode<N, Q>>()[index];
  for (int a = 0; a < 3; ++a) {
    c.origin[a] = n.origin[a];
    c.exp[a] = n.exp[a];
  }
  c.count = n.count;
  for (int row = 0; row < 6; ++row)
    for (int i = 0; i < N; ++i) c.q[row][i] = uint16_t(n.q[row][i]);
}

void copy_node(const hw::DeviceImage& img, uint32_t index, BoxCase& c) {
  const hw::ImageHeader& h = img.header();
  hw::with_node_kind(hw::node_kind(h), h.width, h.q_bytes, [&](auto kind) {
    using K = decltype(kind);
    using Q = std::remove_cvref_t<decltype(K::Node::q[0][0])>;
    constexpr int N = K::kWidth;
    copy_node<N, Q>(img, index, c);
  });
}

}  // namespace

CaseSet traversal_cases(const std::string& scene, const FixedFormat& f, size_t max_nodes, uint64_t seed) {
  CaseSet s;
  s.format = f;
  // Every node a traversal visits, with the closest hit so far as the limit of its box test.
  capture_traversals(
      s, scene, seed, [&] { return s.cases.size() >= max_nodes; },
      [&](const hw::DeviceImage& img, const hw::TraceEvent& e, uint32_t ray, int64_t closest) {
        if (e.kind != hw::TraceEvent::kNode || s.cases.size() >= max_nodes) return;
        BoxCase c;
        c.ray = ray;
        copy_node(img, e.index, c);
        c.tmin = s.rays[ray].tmin;
        c.tlim = closest;
        s.cases.push_back(c);
      });
  return s;
}

// ---- messages ----------------------------------------------------------------------------------------------

std::string describe(const CaseSet& s, const BoxCase& c) {
  const FixedRay& r = s.rays[c.ray];
  std::ostringstream o;
  o << s.name << " | ray o (" << r.o[0] << ", " << r.o[1] << ", " << r.o[2] << ") d (" << r.d[0] << ", " << r.d[1]
    << ", " << r.d[2] << ") rcpm_dn (" << r.rcpm_dn[0] << ", " << r.rcpm_dn[1] << ", " << r.rcpm_dn[2]
    << ") rcpm_up (" << r.rcpm_up[0] << ", " << r.rcpm_up[1] << ", " << r.rcpm_up[2] << ") rcp_sh (" << r.rcp_sh[0]
    << ", " << r.rcp_sh[1] << ", " << r.rcp_sh[2] << ") | node origin (" << c.origin[0] << ", " << c.origin[1]
    << ", " << c.origin[2] << ") exp (" << int(c.exp[0]) << ", " << int(c.exp[1]) << ", " << int(c.exp[2])
    << ") count " << int(c.count) << " | tmin " << c.tmin << " tlim " << c.tlim << "\n";
  const BoxExpect e = expected(s, c);
  for (int i = 0; i < s.format.width; ++i) {
    int64_t lo[3], hi[3];
    child_box(c, i, lo, hi);
    o << "  slot " << i << " box [" << lo[0] << " " << lo[1] << " " << lo[2] << "] - [" << hi[0] << " " << hi[1]
      << " " << hi[2] << "] model hit " << e.c[i].hit << " t_near "
      << (e.c[i].t_written ? std::to_string(e.c[i].t_near) : std::string("(not written)")) << " exact "
      << e.c[i].exact << "\n";
  }
  return o.str();
}

}  // namespace rtu::rtl
