// The procedural scenes of the benchmark suite (suite_scenes.h). Each vertex is computed in double and rounded to
// float once; random numbers come from SplitMix64 with a constant seed per scene, never from the standard
// library's distributions (whose sequences differ between implementations), so every load gives the same bits.
#include "host/scene/suite_scenes.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "host/scene/curves.h"
#include "host/scene/generators.h"

namespace rtu::host {

Material diffuse_material(const std::string& name, Vec3 color) {
  return {.name = name, .type = MaterialType::kDiffuse, .color = color, .ior = 1.5f, .emission = {}};
}

uint32_t add_material(Scene& scene, Material m) {
  scene.materials.push_back(std::move(m));
  return uint32_t(scene.materials.size() - 1);
}

Light point_light(Vec3 position, Vec3 intensity) {
  Light light;
  light.type = LightType::kPoint;
  light.position = position;
  light.intensity = intensity;
  return light;
}

namespace {

using hw::DVec3;
constexpr double kPi = std::numbers::pi;

// SplitMix64 (Steele, Lea and Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014).
class Rng {
 public:
  explicit Rng(uint64_t seed) : m_state(seed) {}
  uint64_t next() {
    uint64_t z = (m_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  uint32_t below(uint32_t n) { return uint32_t(uniform() * n); }

 private:
  uint64_t m_state;
};

// A direction uniform on the unit sphere (rejection from the cube).
DVec3 random_unit(Rng& rng) {
  for (;;) {
    const DVec3 p(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
    const double l2 = glm::dot(p, p);
    if (l2 > 1e-4 && l2 <= 1.0) return p / std::sqrt(l2);
  }
}

// Triangles with their materials and texture coordinates, in the order they are added.
struct Builder {
  std::vector<hw::Triangle> tris;
  std::vector<uint32_t> material;
  std::vector<TriangleUv> uv;

  void add(const IndexedMesh& m, uint32_t mat) {
    for (const auto& f : m.faces) {
      tris.push_back({m.vertices[f[0]], m.vertices[f[1]], m.vertices[f[2]]});
      material.push_back(mat);
      TriangleUv t;
      if (!m.uvs.empty())
        for (int k = 0; k < 3; ++k) {
          t.s[k] = m.uvs[f[k]][0];
          t.t[k] = m.uvs[f[k]][1];
        }
      uv.push_back(t);
    }
  }
};

// Indexed mesh from vertices in double (rounded to float once) and faces.
struct MeshD {
  std::vector<DVec3> v;
  std::vector<std::array<uint32_t, 3>> f;
  uint32_t add(DVec3 p) {
    v.push_back(p);
    return uint32_t(v.size() - 1);
  }
  void quad(uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
    f.push_back({a, b, c});
    f.push_back({a, c, d});
  }
  IndexedMesh mesh() const {
    IndexedMesh m;
    m.vertices.reserve(v.size());
    for (const DVec3& p : v) m.vertices.push_back(Vec3(p));
    m.faces = f;
    return m;
  }
};

// A tube of `sides` around the polyline `path` (at least 2 points, consecutive points distinct), radius
// `radius[i]` at point i, open at both ends. Each ring's frame is the previous one's parallel-transported to
// the new tangent, so the tube does not twist. Counter-clockwise seen from outside.
MeshD make_tube(const std::vector<DVec3>& path, const std::vector<double>& radius, int sides) {
  const size_t n = path.size();
  auto tangent = [&](size_t i) { return glm::normalize(path[std::min(i + 1, n - 1)] - path[i == 0 ? 0 : i - 1]); };
  DVec3 t = tangent(0);
  DVec3 normal = glm::normalize(glm::cross(t, std::fabs(t.x) < 0.9 ? DVec3(1, 0, 0) : DVec3(0, 1, 0)));
  MeshD m;
  for (size_t i = 0; i < n; ++i) {
    t = tangent(i);
    normal = glm::normalize(normal - glm::dot(normal, t) * t);
    const DVec3 binormal = glm::cross(t, normal);
    for (int j = 0; j < sides; ++j) {
      const double phi = 2.0 * kPi * j / sides;
      m.add(path[i] + radius[i] * (std::cos(phi) * normal + std::sin(phi) * binormal));
    }
  }
  for (uint32_t i = 0; i + 1 < n; ++i)
    for (uint32_t j = 0; j < uint32_t(sides); ++j) {
      const uint32_t j1 = (j + 1) % uint32_t(sides);
      m.quad(i * sides + j, i * sides + j1, (i + 1) * sides + j1, (i + 1) * sides + j);
    }
  return m;
}

// An axis-aligned box from lo to hi.
IndexedMesh box_between(DVec3 lo, DVec3 hi) {
  IndexedMesh m = make_box(Vec3(hi - lo));
  const DVec3 c = 0.5 * (lo + hi);
  for (Vec3& p : m.vertices) p = Vec3(DVec3(p) + c);
  return m;
}

// ---- hairball

Scene build_hairball() {
  constexpr int kStrands = 512, kPoints = 33, kSides = 6;
  constexpr double kStep = 0.06, kRadius = 0.008;
  Rng rng(0x4841495242414C4Cull);  // "HAIRBALL"
  Scene scene;
  const uint32_t hair = add_material(scene, diffuse_material("hair", Vec3(0.62f, 0.40f, 0.22f)));
  Builder b;
  std::vector<DVec3> path(kPoints);
  const std::vector<double> radius(kPoints, kRadius);
  for (int s = 0; s < kStrands; ++s) {
    DVec3 p = random_unit(rng) * (0.85 * std::cbrt(rng.uniform()));  // uniform in the ball of radius 0.85
    DVec3 d = random_unit(rng);
    for (DVec3& point : path) {
      point = p;
      d = glm::normalize(d + 0.35 * random_unit(rng));  // a curl
      const double r = glm::length(p);
      if (r > 0.75) d = glm::normalize(d - 4.0 * (r - 0.75) * (p / r));  // turned back into the ball
      p += kStep * d;
    }
    b.add(make_tube(path, radius, kSides).mesh(), hair);
  }
  scene.geometry.triangles = std::move(b.tris);
  scene.prim_material = std::move(b.material);
  scene.lights.push_back(point_light(Vec3(2.5f, 3.0f, 3.5f), Vec3(28.0f)));
  scene.lights.push_back(point_light(Vec3(-3.0f, -1.0f, 2.0f), Vec3(6.0f)));
  scene.camera.position = Vec3(0.0f, 0.5f, 3.3f);
  scene.camera.look_at = Vec3(0.0f);
  scene.camera.width = 512;
  scene.camera.height = 512;
  scene.has_camera = true;
  return scene;
}

// ---- atrium

// A wall panel over x in [xa, xb], y in [y0, y1], z in [zc - th/2, zc + th/2] with a round-arch opening: the half
// disc of radius r centred at ((xa + xb) / 2, y0). Front, back and the arch's underside (intrados); its ends
// and top meet the neighbouring columns, panels and floors. The faces between the arch and the rectangle run
// along rays from the centre, with the rectangle's two top corners among them.
MeshD make_arch_panel(double xa, double xb, double y0, double y1, double zc, double th, double r, int segments) {
  const double xm = 0.5 * (xa + xb);
  std::vector<double> angles;
  for (int k = 0; k <= segments; ++k) angles.push_back(kPi * k / segments);
  const double corner = std::atan2(y1 - y0, xb - xm);
  angles.push_back(corner);
  angles.push_back(kPi - corner);
  std::sort(angles.begin(), angles.end());
  MeshD m;
  const double z[2] = {zc - 0.5 * th, zc + 0.5 * th};
  for (double a : angles) {
    const double c = std::cos(a), s = std::sin(a);
    double t = 1e300;
    if (c > 1e-12) t = std::min(t, (xb - xm) / c);
    if (c < -1e-12) t = std::min(t, (xa - xm) / c);
    if (s > 1e-12) t = std::min(t, (y1 - y0) / s);
    for (double zz : z) {
      m.add(DVec3(xm + r * c, y0 + r * s, zz));  // on the arch
      m.add(DVec3(xm + t * c, y0 + t * s, zz));  // on the rectangle
    }
  }
  // Vertex 4i + 0/1: front arch/rectangle, 4i + 2/3: back.
  for (uint32_t i = 0; i + 1 < angles.size(); ++i) {
    const uint32_t a = 4 * i, n = 4 * (i + 1);
    m.quad(a, n, n + 1, a + 1);          // front
    m.quad(a + 2, a + 3, n + 3, n + 2);  // back
    m.quad(a, a + 2, n + 2, n);          // intrados
  }
  return m;
}

// A drape hanging in the plane z = zc from y_top down to y_top - h, x in [xa, xb], folded: the sheet swings in z
// by up to `depth`, more at the hem than at the top.
MeshD make_drape(double xa, double xb, double y_top, double h, double zc, double depth, int nx, int ny) {
  MeshD m;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const double x = xa + (xb - xa) * i / nx, y = y_top - h * j / ny;
      const double fold = depth * (0.35 + 0.65 * double(j) / ny) * std::sin(2.0 * kPi * 3.0 * i / nx);
      m.add(DVec3(x, y, zc + fold));
    }
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const uint32_t a = uint32_t(j * (nx + 1) + i);
      m.quad(a, a + 1, a + uint32_t(nx) + 2, a + uint32_t(nx) + 1);
    }
  return m;
}

Scene build_atrium() {
  Scene scene;
  const uint32_t stone = add_material(scene, diffuse_material("stone", Vec3(0.74f, 0.69f, 0.60f)));
  const uint32_t floor = add_material(scene, diffuse_material("floor", Vec3(0.52f, 0.47f, 0.42f)));
  const uint32_t marble = add_material(scene, diffuse_material("column", Vec3(0.82f, 0.80f, 0.74f)));
  const uint32_t cloth[3] = {add_material(scene, diffuse_material("red cloth", Vec3(0.60f, 0.08f, 0.06f))),
                             add_material(scene, diffuse_material("green cloth", Vec3(0.08f, 0.40f, 0.12f))),
                             add_material(scene, diffuse_material("blue cloth", Vec3(0.08f, 0.12f, 0.50f)))};

  // Plan: x along the hall (end walls at +-kEnd), the open court |z| < kCourt, colonnades at |z| = kCourt,
  // side aisles out to the outer walls at |z| = kOuter. Two storeys: the gallery floor at y 5.0..5.3, the
  // aisles' roof at 9.6..9.9; the court is open above.
  constexpr double kEnd = 14.4, kCourt = 4.0, kOuter = 7.5, kWall = 0.3, kTop = 11.0;
  constexpr double kHalfDepth = 0.45;  // of the colonnade's panels, bases and capitals
  Builder b;
  b.add(box_between({-kEnd, -0.2, -kOuter}, {kEnd, 0.0, kOuter}), floor);
  for (double side : {-1.0, 1.0}) {
    // Outer wall, end walls, gallery floor and aisle roof on this side.
    b.add(box_between({-kEnd, 0.0, side > 0 ? kOuter : -kOuter - kWall},
                      {kEnd, kTop, side > 0 ? kOuter + kWall : -kOuter}),
          stone);
    b.add(box_between({side > 0 ? kEnd : -kEnd - kWall, 0.0, -kOuter - kWall},
                      {side > 0 ? kEnd + kWall : -kEnd, kTop, kOuter + kWall}),
          stone);
    const double inner = side * (kCourt - kHalfDepth), outer = side * kOuter;
    b.add(box_between({-kEnd, 5.0, std::min(inner, outer)}, {kEnd, 5.3, std::max(inner, outer)}), stone);
    b.add(box_between({-kEnd, 9.6, std::min(inner, outer)}, {kEnd, 9.9, std::max(inner, outer)}), stone);
    const double zc = side * kCourt;
    // Solid piers from the last column to the end walls.
    for (double end : {-1.0, 1.0})
      b.add(box_between({std::min(end * 12.0, end * kEnd), 0.0, zc - kHalfDepth},
                        {std::max(end * 12.0, end * kEnd), 9.6, zc + kHalfDepth}),
            stone);
    // Two storeys of seven columns 4 apart (x = -12..12) and six round arches between them.
    struct Storey {
      double base, shaft, capital, spring, top, radius;
    };
    for (const Storey& st : {Storey{0.0, 0.3, 2.9, 3.2, 5.0, 0.32}, Storey{5.3, 5.5, 7.6, 7.85, 9.6, 0.26}}) {
      for (int k = 0; k < 7; ++k) {
        const double x = -12.0 + 4.0 * k;
        b.add(box_between({x - kHalfDepth, st.base, zc - kHalfDepth}, {x + kHalfDepth, st.shaft, zc + kHalfDepth}),
              stone);
        b.add(box_between({x - kHalfDepth, st.capital, zc - kHalfDepth},
                          {x + kHalfDepth, st.spring, zc + kHalfDepth}),
              stone);
        // The shaft: 24 sides, 8 rings, slightly swelling (entasis) and tapering.
        constexpr int kRings = 8;
        std::vector<DVec3> path;
        std::vector<double> radius;
        for (int i = 0; i <= kRings; ++i) {
          const double f = double(i) / kRings;
          path.emplace_back(x, st.shaft + (st.capital - st.shaft) * f, zc);
          radius.push_back(st.radius * (1.0 + 0.05 * std::sin(kPi * f) - 0.12 * f));
        }
        b.add(make_tube(path, radius, 24).mesh(), marble);
      }
      for (int k = 0; k < 6; ++k) {
        const double xa = -12.0 + 4.0 * k, xb = xa + 4.0;
        b.add(make_arch_panel(xa, xb, st.spring, st.top, zc, 2.0 * kHalfDepth, 2.0 - kHalfDepth, 24).mesh(),
              stone);
      }
    }
    // Drapes hung from the gallery in front of the second and fifth ground-floor arches.
    for (int k : {1, 4}) {
      const double xa = -12.0 + 4.0 * k + 0.6;
      const int colour = (k + (side > 0 ? 1 : 0)) % 3;
      b.add(make_drape(xa, xa + 2.8, 4.95, 3.6, side * (kCourt - kHalfDepth - 0.25), 0.12, 32, 16).mesh(),
            cloth[colour]);
    }
  }
  scene.geometry.triangles = std::move(b.tris);
  std::vector<uint32_t> tri_material = std::move(b.material);

  // Interior light: a warm panel under the open court (facing down, edge_u x edge_v = -y) and two lanterns in
  // each aisle.
  const uint32_t sky = add_material(scene, {.name = "skylight",
                                            .type = MaterialType::kEmissive,
                                            .color = Vec3(1.0f),
                                            .ior = 1.5f,
                                            .emission = Vec3(7.0f, 6.5f, 5.5f)});
  Light light;
  light.type = LightType::kArea;
  light.position = Vec3(-10.0f, 10.5f, -3.0f);
  light.edge_u = Vec3(0.0f, 0.0f, 6.0f);
  light.edge_v = Vec3(20.0f, 0.0f, 0.0f);
  light.intensity = scene.materials[sky].emission;
  light.first_prim = uint32_t(scene.geometry.triangles.size());
  const Vec3 c = light.position, pu = c + light.edge_u, puv = pu + light.edge_v, pv = c + light.edge_v;
  scene.geometry.triangles.push_back({c, pu, puv});
  scene.geometry.triangles.push_back({c, puv, pv});
  tri_material.insert(tri_material.end(), 2, sky);
  scene.lights.push_back(light);
  for (float x : {-6.0f, 6.0f})
    for (float z : {-5.8f, 5.8f}) scene.lights.push_back(point_light(Vec3(x, 3.6f, z), Vec3(6.0f, 4.8f, 3.2f)));
  scene.prim_material = std::move(tri_material);

  scene.camera.position = Vec3(-13.0f, 1.7f, -1.2f);
  scene.camera.look_at = Vec3(8.0f, 4.2f, 0.8f);
  scene.camera.fov_y_deg = 60.0f;
  scene.has_camera = true;
  return scene;
}

// ---- city

struct Prototype {
  hw::Geometry geometry;
  std::vector<uint32_t> material;  // per triangle
};

Prototype to_prototype(Builder&& b) {
  Prototype p;
  p.geometry.triangles = std::move(b.tris);
  p.material = std::move(b.material);
  return p;
}

// The city's prototypes, each on a footprint of about 1.6 x 1.6, standing on y = 0.

// A setback tower: three tiers with a ledge at every floor, an antenna.
Prototype setback_tower(uint32_t concrete, uint32_t glass, uint32_t steel) {
  Builder b;
  const double tiers[3][3] = {{0.80, 0.0, 3.0}, {0.60, 3.0, 5.0}, {0.35, 5.0, 6.5}};  // half width, y0, y1
  for (const auto& t : tiers) {
    b.add(box_between({-t[0], t[1], -t[0]}, {t[0], t[2], t[0]}), concrete);
    for (double y = t[1] + 0.5; y < t[2] - 0.1; y += 0.5)
      b.add(box_between({-t[0] - 0.04, y, -t[0] - 0.04}, {t[0] + 0.04, y + 0.06, t[0] + 0.04}), glass);
  }
  b.add(make_tube({DVec3(0, 6.5, 0), DVec3(0, 7.6, 0)}, {0.03, 0.015}, 6).mesh(), steel);
  return to_prototype(std::move(b));
}

// An office block: a box with a grid of window frames on every side.
Prototype office_block(uint32_t brick, uint32_t glass) {
  Builder b;
  b.add(box_between({-0.8, 0.0, -0.8}, {0.8, 2.4, 0.8}), brick);
  for (int face = 0; face < 4; ++face)
    for (int row = 0; row < 6; ++row)
      for (int col = 0; col < 4; ++col) {
        const double u0 = -0.65 + 0.35 * col, y0 = 0.25 + 0.35 * row;
        DVec3 lo(u0, y0, 0.8), hi(u0 + 0.22, y0 + 0.22, 0.84);  // on the +z face, then turned
        IndexedMesh w = box_between(lo, hi);
        for (Vec3& p : w.vertices) {
          const DVec3 q(p);
          const double x[4] = {q.x, q.z, -q.x, -q.z}, z[4] = {q.z, -q.x, -q.z, q.x};
          p = Vec3(DVec3(x[face], q.y, z[face]));
        }
        b.add(w, glass);
      }
  return to_prototype(std::move(b));
}

// A round tower: 32 sides, 8 storeys, a flat roof and a crown ring.
Prototype round_tower(uint32_t concrete, uint32_t steel) {
  Builder b;
  std::vector<DVec3> path;
  for (int i = 0; i <= 8; ++i) path.emplace_back(0.0, 0.5 * i, 0.0);
  MeshD tower = make_tube(path, std::vector<double>(path.size(), 0.6), 32);
  const uint32_t centre = tower.add(DVec3(0.0, 4.0, 0.0)), top = 8 * 32;
  for (uint32_t j = 0; j < 32; ++j) tower.f.push_back({centre, top + (j + 1) % 32, top + j});
  b.add(tower.mesh(), concrete);
  IndexedMesh ring = make_torus(0.6f, 0.06f, 32, 6);
  for (Vec3& p : ring.vertices) p = Vec3(DVec3(p) + DVec3(0.0, 4.0, 0.0));
  b.add(ring, steel);
  return to_prototype(std::move(b));
}

// A gabled roof: a prism over the box lo..hi's top, its ridge 0.5 higher, along x or along z.
IndexedMesh gable(DVec3 lo, DVec3 hi, bool along_x) {
  MeshD m;
  const double y = hi.y, r = hi.y + 0.5;
  if (along_x) {
    const double zm = 0.5 * (lo.z + hi.z);
    const uint32_t a = m.add({lo.x, y, lo.z}), b2 = m.add({hi.x, y, lo.z}), c = m.add({hi.x, r, zm}),
                   d = m.add({lo.x, r, zm}), e = m.add({lo.x, y, hi.z}), f = m.add({hi.x, y, hi.z});
    m.quad(a, d, c, b2);
    m.quad(e, f, c, d);
    m.f.push_back({a, e, d});
    m.f.push_back({b2, c, f});
  } else {
    const double xm = 0.5 * (lo.x + hi.x);
    const uint32_t a = m.add({lo.x, y, lo.z}), b2 = m.add({lo.x, y, hi.z}), c = m.add({xm, r, hi.z}),
                   d = m.add({xm, r, lo.z}), e = m.add({hi.x, y, lo.z}), f = m.add({hi.x, y, hi.z});
    m.quad(a, b2, c, d);
    m.quad(e, d, c, f);
    m.f.push_back({a, d, e});
    m.f.push_back({b2, f, c});
  }
  return m.mesh();
}

// A house: an L of two blocks under gabled roofs.
Prototype gabled_house(uint32_t brick, uint32_t roof) {
  Builder b;
  b.add(box_between({-0.8, 0.0, -0.8}, {0.8, 1.0, 0.0}), brick);
  b.add(box_between({-0.8, 0.0, 0.0}, {0.0, 1.0, 0.8}), brick);
  b.add(gable({-0.8, 0.0, -0.8}, {0.8, 1.0, 0.0}, true), roof);
  b.add(gable({-0.8, 0.0, 0.0}, {0.0, 1.0, 0.8}, false), roof);
  return to_prototype(std::move(b));
}

// 16 x 16 blocks 2.5 apart: a prototype each (mesh 1 + its index), turned by a multiple of 90 degrees, scaled
// (heights 0.6-1.6x); each instance's triangle materials appended to tri_material.
void place_city_blocks(hw::InstanceSet& set, const std::vector<Prototype>& protos,
                       std::vector<uint32_t>& tri_material) {
  Rng rng(0x43495459ull);  // "CITY"
  constexpr int kBlocks = 16;
  constexpr double kSpacing = 2.5;
  for (int i = 0; i < kBlocks; ++i)
    for (int j = 0; j < kBlocks; ++j) {
      const uint32_t proto = rng.below(uint32_t(protos.size()));
      const int turn = int(rng.below(4));
      const double cs[4] = {1, 0, -1, 0}, sn[4] = {0, 1, 0, -1};
      const double c = cs[turn], s = sn[turn];
      const double sxz = rng.uniform(0.8, 1.1), sy = proto == 3 ? rng.uniform(0.8, 1.2) : rng.uniform(0.6, 1.6);
      const double tx = (i - 0.5 * (kBlocks - 1)) * kSpacing + rng.uniform(-0.1, 0.1);
      const double tz = (j - 0.5 * (kBlocks - 1)) * kSpacing + rng.uniform(-0.1, 0.1);
      hw::Instance in;
      in.mesh = proto + 1;
      const double m[3][4] = {{c * sxz, 0, s * sxz, tx}, {0, sy, 0, 0}, {-s * sxz, 0, c * sxz, tz}};
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 4; ++k) in.to_world.m[r][k] = float(m[r][k]);
      set.instances.push_back(in);
      tri_material.insert(tri_material.end(), protos[proto].material.begin(), protos[proto].material.end());
    }
}

Scene build_city() {
  Scene scene;
  const uint32_t ground = add_material(scene, diffuse_material("street", Vec3(0.35f, 0.35f, 0.37f)));
  const uint32_t concrete = add_material(scene, diffuse_material("concrete", Vec3(0.72f, 0.70f, 0.66f)));
  const uint32_t glass = add_material(scene, diffuse_material("window", Vec3(0.25f, 0.35f, 0.45f)));
  const uint32_t brick = add_material(scene, diffuse_material("brick", Vec3(0.62f, 0.32f, 0.22f)));
  const uint32_t roof = add_material(scene, diffuse_material("roof", Vec3(0.30f, 0.22f, 0.20f)));
  const uint32_t steel = add_material(scene, diffuse_material("steel", Vec3(0.55f, 0.60f, 0.66f)));
  std::vector<Prototype> protos;
  protos.push_back(setback_tower(concrete, glass, steel));
  protos.push_back(office_block(brick, glass));
  protos.push_back(round_tower(concrete, steel));
  protos.push_back(gabled_house(brick, roof));

  // Mesh 0 is the ground (placed once, under the identity), meshes 1..4 the prototypes.
  hw::InstanceSet& set = scene.instances;
  constexpr double kHalf = 21.0;
  set.meshes.emplace_back();
  Builder loose;
  loose.add(box_between({-kHalf, -0.1, -kHalf}, {kHalf, 0.0, kHalf}), ground);
  set.meshes[0].triangles = std::move(loose.tris);
  std::vector<uint32_t> tri_material = std::move(loose.material);
  for (Prototype& p : protos) set.meshes.push_back(p.geometry);
  set.instances.push_back(hw::Instance{});
  place_city_blocks(set, protos, tri_material);
  set.finish();
  scene.geometry = set.flatten({});
  scene.prim_material = std::move(tri_material);

  scene.lights.push_back(point_light(Vec3(50.0f, 110.0f, 35.0f), Vec3(5.0e4f)));
  scene.lights.push_back(point_light(Vec3(-40.0f, 30.0f, 60.0f), Vec3(6.0e3f)));
  scene.camera.position = Vec3(-24.0f, 15.0f, 27.0f);
  scene.camera.look_at = Vec3(1.0f, 0.0f, -1.0f);
  scene.camera.fov_y_deg = 50.0f;
  scene.has_camera = true;
  return scene;
}

// ---- forest

// Texel (x, y) is opaque when its centre lies in one of seven elliptic leaves around the card's centre, or on
// the twig that joins them.
bool leaf_texel(uint32_t x, uint32_t y, double& shade) {
  const DVec3 p((x + 0.5) / kForestLeafSide - 0.5, (y + 0.5) / kForestLeafSide - 0.5, 0.0);
  if (glm::length(p) < 0.05) {
    shade = 0.4;
    return true;
  }
  for (int k = 0; k < 7; ++k) {
    const double a = 2.0 * kPi * k / 7 + 0.3;
    const DVec3 along(std::cos(a), std::sin(a), 0.0), across(-std::sin(a), std::cos(a), 0.0);
    const DVec3 d = p - 0.24 * along;
    const double u = glm::dot(d, along) / 0.22, v = glm::dot(d, across) / 0.085;
    if (u * u + v * v <= 1.0) {
      shade = 1.0 - std::fabs(v);  // darker at the edges, a light midrib
      return true;
    }
  }
  return false;
}

}  // namespace

Texture make_forest_leaf_texture() {
  Texture t;
  t.name = "leaves";
  t.width = t.height = kForestLeafSide;
  t.rgba.reserve(size_t(kForestLeafSide) * kForestLeafSide * 4);
  for (uint32_t y = 0; y < kForestLeafSide; ++y)
    for (uint32_t x = 0; x < kForestLeafSide; ++x) {
      double shade = 0.0;
      const bool leaf = leaf_texel(x, y, shade);
      // Masked texels keep a dark leaf colour, so bilinear filtering at a leaf's edge does not darken it.
      const uint8_t rgba[4] = {uint8_t(40 + 50 * shade), uint8_t(80 + 110 * shade), uint8_t(25 + 20 * shade),
                               uint8_t(leaf ? 255 : 0)};
      t.rgba.insert(t.rgba.end(), rgba, rgba + 4);
    }
  return t;
}

namespace {

Scene build_forest() {
  Scene scene;
  const uint32_t soil = add_material(scene, diffuse_material("ground", Vec3(0.36f, 0.30f, 0.20f)));
  const uint32_t bark = add_material(scene, diffuse_material("bark", Vec3(0.32f, 0.22f, 0.14f)));
  Material leaf = diffuse_material("leaves", Vec3(1.0f));
  leaf.texture = 0;
  leaf.alpha_mode = AlphaMode::kMask;
  leaf.alpha_cutoff = 0.5f;
  const uint32_t leaves = add_material(scene, leaf);
  scene.textures.push_back(make_forest_leaf_texture());

  Builder b;
  b.add(box_between({-24.0, -0.1, -24.0}, {24.0, 0.0, 24.0}), soil);
  Rng rng(0x464F52455354ull);  // "FOREST"
  constexpr int kGrid = 8, kCards = 72;
  constexpr double kSpacing = 4.0, kCard = 1.0;
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j) {
      const DVec3 base((i - 0.5 * (kGrid - 1)) * kSpacing + rng.uniform(-1.2, 1.2), 0.0,
                       (j - 0.5 * (kGrid - 1)) * kSpacing + rng.uniform(-1.2, 1.2));
      const double height = rng.uniform(3.5, 5.5);
      // The trunk: 8 sides, 4 segments, tapering from 0.16 to 0.07, slightly leaning.
      const DVec3 lean(rng.uniform(-0.15, 0.15), 0.0, rng.uniform(-0.15, 0.15));
      std::vector<DVec3> path;
      std::vector<double> radius;
      for (int k = 0; k <= 4; ++k) {
        const double f = k / 4.0;
        path.push_back(base + DVec3(0.0, 0.85 * height * f, 0.0) + f * f * lean);
        radius.push_back(0.16 - 0.09 * f);
      }
      b.add(make_tube(path, radius, 8).mesh(), bark);
      // The crown: cards in an ellipsoid around 0.7 of the height, each facing a random direction.
      const DVec3 centre = base + lean + DVec3(0.0, 0.7 * height, 0.0);
      for (int k = 0; k < kCards; ++k) {
        const DVec3 at = centre + random_unit(rng) * std::cbrt(rng.uniform()) * DVec3(1.4, 1.5, 1.4);
        const DVec3 n = random_unit(rng);
        const DVec3 e1 = glm::normalize(glm::cross(n, std::fabs(n.y) < 0.9 ? DVec3(0, 1, 0) : DVec3(1, 0, 0)));
        const DVec3 e2 = glm::cross(n, e1);
        MeshD card;
        card.add(at - 0.5 * kCard * e1 - 0.5 * kCard * e2);
        card.add(at + 0.5 * kCard * e1 - 0.5 * kCard * e2);
        card.add(at + 0.5 * kCard * e1 + 0.5 * kCard * e2);
        card.add(at - 0.5 * kCard * e1 + 0.5 * kCard * e2);
        card.quad(0, 1, 2, 3);
        IndexedMesh m = card.mesh();
        m.uvs = {{0.0f, 0.0f}, {1.0f, 0.0f}, {1.0f, 1.0f}, {0.0f, 1.0f}};
        b.add(m, leaves);
      }
    }
  scene.geometry.triangles = std::move(b.tris);
  scene.prim_material = std::move(b.material);
  scene.triangle_uv = std::move(b.uv);

  scene.lights.push_back(point_light(Vec3(30.0f, 60.0f, 20.0f), Vec3(1.5e4f, 1.4e4f, 1.2e4f)));
  scene.lights.push_back(point_light(Vec3(-20.0f, 25.0f, 30.0f), Vec3(1.2e3f, 1.3e3f, 1.6e3f)));
  scene.camera.position = Vec3(-17.0f, 2.4f, 19.0f);
  scene.camera.look_at = Vec3(2.0f, 3.0f, -2.0f);
  scene.camera.fov_y_deg = 55.0f;
  scene.has_camera = true;
  return scene;
}

// ---- hair

// The strands of builtin:hair as polylines: roots buried just under the scalp of an ellipsoid head (its upper
// half and back, the face left bare), grown out along the normal and bent by gravity; every second strand curls
// (a helical wobble about its path). Points and radii in double.
struct Strand {
  std::vector<DVec3> p;
  std::vector<double> r;
};
constexpr DVec3 kHeadScale(0.9, 1.05, 1.0);
constexpr int kHairPoints = 9;  // 8 segments a strand

std::vector<Strand> hair_strands(int count) {
  Rng rng(0x48414952ull + uint64_t(count));  // "HAIR"
  std::vector<Strand> out;
  out.reserve(size_t(count));
  while (int(out.size()) < count) {
    const DVec3 n = random_unit(rng);
    if (n.y < -0.15 || (n.z > 0.45 && n.y < 0.55)) continue;  // below the ears, or the face
    const bool curly = out.size() % 2 == 1;
    Strand s;
    DVec3 p = 0.985 * n * kHeadScale;  // the root, inside the scalp
    DVec3 d = glm::normalize(n + DVec3(0.0, 0.05, 0.0));
    const DVec3 a = glm::normalize(glm::cross(d, std::fabs(d.x) < 0.9 ? DVec3(1, 0, 0) : DVec3(0, 1, 0)));
    const DVec3 b = glm::cross(d, a);
    const double len = rng.uniform(0.07, 0.11), phase = rng.uniform(0.0, 2.0 * kPi);
    for (int i = 0; i < kHairPoints; ++i) {
      s.p.push_back(p);
      s.r.push_back(0.0045 - 0.003 * double(i) / (kHairPoints - 1));  // tapered toward the tip
      d = glm::normalize(d + DVec3(0.0, -0.22, 0.0));                 // gravity
      if (curly) d = glm::normalize(d + 0.55 * (std::cos(phase + 1.4 * i) * a + std::sin(phase + 1.4 * i) * b));
      p += len * d;
      const double q = glm::length(p / kHeadScale);
      if (q < 1.04) p *= 1.04 / q;  // kept off the head
    }
    out.push_back(std::move(s));
  }
  return out;
}

// Triangle strips of a strand: one whose side at each point is side(i) (unit), 2 triangles a segment, its width
// twice the strand's radius there.
void add_strip(const Strand& s, const std::function<DVec3(size_t)>& side, uint32_t mat, Builder& b) {
  MeshD m;
  for (size_t i = 0; i < s.p.size(); ++i) {
    m.add(s.p[i] - s.r[i] * side(i));
    m.add(s.p[i] + s.r[i] * side(i));
  }
  for (uint32_t i = 0; i + 1 < s.p.size(); ++i) m.quad(2 * i, 2 * i + 1, 2 * i + 3, 2 * i + 2);
  b.add(m.mesh(), mat);
}

Scene build_hair(HairForm form, int strands) {
  Scene scene;
  const uint32_t skin = add_material(scene, diffuse_material("skin", Vec3(0.72f, 0.55f, 0.45f)));
  const uint32_t hair = add_material(scene, diffuse_material("hair", Vec3(0.30f, 0.19f, 0.10f)));
  scene.camera.position = Vec3(1.6f, 0.5f, 4.4f);
  scene.camera.look_at = Vec3(0.0f, 0.05f, 0.0f);
  scene.camera.width = 512;
  scene.camera.height = 512;
  scene.has_camera = true;
  Builder b;
  IndexedMesh head = make_icosphere(4, 1.0f);
  for (Vec3& v : head.vertices) v = Vec3(DVec3(v) * kHeadScale);
  b.add(head, skin);
  const std::vector<Strand> all = hair_strands(strands);
  const DVec3 eye(scene.camera.position);
  for (const Strand& s : all) {
    const size_t n = s.p.size();
    auto tangent = [&](size_t i) { return glm::normalize(s.p[std::min(i + 1, n - 1)] - s.p[i == 0 ? 0 : i - 1]); };
    if (form == HairForm::kRibbons) {
      // Facing the camera: each point's side across the tangent and the view direction.
      add_strip(
          s, [&](size_t i) { return glm::normalize(glm::cross(tangent(i), eye - s.p[i])); }, hair, b);
    } else if (form == HairForm::kDots) {
      // Two orthogonal strips, each point's sides across the tangent, fixed in the strand (view independent).
      const DVec3 t0 = tangent(0);
      const DVec3 ref = std::fabs(t0.y) < 0.9 ? DVec3(0, 1, 0) : DVec3(1, 0, 0);
      auto s1 = [&](size_t i) { return glm::normalize(glm::cross(tangent(i), ref)); };
      add_strip(s, s1, hair, b);
      add_strip(
          s, [&](size_t i) { return glm::normalize(glm::cross(tangent(i), s1(i))); }, hair, b);
    }
  }
  scene.geometry.triangles = std::move(b.tris);
  scene.prim_material = std::move(b.material);
  if (form == HairForm::kCurves) {
    for (size_t k = 0; k < all.size(); ++k) {
      std::vector<Vec3> p;
      std::vector<float> r;
      for (size_t i = 0; i < all[k].p.size(); ++i) {
        p.push_back(Vec3(all[k].p[i]));
        r.push_back(float(all[k].r[i]));
      }
      add_strand(scene.geometry, p, r, "hair strand " + std::to_string(k));
    }
    scene.prim_material.insert(scene.prim_material.end(), scene.geometry.curves.size(), hair);
  }
  scene.lights.push_back(point_light(Vec3(2.5f, 3.5f, 3.0f), Vec3(30.0f)));
  scene.lights.push_back(point_light(Vec3(-3.0f, 1.0f, -2.0f), Vec3(10.0f)));
  return scene;
}

}  // namespace

Scene make_hair_scene(HairForm form, int strands) {
  return build_hair(form, strands);
}
Scene make_hairball_scene() {
  return build_hairball();
}
Scene make_atrium_scene() {
  return build_atrium();
}
Scene make_city_scene() {
  return build_city();
}
Scene make_forest_scene() {
  return build_forest();
}

}  // namespace rtu::host
