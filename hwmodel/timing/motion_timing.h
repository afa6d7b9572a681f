// The cycles of motion blur on two unit designs, as the field compares them (docs/timing-model.md, "Motion
// blur"): the rays' events from MotionFixedTracer replayed in the timing model (timing_model.h) over the layout of
// a motion image.
// - time-aware (NVIDIA's Ampere RT core, Apple's 2025 patent): each node holds its child boxes at both key frames
//   and the box unit interpolates them at the ray's time (MotionFormat::box_time_bits); each moving triangle's
//   record holds both key frames and the triangle unit interpolates its vertices. Priced: the second key frame's
//   bytes in every node and moving record, and the interpolations' clocks in the box and triangle units' latency.
// - time-oblivious (Turing, which has no such block): the unit tests the boxes over the whole shutter (the image
//   encoded with box_time_bits 0) and hands every moving triangle to the shader, which interpolates and tests it:
//   a round trip of any_hit_latency, as an any-hit call (any_hit.h). Static triangles stay in the unit.
// - static: the same scene frozen (every triangle at one key frame), a static unit: the frame the others are
//   measured against.
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/datapath/motion_instances.h"
#include "hwmodel/datapath/motion_tracer.h"
#include "hwmodel/timing/timing_model.h"

namespace rtu::hw {

enum class MotionUnit : uint8_t { kStatic = 0, kTimeAware = 1, kTimeOblivious = 2 };
const char* motion_unit_name(MotionUnit u);  // "static", "time-aware", "time-oblivious"

// What the time-aware unit's interpolation adds to a pipeline: one multiply-add per plane or coordinate (a
// (B+1) x box_time_bits product for a box plane, (B+1) x time_bits for a vertex), one clock each at the units'
// clock, the triangle unit's a clock more for its wider product.
// A sphere's center and radius and a curve segment's end points and radii are interpolated as a vertex is: the
// triangle's clocks in the sphere and curve units.
// An instance with two transforms (motion_instances.h): the transform unit interpolates the object -> world
// transform (a multiply-add an entry, 1 clock) and inverts it: cofactors (2), determinant (1), its reciprocal (4,
// as a ray setup's), the products and the translation (2): 10 clocks on every instance transform. This project's
// estimate of such a unit, not a published figure.
struct MotionInterpolationClocks {
  int box = 1;
  int triangle = 2;
  int round = 2;
  int instance = 10;
};

// The configuration of unit u: c itself, or for the time-aware unit its box, triangle, sphere, curve and transform
// latencies plus the interpolation's clocks.
TimingConfig motion_timing_config(const TimingConfig& c, MotionUnit u, const MotionInterpolationClocks& k = {});

// Bytes of one node and of one record in the image of unit u: a static node (the format's struct layout, as
// node_struct_bytes) and 40-byte records; the time-aware unit's nodes add the second key frame's child boxes
// (6 planes per child at the format's offset bytes), its moving records the second key frame: a triangle's 9 grid
// coordinates (36 bytes), a sphere's center and radius (32), a curve segment's end points and radii (32).
uint64_t motion_node_bytes(const FixedFormat& f, MotionUnit u);
// The image's layout for unit u: nodes, then records in leaf order (moving ones 76 or 72 bytes on the time-aware
// unit).
TimingModel::Layout motion_layout(const MotionImage& im, MotionUnit u);

// Throws std::invalid_argument for a configuration motion blur cannot be timed on (a chip: c.units > 1).
void check_motion_config(const TimingConfig& c);

struct MotionTiming {
  uint64_t cycles = 0;
  TimingStats timing;
  TraversalStats traversal;
  std::vector<Hit> hits;
};
// Traces and times rays (and their shutter times, validate_shutter_times) on unit u of configuration c (before
// motion_timing_config). im must be encoded for u: box_time_bits 0 for the time-oblivious unit; key frames equal
// for the static one; c one unit (std::invalid_argument for a chip: motion is not timed on chips yet). Events are
// recorded and replayed in chunks, so memory does not grow with the rays.
MotionTiming time_motion_rays(const MotionImage& im, MotionUnit u, const TimingConfig& c,
                              const std::vector<Ray>& rays, const std::vector<float>& times, bool any_hit = false);

// The layout of instances with two transforms on unit u: the top level's nodes (motion_node_bytes), its instance
// records (40 bytes, the bottom level's address and one stored transform; on the time-aware unit both key
// transforms), then every mesh's bottom image (as TimingModel::layout_of of a two-level scene).
TimingModel::Layout motion_instance_layout(const MotionInstancedFixedTracer& t, MotionUnit u);
// time_motion_rays over instances with two transforms: t built with box_time_bits 0 for the time-oblivious unit
// (whose moving instances go to the shader for their transform, kAnyHit), no instance moving for the static one.
MotionTiming time_motion_instance_rays(const MotionInstancedFixedTracer& t, MotionUnit u, const TimingConfig& c,
                                       const std::vector<Ray>& rays, const std::vector<float>& times,
                                       bool any_hit = false);

}  // namespace rtu::hw
