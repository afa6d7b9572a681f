#include "host/oracle/embree_motion.h"

#include <stdexcept>

namespace rtu::oracle {

namespace {

RTCRay embree_ray(const hw::Ray& r, float time) {
  RTCRay ray{};
  ray.org_x = r.origin.x;
  ray.org_y = r.origin.y;
  ray.org_z = r.origin.z;
  ray.tnear = r.tmin;
  ray.dir_x = r.dir.x;
  ray.dir_y = r.dir.y;
  ray.dir_z = r.dir.z;
  ray.time = time;
  ray.tfar = r.tmax;
  ray.mask = 0xFFFFFFFFu;
  return ray;
}

// rtcIntersect1 of r at `time` in `scene`: the ray and hit, geomID RTC_INVALID_GEOMETRY_ID on a miss.
RTCRayHit intersect_at(RTCScene scene, const hw::Ray& r, float time) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh{};
  rh.ray = embree_ray(r, time);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene, &ctx, &rh);
  return rh;
}

// A triangle geometry of n unshared triangles (three vertices each, an index buffer 0, 1, 2, ...) with `steps`
// time steps; tri(k, i) is triangle i at step k.
template <class Tri>
RTCGeometry triangle_geometry(RTCDevice device, unsigned steps, size_t n, Tri&& tri) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  if (steps > 1) rtcSetGeometryTimeStepCount(geom, steps);
  for (unsigned k = 0; k < steps; ++k) {
    auto* v = static_cast<float*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, k, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * n));
    for (size_t i = 0; i < n; ++i) {
      const hw::Triangle& t = tri(k, i);
      const hw::Vec3* p[3] = {&t.v0, &t.v1, &t.v2};
      for (int j = 0; j < 3; ++j)
        for (int a = 0; a < 3; ++a) v[9 * i + size_t(3 * j + a)] = (*p[j])[a];
    }
  }
  auto* idx = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), n));
  for (size_t i = 0; i < 3 * n; ++i) idx[i] = unsigned(i);
  rtcCommitGeometry(geom);
  return geom;
}

}  // namespace

EmbreeMotionScene::EmbreeMotionScene(const hw::MotionGeometry& g, const char* config) {
  m_device = rtcNewDevice(config);
  if (!m_device) throw std::runtime_error("Embree: rtcNewDevice failed");
  m_scene = rtcNewScene(m_device);
  const size_t n = g.triangles.size();
  RTCGeometry geom = triangle_geometry(
      m_device, 2, n, [&](unsigned k, size_t i) -> const hw::Triangle& { return g.triangles[i].key[k]; });
  rtcAttachGeometryByID(m_scene, geom, 0);
  rtcReleaseGeometry(geom);
  if (!g.spheres.empty()) {  // geometry 1: sphere points (center, radius) at two time steps
    RTCGeometry sph = rtcNewGeometry(m_device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    rtcSetGeometryTimeStepCount(sph, 2);
    for (unsigned k = 0; k < 2; ++k) {
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(sph, RTC_BUFFER_TYPE_VERTEX, k, RTC_FORMAT_FLOAT4,
                                                            4 * sizeof(float), g.spheres.size()));
      for (size_t i = 0; i < g.spheres.size(); ++i) {
        for (int a = 0; a < 3; ++a) v[4 * i + size_t(a)] = g.spheres[i].center[k][a];
        v[4 * i + 3] = g.spheres[i].radius[k];
      }
    }
    rtcCommitGeometry(sph);
    rtcAttachGeometryByID(m_scene, sph, 1);
    rtcReleaseGeometry(sph);
  }
  m_triangles = unsigned(n);
  m_round = unsigned(n + g.spheres.size());
  if (!g.curves.empty()) {  // geometry 2: round linear curves, two vertices a segment, at two time steps
    const size_t nc = g.curves.size();
    RTCGeometry cur = rtcNewGeometry(m_device, RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE);
    rtcSetGeometryTimeStepCount(cur, 2);
    for (unsigned k = 0; k < 2; ++k) {
      auto* v = static_cast<float*>(
          rtcSetNewGeometryBuffer(cur, RTC_BUFFER_TYPE_VERTEX, k, RTC_FORMAT_FLOAT4, 4 * sizeof(float), 2 * nc));
      for (size_t i = 0; i < nc; ++i) {
        const hw::CurveSegment& c = g.curves[i].key[k];
        const float pts[8] = {c.p0.x, c.p0.y, c.p0.z, c.r0, c.p1.x, c.p1.y, c.p1.z, c.r1};
        for (int j = 0; j < 8; ++j) v[8 * i + size_t(j)] = pts[j];
      }
    }
    auto* idx = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(cur, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(unsigned), nc));
    for (size_t i = 0; i < nc; ++i) idx[i] = unsigned(2 * i);
    rtcCommitGeometry(cur);
    rtcAttachGeometryByID(m_scene, cur, 2);
    rtcReleaseGeometry(cur);
  }
  rtcSetSceneFlags(m_scene, RTC_SCENE_FLAG_ROBUST);
  rtcCommitScene(m_scene);
}

EmbreeMotionScene::~EmbreeMotionScene() {
  rtcReleaseScene(m_scene);
  rtcReleaseDevice(m_device);
}

hw::Hit EmbreeMotionScene::intersect(const hw::Ray& r, float time) const {
  const RTCRayHit rh = intersect_at(m_scene, r, time);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hw::Hit{};
  if (rh.hit.geomID == 1) return hw::Hit{rh.ray.tfar, m_triangles + rh.hit.primID, 0.0f, 0.0f};
  if (rh.hit.geomID == 2) return hw::Hit{rh.ray.tfar, m_round + rh.hit.primID, rh.hit.u, 0.0f};
  return hw::Hit{rh.ray.tfar, rh.hit.primID, rh.hit.u, rh.hit.v};
}

bool EmbreeMotionScene::occluded(const hw::Ray& r, float time) const {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay ray = embree_ray(r, time);
  rtcOccluded1(m_scene, &ctx, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar to -inf on a hit
}

EmbreeMotionInstances::EmbreeMotionInstances(const hw::MotionInstanceSet& s, const char* config) : m_set(s) {
  m_device = rtcNewDevice(config);
  if (!m_device) throw std::runtime_error("Embree: rtcNewDevice failed");
  for (const hw::Geometry& g : s.set.meshes) {
    if (!g.spheres.empty() || !g.curves.empty())
      throw std::invalid_argument("EmbreeMotionInstances: meshes of triangles only");
    RTCScene mesh = rtcNewScene(m_device);
    RTCGeometry geom =
        triangle_geometry(m_device, 1, g.triangles.size(),
                          [&](unsigned, size_t i) -> const hw::Triangle& { return g.triangles[i]; });
    rtcAttachGeometryByID(mesh, geom, 0);
    rtcReleaseGeometry(geom);
    rtcSetSceneFlags(mesh, RTC_SCENE_FLAG_ROBUST);
    rtcCommitScene(mesh);
    m_meshes.push_back(mesh);
  }
  m_scene = rtcNewScene(m_device);
  for (uint32_t i = 0; i < s.set.instances.size(); ++i) {
    RTCGeometry inst = rtcNewGeometry(m_device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(inst, m_meshes[s.set.instances[i].mesh]);
    rtcSetGeometryTimeStepCount(inst, 2);
    rtcSetGeometryTransform(inst, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, &s.set.instances[i].to_world.m[0][0]);
    rtcSetGeometryTransform(inst, 1, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, &s.end[i].m[0][0]);
    rtcCommitGeometry(inst);
    rtcAttachGeometryByID(m_scene, inst, i);
    rtcReleaseGeometry(inst);
  }
  rtcSetSceneFlags(m_scene, RTC_SCENE_FLAG_ROBUST);
  rtcCommitScene(m_scene);
}

EmbreeMotionInstances::~EmbreeMotionInstances() {
  rtcReleaseScene(m_scene);
  for (RTCScene m : m_meshes) rtcReleaseScene(m);
  rtcReleaseDevice(m_device);
}

hw::Hit EmbreeMotionInstances::intersect(const hw::Ray& r, float time) const {
  const RTCRayHit rh = intersect_at(m_scene, r, time);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hw::Hit{};
  return hw::Hit{rh.ray.tfar, m_set.set.global_prim(rh.hit.instID[0], rh.hit.primID), rh.hit.u, rh.hit.v};
}

}  // namespace rtu::oracle
