// The built-in moving scene (builtin motion blur scene, docs/guide/motion-blur.md): closed balls that move, grow
// or stay, over a static floor, seen by a camera whose shutter stays open from time 0 to 1; and the rays of its
// motion-blurred frame, each pixel sampled at stratified shutter times.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "host/scene/scene.h"
#include "hwmodel/datapath/motion_instances.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/scene/motion.h"

namespace rtu::host {

struct MotionScene {
  hw::MotionGeometry geometry;
  Camera camera;
  // Triangles [first, first + count) of each ball: a closed mesh whose vertices are shared (watertight at every
  // time), with its center and radius at both key frames.
  struct Ball {
    uint32_t first = 0, count = 0;
    hw::Vec3 center[2];
    float radius[2] = {0.0f, 0.0f};
  };
  std::vector<Ball> balls;
};

// Nine balls (an octahedron subdivided `level` times and pushed onto the sphere: 8 * 4^level triangles each):
// three move sideways fast, three slowly, two grow and one stays, none touching another at any time; a floor of
// 2 triangles. Deterministic.
// motion_scale (0..1) scales every ball's move and growth between the key frames (1: as listed in the source).
MotionScene builtin_motion_scene(int level = 4, float motion_scale = 1.0f);

// A loaded scene set in motion: every triangle and sphere at key frame 0 as loaded and at key frame 1 moved by
// `move` (world units), with the scene's camera. Throws Error when the scene holds curves or planes (moving
// geometry is triangles and spheres) or when a moved coordinate leaves the range.
MotionScene moving_scene(const Scene& scene, const hw::Vec3& move);

// The built-in scene of moving instances: one unit ball mesh (as builtin_motion_scene's) placed nine times by two
// transforms each, over a floor mesh placed once. The balls move as builtin_motion_scene's (translation and
// uniform scale between the key frames, scaled by motion_scale) and three of them also turn about their vertical
// axis by 60 degrees (the interpolated transform then shrinks them slightly mid-shutter, as Embree's does).
// balls[i] names instance i's flattened triangles and its centers (the images of the mesh's origin) at both key
// frames.
struct MotionInstanceScene {
  hw::MotionInstanceSet set;
  Camera camera;
  std::vector<MotionScene::Ball> balls;
};
MotionInstanceScene builtin_motion_instances(int level = 4, float motion_scale = 1.0f);

// A loaded scene of instances set in motion: each instance's transform at key frame 1 its transform moved by
// `move`; loose spheres and curves stay (instances holding them do not move). Throws Error when the scene has no
// instances or planes, or when the moved set does not validate.
hw::MotionInstanceSet moving_instances(const Scene& scene, const hw::Vec3& move);

// Rays of a width x height frame with `samples` per pixel: pixel-center primary rays (primary_rays), pixel by
// pixel, and per sample a shutter time stratified in [s / samples, (s + 1) / samples) with a jitter from `seed`.
struct MotionRays {
  std::vector<hw::Ray> rays;
  std::vector<float> times;
};
MotionRays motion_frame_rays(const Camera& cam, int width, int height, int samples, uint64_t seed);

}  // namespace rtu::host
