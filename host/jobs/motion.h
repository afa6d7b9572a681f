// The motion blur job behind `rtusim motion` (docs/guide/motion-blur.md): the built-in moving scene's frame, each
// pixel sampled at stratified shutter times, rendered on the float reference and the fixed unit (images, their
// difference, hit agreement), and timed on three units (hwmodel/timing/motion_timing.h): the scene frozen at
// mid-shutter on a static unit, and the moving scene on the time-aware and on the time-oblivious unit, with the
// ratios to the static frame that the field's measurements compare (Ampere against Turing).
#pragma once

#include <cstdint>
#include <string>

#include "host/io/image.h"
#include "host/io/stats_json.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/motion_tracer.h"
#include "hwmodel/timing/motion_timing.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

struct MotionJobOptions {
  int width = 320, height = 240;
  int samples = 4;            // shutter times per pixel
  int level = 4;              // the balls' subdivision (builtin_motion_scene)
  float motion_scale = 1.0f;  // the balls' moves scaled (builtin_motion_scene)
  // A scene to set in motion instead (load_scene's spec; empty: the built-in one): every triangle moved by `move`
  // between the key frames (moving_scene), seen by the scene's camera.
  std::string scene;
  // The built-in moving instances (builtin_motion_instances: the balls as instances of one mesh, each placed by
  // two transforms) instead of the built-in moving scene. A scene with instances is set in motion as instances
  // (moving_instances: each instance's transform moved by `move`) whatever this says.
  bool instances = false;
  const Scene* loaded = nullptr;  // or a scene already loaded (the Python module's); not owned
  hw::Vec3 move{0.0f};
  uint64_t seed = 1;
  hw::FixedFormat format;  // the default format
  hw::MotionFormat motion;
  hw::TimingConfig timing;  // the default configuration
  int threads = 0;          // float and fixed frames' host threads (0: all); hits do not depend on it
  // Rays of the user's with a shutter time each (read_shutter_times), traced instead of the camera's frame: no
  // images; the hits of the fixed unit in MotionJobResult::hits. Empty: the frame.
  std::vector<hw::Ray> rays;
  std::vector<float> times;
  // Or generated rays (ray_spec.h's kinds: primary..., incoherent...) of the moving scene, its camera's or through
  // its bounds over both key frames (seeded by `seed`), at shutter times time_spec (read_shutter_times).
  std::string ray_spec, time_spec;
  bool user_rays() const { return !rays.empty() || !ray_spec.empty(); }
};

struct MotionDesign {
  hw::MotionUnit unit = hw::MotionUnit::kStatic;
  uint64_t cycles = 0;
  double ratio = 1.0;  // cycles / the static frame's
  hw::TimingStats timing;
  hw::TraversalStats traversal;
  uint64_t node_bytes = 0, image_bytes = 0;
  double interp_mm2 = 0.0, interp_pj = 0.0;  // the interpolators' area (all units) and energy over the frame
};

struct MotionJobResult {
  uint64_t triangles = 0, spheres = 0, curves = 0, moving = 0, rays = 0;  // moving: key frames that differ
  uint64_t instances = 0, moving_instances = 0;  // a scene of instances: instances, those with two transforms
  uint64_t hits_agree = 0;                       // rays on which float and fixed agree on hit or miss
  uint64_t both_hit = 0;                         // rays that hit on both
  uint64_t same_prim = 0;                        // of those, the same triangle
  Image float_image, fixed_image;                // the frame's (empty with the user's rays)
  std::vector<hw::Hit> hits;  // the user's rays: the fixed unit's hits (the timed units' are the same)
  MotionDesign designs[3];    // static, time-aware, time-oblivious
};

// Shutter times of n rays from a file: float32 a ray (any name but .csv), or CSV with a header "time" and a time a
// line; or "uniform" (uniform in [0, 1] from seed) or a number in [0, 1] (every ray at that time). Throws Error
// naming the file and the ray when the count differs from n or a time is not in [0, 1].
std::vector<float> read_shutter_times(const std::string& spec, size_t n, uint64_t seed);

// Throws std::invalid_argument for bad options (sizes, samples, formats).
MotionJobResult run_motion_job(const MotionJobOptions& o);
Json motion_json(const MotionJobOptions& o, const MotionJobResult& r);

}  // namespace rtu::host
