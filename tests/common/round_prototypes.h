// A test scene of round primitives in prototypes: scenes/instances.json with two spheres and two strands added to
// every prototype mesh in object space, so that each instance (rotated about several axes, uniformly scaled)
// places its own. The flattened geometry and the materials follow the new set.
#pragma once

#include <vector>

#include "host/scene/scene.h"
#include "hwmodel/datapath/instancing.h"

namespace rtu::test {

inline host::Scene round_prototypes_scene() {
  host::Scene s = host::load_scene(RTU_SOURCE_DIR "/scenes/instances.json");
  hw::InstanceSet& set = s.instances;
  for (size_t m = 1; m < set.meshes.size(); ++m) {
    hw::Geometry& g = set.meshes[m];
    const hw::Aabb b = g.bounds();
    const hw::Vec3 c = 0.5f * (b.lo + b.hi), e = b.hi - b.lo;
    for (int k = 0; k < 2; ++k) {
      const float side = k ? 0.45f : -0.45f;
      g.spheres.push_back(hw::Sphere{c + hw::Vec3(side * e.x, 0.3f * e.y, 0.0f), 0.12f * e.y + 0.05f});
      std::vector<hw::Vec3> pts;
      for (int p = 0; p < 5; ++p)
        pts.push_back(c + hw::Vec3(side * e.x * 0.8f, -0.5f * e.y + 0.25f * e.y * float(p), 0.1f * float(p)));
      for (size_t p = 0; p + 1 < pts.size(); ++p)
        g.curves.push_back(hw::CurveSegment{pts[p], 0.05f, pts[p + 1], 0.05f, p == 0 ? hw::kCurveCapStart : 0u});
    }
  }
  set.finish();
  set.validate();
  s.geometry = set.flatten(s.geometry.planes);
  s.prim_material.assign(s.geometry.num_prims(), 0);
  return s;
}

}  // namespace rtu::test
