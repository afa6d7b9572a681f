// Pareto fronts of a design sweep (host/jobs/sweep.h) and their plots, drawn by gnuplot (PNG, pngcairo terminal).
// For each scene of a sweep, error (log scale) against up to five costs: simulated cycles, encoded BVH bytes, the
// timed run's DRAM bytes per ray, the unit's area in mm^2 (area_mm2, the 45 nm estimate) and its energy per ray
// (rows without DRAM bytes, an area or an energy, a 0 in the sweep, are left out of that panel; when no row of the
// scene has one, the panel is left out). Points are numbered per scene (1 = the scene's first row);
// the numbers are placed beside the points so that no two overlap (place_labels), and the page or the data
// files say which point a number is.
// Two error measures: hit disagreement (1 - hit agreement; one wrong ray is 1 / rays, the smallest error a
// sample shows, so a zero is drawn apart, kHitZeroBelow times lower, under a dashed break with its own "0" tick)
// and the mean relative t error (a zero drawn at kZeroTError). A point is on the front when no
// other point of the scene is at most as costly and at most as wrong and better in one of the two.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "host/jobs/sweep.h"

namespace rtu::host {

enum class ParetoError { kHitDisagreement, kTRelErrorMean };
enum class ParetoCost { kCycles, kBvhBytes, kAreaMm2, kDramBytesPerRay, kPjPerRay };
inline constexpr int kParetoCostCount = 5;

inline constexpr double kZeroTError = 1e-10;  // where a t error of exactly 0 is drawn on the log axis
// A hit disagreement of exactly 0 is drawn at 1 / (kHitZeroBelow rays): a decade under one wrong ray, so that a
// zero and one wrong ray are two places on the plot.
inline constexpr double kHitZeroBelow = 10.0;

const char* pareto_error_name(ParetoError e);  // "hit_disagreement" | "t_rel_error_mean"
// "cycles" | "bvh_bytes" | "area_mm2" | "dram_bytes_per_ray" | "pj_per_ray"
const char* pareto_cost_name(ParetoCost c);

// The row's error as drawn: > 0 (a zero drawn as above).
double pareto_error(const SweepRow& r, ParetoError e);
// The row's cost; < 0 when unknown (area_mm2 = 0, dram_bytes_per_ray = 0, pj_per_ray = 0).
double pareto_cost(const SweepRow& r, ParetoCost c);

// Indices of the points (cost, error) on the Pareto front (both minimized), by cost ascending. Of points equal
// in both, every one is on the front.
std::vector<size_t> pareto_front(const std::vector<std::pair<double, double>>& points);

// Label of a point: format/width/config.
std::string pareto_label(const SweepPoint& p);

// The gnuplot executable on PATH, or "" when there is none.
std::string find_gnuplot();

// Label placement, in pixels of the image (x right, y down).
struct LabelBox {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // x0 <= x1, y0 <= y1
};
// True when the boxes share interior area (touching edges do not overlap).
bool boxes_overlap(const LabelBox& a, const LabelBox& b);
struct LabelRequest {
  double x = 0, y = 0;  // the point the label names
  double w = 0, h = 0;  // the label's box
};
struct LabelPlace {
  bool placed = false;  // false: no free place was found (the label is left out)
  bool leader = false;  // placed away from its point: draw a line from the point to the box
  LabelBox box;
};
// Places labels greedily in the order given: each goes to the first free place among positions around its point
// (right, above, left, below and the corners, in rings of growing distance; from the second ring on with a
// leader line). A place is free when its box lies inside `bounds` and overlaps no obstacle (e.g. the points'
// markers) and no label placed before it. So no two placed boxes overlap; a label with no free place is not
// placed.
std::vector<LabelPlace> place_labels(const std::vector<LabelRequest>& labels,
                                     const std::vector<LabelBox>& obstacles, const LabelBox& bounds);

// The size of the plot images: two panels per row, so a PNG is kParetoPlotWidth wide (it fits a 1280 px window
// at its natural size) and kParetoPanelHeight per row of panels plus the title's lines (ParetoPlot::title_height).
inline constexpr int kParetoPlotWidth = 1200;
inline constexpr int kParetoPanelHeight = 480;
// The title above the panels is wrapped to the image's width: its lines of 11 pt text, then the legend's of
// 9 pt. The widths are upper bounds of a character's advance in the sans font of the pngcairo terminal (measured:
// about 7.4 px at 11 pt and 6.2 px at 9 pt on average), so that a wrapped line never runs off the image.
inline constexpr double kParetoTitleCharPx = 9.0;
inline constexpr double kParetoTextCharPx = 7.0;
inline constexpr int kParetoTitleLinePx = 18, kParetoTextLinePx = 15;

// `text` broken into lines of at most `width` characters: at spaces, a word longer than a line (a long path) after
// one of "/:," inside it, else anywhere. No line is empty; the lines rejoined give the text but its spaces at the
// breaks.
std::vector<std::string> wrap_text(const std::string& text, size_t width);

struct ParetoPlot {
  std::string scene;  // as in the sweep
  ParetoError error;
  std::string png;  // file name inside the output directory
  size_t points = 0;
  // The scene's rows, as indices into the rows given: point number k + 1 on the plot is rows[k].
  std::vector<size_t> rows;
  // Per cost (ParetoCost: cycles, bytes, area, DRAM bytes per ray, energy per ray): the front, as row indices into
  // the rows given.
  std::vector<size_t> front[kParetoCostCount];
  int title_height = 0;       // pixels above the panels: the title's lines
  bool area_panel = false;    // false: no row of the scene has an area, the panel is left out
  bool dram_panel = false;    // false: no row of the scene has DRAM bytes, the panel is left out
  bool energy_panel = false;  // false: no row of the scene has an energy estimate, the panel is left out
  size_t unlabelled = 0;      // places (over all panels) whose number found no free spot
};

// Writes, per scene of `rows`, the data, the gnuplot script and two PNGs (one per error measure, two to five
// panels each: cycles, bytes, then DRAM bytes per ray, area in mm^2 and energy per ray where the scene has them)
// into `dir` (which must exist), running `gnuplot`. Beside each panel's data, a `.labels` file lists every
// numbered place with its box in pixels. Throws Error when there are no rows or gnuplot fails (naming its log
// file).
std::vector<ParetoPlot> write_pareto_plots(const std::vector<SweepRow>& rows, const std::string& dir,
                                           const std::string& gnuplot);

}  // namespace rtu::host
