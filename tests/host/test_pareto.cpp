// Pareto fronts of a sweep (host/jobs/pareto.h): which points are on the front, how zero errors are drawn on the
// log axis, where the point numbers go (no two overlap), and the gnuplot step writing one PNG per scene and error
// measure.
#include <catch2/catch.hpp>

#include <unistd.h>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "host/io/error.h"
#include "host/io/image.h"
#include "host/jobs/pareto.h"
#include "tests/common/test_util.h"

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
  CHECK(pareto_error(r, ParetoError::kHitDisagreement) == Approx(1.0 / 4000 / kHitZeroBelow));
  CHECK(pareto_error(r, ParetoError::kTRelErrorMean) == kZeroTError);
  r.hit_agreement = 0.99;
  r.t_rel_error_mean = 3e-6;
  CHECK(pareto_error(r, ParetoError::kHitDisagreement) == Approx(0.01));
  CHECK(pareto_error(r, ParetoError::kTRelErrorMean) == 3e-6);
  CHECK(pareto_cost(r, ParetoCost::kAreaMm2) < 0);  // a row without an area estimate
  r.rtl_cells = 1234;
  CHECK(pareto_cost(r, ParetoCost::kAreaMm2) < 0);  // the area panel is in mm^2, not the RTL unit's cells
  r.area_mm2 = 1.25;
  CHECK(pareto_cost(r, ParetoCost::kAreaMm2) == 1.25);
  CHECK(std::string(pareto_cost_name(ParetoCost::kAreaMm2)) == "area_mm2");
  CHECK(pareto_cost(r, ParetoCost::kDramBytesPerRay) < 0);  // a row without DRAM bytes
  r.dram_bytes_per_ray = 12.5;
  CHECK(pareto_cost(r, ParetoCost::kDramBytesPerRay) == 12.5);
  CHECK(std::string(pareto_cost_name(ParetoCost::kDramBytesPerRay)) == "dram_bytes_per_ray");
  CHECK(pareto_cost(r, ParetoCost::kPjPerRay) < 0);  // a row without an energy estimate
  r.pj_per_ray = 8000;
  CHECK(pareto_cost(r, ParetoCost::kPjPerRay) == 8000);
  CHECK(std::string(pareto_cost_name(ParetoCost::kPjPerRay)) == "pj_per_ray");
  CHECK(pareto_label(r.p) == "default:coord_bits=16/8/intel");
}

namespace {

// Checks that placed labels overlap neither each other nor an obstacle and lie inside the bounds.
void check_placement(const std::vector<LabelRequest>& q, const std::vector<LabelPlace>& p,
                     const std::vector<LabelBox>& obstacles, const LabelBox& bounds) {
  REQUIRE(p.size() == q.size());
  for (size_t i = 0; i < p.size(); ++i) {
    if (!p[i].placed) continue;
    INFO("label " << i);
    const LabelBox& b = p[i].box;
    CHECK(b.x1 - b.x0 == Approx(q[i].w));
    CHECK(b.y1 - b.y0 == Approx(q[i].h));
    CHECK(b.x0 >= bounds.x0);
    CHECK(b.y0 >= bounds.y0);
    CHECK(b.x1 <= bounds.x1);
    CHECK(b.y1 <= bounds.y1);
    for (const LabelBox& o : obstacles) CHECK_FALSE(boxes_overlap(b, o));
    for (size_t j = 0; j < i; ++j)
      if (p[j].placed) CHECK_FALSE(boxes_overlap(b, p[j].box));
  }
}

// The labels of one panel as write_pareto_plots lists them: placed boxes and how many found no place.
struct PanelLabels {
  std::vector<LabelBox> boxes;
  size_t unplaced = 0, places = 0;
};
PanelLabels read_labels(const fs::path& file) {
  PanelLabels out;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    ++out.places;
    std::istringstream ss(line);
    std::string text, x0;
    double px = 0, py = 0;
    ss >> text >> px >> py >> x0;
    if (x0 == "-") {
      ++out.unplaced;
      continue;
    }
    LabelBox b;
    b.x0 = std::stod(x0);
    ss >> b.y0 >> b.x1 >> b.y1;
    out.boxes.push_back(b);
  }
  return out;
}

}  // namespace

TEST_CASE("label placement: no two labels overlap, none covers a point, each stays by its point", "[pareto]") {
  CHECK(boxes_overlap(LabelBox{0, 0, 10, 10}, LabelBox{5, 5, 15, 15}));
  CHECK_FALSE(boxes_overlap(LabelBox{0, 0, 10, 10}, LabelBox{10, 0, 20, 10}));  // edges touch
  CHECK_FALSE(boxes_overlap(LabelBox{0, 0, 10, 10}, LabelBox{0, 11, 10, 20}));
  const LabelBox bounds{0, 0, 500, 400};
  // Sparse points: every label beside its point, no leader line.
  {
    std::vector<LabelRequest> q;
    std::vector<LabelBox> marks;
    for (int i = 0; i < 5; ++i) {
      q.push_back(LabelRequest{50.0 + 100 * i, 200.0, 20, 16});
      marks.push_back(LabelBox{q.back().x - 6, q.back().y - 6, q.back().x + 6, q.back().y + 6});
    }
    const std::vector<LabelPlace> p = place_labels(q, marks, bounds);
    check_placement(q, p, marks, bounds);
    for (size_t i = 0; i < p.size(); ++i) {
      CHECK(p[i].placed);
      CHECK_FALSE(p[i].leader);
      CHECK(p[i].box.x0 == Approx(q[i].x + 10));  // the first choice: right of the point
    }
  }
  // A crowded cluster (as a sweep's points bunch on a log axis): labels at one fixed offset would pile up (the
  // old plots' unreadable string); placed ones must not, and most still find a place.
  {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> jitter(-12.0, 12.0);
    std::vector<LabelRequest> q;
    std::vector<LabelBox> marks;
    for (int i = 0; i < 30; ++i) {
      q.push_back(
          LabelRequest{250 + 3.0 * i + jitter(rng), 200 - 2.0 * i + jitter(rng), 8.0 * (i < 9 ? 1 : 2) + 4, 16});
      marks.push_back(LabelBox{q.back().x - 6, q.back().y - 6, q.back().x + 6, q.back().y + 6});
    }
    size_t naive_overlaps = 0;
    for (size_t i = 0; i < q.size(); ++i)
      for (size_t j = 0; j < i; ++j)
        naive_overlaps += boxes_overlap(LabelBox{q[i].x + 8, q[i].y - 8, q[i].x + 8 + q[i].w, q[i].y + 8},
                                        LabelBox{q[j].x + 8, q[j].y - 8, q[j].x + 8 + q[j].w, q[j].y + 8});
    CHECK(naive_overlaps > 10);
    const std::vector<LabelPlace> p = place_labels(q, marks, bounds);
    check_placement(q, p, marks, bounds);
    const size_t placed = size_t(std::count_if(p.begin(), p.end(), [](const LabelPlace& l) { return l.placed; }));
    CHECK(placed >= 25);
    // A label is never far from its point: within the outermost ring plus its own size.
    for (size_t i = 0; i < p.size(); ++i)
      if (p[i].placed) {
        const double dx = std::max({p[i].box.x0 - q[i].x, q[i].x - p[i].box.x1, 0.0});
        const double dy = std::max({p[i].box.y0 - q[i].y, q[i].y - p[i].box.y1, 0.0});
        CHECK(std::hypot(dx, dy) <= 100.0);
      }
  }
  // More labels than room: some are not placed, and the placed ones still do not overlap.
  {
    const LabelBox tiny{0, 0, 60, 40};
    std::vector<LabelRequest> q(20, LabelRequest{30, 20, 20, 10});
    const std::vector<LabelPlace> p = place_labels(q, {}, tiny);
    check_placement(q, p, {}, tiny);
    CHECK(std::count_if(p.begin(), p.end(), [](const LabelPlace& l) { return !l.placed; }) > 0);
  }
}

TEST_CASE("pareto plots: gnuplot writes one PNG per scene and error measure", "[pareto]") {
  const std::string gnuplot = find_gnuplot();
  if (gnuplot.empty()) {
    WARN("gnuplot not installed: plot test skipped");
    return;
  }
  const rtu::test::TempDir dir("pareto");
  const fs::path& d = dir.path;
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
    r.area_mm2 = i == 0 ? 0.5 : 0.0;  // one point with area, then none
    r.dram_bytes_per_ray =
        i < 3 ? 100.0 - 10.0 * i : 0.0;               // the seed scene's points have DRAM bytes, the mesh's not
    r.pj_per_ray = i < 3 ? 9000.0 + 500.0 * i : 0.0;  // and energy: the first point is the front's alone
    rows.push_back(r);
  }
  // A crowded scene: 24 points whose costs and errors differ by little, so that their numbers compete for room.
  for (int i = 0; i < 24; ++i) {
    SweepRow r;
    r.p = SweepPoint{"builtin:cornell", "default:coord_bits=" + std::to_string(10 + i), 4, "rdna2"};
    r.rays = 1000;
    r.hit_agreement = 1.0 - 0.001 * (1 + i % 5);
    r.t_rel_error_mean = 1e-4 * (1 + i % 7);
    r.cycles = 10000 + 50 * uint64_t(i);
    r.bvh_bytes = 8000 + 20 * uint64_t(i % 6);
    r.area_mm2 = 1.0 + 0.01 * i;
    rows.push_back(r);
  }
  const std::vector<ParetoPlot> plots = write_pareto_plots(rows, d.string(), gnuplot);
  REQUIRE(plots.size() == 6);  // 3 scenes x 2 error measures
  for (const ParetoPlot& p : plots) {
    INFO(p.png);
    const Image img = read_png((d / p.png).string());
    // Fits a 1280 px window; two panels per row: DRAM bytes, area and energy only where a row has them.
    CHECK(img.width == kParetoPlotWidth);
    CHECK(img.width <= 1200);
    const int panels = 2 + int(p.area_panel) + int(p.dram_panel) + int(p.energy_panel);
    CHECK(img.height == p.title_height + (panels + 1) / 2 * kParetoPanelHeight);
    // Every panel's numbers: no two boxes overlap, each inside the image; crowding may leave a few out.
    for (const char* cost : {"cycles", "bvh_bytes", "area_mm2", "dram_bytes_per_ray", "pj_per_ray"}) {
      const std::string stem = p.png.substr(0, p.png.size() - 4);
      const fs::path f = d / (stem + "_" + cost + ".labels");
      INFO(f);
      if ((std::string(cost) == "area_mm2" && !p.area_panel) ||
          (std::string(cost) == "dram_bytes_per_ray" && !p.dram_panel) ||
          (std::string(cost) == "pj_per_ray" && !p.energy_panel)) {
        CHECK_FALSE(fs::exists(f));
        continue;
      }
      const PanelLabels l = read_labels(f);
      CHECK(l.places > 0);
      CHECK(l.boxes.size() + l.unplaced == l.places);
      for (size_t i = 0; i < l.boxes.size(); ++i) {
        CHECK(l.boxes[i].x0 >= 0);
        CHECK(l.boxes[i].x1 <= img.width);
        CHECK(l.boxes[i].y1 <= img.height);
        for (size_t j = 0; j < i; ++j) CHECK_FALSE(boxes_overlap(l.boxes[i], l.boxes[j]));
      }
    }
    CHECK(p.rows.size() == p.points);
  }
  CHECK(plots[0].area_panel);
  CHECK_FALSE(plots[2].area_panel);  // the mesh's row has no area: its panel is left out
  CHECK(plots[0].dram_panel);
  CHECK_FALSE(plots[2].dram_panel);  // nor DRAM bytes
  CHECK_FALSE(plots[4].dram_panel);
  CHECK(plots[0].energy_panel);
  CHECK_FALSE(plots[2].energy_panel);
  CHECK_FALSE(plots[4].energy_panel);
  // Energy rises with each point while the error falls: every point is on the front against energy.
  CHECK(plots[0].front[int(ParetoCost::kPjPerRay)] == std::vector<size_t>{0, 1, 2});
  // Less DRAM traffic with each point, and less error: the last point alone is the front against DRAM bytes.
  CHECK(plots[0].front[int(ParetoCost::kDramBytesPerRay)] == std::vector<size_t>{2});
  CHECK(plots[4].points == 24);
  CHECK(plots[4].unlabelled <= 4);  // crowded, but nearly every place keeps its number
  CHECK(plots[0].unlabelled == 0);  // sparse: every number placed
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
}

TEST_CASE("wrap_text: lines of at most the width, words kept, a long path cut after a separator", "[pareto]") {
  const std::string text = "a b  ccc dddd /usr/share/some/very/long/path/to/a/mesh.glb: end";
  for (size_t width : {1, 4, 10, 17, 200}) {
    INFO(width);
    const std::vector<std::string> lines = wrap_text(text, width);
    std::string joined, plain;
    for (const std::string& l : lines) {
      CHECK_FALSE(l.empty());
      CHECK(l.size() <= width);
      joined += l;
    }
    for (char c : text)
      if (c != ' ') plain += c;
    joined.erase(std::remove(joined.begin(), joined.end(), ' '), joined.end());
    CHECK(joined == plain);
  }
  CHECK(wrap_text(text, 200) ==
        std::vector<std::string>{"a b ccc dddd /usr/share/some/very/long/path/to/a/mesh.glb: end"});
  CHECK(wrap_text("/usr/share/models/x.glb", 12) == std::vector<std::string>{"/usr/share/", "models/x.glb"});
  CHECK(wrap_text("", 10).empty());
}

namespace {

// The single-quoted strings of a gnuplot line (gp_quote doubles a quote inside one).
std::vector<std::string> gp_strings(const std::string& line) {
  std::vector<std::string> out;
  for (size_t i = line.find('\''); i != std::string::npos; i = line.find('\'', i + 1)) {
    std::string s;
    for (++i; i < line.size(); ++i) {
      if (line[i] != '\'') {
        s += line[i];
      } else if (i + 1 < line.size() && line[i + 1] == '\'') {
        s += '\'';
        ++i;
      } else {
        break;
      }
    }
    out.push_back(s);
  }
  return out;
}

}  // namespace

TEST_CASE("pareto plots: the titles fit the image, the area panel is in mm^2", "[pareto]") {
  const std::string gnuplot = find_gnuplot();
  if (gnuplot.empty()) {
    WARN("gnuplot not installed: plot test skipped");
    return;
  }
  const rtu::test::TempDir dir("pareto_titles");
  const std::string scene =
      "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/some/deeper/folder/2CylinderEngine.glb";
  std::vector<SweepRow> rows;
  for (int i = 0; i < 4; ++i) {
    SweepRow r;
    r.p = SweepPoint{scene, "default:coord_bits=" + std::to_string(12 + 4 * i), 4, i % 2 ? "rdna2" : "intel"};
    r.rays = 20000;
    r.hit_agreement = 1.0 - 0.01 / (i + 1);
    r.t_rel_error_mean = 1e-3 / (i + 1);
    r.cycles = 1000 + 100 * uint64_t(i);
    r.bvh_bytes = 5000 + 1000 * uint64_t(i);
    r.rtl_cells = 150000 + 10000 * i;
    r.area_mm2 = 0.4 + 0.3 * i;
    rows.push_back(r);
  }
  const std::vector<ParetoPlot> plots = write_pareto_plots(rows, dir.path.string(), gnuplot);
  REQUIRE(plots.size() == 2);
  for (const ParetoPlot& p : plots) {
    INFO(p.png);
    const std::string stem = p.png.substr(0, p.png.size() - 4);
    std::ifstream script(dir.path / (stem + ".gp"));
    std::string title, area_panel;
    bool in_area = false;
    for (std::string line; std::getline(script, line);) {
      INFO(line);
      if (line.rfind("set label ", 0) == 0 && line.find(" center") != std::string::npos) {
        // The title's lines, centred on the image: 11 pt glyphs advance at most 9 px, 9 pt ones at most 7 px.
        const std::string text = gp_strings(line).at(0);
        const bool large = line.find("font ',11'") != std::string::npos;
        CHECK(double(text.size()) * (large ? 9.0 : 7.0) <= kParetoPlotWidth);
        if (large) title += text;
      }
      if (line.rfind("set title ", 0) == 0) {
        // A panel's title, over its half of the image.
        CHECK(gp_strings(line).at(0).size() * 7.0 <= kParetoPlotWidth / 2.0);
        in_area = line.find("'area") != std::string::npos;
      }
      if (in_area) area_panel += line + "\n";
    }
    // The title names the whole scene, over as many lines as it takes; the image grows by them.
    title.erase(std::remove(title.begin(), title.end(), ' '), title.end());
    CHECK(title.find(scene) != std::string::npos);
    CHECK(p.title_height >= 50);
    CHECK(read_png((dir.path / p.png).string()).height == p.title_height + 2 * kParetoPanelHeight);  // 3 panels
    // The area panel: mm^2 on its title and axis, plain numbers on its ticks (no SI prefix: 0.4, not 400m).
    REQUIRE(p.area_panel);
    CHECK(area_panel.find("mm^2") != std::string::npos);
    CHECK(area_panel.find("cells") == std::string::npos);
    CHECK(area_panel.find("set xlabel 'area_mm2'") != std::string::npos);
    CHECK(area_panel.find("%c") == std::string::npos);
    // Its front is drawn at the rows' area_mm2.
    std::ifstream front(dir.path / (stem + "_area_mm2.front"));
    std::vector<double> costs;
    for (std::string line; std::getline(front, line);)
      if (!line.empty() && line[0] != '#') costs.push_back(std::stod(line.substr(0, line.find(' '))));
    REQUIRE_FALSE(costs.empty());
    for (double c : costs)
      CHECK(std::any_of(rows.begin(), rows.end(), [&](const SweepRow& r) { return r.area_mm2 == Approx(c); }));
  }
}
