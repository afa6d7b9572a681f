// Ray sorting on the controller: before a TRACE the renderer may sort the packet's rays by a key, so that rays
// the key puts together reach the unit together, as Meister, Boksansky, Guthe and Bittner do before the trace
// kernel of a wavefront path tracer ("On Ray Reordering Techniques for Faster GPU Ray Tracing", arXiv
// 2506.11273, 2025). The sorted copy is traced, and after the fence each hit goes back to its ray's place, so
// shading, and with it the image, is exactly what it is without sorting.
//
// Keys (RaySortKey; the host's names and widths are hwmodel/timing/sort_timing.h's kRaySortKeys, and a test holds
// the two lists together):
// - origin: the Morton code of the origin quantized to 10 bits an axis in the scene's bounds (rays that start
//   near one another: camera rays, the rays of one surface);
// - direction: the direction's octant (3 bits), then its octahedral coordinates |dx|/|d|_1 and |dy|/|d|_1 at 13
//   bits each, interleaved (rays that go the same way: the near-parallel rays that share BVH nodes);
// - origin_direction: origin and direction interleaved level by level, 5 bits an axis each, the origin's bits
//   first (a 6-D Morton code, as combined ray keys are formed in ray hashing);
// - termination: the Morton code of an estimated termination point o + min(tmax, L/|d|) d, L a distance the host
//   sets (a quarter of the scene's diagonal), in the spirit of the termination-point keys the paper modifies
//   for secondary rays (its modification is not reproduced: its abstract does not give it).
// The sort is an LSD radix sort of (key, index) pairs with digits of RaySortJob::radix_bits, stable, so rays of
// equal keys keep their order and the result does not depend on anything but the rays. Freestanding: working
// memory from the arena; no heap.
#pragma once

#include <cstdint>

#include "firmware/hal.h"
#include "firmware/render_scene.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/interface/ray.h"

namespace rtu::fw {

// What the sorter did (the counts of hwmodel/timing/sort_timing.h's SortWork, and the rays by type).
struct SortStats {
  uint64_t sorts = 0;                             // segments sorted (each of at least 2 rays)
  uint64_t rays = 0;                              // rays sorted (keyed, permuted, their hits returned)
  uint64_t passes = 0;                            // radix passes, summed over the sorts
  uint64_t pass_rays = 0;                         // keys through the passes: the sum of passes * rays
  uint64_t by_type[hw::cmd::kRayTypeCount] = {};  // rays sorted, by ray type
};

// The key's width in bits (0 for kNone or an unknown key).
uint32_t ray_sort_key_bits(RaySortKey key);
// The key of one ray (job: the key, the bounds, the distance).
uint32_t ray_sort_key(const RaySortJob& job, const hw::Ray& ray);

class RaySorter {
 public:
  // Working memory for up to `capacity` rays in sorted order at once: sorted rays, their hits, the permutation,
  // and the radix sort's buffers. False when the arena cannot hold it.
  bool init(Hal& hal, Arena& arena, const RaySortJob& job, uint32_t capacity, SortStats& stats);
  // Arena bytes init() takes per ray of capacity, and once (the digit histogram, alignment).
  static constexpr uint64_t kBytesPerRay = sizeof(hw::Ray) + sizeof(hw::Hit) + 4 * sizeof(uint32_t);
  static uint64_t fixed_bytes(uint32_t radix_bits) { return (uint64_t(4) << radix_bits) + 256; }

  // Sorts rays[0, n) (n <= capacity - place) into sorted places [place, place + n): ray i of the sorted order
  // is at ray_addr(place + i); its index in `rays` is kept for unsort(). Counted as n rays of `type`.
  void sort(const hw::Ray* rays, uint32_t n, uint32_t place, hw::cmd::RayType type);
  // Device addresses of sorted place `place`'s ray and hit.
  uint64_t ray_addr(uint32_t place) const { return m_rays + uint64_t(place) * sizeof(hw::Ray); }
  uint64_t hit_addr(uint32_t place) const { return m_hits + uint64_t(place) * sizeof(hw::Hit); }
  // After the TRACE of sorted places [place, place + n): each hit back to its ray's place in the segment,
  // hits[index] = the sorted hit.
  void unsort(hw::Hit* hits, uint32_t n, uint32_t place);

 private:
  Hal* m_hal = nullptr;
  const RaySortJob* m_job = nullptr;
  SortStats* m_stats = nullptr;
  uint32_t m_capacity = 0, m_passes = 0;
  uint64_t m_rays = 0, m_hits = 0;  // device addresses: sorted rays and hits
  uint32_t* m_perm = nullptr;       // per sorted place: the ray's index in its segment
  uint32_t *m_key_a = nullptr, *m_key_b = nullptr, *m_idx_b = nullptr, *m_hist = nullptr;
};

}  // namespace rtu::fw
