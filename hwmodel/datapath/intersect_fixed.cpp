#include "hwmodel/datapath/intersect_fixed.h"

#include <algorithm>
#include <bit>
#include <cmath>

namespace rtu::hw {

namespace {

// x * 2^e rounded by r, exactly (x finite). Values beyond 2^70 in magnitude come back as +-2^70.
inline Wide scaled_round(float x, int e, Round r) {
  if (x == 0.0f) return 0;
  int64_t m;
  int k;
  split_float(x, m, k);  // x = m * 2^k, |m| < 2^24
  const int sh = k + e;
  if (sh >= -62 && sh <= 38) return sh >= 0 ? Wide(m << sh) : Wide(round_shift64(m, -sh, r));  // 64 bits
  if (sh >= 0) {
    if (sh > 46) return m > 0 ? (Wide(1) << 70) : -(Wide(1) << 70);
    return Wide(m) << sh;
  }
  if (-sh > 100) {  // |x * 2^e| < 2^-76: 0, or one unit by the sign and the rounding
    if (m > 0 && r == Round::kUp) return 1;
    if (m < 0 && r == Round::kDown) return -1;
    return 0;
  }
  return round_shift(Wide(m), -sh, r);
}

// std::ilogb of a finite x > 0, from its bits.
inline int ilogb_float(float x) {
  const uint32_t b = std::bit_cast<uint32_t>(x);
  const int biased = int((b >> 23) & 0xFFu);
  if (biased != 0) return biased - 127;
  return (31 - __builtin_clz(b & 0x7FFFFFu)) - 149;  // subnormal
}

}  // namespace

void set_format_fields(FixedRay& r, const FixedFormat& f) {
  r.frac = f.frac_bits;
  r.dir_bits = f.dir_bits;
  r.box_shift = f.frac_bits + f.rcp_bits - f.t_frac_bits;
  r.t_shift = f.t_shift();
  r.t_limit = int64_t((uint64_t(1) << f.t_bits) - 1);
  r.curve_bits = f.curve_bits;
}

RayStatus setup_ray(const Ray& r, const QuantFrame& frame, const FixedFormat& f, FixedRay& out) {
  const RayStatus st = validate_ray(r);
  if (st != RayStatus::kOk) return st;
  set_format_fields(out, f);

  // Origin: grid.F, nearest; out of frame beyond the guard range. Where to_grid's 64-bit path does not apply, a
  // coarse test in double first keeps far origins away from to_grid's saturation (which would be counted as an
  // overflow of an in-range value). The 64-bit path cannot saturate, and the coarse test rejects only origins
  // beyond twice the guard range (|rel| > 2^(B+G+1) steps, up to double rounding), which the exact test below
  // rejects as well: the same status either way.
  const int range_exp = f.coord_bits + f.guard_bits;
  const int64_t olim = int64_t(1) << (range_exp + f.frac_bits);
  for (int a = 0; a < 3; ++a) {
    if (!frame.to_grid_64(r.origin[a], a, Round::kNearestEven, f.frac_bits, out.o[a])) {
      const double rel = double(r.origin[a]) - double(frame.origin[a]) * pow2(frame.step_exp);
      if (std::abs(rel) > pow2(range_exp + 1 + frame.step_exp)) return RayStatus::kOutOfFrame;
      out.o[a] = frame.to_grid(r.origin[a], a, Round::kNearestEven, f.frac_bits);
    }
    if (out.o[a] >= olim || out.o[a] <= -olim) return RayStatus::kOutOfFrame;
  }

  // Direction: scaled by 2^-(E+1) so the largest component is in [1/2, 1), then D fraction bits, nearest
  // (the largest may round up to exactly 1). Components far smaller than the largest round to 0.
  const float m = std::max({std::abs(r.dir.x), std::abs(r.dir.y), std::abs(r.dir.z)});
  const int E = ilogb_float(m);
  int64_t d[3];
  for (int a = 0; a < 3; ++a) d[a] = int64_t(scaled_round(r.dir[a], f.dir_bits - E - 1, Round::kNearestEven));
  set_direction(out, d, f);
  // Grid displacement per world t is dir * 2^-step_exp = d * 2^(E + 1 - step_exp): t_ray = t_world * 2^k.
  const int k = E + 1 - frame.step_exp;
  out.t_exp = f.t_frac_bits + k;
  out.tmin = clamp_t(scaled_round(r.tmin, out.t_exp, Round::kDown), out.t_limit);
  out.tmax = std::isinf(r.tmax) ? (r.tmax > 0 ? out.t_limit : -out.t_limit)
                                : clamp_t(scaled_round(r.tmax, out.t_exp, Round::kUp), out.t_limit);
  return RayStatus::kOk;
}

namespace {

// FixedRay::narrow: the box test's products fit 64 bits in this format.
bool narrow_products(const FixedFormat& f) {
  return f.translated_bits() + f.rcp_bits + 2 <= 63 && f.frac_bits + f.rcp_bits - f.t_frac_bits <= 61;
}

// One axis of set_direction: one = 2^(D+R), sh0 = F + R - T.
inline void set_axis(FixedRay& r, int a, int64_t d, int64_t one, int rcp_bits, int sh0) {
  r.d[a] = d;
  r.zero[a] = d == 0;
  if (d == 0) {
    r.rcp_dn[a] = r.rcp_up[a] = r.rcpm_dn[a] = r.rcpm_up[a] = 0;
    r.rcp_sh[a] = 0;
    return;
  }
  // q = one / d truncated toward zero, rem = one - q d (0 <= rem < |d|); floor and ceil follow from the
  // sign and the remainder. The quotient comes from a double division (one is a power of two, d exact below
  // 2^53) corrected to the exact integer one by the remainder: the double is within q 2^-52 + 1 of q, so one
  // or two steps; a 64-bit division where that does not apply.
  int64_t q, rem;
  const int64_t ad = d < 0 ? -d : d, sg = d < 0 ? -1 : 1;
  if (ad < (int64_t(1) << 53)) {
    q = int64_t(double(one) / double(d));
    rem = one - q * d;  // |q d| <= one (1 + 2^-52) + |d| < 2^63
    if (rem < -4 * ad || rem >= 5 * ad) {
      q = one / d;
      rem = one % d;
    }
    while (rem < 0) {
      q -= sg;
      rem += ad;
    }
    while (rem >= ad) {
      q += sg;
      rem -= ad;
    }
  } else {
    q = one / d;
    rem = one % d;
  }
  r.rcp_dn[a] = rem != 0 && d < 0 ? q - 1 : q;
  r.rcp_up[a] = rem != 0 && d > 0 ? q + 1 : q;
  // R + 1 significant bits: drop e low bits of the larger magnitude, rounding down and up again.
  const uint64_t mag = uint64_t(std::max(std::abs(r.rcp_dn[a]), std::abs(r.rcp_up[a])));
  const int bits = 64 - __builtin_clzll(mag);
  const int e = std::max(0, bits - (rcp_bits + 1));
  r.rcpm_dn[a] = r.rcp_dn[a] >> e;                                     // floor
  r.rcpm_up[a] = e == 0 ? r.rcp_up[a] : ((r.rcp_up[a] - 1) >> e) + 1;  // ceil
  r.rcp_sh[a] = sh0 - e;
}

}  // namespace

void set_direction(FixedRay& r, const int64_t d[3], const FixedFormat& f) {
  const int64_t one = int64_t(1) << (f.dir_bits + f.rcp_bits);  // D + R <= 62 (validate)
  const int sh0 = f.frac_bits + f.rcp_bits - f.t_frac_bits;
  for (int a = 0; a < 3; ++a) set_axis(r, a, d[a], one, f.rcp_bits, sh0);
  r.narrow = narrow_products(f);
}

RaySetup::RaySetup(const QuantFrame& frame, const FixedFormat& f) : m_frame(frame), m_f(f) {
  m_olim = int64_t(1) << (f.coord_bits + f.guard_bits + f.frac_bits);
  m_one = int64_t(1) << (f.dir_bits + f.rcp_bits);
  set_format_fields(m_fields, f);
  m_fields.narrow = narrow_products(f);
}

RayStatus RaySetup::operator()(const Ray& r, FixedRay& out) const {
  uint32_t ob[3], db[3];
  for (int a = 0; a < 3; ++a) {
    ob[a] = std::bit_cast<uint32_t>(r.origin[a]);
    db[a] = std::bit_cast<uint32_t>(r.dir[a]);
  }
  const uint32_t bmin = std::bit_cast<uint32_t>(r.tmin), bmax = std::bit_cast<uint32_t>(r.tmax);
  // What validate_ray rejects goes through setup_ray, which gives the reason: a NaN or infinite origin or
  // direction component (exponent all ones), a zero direction, a NaN interval end or an infinite tmin.
  constexpr uint32_t kExp = 0x7F800000u, kMag = 0x7FFFFFFFu;
  bool odd = (bmin & kExp) == kExp || (bmax & kMag) > kExp || ((db[0] | db[1] | db[2]) & kMag) == 0;
  for (int a = 0; a < 3; ++a) odd = odd || (ob[a] & kExp) == kExp || (db[a] & kExp) == kExp;
  if (odd) return setup_ray(r, m_frame, m_f, out);

  // Origin: to_grid_64 (setup_ray's first choice too); where it does not apply, setup_ray's slower paths.
  for (int a = 0; a < 3; ++a) {
    int64_t g;
    if (!m_frame.to_grid_64(r.origin[a], a, Round::kNearestEven, m_f.frac_bits, g))
      return setup_ray(r, m_frame, m_f, out);
    if (g >= m_olim || g <= -m_olim) return RayStatus::kOutOfFrame;
    out.o[a] = g;
  }

  // Direction: scaled_round's 64-bit path. The largest component's exponent E; the others' shifts are at most
  // D - 24 (normal) or D - 1 (subnormal); one below -62 leaves |value| < 2^24 2^-63, which rounds to 0.
  const uint32_t mb = std::max({db[0] & kMag, db[1] & kMag, db[2] & kMag});  // bit order = magnitude order
  const int E = ilogb_float(std::bit_cast<float>(mb));
  const int D = m_f.dir_bits;
  for (int a = 0; a < 3; ++a) {
    int64_t m;
    int k;
    split_float(r.dir[a], m, k);
    const int sh = k + D - E - 1;
    const int64_t d = m == 0 ? 0 : sh >= 0 ? m << sh : sh < -62 ? 0 : round_shift64(m, -sh, Round::kNearestEven);
    set_axis(out, a, d, m_one, m_f.rcp_bits, m_fields.box_shift);
  }
  out.narrow = m_fields.narrow;
  out.frac = m_fields.frac;
  out.dir_bits = m_fields.dir_bits;
  out.box_shift = m_fields.box_shift;
  out.t_shift = m_fields.t_shift;
  out.t_limit = m_fields.t_limit;
  out.curve_bits = m_fields.curve_bits;
  const int kk = E + 1 - m_frame.step_exp;
  out.t_exp = m_f.t_frac_bits + kk;
  out.tmin = bmin == 0 ? 0 : clamp_t(scaled_round(r.tmin, out.t_exp, Round::kDown), out.t_limit);
  out.tmax = std::isinf(r.tmax) ? (r.tmax > 0 ? out.t_limit : -out.t_limit)
                                : clamp_t(scaled_round(r.tmax, out.t_exp, Round::kUp), out.t_limit);
  return RayStatus::kOk;
}

float t_to_world(int64_t t, const FixedRay& r) {
  return float(double(t) * pow2(-r.t_exp));
}

bool box_test_exact(const FixedRay& r, const int64_t lo[3], const int64_t hi[3], int64_t tmin, int64_t tlim) {
  // Distances as fractions p / q (q > 0) in t raw units: t = (plane - origin) * 2^s / d.
  struct Frac {
    Wide p, q;
  };
  Frac enters[4], exits[4];
  int ne = 0, nx = 0;
  enters[ne++] = {tmin, 1};
  exits[nx++] = {tlim, 1};
  for (int a = 0; a < 3; ++a) {
    const int64_t dl = (lo[a] << r.frac) - r.o[a], dh = (hi[a] << r.frac) - r.o[a];
    if (r.zero[a]) {
      if (dl > 0 || dh < 0) return false;
      continue;
    }
    const bool pos = r.d[a] > 0;
    const Wide sgn = pos ? 1 : -1;
    const int64_t dn = pos ? dl : dh, df = pos ? dh : dl;
    enters[ne++] = {sgn * (Wide(dn) << r.t_shift), sgn * r.d[a]};
    exits[nx++] = {sgn * (Wide(df) << r.t_shift), sgn * r.d[a]};
  }
  for (int i = 0; i < ne; ++i)
    for (int j = 0; j < nx; ++j)
      if (enters[i].p * exits[j].q > exits[j].p * enters[i].q) return false;
  return true;
}

bool sphere_test(const FixedRay& r, const SphereRecord& s, int64_t tmin, int64_t tlim, FixedPrimHit& out) {
  int64_t f[3];
  for (int a = 0; a < 3; ++a) f[a] = r.o[a] - s.center[a];
  Wide fd = 0, dd = 0;
  for (int a = 0; a < 3; ++a) {
    fd += Wide(f[a]) * r.d[a];
    dd += Wide(r.d[a]) * r.d[a];
  }
  const int64_t tca = div_shift(-fd, dd, r.t_shift, Round::kNearestEven, r.t_limit);
  // The perpendicular from the center to the line. Beyond 2^62 it is far outside any sphere of the frame
  // (radii are below 2^(B+F+1)); clamping there keeps the miss and the squares inside 127 bits.
  constexpr Wide kLMax = Wide(1) << 62;
  Wide ll = 0;
  for (int a = 0; a < 3; ++a) {
    Wide l = f[a] + round_shift(Wide(tca) * r.d[a], r.t_shift, Round::kNearestEven);
    l = l > kLMax ? kLMax : (l < -kLMax ? -kLMax : l);
    ll += l * l;
  }
  const Wide disc = Wide(s.radius) * s.radius - ll;
  if (disc < 0) return false;
  const Wide h2 = div_shift_wide(disc, dd, 2 * r.t_shift, Round::kDown, Wide(1) << 124);
  const int64_t h = clamp_t(isqrt_round(h2, Round::kNearestEven), r.t_limit);
  const int64_t t0 = clamp_t(Wide(tca) - h, r.t_limit), t1 = clamp_t(Wide(tca) + h, r.t_limit);
  const int64_t t = t0 >= tmin ? t0 : t1;
  if (t < tmin || t > tlim || !in_register(t, r)) return false;
  out.t = t;
  out.u = out.v = 0.0f;  // filled for the final hit only (sphere_uv)
  return true;
}

namespace {

int bit_length(Wide x) {
  int n = 0;
  while (x > 0) {
    x >>= 1;
    ++n;
  }
  return n;
}
Wide abs_wide(Wide x) {
  return x < 0 ? -x : x;
}

}  // namespace

bool swept_sphere_test(const FixedRay& r, const CurveRecord& c, int64_t tmin, int64_t tlim, FixedPrimHit& out) {
  const int F = r.frac;
  int64_t p0[3], p1[3], e[3];
  for (int a = 0; a < 3; ++a) {
    p0[a] = int64_t(c.p0[a]) << F;
    p1[a] = int64_t(c.p1[a]) << F;
    e[a] = p1[a] - p0[a];
  }
  const int64_t R0 = curve_radius(c.r0), R1 = curve_radius(c.r1), dr = R1 - R0;
  const Wide E2 = Wide(e[0]) * e[0] + Wide(e[1]) * e[1] + Wide(e[2]) * e[2];
  int64_t best = INT64_MAX;
  float best_s = 0.0f;
  auto sphere = [&](const int64_t* center, int64_t radius, float s) {
    if (radius <= 0) return;  // a zero radius: a point, hit by no ray of positive measure
    SphereRecord sr{};
    for (int a = 0; a < 3; ++a) sr.center[a] = center[a];
    sr.radius = radius;
    FixedPrimHit h;
    if (sphere_test(r, sr, tmin, tlim, h) && h.t < best) {
      best = h.t;
      best_s = s;
    }
  };
  sphere(p1, R1, 1.0f);
  if ((c.round & kRoundCapStart) || E2 <= Wide(dr) * dr) sphere(p0, R0, 0.0f);

  // 1. o' near the closest approach to the midpoint (twice the midpoint keeps it exact).
  Wide fd = 0, dd = 0;
  for (int a = 0; a < 3; ++a) {
    fd += Wide(2 * r.o[a] - p0[a] - p1[a]) * r.d[a];
    dd += Wide(r.d[a]) * r.d[a];
  }
  const int64_t tc = div_shift(-fd, 2 * dd, r.t_shift, Round::kNearestEven, r.t_limit);
  // Beyond 2^61 grid.F units from the midpoint the ray is far outside every segment of the frame (whose
  // lengths and radii are below 2^(B+F+2)); the clamp keeps the squares below inside 127 bits.
  constexpr Wide kFar = Wide(1) << 61;
  Wide g[3], m2 = 0;
  bool near = true;
  for (int a = 0; a < 3; ++a) {
    const Wide o2 = r.o[a] + round_shift(Wide(tc) * r.d[a], r.t_shift, Round::kNearestEven);
    const Wide c2 = 2 * o2 - p0[a] - p1[a];
    near = near && c2 <= kFar && c2 >= -kFar;
    m2 += near ? c2 * c2 : 0;
    g[a] = o2 - p0[a];
  }
  // The union lies within L/2 + max(r0, r1) of the midpoint (L = |e| rounded up); o' is within one unit of the
  // line's closest point. Twice both sides: |2 o' - (p0 + p1)| against L + 2 max(r) + 4.
  const Wide L = isqrt_round(E2, Round::kUp);
  const Wide reach = L + 2 * Wide(std::max(R0, R1)) + 4;
  const Wide K_full = E2 - Wide(dr) * dr;
  if (near && K_full > 0 && m2 <= reach * reach) {
    // 2. The local scale: everything below 2^curve_bits after a shift by z.
    Wide mag = std::max(R0, R1);
    for (int a = 0; a < 3; ++a) mag = std::max({mag, abs_wide(g[a]), Wide(e[a] < 0 ? -e[a] : e[a])});
    const int z = std::max(0, bit_length(mag) - r.curve_bits);
    Wide gz[3], ez[3];
    for (int a = 0; a < 3; ++a) {
      gz[a] = round_shift(g[a], z, Round::kNearestEven);
      ez[a] = round_shift(e[a], z, Round::kNearestEven);
    }
    const Wide r0 = round_shift(R0, z, Round::kUp), r1 = round_shift(R1, z, Round::kUp), drz = r1 - r0;
    const Wide e2 = ez[0] * ez[0] + ez[1] * ez[1] + ez[2] * ez[2];
    const Wide K = e2 - drz * drz;
    if (K > 0) {
      // 3. U = K g - (g . e + r0 dr) e, W = K d - (d . e) e, Rho = |e|^2 r0 + (g . e) dr, Sigma = (d . e) dr,
      // over 2^n.
      const int n = bit_length(e2) - 1;
      // w and sigma keep X more fraction bits than the direction, Dc = D + X = max(D, 54 - curve_bits) in all.
      const int X = std::max(0, 54 - r.curve_bits - r.dir_bits);
      const Wide ge = gz[0] * ez[0] + gz[1] * ez[1] + gz[2] * ez[2];
      const Wide de = r.d[0] * ez[0] + r.d[1] * ez[1] + r.d[2] * ez[2];
      const Wide a0 = ge + r0 * drz;  // K s at t = 0
      Wide u[3], w[3];
      for (int a = 0; a < 3; ++a) {
        u[a] = round_shift(K * gz[a] - a0 * ez[a], n, Round::kNearestEven);
        w[a] = round_shift((K * r.d[a] - de * ez[a]) << X, n, Round::kNearestEven);
      }
      const Wide rho = round_shift(e2 * r0 + ge * drz, n, Round::kNearestEven);
      const Wide sigma = round_shift((de * drz) << X, n, Round::kNearestEven);
      const Wide A = w[0] * w[0] + w[1] * w[1] + w[2] * w[2] - sigma * sigma;
      const Wide B = u[0] * w[0] + u[1] * w[1] + u[2] * w[2] - rho * sigma;
      const Wide C = u[0] * u[0] + u[1] * u[1] + u[2] * u[2] - rho * rho;
      const int sh = r.t_shift + z + X;  // (grid.F 2^z) / (direction 2^-X) quotients -> t raw
      // A root num / den (den != 0): its t, kept when its tangent sphere's s = (a0 + root de) / K is in [0, 1],
      // i.e. a0 den + num de between 0 and K den (den > 0; reversed for den < 0).
      auto root = [&](Wide num, Wide den) {
        if (den < 0) {
          num = -num;
          den = -den;
        }
        const Wide ks = a0 * den + ((num * de) << X);
        if (ks < 0 || ks > K * den) return;
        const int64_t t = clamp_t(Wide(tc) + div_shift(num, den, sh, Round::kNearestEven, r.t_limit), r.t_limit);
        if (t < tmin || t > tlim || !in_register(t, r) || t >= best) return;
        best = t;
        best_s = float(double(ks) / (double(K) * double(den)));
      };
      // 4. The stable quadratic: A t^2 + 2 B t + C = 0.
      if (A != 0) {
        const Wide disc = B * B - A * C;
        if (disc >= 0) {
          const Wide q = -(B + (B < 0 ? -1 : 1) * isqrt_round(disc, Round::kNearestEven));
          if (q != 0) {
            root(C, q);
            root(q, A);
          } else {
            root(0, 1);  // B = disc = 0, so C = 0: the ray touches the cone at t' = 0
          }
        }
      } else if (B != 0) {
        root(-C, 2 * B);  // the ray parallel to a generator of the cone
      }
    }
  }
  if (best == INT64_MAX) return false;
  out.t = best;
  out.u = best_s;
  out.v = 0.0f;
  return true;
}

bool plane_test(const FixedRay& r, const PlaneRecord& p, int64_t tmin, int64_t tlim, FixedPrimHit& out) {
  // n . x = w with n at D fraction bits and w, x at F: num and den share the scale 2^-(F+D) and 2^-2D.
  Wide num = Wide(p.offset) << r.dir_bits, den = 0;
  for (int a = 0; a < 3; ++a) {
    num -= Wide(p.normal[a]) * r.o[a];
    den += Wide(p.normal[a]) * r.d[a];
  }
  if (den == 0) return false;
  const int64_t t = div_shift(num, den, r.t_shift, Round::kNearestEven, r.t_limit);
  if (!in_register(t, r)) {
    // A plane met beyond the unit's t range (far outside the frame): no hit, counted as a saturation.
    if (t > 0 && tlim == r.t_limit) ++saturation_counter();
    return false;
  }
  if (t < tmin || t > tlim) return false;
  out.t = t;
  out.u = out.v = 0.0f;
  return true;
}

}  // namespace rtu::hw
