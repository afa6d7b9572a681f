#include "host/scene/ray_gen.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "host/io/error.h"
#include "host/io/limits.h"
#include "hwmodel/numeric/rng.h"

namespace rtu::host {

namespace {

struct CameraBasis {
  hw::DVec3 origin, forward, right, up;
  double tan_half_y, aspect;
};

CameraBasis basis(const Camera& cam, int width, int height) {
  CameraBasis b;
  b.origin = hw::DVec3(cam.position);
  b.forward = glm::normalize(hw::DVec3(cam.look_at) - b.origin);
  b.right = glm::normalize(glm::cross(b.forward, hw::DVec3(cam.up)));
  b.up = glm::cross(b.right, b.forward);
  b.tan_half_y = std::tan(double(cam.fov_y_deg) * 3.141592653589793 / 360.0);
  b.aspect = double(width) / double(height);
  return b;
}

hw::Ray pixel_ray(const CameraBasis& b, double px, double py, int width, int height) {
  const double sx = (2.0 * px / width - 1.0) * b.tan_half_y * b.aspect;
  const double sy = (1.0 - 2.0 * py / height) * b.tan_half_y;
  const hw::DVec3 d = glm::normalize(b.forward + sx * b.right + sy * b.up);
  return hw::Ray{hw::Vec3(b.origin), 0.0f, hw::Vec3(d), std::numeric_limits<float>::infinity()};
}

// The rays' own memory against the budget, before it is reserved (callers that trace them check their hits too).
void check_rays(uint64_t count, const char* kind) {
  check_memory(std::to_string(count) + " " + kind + " rays", count * sizeof(hw::Ray));
}

}  // namespace

std::vector<hw::Ray> primary_rays(const Camera& cam, int width, int height) {
  if (width <= 0 || height <= 0) throw Error("primary rays: width and height must be positive");
  check_rays(uint64_t(width) * uint64_t(height), "primary");
  const CameraBasis b = basis(cam, width, height);
  std::vector<hw::Ray> rays;
  rays.reserve(size_t(width) * size_t(height));
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) rays.push_back(pixel_ray(b, x + 0.5, y + 0.5, width, height));
  return rays;
}

std::vector<hw::Ray> primary_rays(const Camera& cam, uint64_t count) {
  if (count == 0) return {};
  const double aspect = double(cam.width) / double(cam.height);
  const uint64_t h = std::max<uint64_t>(1, uint64_t(std::llround(std::sqrt(double(count) / aspect))));
  const uint64_t w = (count + h - 1) / h;
  if (w > uint64_t(std::numeric_limits<int>::max()) || h > uint64_t(std::numeric_limits<int>::max()))
    throw Error("primary rays: count too large");
  check_rays(count, "primary");
  const CameraBasis b = basis(cam, int(w), int(h));
  std::vector<hw::Ray> rays;
  rays.reserve(count);
  for (uint64_t i = 0; i < count; ++i)
    rays.push_back(pixel_ray(b, double(i % w) + 0.5, double(i / w) + 0.5, int(w), int(h)));
  return rays;
}

std::vector<hw::Ray> incoherent_rays(const hw::Aabb& bounds, uint64_t count, uint64_t seed) {
  if (bounds.empty()) throw Error("incoherent rays: the scene has no bounded primitives");
  check_rays(count, "incoherent");
  hw::Pcg32 rng(seed);
  std::vector<hw::Ray> rays;
  rays.reserve(count);
  const hw::Vec3 ext = bounds.extent();
  for (uint64_t i = 0; i < count; ++i) {
    hw::Vec3 o;
    for (int a = 0; a < 3; ++a) o[a] = bounds.lo[a] + rng.next_float() * ext[a];
    // Uniform direction: z uniform in [-1, 1], azimuth uniform (Archimedes).
    const double z = 1.0 - 2.0 * double(rng.next_float());
    const double phi = 2.0 * 3.141592653589793 * double(rng.next_float());
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    const hw::Vec3 d(float(s * std::cos(phi)), float(s * std::sin(phi)), float(z));
    rays.push_back(hw::Ray{glm::min(o, bounds.hi), 0.0f, d, std::numeric_limits<float>::infinity()});
  }
  return rays;
}

}  // namespace rtu::host
