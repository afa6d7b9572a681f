// Cost model of ray sorting in the firmware (firmware/ray_sort.h): before each TRACE the controller sorts the
// bounce's rays of one type by a key (the ray_sort key), as Meister, Boksansky, Guthe and Bittner do in software
// ("On Ray Reordering Techniques for Faster GPU Ray Tracing", arXiv 2506.11273, 2025), and after the fence puts
// the hits back in the rays' order. Priced from what the firmware did (SortWork) and the sort_* keys.
//
// What one sort of n rays does, in four phases; within a phase the controller's work and its memory traffic
// overlap (a streaming loop), so a phase costs the larger of the two; the phases run one after another, each
// starting with one memory latency that streaming does not hide:
// - keys: n keys computed at sort_key_cycles each; each 32-byte ray read, a 4-byte key and a 4-byte index
//   written (40 bytes a ray);
// - radix passes: an LSD radix sort of the (key, index) pairs, passes = ceil(key bits / sort_radix_bits); a pass
//   counts the keys' digits and scatters the pairs stably at sort_keys_per_clock, after a prefix sum over the
//   2^sort_radix_bits bins at one bin per clock; it reads each key to count (4 bytes), reads and writes each pair
//   to scatter (16 bytes): 20 bytes a key and pass;
// - permute: the rays gathered into sorted order at sort_keys_per_clock: an index read, a ray read and written
//   (68 bytes a ray);
// - return: after the fence, each hit scattered back to its ray's place at sort_keys_per_clock: an index read,
//   a 16-byte hit read and written (36 bytes a ray).
// Bytes move at dram_bytes_per_cycle; the latency is dram_latency per phase. A chip of `units` units sorts on
// `units` controllers side by side (as a GPU sorts on all its compute units, one per ray-tracing unit on the GPU
// presets): they share the keys and pairs, each computes the prefix sum of its own share's bins, and they share
// the chip's DRAM bandwidth. Over a frame:
//   cycles = (3 sorts + passes) * dram_latency
//            + ceil(max(rays * sort_key_cycles / units, 40 rays / bw)
//                   + max(pass_rays / rate + passes * 2^radix_bits, 20 pass_rays / bw)
//                   + max(rays / rate, 68 rays / bw) + max(rays / rate, 36 rays / bw))
// with pass_rays = the sum over sorts of passes * n, rate = sort_keys_per_clock * units, bw =
// dram_bytes_per_cycle.
// With sort_gather = index (Meister, Boksansky, Guthe and Bittner's tracer: its trace kernel reads the rays
// through the sorted index array and no kernel moves them) there is no permute and no return phase: the frame
// pays the keys and the radix passes, and (sorts + passes) latencies. The unit's 4-byte index read beside each
// ray (whose own read the model does not charge either) is left out.
// Segments of fewer than 2 rays are not sorted. The frame's cycles are raster + sort + the unit's device clock:
// the controllers sort while the unit waits, and the unit traces while they wait.
//
// Left out: the merge of the controllers' histograms on a chip (a scan over units x bins per pass); overlap of
// a sort with the unit's tracing (the controller could sort one ray type while the unit traces the one before);
// caches on the controller (every byte goes to DRAM, as sorting a wavefront larger than any cache does); the
// sort's traffic competing with the unit's for the DRAM channel (they do not overlap in time here); skipping a
// pass whose digit is the same for every key; an odd pass count's final copy (the firmware starts the passes in
// the buffer that makes the last one land in place); the controller's shading, which is not priced at all.
//
// The keys' default figures are estimates of a compute unit's share, as the rasterizer's are a GPU's raster
// hardware's: a Morton code is about 30 integer operations, one clock of a 32-lane SIMD (sort_key_cycles 1); a
// radix pass counts and scatters one key per clock (sort_keys_per_clock 1); 8-bit digits as GPU radix sorts
// use (CUB's and Onesweep's, Adinets and Merrill 2022), so 30-bit keys take 4 passes.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

// The keys a ray may be sorted by (the ray_sort timing key), in the order of the firmware's fw::RaySortKey;
// firmware/ray_sort.h computes them. bits: the key's width, from which the radix passes follow.
struct RaySortKeyInfo {
  const char* name;
  int bits;
  const char* description;
};
inline constexpr std::array<RaySortKeyInfo, 5> kRaySortKeys = {{
    {"none", 0, "no sorting: rays go to the unit in the order the renderer made them"},
    {"origin", 30, "Morton code of the origin quantized to 10 bits an axis in the scene's bounds"},
    {"direction", 29,
     "direction octant (3 bits), then the octahedral coordinates |dx|/|d|_1, |dy|/|d|_1 at 13 bits each, "
     "interleaved"},
    {"origin_direction", 30,
     "origin (5 bits an axis in the scene's bounds) and direction (5 bits a component of d/|d|_1) interleaved, "
     "origin bits first at each level"},
    {"termination", 30,
     "Morton code of the estimated termination point o + min(tmax, L/|d|) d, L a quarter of the scene's "
     "diagonal, 10 bits an axis in the scene's bounds"},
}};

// The key a ray_sort value names.
inline const RaySortKeyInfo& ray_sort_key(RaySort k) {
  return kRaySortKeys[size_t(k)];
}

// Bytes the sort moves per ray or key (the phases above).
inline constexpr uint64_t kSortKeyPhaseBytes = 32 + 4 + 4;  // ray read, key and index written
inline constexpr uint64_t kSortPassBytes = 4 + 8 + 8;       // key read to count, pair read and written
inline constexpr uint64_t kSortPermuteBytes = 4 + 32 + 32;  // index, ray read, ray written
inline constexpr uint64_t kSortReturnBytes = 4 + 16 + 16;   // index, hit read, hit written

// What the firmware's sorts did in a frame (the counts of fw::SortStats that cost cycles).
struct SortWork {
  uint64_t sorts = 0;      // segments sorted (each of at least 2 rays)
  uint64_t rays = 0;       // rays keyed, permuted, and whose hits went back
  uint64_t passes = 0;     // radix passes, summed over the sorts
  uint64_t pass_rays = 0;  // keys through the radix passes: the sum over sorts of passes * rays
};

struct SortCycles {
  uint64_t cycles = 0;          // the sort's cycles in the frame
  uint64_t latency_cycles = 0;  // (3 sorts + passes) * dram_latency
  double key_cycles = 0.0, pass_cycles = 0.0, permute_cycles = 0.0, return_cycles = 0.0;  // per phase
  double compute_cycles = 0.0;  // the controller's work, summed over the phases
  double dram_cycles = 0.0;     // the bytes over the bandwidth, summed over the phases
  uint64_t dram_bytes = 0;
  const char* limit = "none";  // "dram" when dram_cycles >= compute_cycles, else "compute" ("none": no sort)
};

SortCycles sort_cycles(const SortWork& w, const TimingConfig& c);

}  // namespace rtu::hw
