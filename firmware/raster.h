// The rasterizer of hybrid mode: primary visibility of triangles, spheres, curves and planes into a G-buffer, at
// the same sample positions as the ray tracer's camera rays (firmware/sampling.h), so that its texels can stand
// in for the primary hits.
//
// - Triangles: vertices to view space (double), clipped in homogeneous view space (w = view z) against the near
//   plane z = RenderJob::raster_near and a guard band of kGuardPixels around the image (Sutherland-Hodgman; the
//   point where an edge crosses a plane is computed from its endpoints in a canonical order, so the two triangles
//   of a shared edge clip it identically), fanned, projected and snapped to 1/2^kSubpixelBits pixel. Coverage by
//   integer edge functions at the snapped sample position with the top-left fill rule (y down: an edge whose
//   inward normal points right, or straight down, owns the samples on it), so a sample on an edge shared by two
//   triangles goes to exactly one of them. Both faces are drawn (the ray tracer has no back-face culling).
//   Barycentrics are perspective-correct (lambda_i / z_i interpolated across the screen); depth is the
//   triangle's plane met by the sample's camera ray (exact up to float rounding, not interpolated between
//   snapped vertices, so that the hit point lies on the surface as the spawn offsets of secondary rays expect).
// - Spheres: a bounding rectangle of the projected sphere (the projection of its view-space bounding box's
//   corners, or the whole band when the sphere reaches the near plane), then per sample the camera ray against
//   the sphere, the float reference's stable quadratic (an impostor, as GPUs draw spheres).
// - Curve segments (round linear curves): a bounding rectangle of the view-space box of the segment's end spheres
//   (as a sphere's), then per sample the camera ray against the segment, the float reference's swept-sphere test
//   in double (intersect_swept_sphere), u the hit's position along the segment.
// - Planes: a full-screen pass, per sample the camera ray against the plane.
// Depth: the distance along the normalized camera ray (t), which orders a pixel's fragments as view z does; a
// fragment replaces the texel when it is strictly nearer, so a tie keeps the lower primitive index.
// Images up to kMaxRasterSide pixels a side (the renderer refuses larger ones in hybrid mode).
// Freestanding: no heap; the G-buffer is the renderer's primary hit buffer.
#pragma once

#include <cstdint>

#include "firmware/render_scene.h"
#include "firmware/sampling.h"
#include "hwmodel/interface/any_hit.h"
#include "hwmodel/interface/ray.h"

namespace rtu::fw {

// Snapped vertex and sample positions: 1/4096 pixel. Direct3D asks for at least 8 bits; at 8 the snapping (up
// to 1/512 pixel) moves edges enough to give 0.11% of the samples of a mesh with 3 triangles per pixel
// (Suzanne at 320x240) another primitive than the ray tracer's, at 12 bits 0.0065%.
inline constexpr int kSubpixelBits = 12;
inline constexpr double kGuardPixels = 4096.0;  // guard band around the image (clip beyond it)
// Largest image side: with the guard band, snapped coordinates stay below (16384 + 4096) * 2^12 < 2^27, so the
// edge coefficients are below 2^28, each product below 2^55 and an edge function (three terms) below 2^57.
inline constexpr uint32_t kMaxRasterSide = 16384;

// What the rasterizer did, the inputs of its cost model (hwmodel/timing/raster_timing.h).
struct RasterStats {
  uint64_t passes = 0;                // raster passes (one per batch of samples)
  uint64_t prims_read = 0;            // primitive records read (each primitive once per pass)
  uint64_t triangles_culled = 0;      // outside the view, behind the near plane or outside the pass's rows
  uint64_t triangles_clipped = 0;     // cut by the near plane or the guard band
  uint64_t triangles_degenerate = 0;  // zero area after snapping (no sample can be covered)
  uint64_t setups = 0;          // set up: triangles (each piece of a clipped one), sphere squares, plane passes
  uint64_t samples_tested = 0;  // coverage tests (edge functions, or a ray-sphere / ray-plane test)
  uint64_t fragments = 0;       // covered samples (each a depth test)
  uint64_t depth_writes = 0;    // fragments nearer than the texel (depth and G-buffer written)
  uint64_t clears = 0;          // texels cleared at the start of a pass
};

// Rasterizes the primary visibility of paths [first, first + n) (path k is sample k % spp of pixel k / spp)
// into gbuf[0, n): texel k - first is the nearest primitive at that sample as a hit record: t along the
// normalized camera ray, the primitive index, u, v (triangle barycentrics, p = (1-u-v) v0 + u v1 + v v2; 0, 0
// for spheres and planes, whose normal follows from the hit point), or a miss (t = +inf, prim = kMissPrim).
// offsets[k - first] is the sample's offset in its pixel (null at 1 spp: pixel centers). Draws nothing on an
// image wider or taller than kMaxRasterSide; primitives with NaN or infinite coordinates (records the host
// does not write) draw nothing. With an any-hit stage (alpha-tested materials), fragments it ignores are not
// drawn.
void rasterize(const RenderJob& job, const SurfaceRecord* surfaces, const SampleOffset* offsets, uint64_t first,
               uint32_t n, hw::Hit* gbuf, RasterStats& stats, const hw::AnyHitStage* stage = nullptr);

}  // namespace rtu::fw
