// Sampled timing (SMARTS-style sampling, Wunderlich et al., ISCA 2003): the timed device simulates a fraction of a
// TRACE packet's rays in the timing model and estimates the packet's cycles with a stated 95% interval.
//
// A packet is cut into units of unit_rays consecutive rays. The first unit is simulated from the packet's start
// (its fill) and the last to the packet's end (its drain). Of the units between, about one in k (k = round(1 /
// fraction)) is measured, each after
// - functional warming: rays before it whose fetches only warm the cache, walked backwards until they fix the
//   cache state the measured rays meet (TimingModel::walk_add), at most cache_warm_rays;
// - a detailed warm-up: rays simulated but not measured, so that slots and queues are in steady state; its length
//   follows from how long the stream's rays hold their slots (warmup_rays());
// and before 2 x ray_slots tail rays; its cost is the cycles between the hit of the warm-up's last ray and the
// unit's last hit, counted in order of writing.
//
// The units between are sampled in two strata where both are large (units whose rays test no primitive and units
// whose rays do: camera rays' sky and geometry), the sample shared by sqrt(units x auxiliary total) of each
// stratum (Neyman's allocation with costs, Cochran, "Sampling Techniques", 5.5) and spread evenly over its units;
// otherwise systematically, every k-th from a seeded offset. Each stratum's cycles are a ratio estimate (Cochran
// 6.10) on an auxiliary known for every unit, the unit's work rays + box tests / box rate + primitive tests /
// test rate, with the jackknife variance of the ratio, finite-population corrected. The auxiliary comes from
// every ray when hits are needed (the datapath then traces every ray anyway; only the timing model is sampled),
// else from one ray in each block of 32 at a seeded random place in the block, scaled up (a cheap functional
// probe), and from all rays for the measured units (two-phase sampling). The auxiliary is a sum, not a maximum
// of rates, because the probe's estimate of a sum is unbiased and that of a maximum is not.
//
// Measured units and probed rays are drawn afresh for each packet, from the seed and the packet's number. A
// packet too short for 10 measured units at every k-th is sampled at the largest k that gives 10, provided the
// measured units' rays with their warm-up and tail are at most half of its rays; otherwise it is simulated in
// full. Timing counters are those of the simulated rays scaled to the packet (timing_stats.h, SampleScale).
//
// This header holds the options, the statistics and the estimator's pure functions; TimedEngine
// (timed_engine_sampled.cpp, timed_engine_chip.cpp) runs the datapath and the timing model around them.
// docs/timing-model.md says how the constants were chosen and what the estimator's error is on the benchmark
// meshes.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace rtu::hw {

struct SampleOptions {
  double fraction = 0.0;  // 0 (or >= 1): simulate every ray
  uint32_t unit_rays = 256;
  // Detailed warm-up before each measured unit; 0: chosen for each stream from how long its rays hold their slots
  // (warmup_rays()).
  uint32_t warmup_rays = 0;
  // At most this many rays before the detailed warm-up warm the cache functionally (fetches only): as many as it
  // takes to fix the cache state the simulated rays meet (a few hundred incoherent rays; camera rays find their
  // lines in the previous image row, more than a detailed warm-up can afford).
  uint32_t cache_warm_rays = 4096;
  uint64_t seed = 1;
  bool need_hits = true;
};

struct SampleStats {
  uint64_t packets = 0, packets_sampled = 0;  // TRACE packets, and those estimated from a sample
  uint64_t rays = 0, rays_simulated = 0;      // rays in them, and rays through the timing model (with warm-up)
  uint64_t rays_warmed = 0;                   // rays traced only to warm the cache (functional warming)
  uint64_t units_measured = 0;
  uint64_t warmup_rays = 0;         // detailed warm-up rays simulated before the measured units, in all
  uint64_t packets_stratified = 0;  // sampled in two strata: units testing no primitive, units testing some
  uint64_t packets_unthinned = 0;   // sampling asked for (--sample) but the packet simulated in full
  std::string unthinned_why;        // why, for the first of them
  double variance = 0.0;            // of the summed cycle estimate (0 for fully simulated packets)
  double ci95() const;              // half-width of the 95% confidence interval of the cycles, 1.96 sqrt(variance)
};

// Every k-th unit measured for a fraction: round(1 / fraction); 1 (every ray simulated) for a fraction of 0.
size_t sample_step(double fraction);

// The step for a packet of n rays in units of unit_rays: k itself when the packet holds 10 measured units at every
// k-th; else the largest k' that gives 10, if the measured units' rays (per_unit each, with warm-up and tail) are
// then at most half of the packet's rays; else 1 (simulate the packet in full). k < 2 is returned as is.
size_t packet_step(size_t n, size_t unit_rays, size_t k, size_t per_unit);

// The random numbers of a packet: from the seed and the number of packets sampled before it.
uint64_t packet_draw(uint64_t seed, uint64_t packet);

// The ray probed in each block of `stride` consecutive rays of n (one per block, at a place drawn from `draw`
// within it; the last block may be shorter). stride 1: every ray.
std::vector<size_t> probe_rays(size_t n, size_t stride, uint64_t draw);

// A unit's auxiliary: its rays plus its box tests over the box rate plus its primitive tests over the test rate.
inline double unit_work(double rays, double box_tests, double prim_tests, double box_rate, double test_rate) {
  return rays + box_tests / box_rate + prim_tests / test_rate;
}

struct Stratum {
  std::vector<size_t> units;       // its units, in order
  std::vector<size_t> picked;      // the measured ones among them, in order
  std::vector<double> measured_c;  // their cycles, in the order of `picked`
  double probe_error2 = 0.0;       // sum over them of (probe's auxiliary - exact auxiliary)^2
};

// The strata of units 1 .. aux.size() - 2 and the units measured in each (`picked`; measured_c left empty):
// two strata (units whose probed rays test no primitive, units whose rays do) when each holds at least 2k units,
// the sample shared by sqrt(units x auxiliary total) with at least 2 in each, spread evenly from a seeded fraction
// of a step; otherwise one stratum, every k-th unit from a seeded offset in [1, k]. k >= 2.
std::vector<Stratum> choose_strata(const std::vector<double>& aux, const std::vector<uint8_t>& tests_prims,
                                   size_t k, uint64_t draw);

// The jackknife variance of the ratio sum(c) / sum(x) over pairs (c[q], x[q]): (m - 1) / m times the squared
// deviations of the ratios with each pair left out from their mean; 0 for fewer than 2 pairs.
double jackknife_ratio_variance(const std::vector<double>& c, const std::vector<double>& x);

// The packet's cycles and the variance of the estimate: `exact` (the cycles of the units simulated in full) plus,
// per stratum, the ratio estimate (measured cycles / measured auxiliary x the stratum's auxiliary total; aux holds
// the exact values of the measured units); the variance is, per stratum, the ratio's jackknife variance,
// finite-population corrected, plus what the probe's error in the unmeasured units' auxiliary adds.
struct CycleEstimate {
  double cycles = 0.0, variance = 0.0;
};
CycleEstimate estimate_cycles(const std::vector<Stratum>& strata, const std::vector<double>& aux, double exact);

// Sampled timing on a chip (ray_policy dynamic: a wave of ray_slots rays to whichever unit asks first). A chip's
// packet is short for its slots (262,144 rays are about 100 rays per slot on 80 units of 32), too short for units
// measured apart, each after its own warm-up from empty slots. The chip runs a thinned packet instead, every unit
// and the shared memory simulated, so the measured rays meet the contention the whole packet has:
// - the lead: its first kChipLeadTurns turns (a turn: a wave per unit), the fill, simulated;
// - bursts of kChipBurstTurns turns between, every k-th from a seeded offset measured, each after kChipWarmTurns
//   warm-up turns and before kChipTailTurns tail turns, simulated but not measured (the slots in steady state on
//   both sides of it; the warm-up and the tail lie in the bursts next to it);
// - the trail: its last kChipTrailTurns turns, the drain, simulated;
// - before each simulated wave the waves skipped since the last warm the chip functionally (their fetches'
//   lines as reads would leave them; no time): the shared L2 with every skipped wave, and each unit's node cache
//   with the skipped waves it would have taken in turn (wave number mod units; under dynamic dispatch which unit
//   takes a wave is decided only as the packet runs, and in turn is each unit's share of them).
// The lead and the trail are taken as simulated. A measured burst's cost is the cycles from the last hit of the
// rays before it to the last of its own, counted in order of writing (as a single unit's sample is); the cycles
// between lead and trail are the ratio of the bursts' cost to their work (unit_work) times the work of every wave
// between, with the ratio's jackknife variance over the bursts, finite-population corrected. Every ray is traced
// (the skipped ones too: their hits and their lines), so the speed-up is the timing model's, not the datapath's.
// docs/timing-model.md gives the error measured on renders.
struct ChipThinning {
  bool sampled = false;
  size_t lead = 0, trail = 0;            // waves
  size_t burst = 0, warm = 0, tail = 0;  // turns per measured burst, and simulated before and after it
  std::string why_not;                   // not sampled though k >= 2: why (for the summary and the stats)
};
inline constexpr size_t kChipLeadTurns = 4, kChipTrailTurns = 4, kChipBurstTurns = 4, kChipWarmTurns = 2,
                        kChipTailTurns = 1;
// Bursts measured at the least: the interval's t quantile for 3 degrees of freedom is 3.18 (for 1, 12.7).
inline constexpr size_t kChipMinBursts = 4;
static_assert(kChipWarmTurns + kChipTailTurns <= kChipBurstTurns,
              "a burst's warm-up and tail lie in its neighbours");
// The thinning of a packet of `waves` waves on `units` units at every k-th burst: sampled when at least
// kChipMinBursts bursts are measured and what is simulated is at most half the waves; otherwise not (every wave
// simulated, why_not says why). Shorter bursts would thin shorter packets (a chip's 262,144-ray packets: 8192
// waves on 80 units hold 23 bursts of 4 turns, 2 measured at 1 in 10; 47 of 2 turns, 4 measured), but 2-turn
// bursts with one warm-up turn left the estimate 1-3.5% low on them, outside its interval for 2 of 4 seeds
// (docs/timing-model.md): the packet is simulated in full instead, and the statistics say why.
ChipThinning chip_thinning(size_t waves, size_t units, size_t k, size_t burst_turns = kChipBurstTurns);
struct ChipSample {
  uint64_t lead_done = 0, mid_done = 0;        // the last hit of the lead's rays, and of the rays before the trail
  uint64_t end = 0;                            // the thinned packet's last hit
  std::vector<double> measured_c, measured_a;  // per measured burst: cycles (in order of writing), work
  double skipped_work = 0.0;                   // of the waves between lead and trail not in a measured burst
  double population = 0.0, sampled = 0.0;      // waves between lead and trail, and those measured
};
// Student's t quantile for a two-sided 95% interval with df degrees of freedom (1.96 beyond 30).
double student_t975(size_t df);
// The packet's cycles from `start`, and the variance: the lead, the ratio x the work between, the trail; the
// variance scaled so that 1.96 sqrt(variance) is the t interval of the bursts' jackknife.
CycleEstimate estimate_chip_cycles(const ChipSample& c, uint64_t start);

// The detailed warm-up's length. A segment starts with every ray slot free, but in the full simulation some slots
// are held at that point by rays that entered long before (a stream's slowest rays, chains of cache misses, stay
// in flight while hundreds of others pass). After a warm-up of w rays, rays that entered up to w rays before the
// unit can hold slots in it; older ones are missing and the unit runs faster than it would. The share of slot time
// they would hold is, of each measured ray's time in its slot, the part beyond the time w + unit_rays / 2 rays
// take to pass at its unit's rate, summed and divided by the rays' total time in slots. The account keeps those
// sums for each w of the grid (multiples of ray_slots), over the measured units of one stream (a ray type and
// bounce).
inline constexpr std::array<size_t, 15> kWarmupGrid = {8, 10, 12, 14, 16, 18, 20, 22, 24, 28, 32, 40, 48, 56, 64};
struct SlotTimeAccount {
  std::array<double, kWarmupGrid.size()> late{};
  double held = 0.0;
  uint64_t rays = 0;
};
// Adds a measured unit to the account: its rays are those that entered between the w-th and the (w + unit_rays -
// 1)-th entry of `entered` in order; `written` and `entered` are every simulated ray's hit-write and entry cycles
// (in the same order), `done` the hit-write cycles sorted.
void account_slot_time(SlotTimeAccount& a, const std::vector<uint64_t>& done, const std::vector<uint64_t>& written,
                       const std::vector<uint64_t>& entered, size_t w, size_t unit_rays, size_t ray_slots);
// The shortest warm-up of the grid whose share is at most 0.5% over the stream so far; 16 x ray_slots until 512
// rays are accounted; `fixed` (SampleOptions::warmup_rays) when not 0. Never shorter than 8 x ray_slots: a shorter
// one misses a fill transient the share does not see.
size_t warmup_rays(const SlotTimeAccount& a, size_t ray_slots, size_t fixed);

}  // namespace rtu::hw
