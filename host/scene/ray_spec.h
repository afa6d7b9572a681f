// Rays named by a spec (rtusim's --rays): a ray file, or rays generated from the scene.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "host/scene/scene.h"
#include "hwmodel/interface/ray.h"

namespace rtu::host {

// The kinds of generated rays a spec may name (for messages and help).
inline constexpr const char* kRaySpecKinds = "primary, primary:N, primary:WxH, incoherent, incoherent:N";

// Rays from a spec: a ray file, or "primary" (the camera's image), "primary:N", "primary:WxH", "incoherent" (as
// many as "primary" has), "incoherent:N" (seeded by `seed`). Throws Error naming --rays for a bad count, a set of
// rays too large for memory, or a spec that is neither a kind above nor an existing file.
std::vector<hw::Ray> rays_from_spec(const std::string& spec, const Scene& scene, uint64_t seed);
// The same for a scene known only by its camera (primary rays) and bounds (incoherent rays).
std::vector<hw::Ray> rays_from_spec(const std::string& spec, const Camera& camera, const hw::Aabb& bounds,
                                    uint64_t seed);

}  // namespace rtu::host
