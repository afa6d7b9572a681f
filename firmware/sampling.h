// Where a camera sample lies: the counter-based generator of the renderer and the sample position of (pixel,
// sample) on the image plane. The ray tracer (camera rays) and the rasterizer (hybrid mode) both read them, so
// the two see the same primary samples. Freestanding.
#pragma once

#include <cstdint>

#include "firmware/render_scene.h"

namespace rtu::fw {

// splitmix64's finalizer: a counter-based generator, so every sample's numbers depend only on what it is.
inline uint64_t mix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

struct Rng {
  uint64_t state;
  float next() {  // uniform in [0, 1), 24 bits
    state = mix(state);
    return float(state >> 40) * (1.0f / 16777216.0f);
  }
};

inline Rng rng_for(uint32_t seed, uint32_t pixel, uint32_t sample, uint32_t bounce) {
  return Rng{mix(mix(mix(uint64_t(seed) << 32 | pixel) ^ sample) ^ (uint64_t(bounce) << 40))};
}

// Offset of a sample inside its pixel, in [0, 1)^2: the center (0.5, 0.5) at 1 spp, jittered otherwise.
struct SampleOffset {
  float jx, jy;
};
inline SampleOffset sample_offset(const RenderJob& job, uint32_t pixel, uint32_t sample) {
  if (job.spp <= 1) return SampleOffset{0.5f, 0.5f};
  Rng rng = rng_for(job.seed, pixel, sample, 0xFFFFu);
  const float jx = rng.next();
  return SampleOffset{jx, rng.next()};
}

// Image-plane coordinates (sx, sy) in [-1, 1] of a sample at pixel (x, y) with offset o: the camera ray's
// direction is forward + sx * right + sy * up (RenderJob).
inline void image_plane(const RenderJob& job, uint32_t x, uint32_t y, SampleOffset o, float& sx, float& sy) {
  sx = 2.0f * (float(x) + o.jx) / float(job.width) - 1.0f;
  sy = 1.0f - 2.0f * (float(y) + o.jy) / float(job.height);
}

}  // namespace rtu::fw
