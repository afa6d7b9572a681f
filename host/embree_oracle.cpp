#include "host/embree_oracle.h"

#include <limits>
#include <stdexcept>

namespace rtu::oracle {

EmbreeScene::EmbreeScene(const hw::Geometry& g, const char* config, RTCMemoryMonitorFunction monitor) : m_geom(g) {
  m_device = rtcNewDevice(config);
  if (!m_device) throw std::runtime_error("embree: rtcNewDevice failed");
  if (monitor) rtcSetDeviceMemoryMonitorFunction(m_device, monitor, nullptr);
  m_scene = rtcNewScene(m_device);
  if (!g.triangles.empty()) {
    RTCGeometry geom = rtcNewGeometry(m_device, RTC_GEOMETRY_TYPE_TRIANGLE);
    const size_t n = g.triangles.size();
    auto* v = static_cast<float*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * n));
    auto* idx = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), n));
    for (size_t i = 0; i < n; ++i) {
      const hw::Triangle& t = g.triangles[i];
      const hw::Vec3* vs[3] = {&t.v0, &t.v1, &t.v2};
      for (int k = 0; k < 3; ++k) {
        for (int a = 0; a < 3; ++a) v[9 * i + 3 * size_t(k) + size_t(a)] = (*vs[k])[a];
        idx[3 * i + size_t(k)] = unsigned(3 * i + size_t(k));
      }
    }
    rtcCommitGeometry(geom);
    m_tri_geom = rtcAttachGeometry(m_scene, geom);
    rtcReleaseGeometry(geom);
  }
  if (!g.spheres.empty()) {
    RTCGeometry geom = rtcNewGeometry(m_device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                                          4 * sizeof(float), g.spheres.size()));
    for (size_t i = 0; i < g.spheres.size(); ++i) {
      v[4 * i + 0] = g.spheres[i].center.x;
      v[4 * i + 1] = g.spheres[i].center.y;
      v[4 * i + 2] = g.spheres[i].center.z;
      v[4 * i + 3] = g.spheres[i].radius;
    }
    rtcCommitGeometry(geom);
    m_sphere_geom = rtcAttachGeometry(m_scene, geom);
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(m_scene);
  if (rtcGetDeviceError(m_device) != RTC_ERROR_NONE) throw std::runtime_error("embree: scene build failed");
}

EmbreeScene::~EmbreeScene() {
  rtcReleaseScene(m_scene);
  rtcReleaseDevice(m_device);
}

bool EmbreeScene::plane_hit(const hw::Ray& r, float tmax, hw::Hit& h) const {
  bool any = false;
  for (size_t i = 0; i < m_geom.planes.size(); ++i) {
    const hw::Plane& p = m_geom.planes[i];
    const double dn = glm::dot(hw::DVec3(r.dir), hw::DVec3(p.normal));
    if (dn == 0.0) continue;
    const float t = float((double(p.offset) - glm::dot(hw::DVec3(r.origin), hw::DVec3(p.normal))) / dn);
    if (t >= r.tmin && t <= tmax) {
      tmax = t;
      h = hw::Hit{t, m_geom.plane_prim(uint32_t(i)), 0.0f, 0.0f};
      any = true;
    }
  }
  return any;
}

hw::Hit EmbreeScene::intersect(const hw::Ray& r) const {
  hw::Hit h;
  float tmax = r.tmax;
  if (plane_hit(r, tmax, h)) tmax = h.t;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRayHit rh{};
  rh.ray.org_x = r.origin.x;
  rh.ray.org_y = r.origin.y;
  rh.ray.org_z = r.origin.z;
  rh.ray.tnear = r.tmin;
  rh.ray.dir_x = r.dir.x;
  rh.ray.dir_y = r.dir.y;
  rh.ray.dir_z = r.dir.z;
  rh.ray.tfar = tmax;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(m_scene, &ctx, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return h;
  if (rh.hit.geomID == m_tri_geom) return hw::Hit{rh.ray.tfar, rh.hit.primID, rh.hit.u, rh.hit.v};
  return hw::Hit{rh.ray.tfar, m_geom.sphere_prim(rh.hit.primID), 0.0f, 0.0f};
}

bool EmbreeScene::occluded(const hw::Ray& r) const {
  hw::Hit h;
  if (plane_hit(r, r.tmax, h)) return true;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  RTCRay ray{};
  ray.org_x = r.origin.x;
  ray.org_y = r.origin.y;
  ray.org_z = r.origin.z;
  ray.tnear = r.tmin;
  ray.dir_x = r.dir.x;
  ray.dir_y = r.dir.y;
  ray.dir_z = r.dir.z;
  ray.tfar = r.tmax;
  ray.mask = 0xFFFFFFFFu;
  rtcOccluded1(m_scene, &ctx, &ray);
  return ray.tfar < 0.0f;  // Embree sets tfar to -inf on occlusion
}

}  // namespace rtu::oracle
