// Shared by the image tests (test_packed_layout.cpp, test_clusters.cpp): an image of a scene over its BVH, its
// bytes, the message an image's check refuses it with, and random rays through the tests' scenes.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::hw::image_checks {

using fixed_checks::kInf;
using fixed_checks::rand_float;

// The image of g in format f over a BVH of leaves of at most `leaf` primitives.
inline DeviceImage encode(const Geometry& g, const FixedFormat& f, int leaf = 8) {
  BvhBuildParams bp;
  bp.width = f.width;
  bp.max_leaf_size = leaf;
  const Bvh bvh = Bvh::build(g, bp);
  return encode_scene(g, f, &bvh);
}

// The image's bytes, to corrupt.
inline std::vector<uint8_t> bytes_of(const DeviceImage& img) {
  return std::vector<uint8_t>(img.data(), img.data() + img.size());
}

// The message DeviceImage::from_bytes refuses b with; empty when it accepts b.
inline std::string refusal(const std::vector<uint8_t>& b) {
  try {
    (void)DeviceImage::from_bytes(b.data(), b.size());
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// n rays from the cube [-12, 12]^3 in random directions.
inline std::vector<Ray> rays(uint64_t seed, int n) {
  Pcg32 rng(seed);
  std::vector<Ray> out;
  for (int i = 0; i < n; ++i) {
    Ray r;
    for (int a = 0; a < 3; ++a) {
      r.origin[a] = rand_float(rng, -12.0f, 12.0f);
      r.dir[a] = rand_float(rng, -1.0f, 1.0f);
    }
    r.tmin = 0.0f;
    r.tmax = kInf;
    out.push_back(r);
  }
  return out;
}

}  // namespace rtu::hw::image_checks
