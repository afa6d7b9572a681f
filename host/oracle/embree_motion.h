// Embree 3's motion blur as the oracle of rtu's moving triangles (hwmodel/scene/motion.h): one triangle mesh with
// two time steps (rtcSetGeometryTimeStepCount), the ray's time in RTCRay::time; Embree interpolates the vertices
// linearly between the steps, as rtu does. Tests and benchmarks only.
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
};

}  // namespace rtu::oracle
