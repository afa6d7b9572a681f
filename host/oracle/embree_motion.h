// Embree 3's motion blur as the oracle of rtu's moving triangles and spheres (hwmodel/scene/motion.h): a triangle
// mesh and sphere points with two time steps (rtcSetGeometryTimeStepCount), the ray's time in RTCRay::time; Embree
// interpolates vertices, centers and radii linearly between the steps, as rtu does. Hits in rtu's numbering
// (triangles, then spheres; a sphere's u, v are 0). Tests and benchmarks only.
#pragma once

#include <embree3/rtcore.h>

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
  unsigned m_triangles = 0;
};

}  // namespace rtu::oracle
