#include "hwmodel/timing/sort_timing.h"

#include <algorithm>
#include <cmath>

namespace rtu::hw {

SortCycles sort_cycles(const SortWork& w, const TimingConfig& c) {
  SortCycles r;
  if (w.sorts == 0) return r;
  // The keys and the pairs are shared by `units` controllers working side by side; each runs the prefix sum over
  // the bins of its own share.
  const double bw = c.dram_bytes_per_cycle, rate = c.sort_keys_per_clock * c.units;
  const double rays = double(w.rays), pass_rays = double(w.pass_rays);
  const uint64_t bins = uint64_t(1) << c.sort_radix_bits;
  // Per phase: the controllers' work and its bytes over the bandwidth; the phase costs the larger.
  const double key_compute = rays * c.sort_key_cycles / c.units;
  const double pass_compute = pass_rays / rate + double(w.passes * bins);
  const double move_compute = rays / rate;  // permute and return alike
  const uint64_t key_bytes = w.rays * kSortKeyPhaseBytes, pass_bytes = w.pass_rays * kSortPassBytes;
  // sort_gather index: no permute and no return phase (the unit reads through the index, writes in place).
  const bool copies = c.sort_gather == SortGather::kCopy;
  const uint64_t permute_bytes = copies ? w.rays * kSortPermuteBytes : 0;
  const uint64_t return_bytes = copies ? w.rays * kSortReturnBytes : 0;
  r.key_cycles = std::max(key_compute, double(key_bytes) / bw);
  r.pass_cycles = std::max(pass_compute, double(pass_bytes) / bw);
  if (copies) {
    r.permute_cycles = std::max(move_compute, double(permute_bytes) / bw);
    r.return_cycles = std::max(move_compute, double(return_bytes) / bw);
  }
  r.compute_cycles = key_compute + pass_compute + (copies ? 2 * move_compute : 0.0);
  r.dram_bytes = key_bytes + pass_bytes + permute_bytes + return_bytes;
  r.dram_cycles = double(r.dram_bytes) / bw;
  r.limit = r.dram_cycles >= r.compute_cycles ? "dram" : "compute";
  r.latency_cycles = ((copies ? 3 : 1) * w.sorts + w.passes) * uint64_t(c.dram_latency);
  r.cycles =
      r.latency_cycles + uint64_t(std::ceil(r.key_cycles + r.pass_cycles + r.permute_cycles + r.return_cycles));
  return r;
}

}  // namespace rtu::hw
