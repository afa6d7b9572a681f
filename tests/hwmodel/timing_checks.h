// Shared by the timing tests: two runs that must agree cycle for cycle agree in every timing statistic, each
// checked on its own so that a failure names the counter (the counters are those of the table in timing_stats.h).
#pragma once

#include <catch2/catch.hpp>

#include <cstdint>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"
#include "image_checks.h"

inline void check_same_timing(const rtu::hw::TimingStats& a, const rtu::hw::TimingStats& b) {
  for (const rtu::hw::TimingCounter& c : rtu::hw::timing_counters()) {
    CAPTURE(c.name);
    CHECK(a.*c.member == b.*c.member);
  }
}

// A configuration with distinct latencies, so a sum that misses or doubles one does not match by accident.
inline rtu::hw::TimingConfig test_config() {
  using rtu::hw::TimingConfig;
  TimingConfig c;
  c.packet_latency = 20;
  c.ray_fetch_latency = 10;
  c.setup_latency = 8;
  c.writeback_latency = 5;
  c.traversal_latency = 3;
  c.ray_slots = 64;
  c.stack_entries = 4;
  c.box_units = 1;
  c.box_rate = 4;
  c.box_latency = 6;
  c.tri_units = 1;
  c.tri_latency = 12;
  c.sphere_latency = 16;
  c.plane_latency = 7;
  c.queue_depth = 64;
  c.cache_kib = 16;
  c.cache_ways = 4;
  c.line_bytes = 64;
  c.cache_latency = 2;
  c.dram_latency = 100;
  c.dram_bytes_per_cycle = 8.0;  // a 64-byte line transfers in 8 cycles
  return c;
}

// Traces `rays` (closest hit) on a timed device of configuration c, bound to the image `bytes`, on `threads` host
// threads: the hits in `got`, the device's statistics in `timing` (if given); returns the cycles.
inline uint64_t trace_timed(const rtu::hw::TimingConfig& c, const std::vector<uint8_t>& bytes,
                            const std::vector<rtu::hw::Ray>& rays, int threads, std::vector<rtu::hw::Hit>& got,
                            rtu::hw::TimingStats* timing = nullptr) {
  rtu::hw::TimedEngine timed(rtu::hw::EngineOptions{}, c);
  timed.set_threads(threads);
  timed.bind(bytes.data(), bytes.size());
  got.assign(rays.size(), rtu::hw::Hit{});
  rtu::hw::TraversalStats ts;
  const uint64_t cycles = timed.trace_cycles(rays.data(), got.data(), rays.size(), false, ts, 0, 0);
  if (timing) *timing = timed.timing();
  return cycles;
}

// A random soup (fixed_checks::random_scene(seed, 2000, 20)) encoded at a format preset: the image's bytes, and
// the fixed device's closest hits of `rays`, which every timed run must reproduce bit for bit.
struct FixedReference {
  std::vector<uint8_t> bytes;
  std::vector<rtu::hw::Hit> hits;
};
inline FixedReference fixed_reference(uint64_t seed, const std::vector<rtu::hw::Ray>& rays,
                                      const char* format = "default") {
  using namespace rtu::hw;
  const Geometry g = fixed_checks::random_scene(seed, 2000, 20);
  const DeviceImage img = image_checks::encode(g, format_preset(format));
  FixedReference ref{std::vector<uint8_t>(img.data(), img.data() + img.size()), std::vector<Hit>(rays.size())};
  TraversalStats fs;
  FixedTracer(img).trace_batch(rays.data(), ref.hits.data(), rays.size(), false, 1, fs);
  return ref;
}

// n rays from random origins in [-12, 12]^3 in random directions (components in [-1, 1]), t in [0, 1e30].
inline std::vector<rtu::hw::Ray> random_box_rays(uint64_t seed, int n) {
  rtu::hw::Pcg32 rng(seed);
  std::vector<rtu::hw::Ray> rays;
  for (int i = 0; i < n; ++i) {
    rtu::hw::Ray r;
    for (int a = 0; a < 3; ++a) {
      r.origin[a] = rtu::hw::fixed_checks::rand_float(rng, -12.0f, 12.0f);
      r.dir[a] = rtu::hw::fixed_checks::rand_float(rng, -1.0f, 1.0f);
    }
    r.tmin = 0.0f;
    r.tmax = 1e30f;
    rays.push_back(r);
  }
  return rays;
}
