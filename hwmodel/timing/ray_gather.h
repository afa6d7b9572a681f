// The ray coherence gathering unit (gather key, off by default): rays fetched from the ray buffer wait in a gather
// buffer of gather_buffer rays, binned by a key computed from the ray, and a bin goes to the ray slots as a group.
// Rays of one bin start close together and in similar directions, so they fetch the same nodes while those are in
// the node cache.
//
// - Key (gather): "octant" (the direction's three sign bits), "origin" (the origin's cell in a grid of
//   2^gather_grid_bits cells per axis over the scene's frame), "origin_octant" (both), "two_point" (the origin's
//   cell and the cell of a point a quarter of the frame's extent along the direction). These follow the hash
//   functions of Vulkan-Sim's ray coherence engine (src/gpgpu-sim/ray_coherency_engine.cc: origin grid,
//   direction, two-point); the engine computes the key when it records the ray (a kRayKey event first in the
//   ray's events), as the unit's setup would from the ray's floats.
// - A bin is issued when it holds gather_rays rays (full), when gather_timeout cycles have passed since its first
//   ray arrived (timeout), when the buffer is full and nothing is issued (the fullest bin, oldest first on a tie:
//   forced), or when the packet's last ray has arrived (every bin, oldest first: flush). Issued rays wait in issue
//   order for free slots; a free slot takes the first.
// - Ray fetch: ray i is fetched at the earliest at packet start + i, once the buffer has room for it (fewer than
//   gather_buffer rays fetched and not yet in a slot), and arrives ray_fetch_latency later. The gather buffer
//   takes the place of the ray queue of queue_depth rays.
// - Left out: the bins' number (a CAM of that many keys; here any number, as the rays bound them) and the cycles
//   of the key's arithmetic (in ray setup's latency).
// Area and energy: the buffer is SRAM of gather_buffer rays (kQueueRayBytes each) and a key per ray; each ray is
// written and read once (energy_model.cpp).
#pragma once

#include <cmath>
#include <cstdint>
#include <deque>
#include <set>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/interface/ray.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

// The bin key of a world ray: `lo` is the scene frame's low corner and `extent` its edge (a cube).
inline uint32_t gather_key(GatherKey k, int grid_bits, const Ray& r, const double lo[3], double extent) {
  const uint32_t octant = uint32_t(std::signbit(r.dir[0])) | uint32_t(std::signbit(r.dir[1])) << 1 |
                          uint32_t(std::signbit(r.dir[2])) << 2;
  const double cells = double(1u << grid_bits);
  auto cell = [&](const double p[3]) {
    uint32_t c = 0;
    for (int a = 0; a < 3; ++a) {
      double u = (p[a] - lo[a]) / extent * cells;
      u = std::isfinite(u) ? std::fmin(std::fmax(u, 0.0), cells - 1.0) : 0.0;
      c = c << grid_bits | uint32_t(u);
    }
    return c;
  };
  const double o[3] = {r.origin[0], r.origin[1], r.origin[2]};
  switch (k) {
    case GatherKey::kOctant:
      return octant;
    case GatherKey::kOrigin:
      return cell(o);
    case GatherKey::kOriginOctant:
      return cell(o) << 3 | octant;
    case GatherKey::kTwoPoint: {
      const double len =
          std::sqrt(double(r.dir[0]) * r.dir[0] + double(r.dir[1]) * r.dir[1] + double(r.dir[2]) * r.dir[2]);
      const double s = len > 0 ? 0.25 * extent / len : 0.0;
      const double p[3] = {o[0] + s * r.dir[0], o[1] + s * r.dir[1], o[2] + s * r.dir[2]};
      return cell(o) << (3 * grid_bits) | cell(p);
    }
    case GatherKey::kNone:
      break;
  }
  return 0;
}

class RayGather {
 public:
  static constexpr uint64_t kNever = ~uint64_t(0);
  explicit RayGather(const TimingConfig& c);

  // A packet of n rays, the first fetched at t0.
  void begin(size_t n, uint64_t t0);
  // The cycle ray arrived() reaches the buffer; kNever when every ray has arrived, or when the buffer has no room
  // for it until a ray leaves.
  uint64_t next_arrival() const;
  size_t arrived() const { return m_arrived; }
  // Ray arrived() reaches the buffer at next_arrival(): its events move in (swapped with `events`) and its bin
  // takes it; then bins issue as the rules say (full, forced, flush).
  void arrive(std::vector<TraceEvent>& events, TimingStats& s);
  // Issues every bin whose timeout is at or before t, in the order of their timeouts.
  void expire(uint64_t t, TimingStats& s);
  uint64_t next_timeout() const { return m_timeouts.empty() ? kNever : m_timeouts.begin()->first; }
  bool ready() const { return !m_ready.empty(); }
  // The first issued ray: returns its index in the packet and swaps its events into `events`; `issued` is the
  // cycle its bin was issued. leave() says when a slot took it.
  size_t take(std::vector<TraceEvent>& events, uint64_t& issued);
  void leave(uint64_t cycle);

 private:
  struct Bin {
    std::vector<uint32_t> entries;  // buffer entries, in arrival order
    uint64_t first = 0;             // the first ray's arrival
  };
  void issue(uint32_t key, uint64_t t, TimingStats& s);

  uint64_t m_buffer, m_bin_rays, m_timeout, m_fetch_latency;
  size_t m_n = 0, m_arrived = 0, m_left = 0;
  uint64_t m_t0 = 0;
  std::vector<std::vector<TraceEvent>> m_events;  // per buffer entry
  std::vector<size_t> m_ray;                      // per buffer entry: the ray's index
  std::vector<uint64_t> m_arrival;                // per buffer entry
  std::vector<uint32_t> m_free;                   // free buffer entries
  std::vector<uint64_t> m_departed;               // cycle each of the last m_buffer rays left (a ring)
  std::unordered_map<uint32_t, Bin> m_bins;
  std::set<std::pair<uint64_t, uint32_t>> m_timeouts;  // (timeout cycle, key) of every bin
  std::deque<std::pair<uint32_t, uint64_t>> m_ready;   // (entry, issue cycle), in issue order
};

}  // namespace rtu::hw
