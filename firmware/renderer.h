// The renderer: a wavefront path tracer that runs on the unit's controller and uses the unit for every ray.
// Per batch of paths and per bounce: build the rays, TRACE them (one packet per ray type), wait on a fence,
// shade; shadow and occlusion rays go out as any-hit TRACEs after each bounce. With kRenderRaySort each TRACE's
// rays are sorted by a key first (ray_sort.h) and the hits put back in order after the fence. Primary rays from a
// pinhole camera (jittered when spp > 1), shadow rays toward every light at diffuse hits, mirror reflection, glass
// with Snell refraction, exact dielectric Fresnel and total internal reflection, diffuse indirect bounces (cosine
// sampled) or ambient occlusion. Random numbers come from a counter-based hash of (seed, pixel, sample, bounce,
// use), so the image does not depend on the batch size. Freestanding: working memory from the arena.
#pragma once

#include <cstdint>

#include "firmware/hal.h"
#include "firmware/raster.h"
#include "firmware/ray_sort.h"
#include "firmware/render_scene.h"
#include "firmware/ring.h"
#include "hwmodel/interface/commands.h"

namespace rtu::fw {

struct RenderStats {
  uint64_t rays[hw::cmd::kRayTypeCount] = {};  // rays submitted, by type (hw::cmd::RayType)
  uint64_t traces = 0;                         // TRACE packets
  uint64_t paths = 0;                          // camera paths (width * height * spp)
  uint64_t batches = 0;                        // path batches
  uint64_t bounces = 0;                        // bounce iterations over all batches
  uint32_t batch_paths = 0;                    // paths per batch (from the arena's size)
  // What the scene does not need, decided from its materials and lights before any ray is built.
  bool need_shadow = false;      // some light and some diffuse surface
  bool need_reflection = false;  // a mirror or glass material
  bool need_refraction = false;  // a glass material
  bool need_diffuse = false;     // indirect light on and a diffuse material
  bool need_occlusion = false;   // ambient occlusion on and a diffuse material
  // Hybrid mode (kRenderHybrid): primary visibility came from the rasterizer, not from TRACE.
  bool hybrid = false;
  uint64_t primary_rasterized = 0;  // camera samples whose primary hit the G-buffer gave: primary rays saved
  RasterStats raster;
  // Ray sorting (kRenderRaySort): rays sorted before their TRACE, and the sorts' work.
  bool sorted = false;
  SortStats sort;
};

// Renders job (a RenderJob at device address job_addr) through the ring; working buffers come from the arena.
// Returns kOk, or the first failure (a device error, no memory for even one path, a timeout).
Status render(Hal& hal, Ring& ring, Arena& arena, uint64_t job_addr, RenderStats& stats);

}  // namespace rtu::fw
