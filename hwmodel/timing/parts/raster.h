// The rasterizer of hybrid mode (raster_timing.h): a raster pipeline beside the unit, sharing its DRAM channel.
#pragma once

#include "hwmodel/timing/timing_key.h"

namespace rtu::hw {

struct RasterConfig {
  double raster_setup_cycles = 20.0;        // cycles per primitive set up
  double raster_samples_per_clock = 6.4;    // coverage tests per clock (scan of each primitive's rectangle)
  double raster_fragments_per_clock = 1.6;  // covered samples through interpolation and the depth test per clock
  int raster_latency = 100;                 // pipeline depth, paid once per raster pass
  int raster_prim_bytes = 36;               // bytes fetched per primitive per pass (three float3 vertices)
  int raster_depth_bytes = 4;               // depth bytes read per fragment, written per pass and per clear
  int raster_gbuffer_bytes = 12;            // G-buffer bytes written per pass besides depth (prim, u, v)
};

const TimingKeyTable& raster_keys();

}  // namespace rtu::hw
