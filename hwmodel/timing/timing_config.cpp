#include "hwmodel/timing/timing_config.h"

#include <array>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <system_error>
#include <variant>

#include "hwmodel/numeric/fixed_format.h"

namespace rtu::hw {

namespace {

using KeyInfo = TimingKeyInfo;

// The datapath's own keys.
const TimingKeyTable& own_keys() {
  using C = TimingConfig;
  static const TimingKeyTable keys = {
      {"format", &C::format, 0, 0,
       "fixed-point format of the datapath: a preset (rtusim info --formats), optionally with changes of its "
       "fields, e.g. packed:coord_bits=16",
       [](const C& c) -> std::string {
         // A format spec, as sweep --formats takes it: a preset, optionally with :key=value changes of its fields.
         try {
           (void)format_from_spec(c.format);
         } catch (const std::invalid_argument& e) {
           return "format = '" + c.format + "' is not a fixed-point format spec: " + e.what();
         }
         return {};
       }},
      {"bvh_width", &C::bvh_width, kNoRange, -kNoRange,
       "children per BVH node: 2, 4, 6 or 8 (overrides the format's width)",
       [](const C& c) -> std::string {
         if (c.bvh_width != 2 && c.bvh_width != 4 && c.bvh_width != 6 && c.bvh_width != 8)
           return "bvh_width = " + std::to_string(c.bvh_width) + " must be 2, 4, 6 or 8";
         return {};
       }},
      {"clock_ghz", &C::clock_ghz, 0.001, 1000, "clock in GHz, for reporting seconds and GB/s only"},
  };
  return keys;
}

// Every key, in the order of the parts: one row a part (its keys in parts/*.cpp). validate(), timing_keys() and
// set_timing_key() all read it.
std::vector<KeyInfo> make_key_table() {
  const TimingKeyTable* const parts[] = {
      &own_keys(),       &command_keys(),        &slot_keys(),     &stack_keys(),  &scheduler_keys(), &unit_keys(),
      &fetch_keys(),     &dram_channel_keys(),   &prefetch_keys(), &gather_keys(), &chip_keys(),      &l2_keys(),
      &dram_bank_keys(), &dram_scheduler_keys(), &raster_keys(),   &sort_keys(),   &watchdog_keys(),
  };
  std::vector<KeyInfo> table;
  for (const TimingKeyTable* part : parts) table.insert(table.end(), part->begin(), part->end());
  for (KeyInfo& k : table)
    if (auto c = std::get_if<ChoiceField>(&k.field)) k.description += ": " + choice_names(c->choices());
  return table;
}

const std::vector<KeyInfo>& key_table() {
  static const std::vector<KeyInfo> table = make_key_table();
  return table;
}

std::string known_keys() {
  std::string s;
  for (const KeyInfo& k : key_table()) s += (s.empty() ? "" : ", ") + std::string(k.key);
  return s;
}

// Shortest text that parses back to the same double.
std::string double_text(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string range_text(double lo, double hi, bool is_int) {
  std::string s(1, '[');  // appended piece by piece: GCC 12's -Wrestrict misfires on "[" + std::string
  s += is_int ? std::to_string(int(lo)) : double_text(lo);
  s += ", ";
  s += is_int ? std::to_string(int(hi)) : double_text(hi);
  s += ']';
  return s;
}

}  // namespace

void TimingConfig::validate() const {
  auto fail = [&](const std::string& what) { throw std::invalid_argument("timing config " + name + ": " + what); };
  for (const KeyInfo& k : key_table()) {
    if (auto f = std::get_if<int TimingConfig::*>(&k.field)) {
      const int v = this->*(*f);
      if (v < k.lo || v > k.hi)
        fail(std::string(k.key) + " = " + std::to_string(v) + " outside " + range_text(k.lo, k.hi, true));
    } else if (auto d = std::get_if<double TimingConfig::*>(&k.field)) {
      const double v = this->*(*d);
      if (!std::isfinite(v) || v < k.lo || v > k.hi)
        fail(std::string(k.key) + " = " + double_text(v) + " outside " + range_text(k.lo, k.hi, false));
    }
    if (auto c = std::get_if<ChoiceField>(&k.field)) {
      const int v = c->get(*this);
      if (v < 0 || size_t(v) >= c->choices().size())
        fail(std::string(k.key) + " = " + std::to_string(v) + " is not one of " + choice_names(c->choices()));
    }
    // Rules beyond a range, checked in key order so that the first bad key is the one named.
    if (k.rule) {
      const std::string why = k.rule(*this);
      if (!why.empty()) fail(why);
    }
  }
}

// Where the presets' figures come from. Only the BVH width and the box and triangle tests per clock are published
// by the vendors; the other figures are ours, chosen to be of the right order and stated as estimates. The model
// has one cache level: "DRAM" stands for everything behind it (on a GPU: L1/L2, a last-level cache and VRAM), and
// both GPU presets put it about 100 ns behind the unit. The memory-bound presets (rdna2-mem, intel-mem, at the
// end) take their memory from figures published for whole chips: VRAM bandwidth, unit count, clock and cache
// sizes.
//
// rdna2 (the default-constructed TimingConfig): one Ray Accelerator of an RDNA2 compute unit.
//   - BVH4 and 4 ray-box or 1 ray-triangle test per clock per CU: AMD's RDNA2 announcement and "RDNA 2"
//     Instruction Set Architecture reference guide (IMAGE_BVH_INTERSECT_RAY takes a 4-wide box node or one
//     triangle per call); also Chips and Cheese, "RDNA 4's raytracing improvements" (2025), on RDNA2/3's single
//     intersection engine of four box tests or one triangle test per cycle.
//   - 2.0 GHz: the game clock of the RX 6800 XT / 6900 XT (2015 MHz) at its launch (AMD, 2020).
//   - 32 ray slots: one wave32 of rays; RDNA2 runs traversal in shader code, one ray per lane (estimate).
//   - 64 KiB 4-way cache with 64-byte lines: between RDNA's 16 KB per-CU L0 and 128 KB per-array L1 (AMD RDNA
//     whitepaper, 2019); AMD's lines are 128 bytes for its 128-byte float box node, ours 64 bytes for the fixed
//     device's 56-byte BVH4 node (hw_format.h).
//   - 200 cycles (100 ns at 2 GHz) and one 64-byte line per clock behind the cache: estimates.
//   - Pipeline depths (box 6, triangle 12, sphere 16, plane 8) and the command processor's latencies: estimates.
//   - irq_latency 100 cycles (50 ns at 2 GHz): the fence's memory write, the interrupt controller and the message
//     to the host's interrupt controller (an MSI write over the host bus); an estimate of the right order, and
//     kept for every preset (the embedded unit's 1 GHz makes it 100 ns).
//   - any_hit_latency 400 cycles, every preset: the unit's any-hit request reaching the firmware (of the order of
//     irq_latency), the stage's mask lookup (one texel read from memory, of the order of dram_latency) and the
//     answer's way back (irq_latency again); an estimate. DXR and Vulkan leave the cost to the implementation;
//     what is known is that an any-hit shader takes the ray out of the fixed-function unit and back.
//   - xform_latency 12 cycles, every preset: the transform of a two-level scene's ray is three dependent
//     float32 multiply-adds per output component (x' = m0 x + m1 y + m2 z + m3), 4 clocks each in a GPU's FMA
//     pipeline; an estimate, pipelined (no unit is modelled to contend for). Vendors do not publish it.
// intel: one RTU of an Xe core of Intel's Arc A-series (Xe-HPG, "Alchemist").
//   - 12 box tests and 1 triangle test per clock per RTU, in two traversal pipelines, with a dedicated BVH cache:
//     Intel's Arc ray-tracing architecture disclosure (Aug./Sep. 2022, "Intel Arc Graphics: ray tracing"; as
//     reported e.g. by TechPowerUp, "Intel Details its Ray Tracing Architecture", 2022-09-01). Modelled as two box
//     units of rate 6, one per traversal pipeline: each takes a 6-wide node a clock, so two rays' nodes give the
//     12 tests of a clock (one unit of rate 12 would reach 12 only with 12-wide nodes, which Intel's BVH6 has
//     not).
//   - BVH6 of 64-byte nodes: Intel's hardware BVH is 6-wide with 64-byte internal nodes (Embree's GPU BVH
//     layout, as Intel's ray-tracing disclosures describe it); format xe6: the default format's widths in
//     bit-packed 6-wide nodes padded to 64 bytes, primitives in 40-byte records.
//   - 2.1 GHz: the Arc A770's graphics clock (Intel, 2022).
//   - 64 ray slots: traversal runs in the RTU asynchronously from the shaders (Intel's "asynchronous ray
//     tracing"), so more rays are in flight than one SIMD thread's (estimate).
//   - 192 KiB 16-way cache (192 sets) with 64-byte lines: the Xe core's 192 KB L1/shared local memory (Intel
//   Xe-HPG
//     disclosures, 2021-2022), with the RTU's small BVH cache (8 KB on Alchemist per Chips and Cheese, "Raytracing
//     on Intel's Arc B580", 2025) folded into it; Intel GPUs use 64-byte lines.
//   - 210 cycles (100 ns at 2.1 GHz) and one 64-byte line per clock behind the cache: estimates, as for rdna2.
// embedded: a small unit for a mobile or embedded SoC; no vendor publishes such figures, so all are our choices.
//   - Format compact (16-bit grid coordinates), BVH4, one box unit of 2 tests per clock (a BVH4 node in two
//     clocks), one triangle unit, shallower pipelines for the narrower datapath.
//   - 1.0 GHz; 16 ray slots with 4-entry stacks; 16 KiB 4-way cache with 64-byte lines.
//   - 100 cycles (100 ns at 1 GHz) and 16 bytes per cycle behind the cache: about one LPDDR4X-4266 x32 channel
//     (17 GB/s) at 1 GHz.
// The rasterizer (hybrid mode): each preset models one ray-tracing unit, so its raster pipeline is that unit's
// share of the GPU's raster hardware (whole-chip figures divided by the number of ray-tracing units); the
// G-buffer texel is 16 bytes (4 of depth, 12 of primitive index and barycentrics), a primitive 36 bytes.
//   - rdna2: Navi 21 (RX 6900 XT) has 80 CUs (80 Ray Accelerators), 4 primitive units (one triangle per clock
//     each) and 128 ROPs (AMD RDNA2 specifications, 2020): 80 / 4 = 20 cycles per primitive and 128 / 80 = 1.6
//     fragments per clock per unit. Coverage tests at 4x the fragment rate (a rasterizer rejects empty tiles
//     of its scan faster than it emits fragments) and a 100-cycle pipeline: estimates.
//   - intel: Arc A770 has 32 Xe cores (32 RTUs), 8 render slices with one geometry/raster pipeline each and
//     128 ROPs (Intel, 2022): 32 / 8 = 4 cycles per primitive, 128 / 32 = 4 fragments per clock; coverage
//     tests at 4x: estimate.
//   - embedded: our choices for a small SoC GPU with one raster pipeline shared by two units: 8 cycles per
//     primitive, 1 fragment and 4 coverage tests per clock, a 50-cycle pipeline.
// The memory-bound presets, rdna2-mem and intel-mem: the datapath of rdna2 and intel (format, width, units,
// rates, pipeline depths, slots, raster figures) with the memory a real GPU gives one ray-tracing unit: its small
// first-level cache, the latency to VRAM, and its share of the chip's VRAM bandwidth, bandwidth / (units x clock).
// The model has one cache level, so every miss pays the VRAM latency and uses the VRAM bandwidth: real misses of
// the small cache often hit a larger cache first (an L1, an L2, AMD's Infinity Cache), so these presets are the
// pessimistic end of the memory system as rdna2 and intel (a large cache, 64 bytes per clock) are the optimistic
// end. Silicon is between; these are the presets on which bytes cost what they cost when they come from VRAM.
//   - rdna2-mem, one Ray Accelerator of the Radeon RX 6900 XT (Navi 21): 80 CUs with one Ray Accelerator each,
//     2015 MHz game clock (taken as 2.0 GHz, as rdna2), 16 GB GDDR6 on 256 bits = 512 GB/s (AMD, Radeon RX 6000
//     series announcement, Oct. 2020; as reported e.g. by Wccftech, "AMD Radeon RX 6900 XT 'Big Navi' graphics
//     card launches", Dec. 2020). Share: 512 GB/s / (80 x 2.0 GHz) = 3.2 bytes per clock. Cache: the CU's 16 KB
//     L0 vector cache (AMD, "RDNA Architecture" whitepaper, 2019; 32 KB per two-CU WGP on RDNA2 per Wikipedia,
//     "RDNA 2"), with rdna2's 4 ways and 64-byte lines (AMD's L0 lines are 128 bytes; ours stay 64 so that only
//     the size, latency and bandwidth differ from rdna2). The 128 MB Infinity Cache's claimed effective bandwidth
//     (1664 GB/s, 3.25x, in the same announcement) would give 10.4 bytes per clock: this preset is the VRAM miss.
//   - intel-mem, one RTU of the Arc A770 16 GB (Xe-HPG, ACM-G10): 32 Xe cores with one RTU each, 2.1 GHz
//     graphics clock, 560 GB/s on 256 bits (Intel, Arc A-series specifications, Sept. 2022; as reported e.g. by
//     Svět hardware, "Intel zveřejnil oficiální specifikace grafických karet Arc", Sept. 2022). Share: 560 GB/s /
//     (32 x 2.1 GHz) = 8.33 bytes per clock (8.333..., rounded down). Cache: the RTU's own BVH cache, 8 KB on
//     Alchemist (Chips and Cheese, "Raytracing on Intel's Arc B580", 2025); its 4 ways are our estimate, lines
//     64 bytes as on Intel GPUs.
//   - VRAM latency, both: 300 ns from the unit, 600 cycles at 2.0 GHz and 630 at 2.1 GHz. An estimate of the
//     order, not a published figure: Chips and Cheese's pointer-chasing measurements ("Measuring GPU Memory
//     Latency", 2021, on an RX 6800 XT and an RTX 3090) put an L2 hit alone about 66 ns past RDNA2's L0 and over
//     100 ns past Ampere's L1, and VRAM, about equally far on both, well beyond the last cache level: hundreds of
//     ns, here three times the 100 ns that rdna2 and intel take for everything behind their cache.
// The chip presets, rdna2-chip, intel-chip and embedded-chip: the whole chip's units sharing its L2 and DRAM
// (memory_system.h). Each unit is its -mem preset's (the datapath and the unit's small first-level cache); behind
// the units, the chip's L2 and its DRAM channels with banks. A miss that also misses the L2 and opens a row costs
// about the -mem preset's 300 ns: l2_latency + activate + transfer + dram_latency.
//   - rdna2-chip, the RX 6900 XT (Navi 21): 80 units (above). L2: 4 MB in 16 channels of 64 bytes per clock each
//     (AMD, "RDNA Architecture" whitepaper, 2019, for Navi 10's L2; Navi 21 keeps 4 MB, AMD RDNA2 specifications
//     2020), 16 ways (whitepaper). L2 latency 130 cycles: about 66 ns past the L0 (Chips and Cheese, "Measuring
//     GPU Memory Latency", 2021, RX 6800 XT). DRAM: 256-bit GDDR6 is 8 devices of 2 x16 channels = 16 channels,
//     16 banks and 2 KB pages each (Micron MT61K256M32 8 Gb GDDR6 brief, 2018-2019), 512 GB/s = 256 bytes per
//     clock at 2.0 GHz; tRCD = tRP = 26 clocks of 0.57 ns = 14.8 ns (Ramulator 2.0's GDDR6 timing preset, CMU
//     SAFARI), 30 cycles at 2 GHz; dram_latency 440 = 600 - 130 - 30 (rounded). Not modelled: the 128 MB Infinity
//     Cache, which by the same measurements adds about 20 ns to an L2 miss and holds any BVH here: with it, what
//     this preset charges to DRAM would mostly be Infinity Cache hits (about 1.99 TB/s peak, AMD), so this preset
//     is the chip without it, the bandwidth-bound end. `--set l2_kib=131072 --set l2_latency=170` approximates
//     the Infinity Cache as the L2 instead.
//   - intel-chip, the Arc A770 (ACM-G10): 32 units (above). L2: 16 MB (Intel, Arc A-series specifications,
//     2022); its slices (16), ways (16), port width (64 bytes per clock) and latency (136 cycles, 65 ns at 2.1
//     GHz, rdna2-chip's in ns) are our estimates, no figure being published. DRAM: 256-bit GDDR6 at 560 GB/s
//     (above) = 266.67 bytes per clock at 2.1 GHz, 16 channels of 16 banks with 2 KB pages, tRCD = tRP = 14.8 ns =
//     31 cycles (as rdna2-chip); dram_latency 460 = 630 - 136 - 31 (rounded).
//   - embedded-chip: 4 embedded units, our choice for a small SoC GPU. DRAM: LPDDR5-6400 on 64 bits, 4 x16
//     channels of 16 banks with 2 KB pages (JEDEC LPDDR5 organization as Ramulator 2.0's LPDDR5_8Gb_x16 preset
//     has it), 51.2 GB/s = 51.2 bytes per clock at 1 GHz; tRCD = tRP = 15 clocks of 1.25 ns = 18.75 ns (Ramulator
//     2.0's LPDDR5_6400 preset), 19 cycles. L2: 1 MiB in 4 slices of 32 bytes per clock, 16 ways, 30 cycles: our
//     choices; dram_latency 70, so that a miss is the embedded unit's 100 ns plus the row.
// The 2025 units, rdna4 and xe2, with their -mem and -chip presets: built as rdna2 and intel are, and their
// pairs are. Only the BVH width, the box and triangle tests per clock, Xe2's traversal pipelines and BVH cache,
// and the chips' published figures (units, clock, bandwidth, cache sizes) are sources; the rest is marked
// "estimate". rdna4: one Ray Accelerator of an RDNA4 compute unit (Radeon RX 9070 XT, Navi 48).
//   - Two intersection engines per Ray Accelerator: together 8 box tests or 2 triangle tests per clock, where
//     RDNA2/3's one engine did 4 or 1; 8-wide box nodes of 128 bytes with 12-bit quantized child boxes, tested by
//     IMAGE_BVH8_INTERSECT_RAY on both engines at once; compressed primitive nodes that pack triangle pairs (Chips
//     and Cheese, "RDNA 4's raytracing improvements", 2025; AMD, "RDNA4" Instruction Set Architecture reference
//     guide, 2025). Modelled as one box unit of rate 8 (an 8-wide node a clock: the BVH8 instruction's two
//     engines together) and two triangle units of rate 1 (one per engine). Format rdna4 (fixed_format.cpp): the
//     default format's widths with 12-bit child boxes, 8-wide bit-packed nodes padded to 128 bytes, and triangle
//     blocks standing in for AMD's compressed primitive nodes (the triangle-pair layout is not in the model).
//   - The model's box and triangle units work side by side; AMD's engines do box tests or triangle tests in a
//     clock. The same holds for rdna2: both are optimistic when a ray mixes the two in one clock.
//   - 2.4 GHz: the RX 9070 XT's game clock (2400 MHz; boost 2970 MHz; AMD, Radeon RX 9070 series
//     specifications, Feb. 2025, as reported e.g. by Multiplayer.it, 2025). The game clock, as rdna2 takes the RX
//     6900 XT's, so that the rdna2 -> rdna4 step compares like with like; at the boost clock the same unit's
//     figures per clock hold and only the seconds and bytes per clock change.
//   - 64 ray slots: two wave32s of rays, one per intersection engine, as rdna2's 32 for its one (estimate).
//   - 64 KiB 4-way cache with 64-byte lines, 240 cycles (100 ns at 2.4 GHz) and 64 bytes per clock behind it:
//     rdna2's estimates, the latency kept at 100 ns.
//   - Pipeline depths and the command processor's latencies: rdna2's (estimates).
//   - Rasterizer: 64 CUs and 128 ROPs (AMD, same specifications): 2 fragments per clock per unit, coverage
//     tests at 4x (estimate); Navi 48's four shader engines (AMD's RDNA4 architecture deck, Feb. 2025, as reported
//     by Neowin and TechPowerUp) with one primitive unit each (estimate): 64 / 4 = 16 cycles per primitive.
// xe2: one RTU of an Xe2 core of Intel's Arc B580 (Xe2-HPG, "Battlemage", BMG-G21).
//   - 18 box tests and 2 triangle tests per clock per RTU, in three traversal pipelines where Xe-HPG had two,
//     and a 16 KB BVH cache where Xe-HPG had 8 KB (Chips and Cheese, "Raytracing on Intel's Arc B580", 2025):
//     6 box tests per pipeline, as Xe-HPG's 12 in two. Modelled as intel is: three box units of rate 6, one per
//     traversal pipeline, and two triangle units of rate 1. The model has no traversal pipeline of its own (the
//     scheduler's traversal_latency is pipelined, without an issue limit), so a pipeline is its box unit and its
//     share of the ray slots: 96 slots, 32 per pipeline as intel's 64 for two (estimate).
//   - BVH6 of 64-byte nodes, format xe6, as intel (Xe2 keeps Xe-HPG's BVH; the same article).
//   - 2.67 GHz: the B580's graphics clock (2670 MHz; Intel, Arc B-series specifications, Dec. 2024, as
//     TechPowerUp's review and GPU database list it), as intel takes the A770's graphics clock; partner cards and
//     Geekbench runs boost to 2.85 GHz.
//   - 256 KiB 16-way cache (256 sets) with 64-byte lines: the Xe2 core's 256 KB L1/shared local memory (Intel
//     Xe2 disclosures, 2024; TechPowerUp's GPU database), with the 16 KB BVH cache folded into it as intel folds
//     its 8 KB; 267 cycles (100 ns at 2.67 GHz) and 64 bytes per clock behind it: estimates, as intel's.
//   - Rasterizer: 20 Xe cores, 5 render slices, 80 ROPs (TechPowerUp's GPU database): 20 / 5 = 4 cycles per
//     primitive, 80 / 20 = 4 fragments per clock, coverage tests at 4x (estimate): intel's figures.
// rdna4-mem and xe2-mem: the datapath of rdna4 and xe2 with one unit's share of the chip's memory, as rdna2-mem
// and intel-mem are built; every miss pays 300 ns (the same estimate) and the VRAM bandwidth.
//   - rdna4-mem, one Ray Accelerator of the RX 9070 XT: 64 CUs with one Ray Accelerator each, 2.4 GHz (above),
//     16 GB GDDR6 on 256 bits: 644.6 GB/s at 20.1 Gbps (TechPowerUp's GPU database; AMD rounds to 640 GB/s at 20
//     Gbps). Share: 644.6 / (64 x 2.4) = 4.197, 4.19 bytes per clock (rounded down). Cache: the CU's 32 KB L0
//     vector cache (doubled from 16 KB in RDNA3, AMD's RDNA3 disclosure, 2022; taken as unchanged in RDNA4, an
//     estimate), 4 ways and 64-byte lines as rdna2-mem. VRAM 300 ns = 720 cycles at 2.4 GHz. The 64 MB Infinity
//     Cache (AMD, same specifications) is left out as rdna2-mem leaves out Navi 21's 128 MB: this preset is the
//     VRAM miss, the pessimistic end.
//   - xe2-mem, one RTU of the Arc B580: 20 Xe2 cores with one RTU each, 2.67 GHz, 12 GB GDDR6 on 192 bits at
//     19 Gbps = 456 GB/s (Intel, same specifications). Share: 456 / (20 x 2.67) = 8.539, 8.53 bytes per clock
//     (rounded down). Cache: the RTU's 16 KB BVH cache (Chips and Cheese, above); 4 ways as intel-mem (estimate).
//     VRAM 300 ns = 801 cycles at 2.67 GHz.
// rdna4-chip and xe2-chip: the chips' units sharing their L2 and DRAM, built as rdna2-chip and intel-chip.
//   - rdna4-chip, the RX 9070 XT (Navi 48): 64 rdna4-mem units. L2: 8 MB (AMD, same specifications) in 16
//     slices of 64 bytes per clock, 16 ways (rdna2-chip's organization: estimates). L2 latency 158 cycles: rdna2-
//     chip's 66 ns at 2.4 GHz (estimate; no RDNA4 measurement found). DRAM: 256-bit GDDR6, 8 devices of 2 x16
//     channels = 16 channels of 16 banks with 2 KB pages (as rdna2-chip), 644.6 GB/s = 268.58 bytes per clock at
//     2.4 GHz, tRCD = tRP = 14.8 ns = 36 cycles; dram_latency 526 = 720 - 158 - 36. The memory system has one
//     cache level behind the units (memory_system.h), so the 64 MB Infinity Cache between the L2 and DRAM is not
//     modelled: as rdna2-chip, this is the chip without it, the bandwidth-bound end; `--set l2_kib=73728 --set
//     l2_latency=206` approximates the L2 and Infinity Cache as one 72 MB level at the Infinity Cache's latency
//     (rdna2-chip's +20 ns past the L2, an estimate).
//   - xe2-chip, the Arc B580 (BMG-G21): 20 xe2-mem units. L2: 18 MB (Intel, same specifications) in 16 slices
//     of 16 ways and 64 bytes per clock, intel-chip's organization (estimates; 16 slices also keep every chip
//     preset's L2 size a whole number of sets in every other's slices, which `--set` round trips need). L2 latency
//     174 cycles: intel-chip's 65 ns at 2.67 GHz (estimate). DRAM: 192-bit GDDR6, 6 devices of 2 x16 channels = 12
//     channels of 16 banks with 2 KB pages, 456 GB/s = 170.79 bytes per clock at 2.67 GHz, tRCD = tRP = 14.8 ns =
//     40 cycles; dram_latency 587 = 801 - 174 - 40.
// The papers' baseline, vksim-mobile and vksim-rtx2060 with their -chip presets: the GPUs that Vulkan-Sim 2.0
// (ubc-aamodt-group/vulkan-sim, tag v2.0.0) simulates, as its configuration files give them, for the latency
// papers measured on it (bench/results/latency-hiding.md): treelet prefetching (Chou et al., MICRO 2023) ships the
// mobile one with its code (ubc-aamodt-group/treelet-prefetching-for-rt, configs/tested-cfgs/treelet_prefetching/
// gpgpusim.config); TTP's code (yavuz650/vulkan-sim, branch traversal_trend_prefetcher, configs/updated-config/)
// ships both, and which one its paper reports is not published. Vulkan-Sim's figures, in its config options:
//   - clock 1365 MHz for the cores, interconnect and L2 (-gpgpu_clock_domains 1365:1365:1365:3500); one RT unit
//     per SM (-gpgpu_num_rt_core_units 1); a unit holds -gpgpu_rt_max_warps warps of 32 rays: 16 on the mobile
//     SoC (512 ray slots), 4 on the RTX 2060 (128).
//   - the RT unit's node cache is the SM's L1D (-gpgpu_rt_use_l1 1): 64 KB, fully associative, 128-byte lines of
//     32-byte sectors, 20 cycles (-gpgpu_cache:dl1 S:1:128:512, -gpgpu_l1_latency 20). The model has at most 64
//     ways (16 sets of 64 here) and fills whole lines, so its lines are 64 bytes: a node's two sectors.
//   - nodes: Mesa's BVH6 of 64-byte internal nodes (Vulkan-Sim's vulkan_acceleration_structure_util.h): format
//   xe6,
//     bvh_width 6. Node test latencies (-gpgpu_rt_intersection_latency, internal node and quad leaf): 4 and 4
//     cycles on the mobile SoC, 8 and 8 on the RTX 2060. A node per clock (box_rate 6) is our estimate: Vulkan-Sim
//     gives no test rate.
//   - mobile SoC: 8 SMs (-gpgpu_n_clusters 8); L2 64 sets x 16 ways x 128 bytes per channel, 4 channels
//   (-gpgpu_n_mem
//     4): 512 KB (the file's "3MB" comment is the RTX 2060's); DRAM 4 channels of 16 bits, burst 8 at ratio 2 from
//     3500 MHz: 14 GB/s each, 56 GB/s = 41.03 bytes per clock at 1.365 GHz.
//   - RTX 2060: 30 SMs; L2 the same per sub-partition, 12 channels x 2 sub-partitions: 3 MB in 24 slices; 12
//     GDDR6 channels, burst 16 at ratio 4: 28 GB/s each, 336 GB/s = 246.15 bytes per clock.
//   - both: L2 latency 160 (-gpgpu_l2_rop_latency), 100 more to DRAM (-dram_latency), 16 banks per channel, tRCD
//     = tRP = tCL = 20 DRAM clocks at 3.5 GHz = 5.7 ns = 8 cycles: dram_latency 108 (100 + tCL),
//     dram_activate_cycles = dram_precharge_cycles = 8. Our estimates: 2 KB rows, an L2 slice's 32 bytes per
//     clock (one sector), 16-way slices of 128 KB (the config's sets x ways x line per sub-partition).
//   - the unit presets take, as the -mem presets do, one unit's share of the DRAM bandwidth (5.12 and 8.2 bytes
//     per clock, rounded down) and an L2 miss that opens a row for every miss: 160 + 8 + 108 = 276 cycles.
//   Not modelled: Vulkan-Sim's RT unit sends one 32-byte request a clock (a 64-byte node takes two), its warps'
//   rays move through the unit together, and its interconnect; the pipeline depths not named above are rdna2's.
namespace {

void assign_timing_key(TimingConfig& t, const std::string& key, const std::string& value);  // below

// A preset: the preset it starts from (null: the defaults of TimingConfig, which are rdna2's figures), the line
// `rtusim config --list` prints, and what it changes, as the `--set` keys it would take ("key=value ..."; the
// figures' sources are above). A new key whose default in timing_config.h is neutral (it changes nothing unless
// set) needs no entry here.
struct Preset {
  const char* name;
  const char* base;
  const char* description;
  const char* overrides;
};

const std::array<Preset, 19> kPresets = {{
    {"rdna2", nullptr,
     "resembles one AMD RDNA2 Ray Accelerator: BVH4, 4 box tests or 1 triangle test per clock, 2.0 GHz", ""},
    {"intel", "rdna2",
     "resembles one Intel Xe-HPG (Arc A-series) RTU: BVH6, 12 box tests and 1 triangle test per clock, "
     "2.1 GHz",
     "format=xe6 bvh_width=6 clock_ghz=2.1 ray_slots=64 box_units=2 box_rate=6 tri_units=1 tri_rate=1 "
     "cache_kib=192 cache_ways=16 line_bytes=64 layout_align=0 dram_latency=210 dram_bytes_per_cycle=64.0 "
     "raster_setup_cycles=4.0 raster_samples_per_clock=16.0 raster_fragments_per_clock=4.0 raster_latency=100"},
    {"embedded", "rdna2",
     "a small embedded unit: format compact (16-bit coordinates), BVH4, 2 box tests per clock, 16 KiB "
     "cache, 1.0 GHz",
     "format=compact bvh_width=4 clock_ghz=1.0 ray_slots=16 stack_entries=4 box_units=1 box_rate=2 box_latency=4 "
     "tri_units=1 tri_rate=1 tri_latency=10 sphere_latency=12 plane_latency=6 queue_depth=8 cache_kib=16 "
     "cache_ways=4 line_bytes=64 layout_align=0 cache_latency=2 dram_latency=100 dram_bytes_per_cycle=16.0 "
     "memory_type=lpddr5 raster_setup_cycles=8.0 raster_samples_per_clock=4.0 raster_fragments_per_clock=1.0 "
     "raster_latency=50"},
    {"rdna2-mem", "rdna2",
     "rdna2's datapath with one RX 6900 XT Ray Accelerator's memory: 16 KiB cache, 300 ns and 3.2 bytes per "
     "clock (512 GB/s over 80 units) to VRAM",
     "cache_kib=16 cache_ways=4 line_bytes=64 layout_align=0 cache_latency=4 dram_latency=600 "
     "dram_bytes_per_cycle=3.2"},
    {"intel-mem", "intel",
     "intel's datapath with one Arc A770 RTU's memory: 8 KiB BVH cache, 300 ns and 8.33 bytes per clock "
     "(560 GB/s over 32 units) to VRAM",
     "cache_kib=8 cache_ways=4 line_bytes=64 layout_align=0 cache_latency=4 dram_latency=630 "
     "dram_bytes_per_cycle=8.33"},
    {"rdna2-chip", "rdna2-mem",
     "an RX 6900 XT-class chip: 80 rdna2-mem units, a 4 MB L2 in 16 slices, 16 GDDR6 channels of 16 banks, "
     "512 GB/s (no Infinity Cache)",
     "units=80 ray_policy=waves l2_kib=4096 l2_slices=16 l2_ways=16 l2_latency=130 l2_bytes_per_cycle=64.0 "
     "dram_channels=16 dram_banks=16 dram_row_bytes=2048 dram_activate_cycles=30 dram_precharge_cycles=30 "
     "dram_bytes_per_cycle=256.0 dram_latency=440"},
    {"intel-chip", "intel-mem",
     "an Arc A770-class chip: 32 intel-mem units, a 16 MB L2 in 16 slices, 16 GDDR6 channels of 16 banks, "
     "560 GB/s",
     "units=32 ray_policy=waves l2_kib=16384 l2_slices=16 l2_ways=16 l2_latency=136 l2_bytes_per_cycle=64.0 "
     "dram_channels=16 dram_banks=16 dram_row_bytes=2048 dram_activate_cycles=31 dram_precharge_cycles=31 "
     "dram_bytes_per_cycle=266.67 dram_latency=460"},
    {"embedded-chip", "embedded",
     "a small SoC GPU: 4 embedded units, a 1 MiB L2, LPDDR5-6400 on 64 bits (4 channels of 16 banks), "
     "51.2 GB/s",
     "units=4 ray_policy=waves l2_kib=1024 l2_slices=4 l2_ways=16 l2_latency=30 l2_bytes_per_cycle=32.0 "
     "dram_channels=4 dram_banks=16 dram_row_bytes=2048 dram_activate_cycles=19 dram_precharge_cycles=19 "
     "dram_bytes_per_cycle=51.2 dram_latency=70"},
    {"rdna4", "rdna2",
     "resembles one AMD RDNA4 Ray Accelerator: BVH8 (128-byte nodes, 12-bit child boxes), 8 box tests or 2 "
     "triangle tests per clock, 2.4 GHz",
     "format=rdna4 bvh_width=8 clock_ghz=2.4 ray_slots=64 box_units=1 box_rate=8 tri_units=2 tri_rate=1 "
     "dram_latency=240 raster_setup_cycles=16.0 raster_samples_per_clock=8.0 raster_fragments_per_clock=2.0"},
    {"xe2", "intel",
     "resembles one Intel Xe2 (Arc B580) RTU: BVH6, 3 traversal pipelines, 18 box tests and 2 triangle tests per "
     "clock, 2.67 GHz",
     "clock_ghz=2.67 ray_slots=96 box_units=3 box_rate=6 tri_units=2 tri_rate=1 cache_kib=256 cache_ways=16 "
     "dram_latency=267"},
    {"rdna4-mem", "rdna4",
     "rdna4's datapath with one RX 9070 XT Ray Accelerator's memory: 32 KiB cache, 300 ns and 4.19 bytes per "
     "clock (644.6 GB/s over 64 units) to VRAM",
     "cache_kib=32 cache_ways=4 line_bytes=64 layout_align=0 cache_latency=4 dram_latency=720 "
     "dram_bytes_per_cycle=4.19"},
    {"xe2-mem", "xe2",
     "xe2's datapath with one Arc B580 RTU's memory: 16 KiB BVH cache, 300 ns and 8.53 bytes per clock "
     "(456 GB/s over 20 units) to VRAM",
     "cache_kib=16 cache_ways=4 line_bytes=64 layout_align=0 cache_latency=4 dram_latency=801 "
     "dram_bytes_per_cycle=8.53"},
    {"rdna4-chip", "rdna4-mem",
     "an RX 9070 XT-class chip: 64 rdna4-mem units, an 8 MB L2 in 16 slices, 16 GDDR6 channels of 16 banks, "
     "644.6 GB/s (no Infinity Cache)",
     "units=64 ray_policy=waves l2_kib=8192 l2_slices=16 l2_ways=16 l2_latency=158 l2_bytes_per_cycle=64.0 "
     "dram_channels=16 dram_banks=16 dram_row_bytes=2048 dram_activate_cycles=36 dram_precharge_cycles=36 "
     "dram_bytes_per_cycle=268.58 dram_latency=526"},
    {"xe2-chip", "xe2-mem",
     "an Arc B580-class chip: 20 xe2-mem units, an 18 MB L2 in 16 slices, 12 GDDR6 channels of 16 banks, "
     "456 GB/s",
     "units=20 ray_policy=waves l2_kib=18432 l2_slices=16 l2_ways=16 l2_latency=174 l2_bytes_per_cycle=64.0 "
     "dram_channels=12 dram_banks=16 dram_row_bytes=2048 dram_activate_cycles=40 dram_precharge_cycles=40 "
     "dram_bytes_per_cycle=170.79 dram_latency=587"},
    {"rdna4-lss", "rdna4-mem",
     "what-if: rdna4-mem with a curve unit testing one linear swept sphere a clock (20 clocks deep), as NVIDIA "
     "Blackwell's RT core adds for hair; rate and depth are estimates",
     "curve_units=1 curve_rate=1"},
    {"vksim-mobile", "rdna2",
     "the papers' baseline: one RT unit of Vulkan-Sim's mobile SoC (treelet prefetching, MICRO 2023): BVH6, 512 "
     "rays, 64 KB L1 at 20 cycles, 1.365 GHz",
     "format=xe6 bvh_width=6 clock_ghz=1.365 ray_slots=512 box_units=1 box_rate=6 box_latency=4 tri_units=1 "
     "tri_rate=1 tri_latency=4 cache_kib=64 cache_ways=64 line_bytes=64 layout_align=0 cache_latency=20 "
     "dram_latency=276 dram_bytes_per_cycle=5.12"},
    {"vksim-mobile-chip", "vksim-mobile",
     "the papers' baseline chip: Vulkan-Sim's mobile SoC, 8 RT units, a 512 KB L2 in 4 slices, 4 DRAM channels, "
     "56 GB/s",
     "units=8 ray_policy=waves l2_kib=512 l2_slices=4 l2_ways=16 l2_latency=160 l2_bytes_per_cycle=32.0 "
     "dram_channels=4 dram_banks=16 dram_row_bytes=2048 dram_activate_cycles=8 dram_precharge_cycles=8 "
     "dram_bytes_per_cycle=41.03 dram_latency=108"},
    {"vksim-rtx2060", "vksim-mobile",
     "one RT unit of Vulkan-Sim's RTX 2060 configuration: BVH6, 128 rays, 64 KB L1 at 20 cycles, 1.365 GHz",
     "ray_slots=128 box_latency=8 tri_latency=8 dram_bytes_per_cycle=8.2"},
    {"vksim-rtx2060-chip", "vksim-rtx2060",
     "Vulkan-Sim's RTX 2060: 30 RT units, a 3 MB L2 in 24 slices, 12 GDDR6 channels, 336 GB/s",
     "units=30 ray_policy=waves l2_kib=3072 l2_slices=24 l2_ways=16 l2_latency=160 l2_bytes_per_cycle=32.0 "
     "dram_channels=12 dram_banks=16 dram_row_bytes=2048 dram_activate_cycles=8 dram_precharge_cycles=8 "
     "dram_bytes_per_cycle=246.15 dram_latency=108"},
}};

const Preset& find_preset(const std::string& name) {
  for (const Preset& p : kPresets)
    if (name == p.name) return p;
  std::string names;
  for (const Preset& p : kPresets) names += (names.empty() ? "" : ", ") + std::string(p.name);
  throw std::invalid_argument("unknown timing preset '" + name + "' (known: " + names + ")");
}

}  // namespace

const std::vector<std::string>& timing_preset_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> v;
    for (const Preset& p : kPresets) v.push_back(p.name);
    return v;
  }();
  return names;
}

TimingConfig timing_preset(const std::string& name) {
  const Preset& p = find_preset(name);
  TimingConfig c = p.base ? timing_preset(p.base) : TimingConfig{};
  c.name = p.name;
  // Each key=value as --set reads it; the whole preset is validated by the tests (a key alone may not be).
  const std::string text = p.overrides;
  for (size_t at = 0; at < text.size();) {
    const size_t end = std::min(text.find(' ', at), text.size());
    const std::string kv = text.substr(at, end - at);
    const size_t eq = kv.find('=');
    assign_timing_key(c, kv.substr(0, eq), kv.substr(eq + 1));
    at = end + 1;
  }
  return c;
}

std::string timing_preset_description(const std::string& name) {
  return find_preset(name).description;
}

std::vector<TimingKey> timing_keys(const TimingConfig& c) {
  std::vector<TimingKey> keys;
  for (const KeyInfo& k : key_table()) {
    std::string value;
    if (auto f = std::get_if<int TimingConfig::*>(&k.field))
      value = std::to_string(c.*(*f));
    else if (auto d = std::get_if<double TimingConfig::*>(&k.field))
      value = double_text(c.*(*d));
    else if (auto ch = std::get_if<ChoiceField>(&k.field))
      value = size_t(ch->get(c)) < ch->choices().size() ? ch->choices()[size_t(ch->get(c))].name
                                                        : std::to_string(ch->get(c));
    else
      value = c.*std::get<std::string TimingConfig::*>(k.field);
    keys.push_back(TimingKey{k.key, value, k.description});
  }
  return keys;
}

namespace {

// Sets one key of c from its text, as --set does, without validating the whole configuration (a preset's keys
// are validated together); throws std::invalid_argument naming the key for an unknown key or a malformed value.
void assign_timing_key(TimingConfig& t, const std::string& key, const std::string& value) {
  const KeyInfo* info = nullptr;
  for (const KeyInfo& k : key_table())
    if (key == k.key) info = &k;
  if (info == nullptr)
    throw std::invalid_argument("unknown timing config key '" + key + "' (known: " + known_keys() + ")");
  auto bad = [&](const char* what) {
    throw std::invalid_argument("timing config key " + key + ": '" + value + "' is not " + what);
  };
  const char* first = value.data();
  const char* last = value.data() + value.size();
  if (auto f = std::get_if<int TimingConfig::*>(&info->field)) {
    int v = 0;
    const auto r = std::from_chars(first, last, v);
    if (r.ec == std::errc::result_out_of_range && r.ptr == last) bad("an integer in range");
    if (value.empty() || r.ec != std::errc() || r.ptr != last) bad("a decimal integer");
    t.*(*f) = v;
  } else if (auto d = std::get_if<double TimingConfig::*>(&info->field)) {
    double v = 0;
    const auto r = std::from_chars(first, last, v);
    if (value.empty() || r.ec != std::errc() || r.ptr != last || !std::isfinite(v)) bad("a finite number");
    t.*(*d) = v;
  } else if (auto c = std::get_if<ChoiceField>(&info->field)) {
    const std::span<const TimingChoice> choices = c->choices();
    size_t i = 0;
    while (i < choices.size() && value != choices[i].name) ++i;
    if (i == choices.size())
      throw std::invalid_argument("timing config: " + key + " = '" + value + "' must be " + choice_names(choices));
    c->set(t, int(i));
  } else {
    t.*std::get<std::string TimingConfig::*>(info->field) = value;
  }
}

}  // namespace

void set_timing_key(TimingConfig& c, const std::string& key, const std::string& value) {
  TimingConfig t = c;
  assign_timing_key(t, key, value);
  t.validate();
  c = t;
}

}  // namespace rtu::hw
