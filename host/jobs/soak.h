// Soak: random valid scenes and formats, traced and rendered twice, for a bounded time. Each iteration draws a
// scene (random triangles, spheres, planes, materials and lights at a random scale and offset), a fixed-point
// format preset with a random BVH width, and a timing preset; then
// - traces rays (incoherent and primary) on the fixed and the timed device, twice each, on fresh devices with 1
//   and 2 threads: the hits must be identical bit for bit (and the timed device's equal the fixed one's), the
//   cycles identical;
// - renders a small image with the firmware on the timed device, twice: identical pixels and device clock.
// Under the asan preset this also runs with LeakSanitizer (scripts/test.sh): no leaks. `rtusim soak`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace rtu::host {

struct SoakOptions {
  double seconds = 10.0;        // run new iterations until this much wall time has passed
  uint64_t max_iterations = 0;  // and at most this many (0: no bound); at least one always runs
  uint64_t seed = 1;            // iteration i uses seed + i
  bool verbose = false;         // one line per iteration on stderr
};

struct SoakResult {
  uint64_t iterations = 0, scenes_with_bvh = 0;
  uint64_t prims = 0, rays = 0, renders = 0, pixels = 0;
  uint64_t cycles = 0;   // timed device cycles simulated (once per pair of runs)
  uint64_t digest = 0;   // FNV-1a of every hit, pixel and cycle count: equal for equal seeds and iterations
  double seconds = 0.0;  // wall time
  std::vector<std::string> mismatches;  // what differed between two runs, with the iteration's seed and setup
};

SoakResult soak(const SoakOptions& o);

}  // namespace rtu::host
