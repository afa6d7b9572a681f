// One static HTML page (no server, no script; relative links) of run time against error, with the figures as
// report.json beside it (rtusim report):
// - renders of the first scene (default builtin:seed) by the firmware on the float reference and on the fixed
//   datapath with timing (the timed device), and the log heatmap of their difference (diff_heatmap_log) with its
//   colour bar;
// - cycles per scene for each timing preset: the scenes' primary rays traced as one TRACE packet on the timed
//   device (as bench/cycles_table.sh does for meshes);
// - Pareto plots of a sweep (pareto.h, drawn by gnuplot) and per scene a table of its numbered points: the given
//   sweep CSV, or a small sweep run here over the scenes with the RTL areas of --area or the shipped table;
//   without gnuplot the page says so;
// The page fits a 1280 px window (tests/host/check_report_browser.sh checks it in headless Chromium).
// - the stress suite (`rtusim stress`) with a small count.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "host/io/stats_json.h"

namespace rtu::host {

struct ReportOptions {
  std::string out;                  // output directory: index.html, report.json, PNGs, sweep.csv
  std::string sweep;                // sweep CSV to plot; empty: run a small sweep here
  std::string area;                 // RTL area table for the sweep run here (empty: the shipped one, sweep.h)
  std::vector<std::string> scenes;  // empty: builtin:seed and builtin:cornell; the first is rendered
  bool quick = false;               // small sizes (renders 192 wide, few rays, small sweep)
  int threads = 0;                  // 0: all cores
  // Fixed and timed devices trace instanced scenes flattened, in one image (rtusim --flatten): the fixed render,
  // the cycles table and the sweep run here. In report.json's "flatten".
  bool flatten = false;
};

// What the report is doing, as it goes.
enum class ReportStage {
  kStart,   // inputs checked and `count` scenes loaded
  kRender,  // rendered `scene` on `device` in `seconds`
  kCycles,  // the cycles table has `count` rows
  kSweep,   // the sweep has `count` points; `message`: what became of the Pareto plots ("ok" or why not)
  kStress,  // the stress suite found `count` failures
};
struct ReportStep {
  ReportStage stage = ReportStage::kStart;
  std::string scene, device;
  double seconds = 0.0;
  uint64_t count = 0;
  std::string message;
};

struct ReportResult {
  Json json;                        // report.json
  std::vector<std::string> images;  // every image the page embeds (files in the output directory)
  uint64_t stress_failures = 0;     // the page shows them; rtusim exits 1
  double seconds = 0.0;             // wall time of the whole report
};

// Writes the report. Checks every input (output directory writable, sweep CSV, area table, scenes) before the
// first long step (Error); `progress`, when given, sees each step.
ReportResult write_report(ReportOptions o, const std::function<void(const ReportStep&)>& progress = {});

}  // namespace rtu::host
