#include "host/scene/ray_spec.h"

#include <exception>
#include <filesystem>
#include <string>
#include <system_error>

#include "host/io/error.h"
#include "host/io/limits.h"
#include "host/io/ray_io.h"
#include "host/scene/ray_gen.h"

namespace rtu::host {

std::vector<hw::Ray> rays_from_spec(const std::string& spec, const Scene& scene, uint64_t seed) {
  return rays_from_spec(spec, scene.camera, scene.geometry.bounds(), seed);
}

std::vector<hw::Ray> rays_from_spec(const std::string& spec, const Camera& camera, const hw::Aabb& bounds,
                                    uint64_t seed) {
  auto number = [&](const std::string& text) {
    size_t used = 0;
    unsigned long long v = 0;
    try {
      v = std::stoull(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != text.size() || v == 0 || text[0] == '-')
      throw Error("--rays " + spec + ": bad count '" + text + "'");
    return uint64_t(v);
  };
  auto fits = [&](uint64_t n) {  // a ray and its hit per ray
    check_memory("--rays " + spec + ": " + std::to_string(n) + " rays", n * (sizeof(hw::Ray) + sizeof(hw::Hit)));
    return n;
  };
  if (spec == "primary") {
    fits(uint64_t(camera.width) * uint64_t(camera.height));
    return primary_rays(camera, camera.width, camera.height);
  }
  if (spec.rfind("primary:", 0) == 0) {
    const std::string arg = spec.substr(8);
    const size_t x = arg.find('x');
    if (x == std::string::npos) return primary_rays(camera, fits(number(arg)));
    const uint64_t w = number(arg.substr(0, x)), h = number(arg.substr(x + 1));
    if (w > 65536 || h > 65536) throw Error("--rays " + spec + ": image larger than 65536 x 65536");
    fits(w * h);
    return primary_rays(camera, int(w), int(h));
  }
  // "incoherent" alone: as many rays as "primary" has, so the two kinds compare at one size.
  if (spec == "incoherent") {
    const uint64_t n = uint64_t(camera.width) * uint64_t(camera.height);
    return incoherent_rays(bounds, fits(n), seed);
  }
  if (spec.rfind("incoherent:", 0) == 0) return incoherent_rays(bounds, fits(number(spec.substr(11))), seed);
  // Anything else names a ray file; one that does not exist is most likely a misspelled kind.
  std::error_code ec;
  if (!std::filesystem::exists(spec, ec))
    throw Error("--rays " + spec + ": no such ray file, and not a ray spec (" + kRaySpecKinds + ")");
  return read_rays(spec);
}

}  // namespace rtu::host
