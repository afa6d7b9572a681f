#include "firmware/raster.h"

#include <glm/glm.hpp>
#include <initializer_list>

namespace rtu::fw {

namespace {

using V = glm::vec3;

constexpr float kInf = __builtin_inff();
constexpr int64_t kOne = int64_t(1) << kSubpixelBits;
// The edge functions' range (raster.h): coordinates below 2^27, products below 2^55, sums below 2^57.
static_assert((double(kMaxRasterSide) + kGuardPixels) * double(kOne) < double(int64_t(1) << 27));

V vec(const F3& f) {
  return V(f.x, f.y, f.z);
}

// Round half away from zero (no libm).
int64_t round_i64(double v) {
  return v >= 0.0 ? int64_t(v + 0.5) : -int64_t(-v + 0.5);
}
int64_t floor_div(int64_t a, int64_t b) {  // b > 0
  return a >= 0 ? a / b : -((-a + b - 1) / b);
}
int64_t ceil_div(int64_t a, int64_t b) {  // b > 0
  return -floor_div(-a, b);
}
// Finite and within a range where products of a few coordinates stay finite in double (NaN fails too).
bool usable(double v) {
  return v > -1e100 && v < 1e100;
}
bool usable(const F3& f) {
  return usable(double(f.x)) && usable(double(f.y)) && usable(double(f.z));
}
double dmin(double a, double b) {
  return a < b ? a : b;
}
double dmax(double a, double b) {
  return a > b ? a : b;
}

// A vertex in view space (x along right, y along up, z along forward, in world units) with its barycentrics
// (u, v) in the original triangle.
struct CVert {
  double x, y, z, u, v;
};

// A snapped screen vertex: X, Y in 1/2^kSubpixelBits pixel (y down), view z and barycentrics.
struct SVert {
  int64_t X, Y;
  double z, u, v;
};

constexpr int kClipPlanes = 5;  // near, then the guard band's right, left, bottom, top
constexpr int kMaxPolygon = 3 + kClipPlanes;

class Raster {
 public:
  Raster(const RenderJob& job, const SampleOffset* offsets, uint64_t first, uint32_t n, hw::Hit* gbuf,
         const hw::AnyHitStage* stage, RasterStats& st)
      : m_job(job), m_offsets(offsets), m_first(first), m_n(n), m_gbuf(gbuf), m_stage(stage), m_st(st) {
    const uint32_t spp = job.spp ? job.spp : 1;
    m_spp = spp;
    m_p0 = first / spp;
    m_p1 = (first + n - 1) / spp + 1;
    m_y0 = int64_t(m_p0 / job.width);
    m_y1 = int64_t((m_p1 - 1) / job.width);
    // Camera frame in double: eye, forward (unit), right and up (orthogonal to forward, with the lengths
    // tan(fov/2) of the half angles, as RenderJob defines them) and their squared lengths.
    m_eye = glm::dvec3(job.eye.x, job.eye.y, job.eye.z);
    m_fwd = glm::dvec3(job.forward.x, job.forward.y, job.forward.z);
    m_right = glm::dvec3(job.right.x, job.right.y, job.right.z);
    m_up = glm::dvec3(job.up.x, job.up.y, job.up.z);
    m_right2 = glm::dot(m_right, m_right);
    m_up2 = glm::dot(m_up, m_up);
    // The lengths only scale a sphere's bounding square (a pixel of margin): float square roots (the double
    // one is a libm call here, and the firmware takes nothing from libm).
    m_rlen = double(glm::length(vec(job.right)));
    m_ulen = double(glm::length(vec(job.up)));
    if (job.raster_near > 0.0f) m_near = double(job.raster_near);
    m_gx = 1.0 + 2.0 * kGuardPixels / double(job.width);
    m_gy = 1.0 + 2.0 * kGuardPixels / double(job.height);
    // Sample positions within a pixel, in subpixel units: the center at 1 spp, anywhere in [0, 1] otherwise.
    m_smin = spp == 1 ? kOne / 2 : 0;
    m_smax = spp == 1 ? kOne / 2 : kOne;
  }

  void clear() {
    for (uint32_t i = 0; i < m_n; ++i) m_gbuf[i] = hw::Hit{};
    m_st.clears += m_n;
  }
  void triangle(const SurfaceRecord& s, uint32_t prim);
  void sphere(const SurfaceRecord& s, uint32_t prim);
  void curve(const SurfaceRecord& s, uint32_t prim);
  void plane(const SurfaceRecord& s, uint32_t prim);

 private:
  CVert to_view(const F3& p, double u, double v) const {
    const glm::dvec3 d = glm::dvec3(p.x, p.y, p.z) - m_eye;
    // x, y scaled so that the image spans x/z in [-1, 1] (z the distance along forward).
    return CVert{glm::dot(d, m_right) / m_right2, glm::dot(d, m_up) / m_up2, glm::dot(d, m_fwd), u, v};
  }
  // Signed distance of a view vertex to clip plane i (inside >= 0).
  double clip_distance(const CVert& c, int i) const {
    switch (i) {
      case 0:
        return c.z - m_near;
      case 1:
        return m_gx * c.z - c.x;
      case 2:
        return m_gx * c.z + c.x;
      case 3:
        return m_gy * c.z - c.y;
      default:
        return m_gy * c.z + c.y;
    }
  }
  SVert project(const CVert& c) const {
    const double px = (c.x / c.z + 1.0) * 0.5 * double(m_job.width);
    const double py = (1.0 - c.y / c.z) * 0.5 * double(m_job.height);
    return SVert{round_i64(px * double(kOne)), round_i64(py * double(kOne)), c.z, c.u, c.v};
  }
  // The pixels [x0, x1] x [y0, y1] that the projection of a view-space box (z along forward, x and y scaled as
  // CVert's) may cover, with a pixel of margin; the whole image when the box reaches the near plane. False when
  // it is behind the eye, off the image or outside the pass's rows.
  bool bounds(double zlo, double zhi, double xlo, double xhi, double ylo, double yhi, int64_t& x0, int64_t& x1,
              int64_t& y0, int64_t& y1) const;
  // Calls f(x, y, local index, offset) for every sample of the pass in pixels [x0, x1] x [y0, y1] (clamped to
  // the image and the pass's rows), counting coverage tests.
  template <class F>
  void scan(int64_t x0, int64_t x1, int64_t y0, int64_t y1, F&& f);
  // The triangle's plane: n . (p - eye) = w with n in world space (double).
  struct PlaneEq {
    glm::dvec3 n;
    double w;
  };
  void raster_piece(SVert a, SVert b, SVert c, const PlaneEq& plane, uint32_t prim);
  void depth_test(uint32_t i, float t, uint32_t prim, float u, float v) {
    ++m_st.fragments;
    hw::Hit& g = m_gbuf[i];
    // Alpha-tested surfaces: a fragment the any-hit stage ignores is not drawn (as a ray would pass it).
    if (t < g.t && (!m_stage || m_stage->accept(prim, u, v))) {
      g = hw::Hit{t, prim, u, v};
      ++m_st.depth_writes;
    }
  }
  // The camera ray's unnormalized direction at sample (x, y, o), computed as the renderer computes it.
  V direction(uint32_t x, uint32_t y, SampleOffset o) const {
    float sx, sy;
    image_plane(m_job, x, y, o, sx, sy);
    return vec(m_job.forward) + sx * vec(m_job.right) + sy * vec(m_job.up);
  }

  const RenderJob& m_job;
  const SampleOffset* m_offsets;
  uint64_t m_first;
  uint32_t m_n;
  hw::Hit* m_gbuf;
  const hw::AnyHitStage* m_stage;
  RasterStats& m_st;
  uint32_t m_spp = 1;
  uint64_t m_p0 = 0, m_p1 = 0;  // pixels of the pass [p0, p1)
  int64_t m_y0 = 0, m_y1 = 0;   // its rows (inclusive)
  glm::dvec3 m_eye{0.0}, m_fwd{0.0}, m_right{0.0}, m_up{0.0};
  double m_right2 = 1.0, m_up2 = 1.0, m_rlen = 1.0, m_ulen = 1.0, m_gx = 1.0, m_gy = 1.0;
  double m_near = 1e-6;  // > 0: projection divides by z
  int64_t m_smin = 0, m_smax = 0;
};

template <class F>
void Raster::scan(int64_t x0, int64_t x1, int64_t y0, int64_t y1, F&& f) {
  if (x0 < 0) x0 = 0;
  if (x1 > int64_t(m_job.width) - 1) x1 = int64_t(m_job.width) - 1;
  if (y0 < m_y0) y0 = m_y0;
  if (y1 > m_y1) y1 = m_y1;
  for (int64_t y = y0; y <= y1; ++y) {
    for (int64_t x = x0; x <= x1; ++x) {
      const uint64_t pixel = uint64_t(y) * m_job.width + uint64_t(x);
      if (pixel < m_p0 || pixel >= m_p1) continue;
      for (uint32_t s = 0; s < m_spp; ++s) {
        const uint64_t k = pixel * m_spp + s;
        if (k < m_first || k >= m_first + m_n) continue;
        const uint32_t i = uint32_t(k - m_first);
        ++m_st.samples_tested;
        f(uint32_t(x), uint32_t(y), i, m_offsets ? m_offsets[i] : SampleOffset{0.5f, 0.5f});
      }
    }
  }
}

void Raster::raster_piece(SVert a, SVert b, SVert c, const PlaneEq& plane, uint32_t prim) {
  int64_t area = (b.X - a.X) * (c.Y - a.Y) - (b.Y - a.Y) * (c.X - a.X);
  if (area == 0) {
    ++m_st.triangles_degenerate;
    return;
  }
  if (area < 0) {  // both faces are drawn: orient so that inside is positive
    const SVert t = b;
    b = c;
    c = t;
    area = -area;
  }
  // Edge function of edge (p, q): E(X, Y) = A X + B Y + C, positive inside; (A, B) is the inward normal.
  struct Edge {
    int64_t A, B, C, bias;  // bias 0 for a top-left edge (owns samples on it), 1 otherwise
  };
  auto edge = [](const SVert& p, const SVert& q) {
    Edge e;
    e.A = p.Y - q.Y;
    e.B = q.X - p.X;
    e.C = -(e.A * p.X + e.B * p.Y);
    e.bias = (e.A > 0 || (e.A == 0 && e.B > 0)) ? 0 : 1;
    return e;
  };
  const Edge e0 = edge(b, c), e1 = edge(c, a), e2 = edge(a, b);  // e_i is opposite vertex i
  int64_t minX = a.X, maxX = a.X, minY = a.Y, maxY = a.Y;
  for (const SVert* v : {&b, &c}) {
    minX = v->X < minX ? v->X : minX;
    maxX = v->X > maxX ? v->X : maxX;
    minY = v->Y < minY ? v->Y : minY;
    maxY = v->Y > maxY ? v->Y : maxY;
  }
  // Pixels whose samples (at x * kOne + [smin, smax]) can fall in the bounding box.
  const int64_t x0 = ceil_div(minX - m_smax, kOne), x1 = floor_div(maxX - m_smin, kOne);
  const int64_t y0 = ceil_div(minY - m_smax, kOne), y1 = floor_div(maxY - m_smin, kOne);
  // Culled before setup: no sample position in the bounding box (a small triangle between the samples, as GPUs
  // cull them), or the box outside the image or the pass's rows.
  if (x0 > x1 || y0 > y1) return;
  if (x1 < 0 || x0 > int64_t(m_job.width) - 1 || y1 < m_y0 || y0 > m_y1) return;
  ++m_st.setups;
  const double za = 1.0 / a.z, zb = 1.0 / b.z, zc = 1.0 / c.z;
  scan(x0, x1, y0, y1, [&](uint32_t x, uint32_t y, uint32_t i, SampleOffset o) {
    // The sample's position snapped to the subpixel grid (the center x + 1/2 exactly at 1 spp).
    const int64_t X = int64_t(double(float(x) + o.jx) * double(kOne) + 0.5);
    const int64_t Y = int64_t(double(float(y) + o.jy) * double(kOne) + 0.5);
    const int64_t w0 = e0.A * X + e0.B * Y + e0.C, w1 = e1.A * X + e1.B * Y + e1.C,
                  w2 = e2.A * X + e2.B * Y + e2.C;
    if (w0 < e0.bias || w1 < e1.bias || w2 < e2.bias) return;
    // Perspective-correct barycentrics: lambda_i / z_i interpolates linearly on the screen.
    const double q0 = double(w0) * za, q1 = double(w1) * zb, q2 = double(w2) * zc;
    const double q = q0 + q1 + q2;
    if (!(q > 0.0)) return;
    const double b0 = q0 / q, b1 = q1 / q, b2 = q2 / q;
    // Depth from the triangle's plane along the sample's camera ray (normalized as the renderer normalizes
    // it), not interpolated between snapped vertices: the hit point eye + t d then lies on the surface within
    // float rounding, which the spawn offsets of secondary rays are made for.
    const V d = glm::normalize(direction(x, y, o));
    const double dn = glm::dot(plane.n, glm::dvec3(d));
    const float t = float(plane.w / dn);
    if (!(t > 0.0f && t < kInf)) return;
    depth_test(i, t, prim, float(b0 * a.u + b1 * b.u + b2 * c.u), float(b0 * a.v + b1 * b.v + b2 * c.v));
  });
}

void Raster::triangle(const SurfaceRecord& s, uint32_t prim) {
  // A record the host would not write (NaN or infinite coordinates) draws nothing rather than reaching the
  // float-to-integer conversions with a value they cannot represent.
  if (!usable(s.a) || !usable(s.b) || !usable(s.c)) {
    ++m_st.triangles_culled;
    return;
  }
  CVert poly[kMaxPolygon + 1] = {to_view(s.a, 0.0, 0.0), to_view(s.b, 1.0, 0.0), to_view(s.c, 0.0, 1.0)};
  int count = 3;
  // Outcodes against the view frustum (clip space with w = z: x > w is right of the image) and the near plane:
  // a triangle outside one plane with all its vertices is culled.
  unsigned all_out = ~0u, any_clip = 0;
  for (int i = 0; i < 3; ++i) {
    const CVert& c = poly[i];
    unsigned out = 0;
    out |= (c.z < m_near) ? 1u : 0u;
    out |= (c.x > c.z) ? 2u : 0u;
    out |= (-c.x > c.z) ? 4u : 0u;
    out |= (c.y > c.z) ? 8u : 0u;
    out |= (-c.y > c.z) ? 16u : 0u;
    all_out &= out;
    for (int p = 0; p < kClipPlanes; ++p) any_clip |= clip_distance(c, p) < 0.0 ? 1u << p : 0u;
  }
  if (all_out != 0) {
    ++m_st.triangles_culled;
    return;
  }
  if (any_clip != 0) {
    ++m_st.triangles_clipped;
    for (int p = 0; p < kClipPlanes && count > 0; ++p) {
      // Clipping by an earlier plane moves vertices, so each plane is tested on the current polygon.
      bool out = false;
      for (int i = 0; i < count; ++i) out |= clip_distance(poly[i], p) < 0.0;
      if (!out) continue;
      CVert next[kMaxPolygon + 1];
      int m = 0;
      for (int i = 0; i < count; ++i) {
        const CVert& a = poly[i];
        const CVert& b = poly[(i + 1) % count];
        const double da = clip_distance(a, p), db = clip_distance(b, p);
        if (da >= 0.0) next[m++] = a;
        if ((da >= 0.0) != (db >= 0.0)) {
          // The crossing from the endpoints in a canonical order (the lower by x, y, z first), so that the
          // neighbouring triangle, which walks the edge the other way, computes the same point bit for bit.
          const bool a_first = a.x < b.x || (a.x == b.x && (a.y < b.y || (a.y == b.y && a.z <= b.z)));
          const CVert& p0 = a_first ? a : b;
          const CVert& p1 = a_first ? b : a;
          const double d0 = a_first ? da : db, d1 = a_first ? db : da;
          const double t = d0 / (d0 - d1);
          next[m++] = CVert{p0.x + t * (p1.x - p0.x), p0.y + t * (p1.y - p0.y), p0.z + t * (p1.z - p0.z),
                            p0.u + t * (p1.u - p0.u), p0.v + t * (p1.v - p0.v)};
        }
      }
      count = m;
      for (int i = 0; i < count; ++i) poly[i] = next[i];
    }
  }
  if (count < 3) {
    ++m_st.triangles_culled;
    return;
  }
  const glm::dvec3 va(s.a.x, s.a.y, s.a.z), vb(s.b.x, s.b.y, s.b.z), vc(s.c.x, s.c.y, s.c.z);
  PlaneEq plane;
  plane.n = glm::cross(vb - va, vc - va);
  plane.w = glm::dot(plane.n, va - m_eye);
  const uint64_t setups = m_st.setups, degenerate = m_st.triangles_degenerate;
  const SVert v0 = project(poly[0]);
  SVert prev = project(poly[1]);
  for (int i = 2; i < count; ++i) {  // a fan: its pieces share their inner edges, which the fill rule splits
    const SVert cur = project(poly[i]);
    raster_piece(v0, prev, cur, plane, prim);
    prev = cur;
  }
  // Every piece outside the pass's rows or the image: culled (degenerate pieces are counted as such).
  if (m_st.setups == setups && m_st.triangles_degenerate == degenerate) ++m_st.triangles_culled;
}

bool Raster::bounds(double zlo, double zhi, double xlo, double xhi, double ylo, double yhi, int64_t& x0,
                    int64_t& x1, int64_t& y0, int64_t& y1) const {
  if (zhi <= 0.0) return false;  // behind the eye
  x0 = 0;
  x1 = int64_t(m_job.width) - 1;
  y0 = 0;
  y1 = int64_t(m_job.height) - 1;
  if (zlo > m_near) {
    // The projection of the view-space box is bounded by its corners' (x / z is monotone in x and in z for
    // z > 0); a pixel of margin covers the rounding of the bounds.
    double sx0 = 1e300, sx1 = -1e300, sy0 = 1e300, sy1 = -1e300;
    for (double z : {zlo, zhi}) {
      for (double x : {xlo, xhi}) {
        sx0 = dmin(sx0, x / z);
        sx1 = dmax(sx1, x / z);
      }
      for (double y : {ylo, yhi}) {
        sy0 = dmin(sy0, y / z);
        sy1 = dmax(sy1, y / z);
      }
    }
    const double w = double(m_job.width), h = double(m_job.height);
    const double px0 = (sx0 + 1.0) * 0.5 * w, px1 = (sx1 + 1.0) * 0.5 * w;
    const double py0 = (1.0 - sy1) * 0.5 * h, py1 = (1.0 - sy0) * 0.5 * h;
    if (px1 < -1.0 || px0 > w + 1.0 || py1 < -1.0 || py0 > h + 1.0) return false;
    x0 = int64_t(dmax(px0, -1.0)) - 1;
    x1 = int64_t(dmin(px1, w + 1.0)) + 1;
    y0 = int64_t(dmax(py0, -1.0)) - 1;
    y1 = int64_t(dmin(py1, h + 1.0)) + 1;
  }
  return !(y1 < m_y0 || y0 > m_y1);
}

void Raster::sphere(const SurfaceRecord& s, uint32_t prim) {
  if (!usable(s.a) || !(s.b.x > 0.0f && usable(double(s.b.x)))) return;  // not a sphere the host would write
  const CVert c = to_view(s.a, 0.0, 0.0);
  const double r = double(s.b.x);
  const double rx = r / m_rlen, ry = r / m_ulen;  // the radius in the scaled x and y of CVert
  int64_t x0, x1, y0, y1;
  if (!bounds(c.z - r, c.z + r, c.x - rx, c.x + rx, c.y - ry, c.y + ry, x0, x1, y0, y1)) return;
  ++m_st.setups;
  const V center = vec(s.a), eye = vec(m_job.eye);
  const float radius = s.b.x;
  const V f = eye - center;
  const float ff = glm::dot(f, f) - radius * radius;
  scan(x0, x1, y0, y1, [&](uint32_t x, uint32_t y, uint32_t i, SampleOffset o) {
    // The camera ray against the sphere as the float reference computes it (hwmodel/datapath/intersect_float.h):
    // the distance from the center to the line without the cancellation of b^2 - a c.
    const V d = glm::normalize(direction(x, y, o));
    const float a = glm::dot(d, d);
    const float b = -glm::dot(f, d);
    const V l = f + (b / a) * d;
    const float disc = a * (radius * radius - glm::dot(l, l));
    if (!(disc >= 0.0f)) return;
    const float root = glm::sqrt(disc);
    const float q = b + __builtin_copysignf(root, b);  // the sign of b, -0 included, as the reference
    float t0 = 0.0f, t1 = 0.0f;
    if (q != 0.0f) {
      t0 = ff / q;
      t1 = q / a;
    }
    if (t0 > t1) {
      const float t = t0;
      t0 = t1;
      t1 = t;
    }
    const float t = t0 >= 0.0f ? t0 : t1;
    if (!(t >= 0.0f && t <= kInf)) return;
    depth_test(i, t, prim, 0.0f, 0.0f);
  });
}

void Raster::curve(const SurfaceRecord& s, uint32_t prim) {
  const float r0 = s.c.x, r1 = s.c.y;
  if (!usable(s.a) || !usable(s.b) || !usable(double(r0)) || !usable(double(r1)) || !(r0 >= 0.0f && r1 >= 0.0f) ||
      !(r0 > 0.0f || r1 > 0.0f))
    return;  // not a segment the host would write
  // The segment lies in the view-space box of its end spheres.
  const CVert c0 = to_view(s.a, 0.0, 0.0), c1 = to_view(s.b, 0.0, 0.0);
  const double R0 = double(r0), R1 = double(r1);
  int64_t x0, x1, y0, y1;
  if (!bounds(dmin(c0.z - R0, c1.z - R1), dmax(c0.z + R0, c1.z + R1), dmin(c0.x - R0 / m_rlen, c1.x - R1 / m_rlen),
              dmax(c0.x + R0 / m_rlen, c1.x + R1 / m_rlen), dmin(c0.y - R0 / m_ulen, c1.y - R1 / m_ulen),
              dmax(c0.y + R0 / m_ulen, c1.y + R1 / m_ulen), x0, x1, y0, y1))
    return;
  ++m_st.setups;
  // Per sample, the camera ray against the segment as the float reference computes it
  // (hwmodel/datapath/intersect_float.h, intersect_swept_sphere, in [0, inf]): the cone between the end spheres'
  // circles of tangency, the sphere at p1, and the sphere at p0 for a strand's first segment (c.z = 1) or when
  // one end sphere holds the other. In double, relative to p0.
  using D3 = glm::dvec3;
  const D3 p0 = D3(double(s.a.x), double(s.a.y), double(s.a.z));
  const D3 o = D3(double(m_job.eye.x), double(m_job.eye.y), double(m_job.eye.z)) - p0;
  const D3 ba = D3(double(s.b.x), double(s.b.y), double(s.b.z)) - p0;
  const double dr = R1 - R0, L2 = glm::dot(ba, ba), K = L2 - dr * dr;
  const bool start_cap = s.c.z != 0.0f || L2 <= dr * dr;
  scan(x0, x1, y0, y1, [&](uint32_t x, uint32_t y, uint32_t i, SampleOffset so) {
    const V df = glm::normalize(direction(x, y, so));
    const D3 d(double(df.x), double(df.y), double(df.z));
    const double a = glm::dot(d, d);
    double best = double(kInf), best_s = 0.0;
    const auto consider = [&](double t, double sv) {
      if (t >= 0.0 && t <= double(kInf) && t < best) {
        best = t;
        best_s = sv;
      }
    };
    const auto sphere_at = [&](const D3& c, double R, double sv) {
      if (!(R > 0.0)) return;
      const D3 f = o - c;
      const double b = -glm::dot(f, d);
      const D3 l = f + (b / a) * d;
      const double disc = a * (R * R - glm::dot(l, l));
      if (!(disc >= 0.0)) return;
      const double q = b + __builtin_copysign(__builtin_sqrt(disc), b);
      if (q == 0.0) return consider(0.0, sv);
      consider((glm::dot(f, f) - R * R) / q, sv);
      consider(q / a, sv);
    };
    sphere_at(ba, R1, 1.0);
    if (start_cap) sphere_at(D3(0.0), R0, 0.0);
    if (K > 0.0) {
      const double alpha = (glm::dot(o, ba) + R0 * dr) / K, beta = glm::dot(d, ba) / K;
      const D3 u = o - alpha * ba, w = d - beta * ba;
      const double rho = R0 + alpha * dr, sigma = beta * dr;
      const double A = glm::dot(w, w) - sigma * sigma, B = glm::dot(u, w) - rho * sigma,
                   C = glm::dot(u, u) - rho * rho;
      const auto lateral = [&](double t) {
        const double sv = alpha + beta * t;
        if (sv >= 0.0 && sv <= 1.0) consider(t, sv);
      };
      if (A != 0.0) {
        const double disc = B * B - A * C;
        if (disc >= 0.0) {
          const double q = -(B + __builtin_copysign(__builtin_sqrt(disc), B));
          if (q != 0.0) lateral(C / q);
          lateral(q / A);
        }
      } else if (B != 0.0) {
        lateral(-C / (2.0 * B));
      }
    }
    if (!(best < double(kInf))) return;
    const float t = float(best);
    if (!(t >= 0.0f && t <= kInf)) return;
    depth_test(i, t, prim, float(best_s), 0.0f);
  });
}

void Raster::plane(const SurfaceRecord& s, uint32_t prim) {
  ++m_st.setups;
  const V n = vec(s.a), eye = vec(m_job.eye);
  const float c = s.b.x - glm::dot(eye, n);
  scan(0, int64_t(m_job.width) - 1, m_y0, m_y1, [&](uint32_t x, uint32_t y, uint32_t i, SampleOffset o) {
    const V d = glm::normalize(direction(x, y, o));
    const float dn = glm::dot(d, n);
    if (dn == 0.0f) return;
    const float t = c / dn;
    if (!(t >= 0.0f && t <= kInf)) return;
    depth_test(i, t, prim, 0.0f, 0.0f);
  });
}

}  // namespace

void rasterize(const RenderJob& job, const SurfaceRecord* surfaces, const SampleOffset* offsets, uint64_t first,
               uint32_t n, hw::Hit* gbuf, RasterStats& stats, const hw::AnyHitStage* stage) {
  if (n == 0 || job.width == 0 || job.height == 0 || job.width > kMaxRasterSide || job.height > kMaxRasterSide)
    return;
  ++stats.passes;
  Raster r(job, offsets, first, n, gbuf, stage, stats);
  r.clear();
  for (uint32_t p = 0; p < job.num_prims; ++p) {
    const SurfaceRecord& s = surfaces[p];
    ++stats.prims_read;
    if (s.kind == uint32_t(SurfaceKind::kTriangle))
      r.triangle(s, p);
    else if (s.kind == uint32_t(SurfaceKind::kSphere))
      r.sphere(s, p);
    else if (s.kind == uint32_t(SurfaceKind::kPlane))
      r.plane(s, p);
    else if (s.kind == uint32_t(SurfaceKind::kCurve))
      r.curve(s, p);
  }
}

}  // namespace rtu::fw
