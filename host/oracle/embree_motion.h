// Embree 3's motion blur as the oracle of rtu's moving triangles, spheres and curve segments (hwmodel/scene/
// motion.h): a triangle mesh, sphere points and round linear curves with two time steps
// (rtcSetGeometryTimeStepCount), the ray's time in RTCRay::time; Embree interpolates vertices, centers and radii
// linearly between the steps, as rtu does. Each curve segment is its own Embree segment with both end spheres (no
// neighbours): rtu's segments with kCurveCapStart; a strand's joints may name the neighbouring segment. Hits in
// rtu's numbering (triangles, spheres, curve segments; a sphere's u, v are 0, a curve's u is Embree's curve
// parameter). Tests and benchmarks only.
#pragma once

#include <embree3/rtcore.h>

#include <vector>

#include "hwmodel/datapath/motion_instances.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/scene/motion.h"

namespace rtu::oracle {

class EmbreeMotionScene {
 public:
  explicit EmbreeMotionScene(const hw::MotionGeometry& g, const char* config = "threads=1");
  ~EmbreeMotionScene();
  EmbreeMotionScene(const EmbreeMotionScene&) = delete;
  EmbreeMotionScene& operator=(const EmbreeMotionScene&) = delete;

  hw::Hit intersect(const hw::Ray& r, float time) const;  // closest hit at shutter time `time` (rtcIntersect1)
  bool occluded(const hw::Ray& r, float time) const;      // any hit (rtcOccluded1)

 private:
  RTCDevice m_device = nullptr;
  RTCScene m_scene = nullptr;
  unsigned m_triangles = 0, m_round = 0;  // triangles; triangles and spheres
};

// Instances with two transforms (hwmodel/datapath/motion_instances.h) as Embree 3's: each mesh's triangles a scene
// of their own, each instance an RTC_GEOMETRY_TYPE_INSTANCE with two time steps (rtcSetGeometryTransform at steps
// 0 and 1; Embree interpolates the matrices linearly, as rtu does). Meshes of triangles only. Hits in the
// flattened numbering (InstanceSet::global_prim).
class EmbreeMotionInstances {
 public:
  explicit EmbreeMotionInstances(const hw::MotionInstanceSet& s, const char* config = "threads=1");
  ~EmbreeMotionInstances();
  EmbreeMotionInstances(const EmbreeMotionInstances&) = delete;
  EmbreeMotionInstances& operator=(const EmbreeMotionInstances&) = delete;

  hw::Hit intersect(const hw::Ray& r, float time) const;

 private:
  const hw::MotionInstanceSet& m_set;
  RTCDevice m_device = nullptr;
  RTCScene m_scene = nullptr;
  std::vector<RTCScene> m_meshes;
};

}  // namespace rtu::oracle
