// The any-hit seam: who decides whether a candidate hit on a non-opaque triangle counts (alpha-tested geometry:
// foliage, fences). A triangle is non-opaque when its image record carries kRecordNonOpaque (hw_format.h; fixed
// and timed devices) or Geometry::non_opaque marks it (float device). When a tracer finds such a triangle hit
// inside the ray's current interval, it hands the candidate to the stage (in hardware: the unit raises an any-hit
// request and the ray waits in its slot while the firmware's any-hit stage looks up the mask and answers,
// fw::AlphaStage in firmware/surface.h); an ignored candidate is as if the triangle had not been hit and traversal
// goes on, an accepted one is a hit like any other (the closest, or the end of an any-hit ray). Without a stage
// attached, non-opaque triangles are opaque, as in DXR and Vulkan without an any-hit shader. Opaque triangles,
// spheres and planes never reach the stage. As box_unit.h: hwmodel defines the seam and never sees an
// implementation. Freestanding (the firmware implements it).
#pragma once

#include <cstdint>

namespace rtu::hw {

class AnyHitStage {
 public:
  // prim: scene primitive index of the triangle; u, v: the candidate's barycentrics, hit point
  // (1-u-v) v0 + u v1 + v v2 (ray.h). Called from every thread a batch is traced on: must not change state
  // that a concurrent call reads, and must answer the same for the same arguments (determinism).
  virtual bool accept(uint32_t prim, float u, float v) const = 0;

 protected:
  ~AnyHitStage() = default;  // not deleted through the seam (the firmware has no operator delete)
};

}  // namespace rtu::hw
