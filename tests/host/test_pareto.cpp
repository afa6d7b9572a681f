// Pareto fronts of a sweep (host/pareto.h): which points are on the front, how zero errors are drawn on the log
// axis, and the gnuplot step writing one PNG per scene and error measure.
#include <catch2/catch.hpp>

#include <unistd.h>
#include <algorithm>
#include <filesystem>
#include <fstream>

#include "host/error.h"
#include "host/image.h"
#include "host/pareto.h"

namespace fs = std::filesystem;
using namespace rtu::host;

TEST_CASE("pareto front: the points no other point beats in both cost and error", "[pareto]") {
  // (cost, error)
  const std::vector<std::pair<double, double>> pts = {
      {10, 5},  // 0: front (cheapest)
      {20, 3},  // 1: front
      {25, 4},  // 2: dominated by 1
      {30, 3},  // 3: dominated by 1 (equal error, more cost)
      {40, 1},  // 4: front
      {40, 2},  // 5: dominated by 4 (equal cost, more error)
      {15, 6},  // 6: dominated by 0
      {50, 1},  // 7: dominated by 4
      {20, 3},  // 8: equal to 1: on the front too
  };
  const std::vector<size_t> f = pareto_front(pts);
  CHECK(f == std::vector<size_t>{0, 1, 8, 4});
  // Brute force: a point is on the front iff no other point dominates it.
  for (size_t i = 0; i < pts.size(); ++i) {
    bool dominated = false;
    for (size_t j = 0; j < pts.size(); ++j)
      dominated =
          dominated || (pts[j].first <= pts[i].first && pts[j].second <= pts[i].second && pts[j] != pts[i]);
    CHECK(dominated == (std::find(f.begin(), f.end(), i) == f.end()));
  }
  CHECK(pareto_front({}).empty());
  CHECK(pareto_front({{1, 1}}) == std::vector<size_t>{0});
}

TEST_CASE("pareto: errors floored for the log axis, unknown area, labels", "[pareto]") {
  SweepRow r;
  r.p = SweepPoint{"builtin:seed", "default:coord_bits=16", 8, "intel"};
  r.rays = 4000;
  r.hit_agreement = 1.0;
  r.t_rel_error_mean = 0.0;
  CHECK(pareto_error(r, ParetoError::kHitDisagreement) == Approx(1.0 / 4000));
  CHECK(pareto_error(r, ParetoError::kTRelErrorMean) == kZeroTError);
  r.hit_agreement = 0.99;
  r.t_rel_error_mean = 3e-6;
  CHECK(pareto_error(r, ParetoError::kHitDisagreement) == Approx(0.01));
  CHECK(pareto_error(r, ParetoError::kTRelErrorMean) == 3e-6);
  CHECK(pareto_cost(r, ParetoCost::kRtlCells) < 0);
  r.rtl_cells = 1234;
  CHECK(pareto_cost(r, ParetoCost::kRtlCells) == 1234);
  CHECK(pareto_label(r.p) == "default:coord_bits=16/8/intel");
}

TEST_CASE("pareto plots: gnuplot writes one PNG per scene and error measure", "[pareto]") {
  const std::string gnuplot = find_gnuplot();
  if (gnuplot.empty()) {
    WARN("gnuplot not installed: plot test skipped");
    return;
  }
  const fs::path d = fs::temp_directory_path() / ("rtu_test_pareto_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  std::vector<SweepRow> rows;
  for (int i = 0; i < 4; ++i) {
    SweepRow r;
    r.p = SweepPoint{i < 3 ? "builtin:seed" : "/x/y/Some Mesh.glb",
                     "default:coord_bits=" + std::to_string(12 + 4 * i), 4, "rdna2"};
    r.rays = 1000;
    r.hit_agreement = 1.0 - 0.01 / (i + 1);
    r.t_rel_error_mean = i == 2 ? 0.0 : 1e-3 / (i + 1);
    r.cycles = 1000 + 100 * uint64_t(i);
    r.bvh_bytes = 5000 + 1000 * uint64_t(i);
    r.rtl_cells = i == 0 ? 50000 : -1;  // one point with area, then none
    rows.push_back(r);
  }
  const std::vector<ParetoPlot> plots = write_pareto_plots(rows, d.string(), gnuplot);
  REQUIRE(plots.size() == 4);  // 2 scenes x 2 error measures
  for (const ParetoPlot& p : plots) {
    INFO(p.png);
    const Image img = read_png((d / p.png).string());
    CHECK(img.width == 1950);
    CHECK(img.height == 800);
  }
  CHECK(plots[0].png == "pareto_seed_hit.png");
  CHECK(plots[1].png == "pareto_seed_terr.png");
  CHECK(plots[2].png == "pareto_Some_Mesh_hit.png");
  CHECK(plots[0].points == 3);
  // Cost and error both grow or fall with i: each point is cheaper and worse than the next, all on the front.
  CHECK(plots[0].front[0] == std::vector<size_t>{0, 1, 2});
  CHECK(plots[0].front[2] == std::vector<size_t>{0});  // only row 0 has an area
  CHECK(plots[2].front[2].empty());
  CHECK_THROWS_AS(write_pareto_plots({}, d.string(), gnuplot), Error);
  CHECK_THROWS_AS(write_pareto_plots(rows, d.string(), ""), Error);
  // A gnuplot that fails is reported, naming the script.
  CHECK_THROWS_WITH(write_pareto_plots(rows, d.string(), "false"), Catch::Contains("gnuplot failed"));
  fs::remove_all(d);
}
