// The built-in scenes of the benchmark suite (scenes/suite.json): procedural analogues of the field's standard
// scenes, each named after what makes it hard. Deterministic (a fixed-seed SplitMix64, no files); each builder
// returns a scene that load_scene validates and marks (mark_non_opaque). Used by builtin_scenes.cpp only, which
// builds its own scenes from the same building blocks.
#pragma once

#include <cstdint>
#include <string>

#include "host/scene/scene.h"

namespace rtu::host {

// Building blocks of the built-in scenes: a diffuse material (index of refraction 1.5, no emission), a material
// appended to the scene (returns its index), a point light.
Material diffuse_material(const std::string& name, Vec3 color);
uint32_t add_material(Scene& scene, Material m);
Light point_light(Vec3 position, Vec3 intensity);

// hairball: 512 thin curved tubes (6 sides, 32 segments each: 196,608 triangles) crossing inside a unit ball:
// many overlapping thin primitives whose boxes overlap, so traversal visits many nodes per ray.
Scene make_hairball_scene();
// hair: a head (an ellipsoid of 5,120 triangles) with `strands` strands of 8 segments, half straight and half
// curly, tapered from radius 0.0045 to 0.0015 (the head is 2 units tall), as linear swept spheres (curve
// segments), as camera-facing ribbons (2 triangles a segment) or as two orthogonal triangle strips a strand
// (4 triangles a segment, view independent, in the spirit of NVIDIA's DOTS). The same strands in every form.
enum class HairForm { kCurves, kRibbons, kDots };
inline constexpr int kHairStrands = 24000, kMaxHairStrands = 400000;
Scene make_hair_scene(HairForm form, int strands = kHairStrands);
// atrium: a two-storey hall of columns and round arches around an open court, side aisles under galleries,
// lit from inside: heavy occlusion, most light arrives after bounces (a Sponza-like interior).
Scene make_atrium_scene();
// city: 4 building prototypes placed 256 times (instances with rotations and non-uniform scales) on a ground:
// a two-level scene whose top level matters.
Scene make_city_scene();
// forest: 64 trees of alpha-tested leaf cards (a procedural RGBA texture, alpha_mode mask) on tapered trunks,
// on a ground: most candidate hits are on masked texels and go to the any-hit stage.
Scene make_forest_scene();

// The forest's leaf texture: kForestLeafSide x kForestLeafSide RGBA8 texels, alpha 0 (masked) or 255.
inline constexpr uint32_t kForestLeafSide = 64;
Texture make_forest_leaf_texture();

}  // namespace rtu::host
