// How a unit's free ray slots get their rays: the in-unit ray scheduler seam (timing_model.h). The timing model
// asks its admission when a slot is free; the admission says whether it has a ray for it then (or when to ask
// again), which ray, and the cycle it enters ray setup. Two admissions exist:
// - in order (gather = none): rays stream from the ray buffer at one per clock from the packet's decode, at most
//   queue_depth ahead of the slots (a bounded prefetch queue), each ray_fetch_latency after its fetch; a free slot
//   takes the next ray;
// - gathering (ray_gather.h): rays wait in a gather buffer, binned by a key, and a free slot takes the first ray
//   of the bins issued so far.
// A new in-unit ray scheduler is a class derived from RayAdmission in its own files and one line of
// make_ray_admission() (ray_admission.cpp) choosing it from its keys.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

// The rays the caller has given the unit so far in the packet: rays [first, first + count), their event lists at
// rays[0 .. count).
struct RayFeed {
  std::vector<TraceEvent>* rays = nullptr;
  size_t first = 0, count = 0;
  size_t end() const { return first + count; }
};

class RayAdmission {
 public:
  virtual ~RayAdmission() = default;
  // A packet of n rays decoded at cycle t0.
  virtual void begin(size_t n, uint64_t t0) = 0;
  // A slot is free at cycle t: the admission is brought to t (rays arrive, bins issue). False when that needs a
  // ray the feed does not hold yet (the caller feeds more and asks again).
  virtual bool reach(uint64_t t, const RayFeed& feed, TimingStats& s) = 0;
  // After reach(t): whether a ray can go into a slot now; if not, retry_at() is the cycle to ask again (after t).
  virtual bool ready() const = 0;
  virtual uint64_t retry_at() const = 0;
  // The next ray into a slot free at free_at, with ray setup free at setup_free: returns its index in the packet,
  // swaps its events into `events` and sets `enter`, the cycle it enters ray setup.
  virtual size_t take(std::vector<TraceEvent>& events, const RayFeed& feed, uint64_t free_at, uint64_t setup_free,
                      uint64_t& enter) = 0;
  // Rays taken from the feeds so far (into slots, or into a buffer of the admission).
  virtual size_t fed_up_to() const = 0;
  // Whether a slot free at free_at waits for a ray the feed does not hold yet.
  virtual bool starved(const RayFeed& feed, uint64_t free_at) const = 0;
};

std::unique_ptr<RayAdmission> make_ray_admission(const TimingConfig& c);

}  // namespace rtu::hw
