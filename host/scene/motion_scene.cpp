#include "host/scene/motion_scene.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <stdexcept>
#include <utility>

#include "host/io/error.h"
#include "host/scene/ray_gen.h"
#include "hwmodel/numeric/rng.h"

namespace rtu::host {

namespace {

// A unit sphere as a closed indexed mesh: the octahedron, each triangle split in four `level` times, the
// vertices normalized. Midpoints are shared through a map, so neighbouring triangles share their vertices.
void unit_ball(int level, std::vector<hw::Vec3>& verts, std::vector<std::array<uint32_t, 3>>& tris) {
  verts = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  tris = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4}, {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (int l = 0; l < level; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    const auto middle = [&](uint32_t a, uint32_t b) {
      const auto key = std::make_pair(std::min(a, b), std::max(a, b));
      const auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      verts.push_back(glm::normalize(verts[a] + verts[b]));
      return mid[key] = uint32_t(verts.size() - 1);
    };
    std::vector<std::array<uint32_t, 3>> next;
    for (const auto& t : tris) {
      const uint32_t ab = middle(t[0], t[1]), bc = middle(t[1], t[2]), ca = middle(t[2], t[0]);
      next.push_back({t[0], ab, ca});
      next.push_back({ab, t[1], bc});
      next.push_back({ca, bc, t[2]});
      next.push_back({ab, bc, ca});
    }
    tris.swap(next);
  }
}

}  // namespace

MotionScene builtin_motion_scene(int level, float motion_scale) {
  if (level < 0 || level > 7) throw std::invalid_argument("motion scene level must be in 0..7");
  if (!(motion_scale >= 0.0f && motion_scale <= 1.0f))
    throw std::invalid_argument("motion scene motion_scale must be in [0, 1]");
  MotionScene s;
  s.camera.position = hw::Vec3(0.0f, 4.0f, 14.0f);
  s.camera.look_at = hw::Vec3(0.0f, 1.0f, 0.0f);
  s.camera.width = 320;
  s.camera.height = 240;
  std::vector<hw::Vec3> unit;
  std::vector<std::array<uint32_t, 3>> idx;
  unit_ball(level, unit, idx);
  // (center at 0, center at 1, radius at 0, radius at 1): three fast, three slow, two growing, one still.
  struct Motion {
    hw::Vec3 c0, c1;
    float r0, r1;
  };
  const Motion balls[] = {{{-6.0f, 1.0f, -2.0f}, {-3.0f, 1.0f, -2.0f}, 1.0f, 1.0f},
                          {{-1.5f, 1.0f, -3.0f}, {1.5f, 1.0f, -3.0f}, 1.0f, 1.0f},
                          {{3.0f, 1.0f, -2.0f}, {6.0f, 1.5f, -2.0f}, 1.0f, 1.0f},
                          {{-4.0f, 0.7f, 1.5f}, {-3.6f, 0.7f, 1.5f}, 0.7f, 0.7f},
                          {{0.0f, 0.7f, 2.0f}, {0.0f, 1.1f, 2.0f}, 0.7f, 0.7f},
                          {{4.0f, 0.7f, 1.5f}, {3.6f, 0.7f, 1.9f}, 0.7f, 0.7f},
                          {{-2.0f, 0.5f, 4.5f}, {-2.0f, 0.8f, 4.5f}, 0.5f, 0.8f},
                          {{2.0f, 0.8f, 4.5f}, {2.0f, 0.5f, 4.5f}, 0.8f, 0.5f},
                          {{0.0f, 2.5f, -8.0f}, {0.0f, 2.5f, -8.0f}, 2.5f, 2.5f}};
  for (Motion m : balls) {
    m.c1 = m.c0 + motion_scale * (m.c1 - m.c0);
    m.r1 = m.r0 + motion_scale * (m.r1 - m.r0);
    MotionScene::Ball b;
    b.first = uint32_t(s.geometry.triangles.size());
    b.count = uint32_t(idx.size());
    b.center[0] = m.c0;
    b.center[1] = m.c1;
    b.radius[0] = m.r0;
    b.radius[1] = m.r1;
    for (const auto& t : idx) {
      hw::MotionTriangle mt;
      for (int k = 0; k < 2; ++k) {
        const hw::Vec3 c = k == 0 ? m.c0 : m.c1;
        const float r = k == 0 ? m.r0 : m.r1;
        mt.key[k] = hw::Triangle{c + r * unit[t[0]], c + r * unit[t[1]], c + r * unit[t[2]]};
      }
      s.geometry.triangles.push_back(mt);
    }
    s.balls.push_back(b);
  }
  // The floor just below the balls, which do not touch it or each other: a ray from inside a ball meets it first.
  const float y = -0.05f;
  const hw::Vec3 f[4] = {{-12.0f, y, -12.0f}, {12.0f, y, -12.0f}, {12.0f, y, 10.0f}, {-12.0f, y, 10.0f}};
  for (const hw::Triangle& t : {hw::Triangle{f[0], f[1], f[2]}, hw::Triangle{f[0], f[2], f[3]}})
    s.geometry.triangles.push_back(hw::MotionTriangle{{t, t}});
  return s;
}

MotionInstanceScene builtin_motion_instances(int level, float motion_scale) {
  const MotionScene ref = builtin_motion_scene(level, motion_scale);  // the balls' moves, the camera
  MotionInstanceScene s;
  s.camera = ref.camera;
  std::vector<hw::Vec3> unit;
  std::vector<std::array<uint32_t, 3>> idx;
  unit_ball(level, unit, idx);
  hw::Geometry ball, floor;
  for (const auto& t : idx) ball.triangles.push_back(hw::Triangle{unit[t[0]], unit[t[1]], unit[t[2]]});
  const uint32_t floor_first = ref.balls.back().first + ref.balls.back().count;
  for (uint32_t i = floor_first; i < ref.geometry.triangles.size(); ++i)
    floor.triangles.push_back(ref.geometry.triangles[i].key[0]);
  s.set.set.meshes = {ball, floor};
  const float turn = 60.0f * motion_scale * 3.14159265f / 180.0f;
  for (size_t b = 0; b < ref.balls.size(); ++b) {
    const MotionScene::Ball& m = ref.balls[b];
    hw::Affine key[2];
    for (int k = 0; k < 2; ++k) {
      // Balls 1, 4 and 7 turn: r R_y(angle) at key frame 1, r I at 0.
      const float a = (k == 1 && b % 3 == 1) ? turn : 0.0f, c = std::cos(a), sn = std::sin(a), r = m.radius[k];
      key[k].m[0][0] = r * c;
      key[k].m[0][2] = r * sn;
      key[k].m[1][1] = r;
      key[k].m[2][0] = -r * sn;
      key[k].m[2][2] = r * c;
      for (int ax = 0; ax < 3; ++ax) key[k].m[ax][3] = m.center[k][ax];
    }
    s.set.set.instances.push_back(hw::Instance{0, key[0]});
    s.set.end.push_back(key[1]);
  }
  s.set.set.instances.push_back(hw::Instance{1, hw::Affine{}});
  s.set.end.push_back(hw::Affine{});
  s.set.set.finish();
  s.set.validate();
  for (size_t b = 0; b < ref.balls.size(); ++b) {
    MotionScene::Ball m = ref.balls[b];
    m.first = s.set.set.instances[b].tri_base;
    s.balls.push_back(m);
  }
  return s;
}

hw::MotionInstanceSet moving_instances(const Scene& scene, const hw::Vec3& move) {
  if (!scene.instanced()) throw Error(scene.name + ": the scene places no instances");
  if (!scene.geometry.planes.empty())
    throw Error(scene.name + ": moving instances hold no planes (this scene has " +
                std::to_string(scene.geometry.planes.size()) + ")");
  hw::MotionInstanceSet s;
  s.set = scene.instances;
  for (const hw::Instance& in : s.set.instances) {
    hw::Affine e = in.to_world;
    const hw::Geometry& m = s.set.meshes[in.mesh];
    if (m.spheres.empty() && m.curves.empty())
      for (int a = 0; a < 3; ++a) e.m[a][3] = float(double(e.m[a][3]) + double(move[a]));
    s.end.push_back(e);
  }
  try {
    s.validate();
  } catch (const std::invalid_argument& e) {
    throw Error(scene.name + " moved: " + e.what());
  }
  return s;
}

MotionScene moving_scene(const Scene& scene, const hw::Vec3& move) {
  const hw::Geometry& g = scene.geometry;
  if (!g.planes.empty())
    throw Error(scene.name + ": a moving scene holds triangles, spheres and curve segments only (this one has " +
                std::to_string(g.planes.size()) + " planes)");
  MotionScene s;
  s.camera = scene.camera;
  s.geometry.triangles.reserve(g.triangles.size());
  for (const hw::Triangle& t : g.triangles)
    s.geometry.triangles.push_back(hw::MotionTriangle{{t, hw::Triangle{t.v0 + move, t.v1 + move, t.v2 + move}}});
  for (const hw::Sphere& p : g.spheres)
    s.geometry.spheres.push_back(hw::MotionSphere{{p.center, p.center + move}, {p.radius, p.radius}});
  for (const hw::CurveSegment& c : g.curves)
    s.geometry.curves.push_back(
        hw::MotionCurve{{c, hw::CurveSegment{c.p0 + move, c.r0, c.p1 + move, c.r1, c.flags}}});
  try {
    s.geometry.validate();
  } catch (const std::invalid_argument& e) {
    throw Error(scene.name + " moved: " + e.what());
  }
  return s;
}

MotionRays motion_frame_rays(const Camera& cam, int width, int height, int samples, uint64_t seed) {
  if (samples < 1 || samples > 1024) throw std::invalid_argument("samples per pixel must be in 1..1024");
  const std::vector<hw::Ray> px = primary_rays(cam, width, height);
  MotionRays out;
  out.rays.reserve(px.size() * size_t(samples));
  out.times.reserve(px.size() * size_t(samples));
  for (size_t p = 0; p < px.size(); ++p) {
    hw::Pcg32 rng(hw::splitmix64(seed ^ (uint64_t(p) * 0x9E3779B97F4A7C15ULL)));
    for (int s = 0; s < samples; ++s) {
      out.rays.push_back(px[p]);
      // (s + u) / samples with u in [0, 1): below 1, exact up to float rounding of the quotient.
      out.times.push_back(std::min(1.0f, (float(s) + rng.next_float()) / float(samples)));
    }
  }
  return out;
}

}  // namespace rtu::host
