// Pareto fronts of a design sweep (host/sweep.h) and their plots, drawn by gnuplot (PNG, pngcairo terminal).
// For each scene of a sweep, error (log scale) against three costs: simulated cycles, encoded BVH bytes and the
// RTL box unit's area in cells (rows without a synthesis result, rtl_cells = -1, are left out of that panel).
// Two error measures: hit disagreement (1 - hit agreement, a zero drawn at 1 / rays: "fewer than one ray in
// the sample") and the mean relative t error (a zero drawn at kZeroTError). A point is on the front when no
// other point of the scene is at most as costly and at most as wrong and better in one of the two.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "host/sweep.h"

namespace rtu::host {

enum class ParetoError { kHitDisagreement, kTRelErrorMean };
enum class ParetoCost { kCycles, kBvhBytes, kRtlCells };

inline constexpr double kZeroTError = 1e-10;  // where a t error of exactly 0 is drawn on the log axis

const char* pareto_error_name(ParetoError e);  // "hit_disagreement" | "t_rel_error_mean"
const char* pareto_cost_name(ParetoCost c);    // "cycles" | "bvh_bytes" | "rtl_cells"

// The row's error as drawn: > 0 (floored as above).
double pareto_error(const SweepRow& r, ParetoError e);
// The row's cost; < 0 when unknown (rtl_cells = -1).
double pareto_cost(const SweepRow& r, ParetoCost c);

// Indices of the points (cost, error) on the Pareto front (both minimized), by cost ascending. Of points equal
// in both, every one is on the front.
std::vector<size_t> pareto_front(const std::vector<std::pair<double, double>>& points);

// Label of a point: format/width/config.
std::string pareto_label(const SweepPoint& p);

// The gnuplot executable on PATH, or "" when there is none.
std::string find_gnuplot();

struct ParetoPlot {
  std::string scene;  // as in the sweep
  ParetoError error;
  std::string png;  // file name inside the output directory
  size_t points = 0;
  // Per cost (cycles, bytes, area): the front, as row indices into the rows given.
  std::vector<size_t> front[3];
};

// Writes, per scene of `rows`, the data, the gnuplot script and two PNGs (one per error measure, three panels
// each) into `dir` (which must exist), running `gnuplot`. Throws Error when there are no rows or gnuplot fails
// (naming its log file).
std::vector<ParetoPlot> write_pareto_plots(const std::vector<SweepRow>& rows, const std::string& dir,
                                           const std::string& gnuplot);

}  // namespace rtu::host
