// The cheapest format for a scene within an error budget (rtusim plan). Skips the bits a scene does not need: per
// BVH width, the fewest coordinate bits whose error meets the budget, then the child-offset bits with the fewest
// cycles, then the width with the fewest cycles (bytes break ties). Every candidate is a sweep point (sweep.h):
// the same error, cycles and bytes as `rtusim sweep`.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "host/stats_json.h"
#include "host/sweep.h"
#include "hwmodel/fixed_format.h"

namespace rtu::host {

struct PlanOptions {
  std::string scene;           // scene file, mesh file or builtin:NAME
  std::string metric = "hit";  // hit: fraction of rays whose hit/miss differs from float; t: mean relative t error
  double max_error = 1e-4;     // the budget of `metric`
  double min_psnr = 0.0;       // also require the render's PSNR against float (dB; 0: no)
  std::string config = "rdna2";      // timing preset whose cycles are the cost
  std::string area;                  // RTL area table for the rtl_cells figures (empty: none)
  std::vector<int> widths{2, 4, 8};  // BVH widths to consider
  std::vector<int> coord_bits{8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28};  // tried fewest first
  std::vector<int> child_bits{4, 6, 8, 12};                                // child-offset bits to try
  SweepOptions sweep;                                                      // rays, render and threads
};

// What the planner is doing, as it goes.
enum class PlanStage {
  kCoordBits,   // starts on `width`: coordinate bits, fewest first (child bits 8)
  kCandidate,   // measured `row` (a sweep point), which `meets` the budget or not
  kInfeasible,  // no coordinate width meets the budget at `width`
  kChildBits,   // `width` needs `coord_bits` coordinate bits: now the child-offset bits
  kDefault,     // measures the default format at `width` (the plan's), for comparison
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
  SweepRow reference;      // the default format at the plan's width
  // {scene, metric, max_error, min_psnr, config, widths: [every width's candidates], plan, default} (plan: null
  // when nothing meets the budget)
  Json json;
};

// The error `metric` ("hit" or "t") measures of a row.
double plan_error(const SweepRow& r, const std::string& metric);
// True when r meets the options' budget: error, no box false negatives, and the PSNR when one is required.
bool plan_meets(const SweepRow& r, const PlanOptions& o);

// Plans a format. Checks the metric, the budget and the preset before loading the scene (Error naming the option);
// `progress`, when given, sees every step.
PlanResult plan_format(const PlanOptions& o, const std::function<void(const PlanStep&)>& progress = {});

}  // namespace rtu::host
