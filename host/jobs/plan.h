// The cheapest format for a scene within an error budget (rtusim plan). "Cheapest" is, by `minimise`, the fewest
// cycles of the rays on the timing preset (`config`), then the fewest image bytes (bvh_bytes); or the fewest image
// bytes, then the fewest cycles; or the least energy per ray, then the fewest cycles; or the smallest unit
// (area_mm2), then the fewest cycles; or the most rays per clock per mm^2, then the fewest cycles. With an area
// budget each candidate is costed with the units it affords (iso-area, PlanOptions::area_budget). Skips the bits a
// scene does not need: per BVH width, the fewest coordinate bits whose error meets the budget (minimising cycles,
// energy or rays per clock per mm^2, then more bits while they pay: cycles against bits fall while looser boxes
// cost node visits, then rise with the bytes), then the cheapest child-offset bits, then the cheapest width.
// Minimising cycles or energy, a candidate with more bits or area is taken over one with fewer only when it saves
// more than PlanOptions::min_gain_pct (plan_pays). Candidates vary a base format (`format`,
// by default the configuration's own: its `format` key): coordinate and child-offset bits, every other field
// (storage layouts too) as the base has it, so a packed base gives packed candidates, whose bytes follow their
// bits. Every candidate is a sweep point (sweep.h): the same error, cycles and bytes as `rtusim sweep`.
//
// The error is measured on a sample of rays (the camera's and as many incoherent rays, `sweep.seed`), so a
// candidate meets the budget only when a one-sided upper confidence bound on its error does: for the hit metric
// the Clopper-Pearson bound on the disagreement rate (exact for a binomial sample), for the t metric the mean's
// normal-approximation bound, mean + z sd / sqrt(rays hitting the same primitive).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "host/io/stats_json.h"
#include "host/jobs/sweep.h"
#include "hwmodel/numeric/fixed_format.h"

namespace rtu::host {

// The default of PlanOptions::min_gain_pct (rtusim plan --min-gain). The timing model is deterministic, so the
// noise a saving must clear is the model's own approximation: cycles are of a sample of rays, and the model is
// cycle-approximate (timing-model.md lists what it leaves out). The sample part was measured: the saving of one
// format over another on the same rays moves by about a point from one --seed to the next (builtin:seed, 16
// coordinate bits over 12 on rdna2 at 20,000 rays per kind: 1.35% to 2.16% over seeds 1-5). 2% is a saving that
// such a move does not turn into a loss; below it a faster format is not shown to be faster, while its bits cost
// area for certain (16 bits over 12: +11% area).
inline constexpr double kDefaultMinGainPct = 2.0;

struct PlanOptions {
  std::string scene;           // scene file, mesh file or builtin:NAME
  std::string metric = "hit";  // hit: fraction of rays whose hit/miss differs from float; t: mean relative t error
  double max_error = 1e-4;     // the budget of `metric`
  double min_psnr = 0.0;       // also require the render's PSNR against float (dB; 0: no)
  double confidence = 0.95;    // of the error's upper bound, in (0, 1)
  std::string config = "rdna2";  // timing preset whose cycles are the cost
  std::string format;            // base format spec (hw::format_from_spec); empty: the config's `format` key
  // cycles: fewest cycles, then bytes; bytes: fewest image bytes, then cycles; energy: fewest pJ per ray (the
  // estimate of hwmodel/cost/energy_model.h), then cycles; area: smallest area_mm2, then cycles; perf-per-area:
  // most rays per clock per mm^2 (plan_perf_per_area), then cycles
  std::string minimise = "cycles";
  // Minimising cycles or energy: a candidate with more bits or area is taken over the one kept only when it saves
  // more than this percentage of that cost (plan_pays; 0: any saving, 100: never). The other costs price size
  // themselves and take no threshold. The default is argued at kDefaultMinGainPct.
  double min_gain_pct = kDefaultMinGainPct;
  std::string area;  // RTL area table for the rtl_cells and area figures (empty: the shipped one)
  // Iso-area design: the unit's area budget in mm^2 (0: none). Each candidate format then gets the box and
  // triangle units it affords: from the preset's units, one more of the kind that makes it cheaper (by
  // `minimise`) while the area stays within the budget, so that a narrower format can buy more units. A candidate
  // whose preset units already exceed the budget does not meet it.
  double area_budget = 0.0;
  std::vector<int> widths{2, 4, 6, 8};                                     // BVH widths to consider
  std::vector<int> coord_bits{8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28};  // tried fewest first
  std::vector<int> child_bits{4, 6, 8, 12};                                // child-offset bits to try
  SweepOptions sweep;                                                      // rays, render and threads
};

// What the planner is doing, as it goes.
enum class PlanStage {
  kCoordBits,   // starts on `width`: coordinate bits, fewest first (the configuration format's child bits)
  kCandidate,   // measured `row` (a sweep point), which `meets` the budget or not
  kInfeasible,  // no coordinate width meets the budget at `width`
  kChildBits,   // `width` needs `coord_bits` coordinate bits: now the child-offset bits
  kDefault,     // measures the base format at `width` (the plan's), for comparison
};
struct PlanStep {
  PlanStage stage = PlanStage::kCoordBits;
  int width = 0;
  int coord_bits = 0;
  const SweepRow* row = nullptr;
  bool meets = false;
};

struct PlanResult {
  std::string scene;       // the scene's name
  bool found = false;      // a format meets the budget at some width; the rest is set only then
  SweepRow best;           // the plan: its format, BVH width and figures
  hw::FixedFormat format;  // best's format
  SweepRow reference;      // the base format (the configuration's own unless `format`) at the plan's width
  // {scene, metric, max_error, confidence, seed, rays, min_psnr, flatten, config, base_format, minimise, cost,
  // min_gain_pct, min_gain_applies, widths: [every width's candidates], plan, default} (plan: null when nothing
  // meets the budget; psnr_db null when no render measured it)
  Json json;
};

// The error `metric` ("hit" or "t") measures of a row.
double plan_error(const SweepRow& r, const std::string& metric);
// The upper confidence bound of that error at o.confidence (o.metric); +inf when the row has no sample for it.
double plan_error_bound(const SweepRow& r, const PlanOptions& o);
// Rays per clock of a row's timed run (its rays over its cycles; 0 without cycles).
double plan_rays_per_clock(const SweepRow& r);
// Performance per area: rays per clock per mm^2 of the unit (0 without cycles or area).
double plan_perf_per_area(const SweepRow& r);
// True when a costs less than b by o.minimise (its cost, then the next: see PlanOptions::minimise).
bool plan_cheaper(const SweepRow& a, const SweepRow& b, const PlanOptions& o);
// How much better a is than b in the cost o.minimise names first, as a fraction of b's: the saving in cycles,
// bytes, energy per ray or area, or the gain in rays per clock per mm^2 (negative when a is worse).
double plan_gain(const SweepRow& a, const SweepRow& b, const PlanOptions& o);
// True when o.min_gain_pct applies to o.minimise: cycles and energy, whose cost does not price bits or area.
bool plan_min_gain_applies(const PlanOptions& o);
// True when `candidate` is worth taking over `kept`: cheaper by o.minimise and, when it is the larger (more area,
// or as much and more coordinate and child-offset bits) and the threshold applies, saving more than o.min_gain_pct
// percent.
bool plan_pays(const SweepRow& candidate, const SweepRow& kept, const PlanOptions& o);
// Why `costlier`, cheaper than `kept` by o.minimise, was not taken for saving too little, as the plan prints it
// ("0.2% fewer cycles for +12% area, below --min-gain 2%"); empty when it was not cheaper or it pays.
std::string plan_passed_over(const SweepRow& costlier, const SweepRow& kept, const PlanOptions& o);

// Cycles and energy (whose DRAM part follows the DRAM bytes) against coordinate bits are not smooth in a packed
// layout: a node's bytes grow with the bits but not in whole cache lines, so where nodes fall on the 64-byte
// lines, and with it the DRAM bytes per ray, jumps from one width to the next with no trend (the IFC house, packed
// on rdna2-mem: 164 DRAM bytes per ray at 16 bits, 186 at 20, 175 at 24, node visits equal). That spread, +-6.3%
// around its mean, is what placement alone does to a memory-bound unit's cycles; kPlacementNoise (8%) is it with
// a margin. More coordinate bits that do no less traversal work (node visits and primitive tests, which are
// counts, exact) and save less than that fraction of the cost are a tie, and a tie keeps the fewer bits (fewer
// bytes). Minimising bytes needs no margin: image bytes are exact.
inline constexpr double kPlacementNoise = 0.08;
// True when `more` (more coordinate bits, the same width, child bits and base) is worth its bits over `fewer`:
// plan_pays, and (minimising a cost that follows the cycles) either with less traversal work or cheaper by more
// than kPlacementNoise.
bool plan_more_bits_pay(const SweepRow& more, const SweepRow& fewer, const PlanOptions& o);
// What measurably makes `more` cheaper than `fewer`, or a tie: node visits, primitive tests, DRAM bytes per ray
// (with placement on cache lines named when the traversal work is equal), as the plan prints it.
std::string plan_more_bits_cause(const SweepRow& more, const SweepRow& fewer, const PlanOptions& o);
// True when r meets the options' budget: the error's upper bound, no box false negatives, the PSNR when one is
// required, and the area when there is an area budget.
bool plan_meets(const SweepRow& r, const PlanOptions& o);

// One-sided upper confidence bound on a binomial proportion from k successes in n trials (Clopper-Pearson): the
// p at which P(X <= k) = 1 - confidence. 1 when n is 0.
double proportion_upper_bound(uint64_t k, uint64_t n, double confidence);
// One-sided upper confidence bound on a mean from n samples of mean `mean` and standard deviation `sd` (normal
// approximation): mean + z sd / sqrt(n), z the standard normal's `confidence` quantile. +inf when n < 2.
double mean_upper_bound(double mean, double sd, uint64_t n, double confidence);

// The smallest hit-disagreement budget a plan can show on `rays_per_kind` camera and as many incoherent rays: the
// upper bound at `confidence` with no disagreement at all.
double plan_smallest_hit_budget(uint64_t rays_per_kind, double confidence);
// The most camera rays (and as many incoherent ones) a plan or sweep takes: --rays' limit.
inline constexpr uint64_t kMaxPlanRays = uint64_t(1) << 26;

// Plans a format. Checks the metric, the budget, the confidence, the PSNR, the area budget, the minimum gain (each
// finite), the preset, the base format and `minimise` before loading the scene (Error naming the option; also when
// the budget is below what zero disagreements on the rays can show, naming the rays that could, or below what the
// most rays can show); `progress`, when given, sees every step. o.sweep.poll is called between steps.
PlanResult plan_format(const PlanOptions& o, const std::function<void(const PlanStep&)>& progress = {});

}  // namespace rtu::host
