#include "hwmodel/timing/raster_timing.h"

#include <cmath>

namespace rtu::hw {

RasterCycles raster_cycles(const RasterWork& w, const TimingConfig& c) {
  RasterCycles r;
  const uint64_t depth = uint64_t(c.raster_depth_bytes), gbuf = uint64_t(c.raster_gbuffer_bytes);
  r.dram_bytes = w.prims_read * uint64_t(c.raster_prim_bytes) + (w.clears + w.fragments) * depth +
                 w.depth_writes * (depth + gbuf);
  r.setup_cycles = double(w.setups) * c.raster_setup_cycles;
  r.scan_cycles = double(w.samples_tested) / c.raster_samples_per_clock;
  r.fragment_cycles = double(w.fragments) / c.raster_fragments_per_clock;
  r.dram_cycles = double(r.dram_bytes) / c.dram_bytes_per_cycle;
  double slowest = 0.0;
  const struct {
    double v;
    const char* name;
  } stages[] = {{r.setup_cycles, "setup"},
                {r.scan_cycles, "scan"},
                {r.fragment_cycles, "fragments"},
                {r.dram_cycles, "dram"}};
  for (const auto& s : stages) {
    if (s.v > slowest) {
      slowest = s.v;
      r.limit = s.name;
    }
  }
  r.latency_cycles = w.passes * uint64_t(c.raster_latency);
  r.cycles = r.latency_cycles + uint64_t(std::ceil(slowest));
  return r;
}

}  // namespace rtu::hw
