// Ray sets for files and tests: the scene camera's primary rays, and incoherent rays (random origins inside the
// bounds, random directions). Deterministic for a given seed on every platform. Each generator refuses, with
// the budget's Error (limits.h), a count whose rays would not fit the memory limit, before reserving them.
#pragma once

#include <cstdint>
#include <vector>

#include "host/scene/scene.h"
#include "hwmodel/interface/ray.h"

namespace rtu::host {

// One ray through each pixel center of a width x height image, scanline order (row 0 at the top); unit-length
// directions, so t is a distance; tmin 0, tmax +inf.
std::vector<hw::Ray> primary_rays(const Camera& cam, int width, int height);

// `count` primary rays: a grid with the camera's aspect ratio, h = round(sqrt(count / aspect)) rows and
// w = ceil(count / h) columns, the first `count` pixels in scanline order.
std::vector<hw::Ray> primary_rays(const Camera& cam, uint64_t count);

// `count` rays with origins uniform in `bounds` and directions uniform on the unit sphere (PCG32 from `seed`).
std::vector<hw::Ray> incoherent_rays(const hw::Aabb& bounds, uint64_t count, uint64_t seed);

}  // namespace rtu::host
