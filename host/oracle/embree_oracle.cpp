#include "host/oracle/embree_oracle.h"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <vector>

namespace rtu::oracle {

namespace {

// The context of a traced ray, for the filter that asks the any-hit stage (EmbreeScene::set_any_hit).
struct FilterContext {
  RTCIntersectContext ctx;  // first: Embree passes &ctx to the filter
  const EmbreeScene* scene;
};

// Attaches g's triangles and spheres to `scene`; their geometry ids in tri_geom and sphere_geom.
void attach(RTCDevice device, RTCScene scene, const hw::Geometry& g, unsigned& tri_geom, unsigned& sphere_geom) {
  if (!g.triangles.empty()) {
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
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
    tri_geom = rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
  }
  if (!g.spheres.empty()) {
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                                          4 * sizeof(float), g.spheres.size()));
    for (size_t i = 0; i < g.spheres.size(); ++i) {
      v[4 * i + 0] = g.spheres[i].center.x;
      v[4 * i + 1] = g.spheres[i].center.y;
      v[4 * i + 2] = g.spheres[i].center.z;
      v[4 * i + 3] = g.spheres[i].radius;
    }
    rtcCommitGeometry(geom);
    sphere_geom = rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
  }
}

// Attaches g's curve segments as one round linear curve geometry (RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE) and
// returns its id. Segments that continue the one before (no kCurveCapStart, its start the other's end) share that
// vertex, so Embree finds a segment's neighbours where its neighbour flags say: left when it continues the one
// before, right when the next continues it. Embree then leaves out the parts of a segment inside its neighbours'
// (the same union of spheres), and caps only a strand's ends.
unsigned attach_curves(RTCDevice device, RTCScene scene, const hw::Geometry& g) {
  const std::vector<hw::CurveSegment>& c = g.curves;
  std::vector<float> verts;
  std::vector<unsigned> index(c.size());
  std::vector<unsigned char> flags(c.size(), 0);
  auto continues = [&](size_t i) {  // segment i starts where segment i - 1 ends
    return i > 0 && !(c[i].flags & hw::kCurveCapStart) && c[i].p0 == c[i - 1].p1 && c[i].r0 == c[i - 1].r1;
  };
  for (size_t i = 0; i < c.size(); ++i) {
    if (continues(i)) {
      flags[i] |= RTC_CURVE_FLAG_NEIGHBOR_LEFT;
      flags[i - 1] |= RTC_CURVE_FLAG_NEIGHBOR_RIGHT;
    } else {
      verts.insert(verts.end(), {c[i].p0.x, c[i].p0.y, c[i].p0.z, c[i].r0});
    }
    index[i] = unsigned(verts.size() / 4 - 1);
    verts.insert(verts.end(), {c[i].p1.x, c[i].p1.y, c[i].p1.z, c[i].r1});
  }
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                                        4 * sizeof(float), verts.size() / 4));
  std::copy(verts.begin(), verts.end(), v);
  auto* idx = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, sizeof(unsigned), c.size()));
  std::copy(index.begin(), index.end(), idx);
  auto* fl = static_cast<unsigned char*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_FLAGS, 0, RTC_FORMAT_UCHAR, sizeof(unsigned char), c.size()));
  std::copy(flags.begin(), flags.end(), fl);
  rtcCommitGeometry(geom);
  const unsigned id = rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  return id;
}

}  // namespace

EmbreeScene::EmbreeScene(const hw::Geometry& g, const char* config, RTCMemoryMonitorFunction monitor) : m_geom(g) {
  m_device = rtcNewDevice(config);
  if (!m_device) throw std::runtime_error("embree: rtcNewDevice failed");
  if (monitor) rtcSetDeviceMemoryMonitorFunction(m_device, monitor, nullptr);
  m_scene = rtcNewScene(m_device);
  if (!g.non_opaque.empty()) rtcSetSceneFlags(m_scene, RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
  attach(m_device, m_scene, g, m_tri_geom, m_sphere_geom);
  if (!g.curves.empty()) m_curve_geom = attach_curves(m_device, m_scene, g);
  rtcCommitScene(m_scene);
  if (rtcGetDeviceError(m_device) != RTC_ERROR_NONE) throw std::runtime_error("embree: scene build failed");
}

EmbreeScene::EmbreeScene(const hw::InstanceSet& set, const hw::Geometry& flat, const char* config)
    : m_geom(flat), m_set(&set) {
  m_device = rtcNewDevice(config);
  if (!m_device) throw std::runtime_error("embree: rtcNewDevice failed");
  m_scene = rtcNewScene(m_device);
  // The context filter of set_any_hit only where a triangle is non-opaque: elsewhere Embree runs as before.
  const RTCSceneFlags flags =
      flat.non_opaque.empty() ? RTC_SCENE_FLAG_NONE : RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION;
  rtcSetSceneFlags(m_scene, flags);
  for (const hw::Geometry& g : set.meshes) {
    Mesh m;
    m.scene = rtcNewScene(m_device);
    rtcSetSceneFlags(m.scene, flags);
    attach(m_device, m.scene, g, m.tri_geom, m.sphere_geom);
    if (!g.curves.empty()) m.curve_geom = attach_curves(m_device, m.scene, g);
    rtcCommitScene(m.scene);
    m_meshes.push_back(m);
  }
  for (size_t i = 0; i < set.instances.size(); ++i) {
    const hw::Instance& in = set.instances[i];
    if (set.meshes[in.mesh].num_bounded() == 0) continue;
    RTCGeometry geom = rtcNewGeometry(m_device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(geom, m_meshes[in.mesh].scene);
    rtcSetGeometryTransform(geom, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, &in.to_world.m[0][0]);
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(m_scene, geom, unsigned(i));  // the instance id is the instance index
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(m_scene);
  if (rtcGetDeviceError(m_device) != RTC_ERROR_NONE) throw std::runtime_error("embree: scene build failed");
}

EmbreeScene::~EmbreeScene() {
  rtcReleaseScene(m_scene);
  for (const Mesh& m : m_meshes) rtcReleaseScene(m.scene);
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

// The primitive index (flattened numbering) of an Embree hit; `triangle`: whether it is a triangle.
uint32_t EmbreeScene::prim_of(unsigned geom, unsigned prim, unsigned inst, bool& triangle) const {
  if (m_set) {
    const Mesh& m = m_meshes[m_set->instances[inst].mesh];
    const uint32_t ntri = uint32_t(m_set->meshes[m_set->instances[inst].mesh].triangles.size());
    const uint32_t nsph = uint32_t(m_set->meshes[m_set->instances[inst].mesh].spheres.size());
    triangle = geom == m.tri_geom;
    if (geom == m.curve_geom) return m_set->global_prim(inst, ntri + nsph + prim);
    return m_set->global_prim(inst, triangle ? prim : ntri + prim);
  }
  triangle = geom == m_tri_geom;
  if (geom == m_curve_geom) return m_geom.curve_prim(prim);
  return triangle ? prim : m_geom.sphere_prim(prim);
}

void EmbreeScene::filter(const RTCFilterFunctionNArguments* args) {
  const EmbreeScene& self = *reinterpret_cast<const FilterContext*>(args->context)->scene;
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    bool triangle = false;
    const uint32_t prim =
        self.prim_of(RTCHitN_geomID(args->hit, args->N, i), RTCHitN_primID(args->hit, args->N, i),
                     RTCHitN_instID(args->hit, args->N, i, 0), triangle);
    if (triangle && !self.m_geom.opaque(prim) &&
        !self.m_any_hit->accept(prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i)))
      args->valid[i] = 0;
  }
}

hw::Hit EmbreeScene::intersect(const hw::Ray& r) const {
  hw::Hit h;
  float tmax = r.tmax;
  if (plane_hit(r, tmax, h)) tmax = h.t;
  FilterContext fc{{}, this};
  RTCIntersectContext& ctx = fc.ctx;
  rtcInitIntersectContext(&ctx);
  if (m_any_hit) ctx.filter = &EmbreeScene::filter;
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
  bool tri = false;
  const uint32_t prim = prim_of(rh.hit.geomID, rh.hit.primID, rh.hit.instID[0], tri);
  // Triangles: barycentrics; curve segments: u along the segment (ours is the s of the sphere the hit is on).
  const bool curve = m_set ? rh.hit.geomID == m_meshes[m_set->instances[rh.hit.instID[0]].mesh].curve_geom
                           : rh.hit.geomID == m_curve_geom;
  return hw::Hit{rh.ray.tfar, prim, tri || curve ? rh.hit.u : 0.0f, tri ? rh.hit.v : 0.0f};
}

bool EmbreeScene::occluded(const hw::Ray& r) const {
  hw::Hit h;
  if (plane_hit(r, r.tmax, h)) return true;
  FilterContext fc{{}, this};
  RTCIntersectContext& ctx = fc.ctx;
  rtcInitIntersectContext(&ctx);
  if (m_any_hit) ctx.filter = &EmbreeScene::filter;
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
