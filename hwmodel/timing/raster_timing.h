// Cost model of the rasterizer of hybrid mode (firmware/raster.h): a raster pipeline beside the ray-tracing
// unit, priced from what the rasterizer did (RasterWork) and the timing configuration's raster_* keys.
//
// Stages, each with a throughput; they overlap (a pipeline with deep queues between its stages), so a pass costs
// its latency plus its slowest stage:
// - primitive fetch: every primitive record once per pass (raster_prim_bytes each) through the DRAM channel;
// - setup: raster_setup_cycles per primitive set up (a triangle or a piece of a clipped one, a sphere's
//   bounding square, a plane's full-screen pass); culled primitives cost their fetch only;
// - scan: raster_samples_per_clock coverage tests (edge functions, or a sphere/plane test per sample) over each
//   primitive's scan rectangle;
// - fragments: raster_fragments_per_clock covered samples through interpolation and the depth test;
// - z-buffer and G-buffer traffic through the DRAM channel (dram_bytes_per_cycle): a clear of raster_depth_bytes
//   per texel per pass, a depth read of raster_depth_bytes per fragment, and per depth-test pass a write of
//   raster_depth_bytes + raster_gbuffer_bytes.
// cycles = passes * raster_latency + ceil(max(setup, scan, fragments, DRAM bytes / bandwidth)), in cycles of
// the unit's clock. Left out: overlap of one pass with the previous pass's ray tracing (the frame's cycles are
// raster + trace), imbalance between stages within a pass (the throughput bound is reached only with deep
// queues), z-buffer compression and caches (every access goes to DRAM), hierarchical-z rejection.
#pragma once

#include <cstdint>

#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

// What the rasterizer did in a frame (the counts of fw::RasterStats that cost cycles).
struct RasterWork {
  uint64_t passes = 0;          // raster passes
  uint64_t prims_read = 0;      // primitive records fetched
  uint64_t setups = 0;          // primitives set up
  uint64_t samples_tested = 0;  // coverage tests
  uint64_t fragments = 0;       // covered samples (depth tests)
  uint64_t depth_writes = 0;    // fragments that passed the depth test
  uint64_t clears = 0;          // texels cleared
};

struct RasterCycles {
  uint64_t cycles = 0;          // the rasterizer's cycles in the frame
  uint64_t latency_cycles = 0;  // passes * raster_latency
  double setup_cycles = 0.0, scan_cycles = 0.0, fragment_cycles = 0.0, dram_cycles = 0.0;  // per stage
  uint64_t dram_bytes = 0;     // primitive fetch + z-buffer + G-buffer bytes
  const char* limit = "none";  // the slowest stage: "setup", "scan", "fragments", "dram" (or "none": no work)
};

RasterCycles raster_cycles(const RasterWork& w, const TimingConfig& c);

}  // namespace rtu::hw
