// rtusim report: the static HTML report of run time against error (host/jobs/report.h), with a line per step.
// rtusim pareto: only the Pareto plots of a sweep CSV (bench/pareto.sh runs it); exits 2 without gnuplot.
#include <cstdio>
#include <filesystem>
#include <memory>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/jobs/pareto.h"
#include "host/jobs/report.h"
#include "host/jobs/suite.h"
#include "host/jobs/sweep.h"

namespace rtu::host::cli {

namespace {

void run_report(ReportOptions a, const std::string& suite) {
  if (!suite.empty()) {  // the suite's available scenes after --scene's; skipped ones named on stderr
    for (const std::string& spec : suite_scenes(
             suite, [](const std::string& line) { std::fprintf(stderr, "rtusim: warning: %s\n", line.c_str()); }))
      a.scenes.push_back(spec);
    if (a.scenes.empty()) throw Error("report: " + suite + ": no scene of the suite is available");
  }
  const ReportResult r = write_report(a, [&](const ReportStep& s) {
    switch (s.stage) {
      case ReportStage::kStart:
        std::printf("rtusim report%s%s: %zu scenes -> %s\n", a.quick ? " (quick)" : "",
                    a.flatten ? " (instanced scenes flattened)" : "", s.count, a.out.c_str());
        break;
      case ReportStage::kRender:
        std::printf("  render %s on %s: %.2f s\n", s.scene.c_str(), s.device.c_str(), s.seconds);
        break;
      case ReportStage::kCycles:
        std::printf("  cycles per scene: %zu rows\n", s.count);
        break;
      case ReportStage::kSweep:
        std::printf("  sweep: %zu points; pareto: %s\n", s.count, s.message.c_str());
        break;
      case ReportStage::kStress:
        std::printf("  stress: %llu failures\n", (unsigned long long)s.count);
        break;
    }
  });
  std::printf("  wrote %s/index.html, %s/report.json and %zu images in %.1f s\n", a.out.c_str(), a.out.c_str(),
              r.images.size(), r.seconds);
  if (r.stress_failures > 0) {
    std::fprintf(stderr, "rtusim: report: the stress suite found %llu failures (see the page)\n",
                 (unsigned long long)r.stress_failures);
    throw ExitStatus(1);
  }
}

struct ParetoArgs {
  std::string sweep, out;
};

void run_pareto(const ParetoArgs& a) {
  const std::vector<SweepRow> rows = read_sweep_csv(a.sweep);
  if (rows.empty()) throw Error(a.sweep + ": no rows");
  const std::string gnuplot = find_gnuplot();
  if (gnuplot.empty())
    throw Error("pareto: gnuplot not found on PATH; install the Debian package gnuplot-nox (scripts/setup.sh)");
  std::error_code ec;
  std::filesystem::create_directories(a.out, ec);
  if (ec) throw Error("--out " + a.out + ": cannot create the directory: " + ec.message());
  for (const ParetoPlot& p : write_pareto_plots(rows, a.out, gnuplot)) {
    std::printf("%s: %s, %zu points; front against cycles:", p.scene.c_str(), pareto_error_name(p.error),
                p.points);
    for (size_t i : p.front[0]) std::printf(" %s", pareto_label(rows[i].p).c_str());
    std::printf(" -> %s/%s\n", a.out.c_str(), p.png.c_str());
  }
}

}  // namespace

void add_report(CLI::App& app) {
  auto a = std::make_shared<ReportOptions>();
  CLI::App* sub = app.add_subcommand(
      "report", "Write a static HTML report: renders, cycles per scene, Pareto plots of a sweep, stress results");
  sub->add_option("--out", a->out, "output directory (index.html, report.json, PNGs, sweep.csv)")->required();
  CLI::Option* sweep =
      sub->add_option("--sweep", a->sweep, "sweep CSV to plot (rtusim sweep); default: run a small sweep here");
  sub->add_option("--scene", a->scenes,
                  "scenes (repeatable; default builtin:seed and builtin:cornell): the first is rendered, all are "
                  "in the cycles table and in the sweep run here");
  auto suite = std::make_shared<std::string>();
  sub->add_option("--suite", *suite,
                  "benchmark suite manifest (scenes/suite.json): its scenes after --scene's (missing files are "
                  "skipped with a warning)");
  sub->add_option("--area", a->area,
                  "RTL area table for the sweep run here (default: bench/data/rtl_area.csv, compiled in)")
      ->excludes(sweep);  // a given sweep CSV holds its area figures already
  sub->add_flag("--quick", a->quick, "small sizes (renders 192 wide, few rays, small sweep): well under 30 s");
  sub->add_flag("--flatten", a->flatten,
                "fixed and timed devices: trace instanced scenes flattened, in one image instead of two levels "
                "(the fixed render, the cycles table and the sweep run here, not a --sweep CSV's rows, which say "
                "in their flatten column; the float reference keeps two levels)");
  sub->add_option("--threads", a->threads, "worker threads (0 = all cores)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->callback([a, suite] { run_report(*a, *suite); });

  auto p = std::make_shared<ParetoArgs>();
  CLI::App* ps = app.add_subcommand(
      "pareto", "Pareto plots (PNG, gnuplot) of a sweep CSV: error against cycles, memory and area per scene");
  ps->add_option("--sweep", p->sweep, "sweep CSV (rtusim sweep)")->required();
  ps->add_option("--out", p->out, "output directory")->required();
  ps->callback([p] { run_pareto(*p); });
}

}  // namespace rtu::host::cli
