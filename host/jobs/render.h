// Rendering through the firmware: the host writes the unit's scene image and the renderer's records into the
// device memory of an in-process device (FirmwareDevice), runs the firmware renderer (firmware/renderer.h) against
// it through the ring, and reads the framebuffer back.
#pragma once

#include <array>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "firmware/renderer.h"
#include "firmware/ring.h"
#include "host/devices/direct_device.h"
#include "host/io/image.h"
#include "host/io/stats_json.h"
#include "host/scene/micromap_bake.h"
#include "host/scene/scene.h"
#include "hwmodel/device/command_processor.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/timing/raster_timing.h"
#include "hwmodel/timing/sort_timing.h"

namespace rtu::host {

struct RenderOptions {
  DeviceOptions device;       // kind (float, fixed, timed), acceleration/BVH options, fixed format, timing
  bool hybrid = false;        // primary visibility by the firmware rasterizer (G-buffer), secondary rays traced
  int threads = 0;            // unit worker threads per TRACE (0 = all cores); the image does not depend on it
  int width = 0, height = 0;  // 0: the scene camera's
  int spp = 1;                // samples per pixel
  int max_depth = 4;          // bounces after the camera ray
  uint32_t seed = 1;          // of the sampling generator
  bool indirect = true;       // diffuse indirect bounces (path tracing)
  bool ao = false;            // ambient occlusion instead of diffuse indirect light
  float ao_distance = 0.0f;   // 0: a quarter of the scene's bounding-box diagonal
  Vec3 background{0.0f};      // radiance of escaping rays (the ambient light of occlusion)
  bool keep_primary = false;  // return every camera sample's primary hit (RenderResult::primary)
  // Fixed and timed devices, one-level scenes with alpha-masked materials: opacity micromaps of this subdivision
  // level (0..10) baked for the non-opaque triangles (host/scene/micromap_bake.h), which the unit reads before it
  // asks the any-hit stage. -1: none. The image does not depend on it.
  int omm_level = -1;
  hw::PipelineTrace* pipeline_trace = nullptr;  // timed device: pipeline spans of a cycle window (or null)
  bool progress = false;  // a progress line on stderr while rendering, when stderr is a terminal (host::Progress)
  // Called at every doorbell the firmware rings; an exception it throws stops the render (the unit reports an
  // error to the firmware, which returns) and render() rethrows it (Python: Ctrl-C).
  std::function<void()> poll;
};

struct RenderResult {
  int width = 0, height = 0;
  std::vector<float> rgb;  // linear radiance, 3 floats per pixel, top row first
  // keep_primary: per camera sample (pixel * spp + sample) its primary hit: the G-buffer texel (hybrid) or the
  // unit's hit (raytrace).
  std::vector<hw::Hit> primary;
  fw::RenderStats fw;  // the firmware's view: rays by type, TRACE packets, what was skipped
  fw::Ring::Counters ring;
  hw::DeviceCounters device;    // the unit's view: packets by opcode, rays and traversal stats by type
  hw::Geometry::Counts counts;  // primitives the unit holds, by kind
  bool uses_bvh = false;
  uint64_t device_memory_bytes = 0, scene_image_bytes = 0;
  float offset_abs = 0.0f, offset_rel = 0.0f;  // the spawn offsets the job used
  double seconds = 0.0;                        // wall time of the firmware run
  uint64_t device_clock = 0;                   // the unit's clock at the end (timed: cycles; else packets)
  bool timed = false;                          // the timed device: the timing statistics below are filled
  hw::TimingStats timing;
  std::array<hw::TimingStats, hw::cmd::kRayTypeCount> timing_by_type{};
  std::map<int, hw::TimingStats> timing_by_bounce;
  hw::SampleStats sampling;  // sampled timing (RenderOptions::device.sample): what was simulated
  std::vector<hw::TimingStats> timing_by_unit;  // a chip's units (TimedEngine::timing_by_unit); empty for one unit
  hw::MemoryTimeline timeline;                  // the memory's bytes over time (TimedEngine::timeline)
  // Hybrid mode on the timed device: the rasterizer's cycles from its cost model (raster_timing.h); the frame's
  // cycles are raster_cycles.cycles + device_clock (the raster passes and the unit's packets do not overlap).
  hw::RasterCycles raster_cycles;
  // Ray sorting on the timed device (the ray_sort key; RenderStats::sort counts the firmware's work): the
  // controller's sorting cycles from their cost model (sort_timing.h), before each TRACE and after its fence,
  // while the unit waits.
  hw::SortCycles sort_cycles;
  uint64_t frame_cycles = 0;  // timed: raster + sort + device clock (raytrace mode without sorting: the clock)
  // Opacity micromaps (RenderOptions::omm_level): what was baked and their bytes (0 maps: none).
  MicromapStats micromaps;
  uint64_t micromap_bytes = 0;
  // What the job saw before it rendered (render_warnings adds the device's): primitives below the fixed-point
  // grid step (grid_check.h), nothing to light the scene.
  std::vector<std::string> warnings;
};

// Throws Error when the device reports an error or the arena cannot hold one path.
RenderResult render(const Scene& scene, const RenderOptions& o);

// The rasterizer's counts as its cost model takes them.
hw::RasterWork raster_work(const fw::RasterStats& s);
// The sorter's counts as its cost model takes them.
hw::SortWork sort_work(const fw::SortStats& s);

// What the user must know about a render's rays: the rays the device rejected at ray setup (a fixed-point device
// cannot represent an origin beyond its format's guard range, out_of_frame; a NaN from a material) were traced as
// misses, so their pixels or light are missing. One line per finding, by ray type and reason; a separate line
// when most traced rays were rejected (the image is mostly background). Empty when every ray was valid.
std::vector<std::string> render_warnings(const RenderResult& r);

// Clamp to [0, 1], sRGB transfer function, 8 bits.
Image to_image(const RenderResult& r);

// A render's statistics: rays by type, commands, what was skipped and why, the unit's counters, and on the timed
// device its timing (in total, by ray type and bounce, the rasterizer's cycles and the frame's).
Json render_json(const RenderResult& r, const RenderOptions& o);

}  // namespace rtu::host
