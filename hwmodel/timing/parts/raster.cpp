#include "hwmodel/timing/parts/raster.h"

#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

const TimingKeyTable& raster_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"raster_setup_cycles", &C::raster_setup_cycles, 0, kMaxLatency,
       "hybrid rasterizer: cycles per primitive set up (triangle, sphere square, plane pass)"},
      {"raster_samples_per_clock", &C::raster_samples_per_clock, 0.001, 4096,
       "hybrid rasterizer: coverage tests per clock over each primitive's scan rectangle"},
      {"raster_fragments_per_clock", &C::raster_fragments_per_clock, 0.001, 4096,
       "hybrid rasterizer: covered samples per clock through interpolation and depth test"},
      {"raster_latency", &C::raster_latency, 0, kMaxLatency, "hybrid rasterizer: pipeline depth, once per pass"},
      {"raster_prim_bytes", &C::raster_prim_bytes, 0, 4096,
       "hybrid rasterizer: bytes fetched per primitive per pass (DRAM channel)"},
      {"raster_depth_bytes", &C::raster_depth_bytes, 1, 64,
       "hybrid rasterizer: depth bytes read per fragment, written per pass and clear (DRAM channel)"},
      {"raster_gbuffer_bytes", &C::raster_gbuffer_bytes, 0, 4096,
       "hybrid rasterizer: G-buffer bytes written per depth pass besides depth (DRAM channel)"},
  };
  return keys;
}

}  // namespace rtu::hw
