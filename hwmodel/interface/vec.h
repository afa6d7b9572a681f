// Shared vector vocabulary of the unit: GLM vectors of float and double (fixed.h adds GLM over Fixed<>).
#pragma once

#include <glm/glm.hpp>

namespace rtu::hw {

using Vec3 = glm::vec3;
using DVec3 = glm::dvec3;

// Component access by runtime axis index (0 = x, 1 = y, 2 = z) without GLM's debug assertion overhead.
inline float axis(const Vec3& v, int a) {
  return a == 0 ? v.x : (a == 1 ? v.y : v.z);
}

}  // namespace rtu::hw
