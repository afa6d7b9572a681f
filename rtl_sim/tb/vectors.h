// What the box and triangle units' test vectors share (box_vectors.h, tri_vectors.h): a set of vectors over
// fixed-point rays, rays built on the grid, the seeded draws of the random sets, and the capture of vectors from
// real traversals.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/intersect_fixed.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"

namespace rtu::rtl {

// Vectors of one unit: each case names its ray by index into `rays`.
struct RaySet {
  std::string name;
  hw::FixedFormat format;
  std::vector<hw::FixedRay> rays;
  // Traversal sets: rays traced, and rays whose replayed closest hit differs from the tracer's (must be 0).
  uint64_t traced_rays = 0, replay_mismatches = 0;
};
template <class Case>
struct VectorSet : RaySet {
  std::vector<Case> cases;
};

// A ray built on the grid: origin o (grid.F), direction d (D fraction bits), t in ray units with T fraction bits
// (t_exp = T), interval [0, t_limit].
hw::FixedRay grid_ray(const hw::FixedFormat& f, const int64_t o[3], const int64_t d[3]);

inline int64_t rand_int(hw::Pcg32& rng, int64_t lo, int64_t hi) {  // uniform in [lo, hi]
  const uint64_t span = uint64_t(hi - lo) + 1;
  const uint64_t x = (uint64_t(rng.next_u32()) << 32) | rng.next_u32();
  return span == 0 ? int64_t(x) : lo + int64_t(x % span);
}
inline bool one_in(hw::Pcg32& rng, uint32_t n) {
  return rng.next_u32() % n == 0;
}
// A magnitude with a log-uniform number of bits: in [1, 2^bits].
inline int64_t rand_mag(hw::Pcg32& rng, int bits) {
  const int b = int(rand_int(rng, 0, bits));
  return rand_int(rng, int64_t(1) << (b > 0 ? b - 1 : 0), int64_t(1) << b);
}

// Loads `scene` (host::load_scene spec), builds a BVH of the set's format width and the fixed device image, and
// traces camera rays (a 320 x 240 grid) and seeded incoherent rays, interleaved, with
// FixedTracer::trace_recorded until `full()`. Each ray joins s.rays; its events are replayed in order with the
// closest hit so far (tmax to start with, lowered by each primitive or plane hit, as in FixedTracer), and
// visit(image, event, ray index, closest) sees each event before its hit lowers the limit. Names the set
// "traversal <file>" and counts traced rays and rays whose replay differs from the tracer.
using TraversalVisit =
    std::function<void(const hw::DeviceImage& img, const hw::TraceEvent& e, uint32_t ray, int64_t closest)>;
void capture_traversals(RaySet& s, const std::string& scene, uint64_t seed, const std::function<bool()>& full,
                        const TraversalVisit& visit);

}  // namespace rtu::rtl
