// Embree 3 as an independent oracle and benchmark peer: triangles as an Embree triangle mesh, spheres as Embree
// sphere points, planes tested in double precision beside Embree (Embree has no unbounded primitive). Returns
// hits in the project's primitive numbering. Used by tests and benchmarks only.
#pragma once

#include <embree3/rtcore.h>

#include <vector>

#include "hwmodel/datapath/instancing.h"
#include "hwmodel/interface/any_hit.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::oracle {

class EmbreeScene {
 public:
  // `config` is Embree's device configuration, e.g. "threads=1"; `monitor`, if given, sees every allocation.
  explicit EmbreeScene(const hw::Geometry& g, const char* config = "threads=1",
                       RTCMemoryMonitorFunction monitor = nullptr);
  // Two levels: one Embree scene per mesh, an Embree instance per instance (its transform as given), planes of
  // `flat` beside them; hits in the flattened numbering (hw::InstanceSet::global_prim). Keeps references to both.
  EmbreeScene(const hw::InstanceSet& set, const hw::Geometry& flat, const char* config = "threads=1");
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  hw::Hit intersect(const hw::Ray& r) const;  // closest hit (rtcIntersect1)
  bool occluded(const hw::Ray& r) const;      // any hit (rtcOccluded1)

  // The any-hit stage for the geometry's non-opaque triangles (hw::Geometry::non_opaque of the flattened
  // scene), asked by an Embree context filter with the hit's primitive and barycentrics, as the project's tracers
  // ask it; null (the default): every triangle opaque. Not owned. Mark the triangles (host::mark_non_opaque)
  // before constructing: the filter is only enabled on a scene that has non-opaque triangles then.
  void set_any_hit(const hw::AnyHitStage* stage) { m_any_hit = stage; }

 private:
  bool plane_hit(const hw::Ray& r, float tmax, hw::Hit& h) const;
  uint32_t prim_of(unsigned geom, unsigned prim, unsigned inst, bool& triangle) const;
  static void filter(const RTCFilterFunctionNArguments* args);

  struct Mesh {
    RTCScene scene = nullptr;
    unsigned tri_geom = RTC_INVALID_GEOMETRY_ID, sphere_geom = RTC_INVALID_GEOMETRY_ID,
             curve_geom = RTC_INVALID_GEOMETRY_ID;
  };
  const hw::Geometry& m_geom;
  const hw::InstanceSet* m_set = nullptr;
  std::vector<Mesh> m_meshes;
  RTCDevice m_device = nullptr;
  RTCScene m_scene = nullptr;
  unsigned m_tri_geom = RTC_INVALID_GEOMETRY_ID, m_sphere_geom = RTC_INVALID_GEOMETRY_ID;
  unsigned m_curve_geom = RTC_INVALID_GEOMETRY_ID;  // round linear curves (attach_curves)
  const hw::AnyHitStage* m_any_hit = nullptr;
};

}  // namespace rtu::oracle
