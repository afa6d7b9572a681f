#include "host/jobs/pareto.h"

#include <sys/stat.h>
#include <sys/wait.h>

#include <fcntl.h>
#include <unistd.h>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "host/io/error.h"

namespace rtu::host {

namespace {

// A file-name-safe tag of a scene spec: the name of a builtin or the file's stem.
std::string scene_tag(const std::string& scene) {
  std::string s = scene;
  if (s.rfind("builtin:", 0) == 0) {
    s = s.substr(8);
  } else {
    s = std::filesystem::path(s).stem().string();
  }
  std::string t;
  for (char c : s) t += std::isalnum(static_cast<unsigned char>(c)) ? c : '_';
  return t.empty() ? std::string("scene") : t;
}

// A gnuplot string in single quotes (a quote is doubled).
std::string gp_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) {
    q += c;
    if (c == '\'') q += c;
  }
  return q + "'";
}

// Text of a data-file label: no quotes or white space.
std::string label_field(const std::string& s) {
  std::string t;
  for (char c : s) t += (c == '"' || std::isspace(static_cast<unsigned char>(c))) ? '_' : c;
  return '"' + t + '"';
}

std::string g(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

// Runs argv[0] (looked up on PATH) in `dir`, stdout and stderr to `log`; returns the exit status (127: not
// started, 128 + n: killed by signal n).
int run_in(const std::vector<std::string>& args, const std::string& dir, const std::string& log) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = ::fork();
  if (pid < 0) throw Error("cannot start " + args[0] + ": fork failed");
  if (pid == 0) {
    if (::chdir(dir.c_str()) != 0) ::_exit(127);
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::close(fd);
    }
    ::execvp(argv[0], argv.data());
    ::_exit(127);
  }
  int st = 0;
  while (::waitpid(pid, &st, 0) < 0) {
  }
  return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

struct Range {
  double lo = HUGE_VAL, hi = -HUGE_VAL;
  void add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool empty() const { return lo > hi; }
};

// Point numbers as text: ascending, a run of three or more consecutive numbers as "first-last", e.g. "1-3,7".
std::string number_list(std::vector<size_t> n) {
  std::sort(n.begin(), n.end());
  std::string t;
  for (size_t i = 0; i < n.size();) {
    size_t j = i;
    while (j + 1 < n.size() && n[j + 1] == n[j] + 1) ++j;
    if (!t.empty()) t += ',';
    t += std::to_string(n[i]);
    if (j >= i + 2) {
      t += '-';  // appended apart: GCC 12 warns (-Wrestrict, falsely) on "-" + std::to_string(...)
      t += std::to_string(n[j]);
      i = j + 1;
    } else {
      ++i;
    }
  }
  return t;
}

// Each cost's name (its CSV column and JSON key) and its plot axis, in ParetoCost's order.
struct CostText {
  const char* name;
  const char* axis;
};
constexpr CostText kCostText[kParetoCostCount] = {
    {"cycles", "simulated cycles (timed device, the sweep's rays)"},
    {"bvh_bytes", "memory: encoded image bytes (nodes, primitives; the format's layouts)"},
    {"area_mm2", "area: mm^2 of the unit (45 nm estimate: units, caches, ray slots)"},
    {"dram_bytes_per_ray", "memory traffic: DRAM bytes per ray (timed device)"},
    {"pj_per_ray", "energy: pJ per ray (45 nm estimate, timed device)"}};
static_assert(int(ParetoCost::kPjPerRay) == kParetoCostCount - 1);

const char* cost_axis(ParetoCost c) {
  return kCostText[int(c)].axis;
}

const char* error_axis(ParetoError e) {
  return e == ParetoError::kHitDisagreement ? "hit disagreement (1 - hit agreement)" : "mean relative t error";
}

}  // namespace

const char* pareto_error_name(ParetoError e) {
  return e == ParetoError::kHitDisagreement ? "hit_disagreement" : "t_rel_error_mean";
}

const char* pareto_cost_name(ParetoCost c) {
  return kCostText[int(c)].name;
}

double pareto_error(const SweepRow& r, ParetoError e) {
  if (e == ParetoError::kHitDisagreement) {
    const double one_ray = r.rays ? 1.0 / double(r.rays) : 1e-9;
    return r.hit_disagreement() > 0.0 ? std::max(r.hit_disagreement(), one_ray) : one_ray / kHitZeroBelow;
  }
  return r.t_rel_error_mean > 0.0 ? r.t_rel_error_mean : kZeroTError;
}

double pareto_cost(const SweepRow& r, ParetoCost c) {
  switch (c) {
    case ParetoCost::kCycles:
      return double(r.cycles);
    case ParetoCost::kBvhBytes:
      return double(r.bvh_bytes);
    case ParetoCost::kAreaMm2:
      return r.area_mm2 > 0.0 ? r.area_mm2 : -1.0;
    case ParetoCost::kDramBytesPerRay:
      return r.dram_bytes_per_ray > 0.0 ? r.dram_bytes_per_ray : -1.0;
    case ParetoCost::kPjPerRay:
      return r.pj_per_ray > 0.0 ? r.pj_per_ray : -1.0;
  }
  return -1.0;
}

std::vector<size_t> pareto_front(const std::vector<std::pair<double, double>>& points) {
  std::vector<size_t> order(points.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return points[a] < points[b]; });
  std::vector<size_t> front;
  for (size_t i : order) {
    if (front.empty() || points[i].second < points[front.back()].second || points[i] == points[front.back()])
      front.push_back(i);
  }
  return front;
}

std::string pareto_label(const SweepPoint& p) {
  return p.format + "/" + std::to_string(p.bvh_width) + "/" + p.config;
}

std::string find_gnuplot() {
  const char* path = std::getenv("PATH");
  if (!path) return "";
  std::stringstream ss(path);
  for (std::string d; std::getline(ss, d, ':');) {
    std::string f = d.empty() ? std::string(".") : d;
    f += "/gnuplot";
    struct stat st;
    if (::stat(f.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(f.c_str(), X_OK) == 0) return f;
  }
  return "";
}

std::vector<std::string> wrap_text(const std::string& text, size_t width) {
  width = std::max<size_t>(width, 1);
  std::vector<std::string> lines;
  std::string line;
  std::istringstream words(text);
  for (std::string w; words >> w;) {
    // A word longer than a line starts a line of its own and is cut after the last separator that fits.
    while (w.size() > width) {
      if (!line.empty()) lines.push_back(std::move(line));
      line.clear();
      const size_t at = w.find_last_of("/:,", width - 1);
      const size_t cut = at != std::string::npos && at > 0 ? at + 1 : width;
      lines.push_back(w.substr(0, cut));
      w.erase(0, cut);
    }
    if (w.empty()) continue;
    if (line.empty()) {
      line = w;
    } else if (line.size() + 1 + w.size() <= width) {
      line += ' ';
      line += w;
    } else {
      lines.push_back(std::move(line));
      line = w;
    }
  }
  if (!line.empty()) lines.push_back(std::move(line));
  return lines;
}

bool boxes_overlap(const LabelBox& a, const LabelBox& b) {
  return a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;
}

std::vector<LabelPlace> place_labels(const std::vector<LabelRequest>& labels,
                                     const std::vector<LabelBox>& obstacles, const LabelBox& bounds) {
  // Directions from the point to the box, as (dx, dy) in -1..1: the box's near edge or corner sits `r` away.
  static constexpr int kDirs[8][2] = {{1, 0}, {1, -1}, {0, -1}, {-1, -1}, {-1, 0}, {-1, 1}, {0, 1}, {1, 1}};
  // Ring distances in pixels: the first beside the marker, the rest with a leader line.
  static constexpr double kRings[] = {10.0, 26.0, 46.0, 72.0};
  std::vector<LabelPlace> out(labels.size());
  std::vector<LabelBox> taken;
  for (size_t i = 0; i < labels.size(); ++i) {
    const LabelRequest& q = labels[i];
    for (size_t ring = 0; ring < std::size(kRings) && !out[i].placed; ++ring) {
      const double r = kRings[ring];
      for (const auto& d : kDirs) {
        LabelBox b;
        // Horizontally: right of the point, left of it, or centred on it; vertically likewise.
        b.x0 = d[0] > 0 ? q.x + r : d[0] < 0 ? q.x - r - q.w : q.x - q.w / 2;
        b.y0 = d[1] > 0 ? q.y + r : d[1] < 0 ? q.y - r - q.h : q.y - q.h / 2;
        b.x1 = b.x0 + q.w;
        b.y1 = b.y0 + q.h;
        if (b.x0 < bounds.x0 || b.y0 < bounds.y0 || b.x1 > bounds.x1 || b.y1 > bounds.y1) continue;
        const auto hits = [&](const LabelBox& o) { return boxes_overlap(b, o); };
        if (std::any_of(obstacles.begin(), obstacles.end(), hits) || std::any_of(taken.begin(), taken.end(), hits))
          continue;
        out[i] = LabelPlace{true, ring > 0, b};
        taken.push_back(b);
        break;
      }
    }
  }
  return out;
}

namespace {

// One scene's rows of the sweep and where its errors are drawn.
struct SceneRows {
  std::string scene;
  std::vector<size_t> idx;  // its rows, in sweep order (a point's number is its place here + 1)
  std::string base;         // the stem of its files: pareto_TAG, TAG unique among the sweep's scenes
  double one_ray = 0.0;     // one wrong ray of its largest sample
  double hit_zero = 0.0;    // where a hit disagreement of 0 is drawn
  bool hit_zeros = false;   // some row has a hit disagreement of 0

  // Hit disagreements of 0 are drawn at one place for the scene, a decade under one wrong ray of its largest
  // sample (rows of one scene made with other --rays would otherwise put their zeros at other heights).
  double drawn_error(const SweepRow& r, ParetoError e) const {
    return e == ParetoError::kHitDisagreement && r.hit_disagreement() <= 0.0 ? hit_zero : pareto_error(r, e);
  }
};

// The rows by scene, in the order scenes first appear.
std::vector<SceneRows> rows_by_scene(const std::vector<SweepRow>& rows) {
  std::vector<std::string> scenes;
  std::map<std::string, std::vector<size_t>> by_scene;
  for (size_t i = 0; i < rows.size(); ++i) {
    if (!by_scene.count(rows[i].p.scene)) scenes.push_back(rows[i].p.scene);
    by_scene[rows[i].p.scene].push_back(i);
  }
  std::set<std::string> tags;
  std::vector<SceneRows> out;
  for (const std::string& scene : scenes) {
    SceneRows s;
    s.scene = scene;
    s.idx = by_scene[scene];
    std::string tag = scene_tag(scene);
    for (int k = 2; !tags.insert(tag).second; ++k) tag = scene_tag(scene) + "_" + std::to_string(k);
    s.base = "pareto_" + tag;
    uint64_t rays = 0;
    for (size_t i : s.idx) rays = std::max(rays, rows[i].rays);
    s.one_ray = rays ? 1.0 / double(rays) : 1e-9;
    s.hit_zero = s.one_ray / kHitZeroBelow;
    s.hit_zeros =
        std::any_of(s.idx.begin(), s.idx.end(), [&](size_t i) { return rows[i].hit_disagreement() <= 0.0; });
    out.push_back(std::move(s));
  }
  return out;
}

// The scene's data file (BASE.dat), a line per point in number order. The first columns are the costs in
// ParetoCost order (a panel plots column cost + 1).
void write_scene_data(const std::vector<SweepRow>& rows, const SceneRows& s, const std::string& dir) {
  const std::string data = s.base + ".dat";
  std::ofstream f(dir + "/" + data);
  f << "# " << s.scene
    << ": cycles bvh_bytes area_mm2 dram_bytes_per_ray pj_per_ray hit_disagreement t_rel_error_mean label "
       "number "
       "bytes_per_prim (? = unknown)\n";
  for (size_t k = 0; k < s.idx.size(); ++k) {
    const SweepRow& r = rows[s.idx[k]];
    f << r.cycles << ' ' << r.bvh_bytes << ' ' << (r.area_mm2 > 0.0 ? g(r.area_mm2) : "?") << ' '
      << (r.dram_bytes_per_ray > 0.0 ? g(r.dram_bytes_per_ray) : "?") << ' '
      << (r.pj_per_ray > 0.0 ? g(r.pj_per_ray) : "?") << ' ' << g(s.drawn_error(r, ParetoError::kHitDisagreement))
      << ' ' << g(s.drawn_error(r, ParetoError::kTRelErrorMean)) << ' ' << label_field(pareto_label(r.p)) << ' '
      << k + 1 << ' ' << g(r.bytes_per_prim) << '\n';
  }
  if (!f.flush()) throw Error("cannot write " + dir + "/" + data);
}

// The panels drawn, cycles and image bytes always; DRAM bytes, area and energy only when some row of the scene has
// them.
struct Panels {
  std::vector<ParetoCost> costs = {ParetoCost::kCycles, ParetoCost::kBvhBytes};
  bool dram = false, area = false, energy = false;
};

Panels scene_panels(const std::vector<SweepRow>& rows, const SceneRows& s) {
  const auto any_known = [&](ParetoCost c) {
    return std::any_of(s.idx.begin(), s.idx.end(), [&](size_t i) { return pareto_cost(rows[i], c) > 0; });
  };
  Panels p;
  p.dram = any_known(ParetoCost::kDramBytesPerRay);
  p.area = any_known(ParetoCost::kAreaMm2);
  p.energy = any_known(ParetoCost::kPjPerRay);
  if (p.dram) p.costs.push_back(ParetoCost::kDramBytesPerRay);
  if (p.area) p.costs.push_back(ParetoCost::kAreaMm2);
  if (p.energy) p.costs.push_back(ParetoCost::kPjPerRay);
  return p;
}

// The image in pixels (y down) and gnuplot's screen coordinates of a pixel.
struct Canvas {
  double width = 0.0, height = 0.0;
  std::string sx(double px) const { return g(px / width); }
  std::string sy(double py) const { return g(1.0 - py / height); }
};

// The script's lines before the panels: terminal, output, the settings every panel shares.
std::string script_header(const SceneRows& s, ParetoError e, const std::string& png, const std::string& script,
                          const Canvas& cv) {
  std::ostringstream gp;
  gp << "# Pareto plots of " << s.scene << " (rtusim pareto / rtusim report); run: gnuplot " << script << "\n"
     << "set terminal pngcairo noenhanced size " << kParetoPlotWidth << "," << int(cv.height) << " font 'sans,9'\n"
     << "set output " << gp_quote(png) << "\n"
     << "set datafile missing '?'\n"
     << "set grid\nunset key\nset logscale y\nset format y '%.0e'\n"
     << "set style textbox opaque noborder margins 1,1\n"
     << "set ylabel " << gp_quote(error_axis(e)) << "\n";
  return gp.str();
}

// Tags of the title's labels and of the zero axis's break: above any place's label or leader (tagged by its number
// in the panel, 1, 2, ...), so that a crowded panel cannot replace them.
constexpr int kTitleLabelTag = 100001;
constexpr int kZeroBreakTag = 100000;

// Pixels above the first line of the title and below its last.
constexpr int kTitleTopPx = 6, kTitleBottomPx = 11;

// The title above the panels: the scene and the error (11 pt), then how to read the plot (9 pt), each wrapped to
// the image's width.
struct TitleLines {
  std::vector<std::string> title, legend;
  int height() const {
    return kTitleTopPx + int(title.size()) * kParetoTitleLinePx + int(legend.size()) * kParetoTextLinePx +
           kTitleBottomPx;
  }
};

TitleLines title_lines(const SceneRows& s, ParetoError e) {
  const std::string title =
      s.scene + ": " + error_axis(e) + " against cost, " + std::to_string(s.idx.size()) + " points";
  std::string legend = e == ParetoError::kHitDisagreement ? "one wrong ray is 1/rays = " + g(s.one_ray) +
                                                                ", 0 is drawn apart under the dashed line"
                                                          : "0 is drawn at " + g(kZeroTError);
  legend +=
      "; numbers: the points (the scene's rows, format/width/config, in the table under the plots); blue: sweep "
      "points; red staircase and circles: the Pareto front";
  const double room = kParetoPlotWidth - 20.0;  // 10 px each side
  return TitleLines{wrap_text(title, size_t(room / kParetoTitleCharPx)),
                    wrap_text(legend, size_t(room / kParetoTextCharPx))};
}

// The title's lines as labels at fixed places, so that they cannot move the panels. Drawn with the first panel
// (each panel starts with `unset label`).
std::string title_labels(const TitleLines& t, const Canvas& cv) {
  std::string gp;
  int tag = kTitleLabelTag;
  double y = kTitleTopPx;
  for (const std::string& line : t.title) {
    gp += "set label " + std::to_string(tag++) + ' ' + gp_quote(line) + " at screen 0.5," +
          cv.sy(y + kParetoTitleLinePx / 2.0) + " center font ',11'\n";
    y += kParetoTitleLinePx;
  }
  for (const std::string& line : t.legend) {
    gp += "set label " + std::to_string(tag++) + ' ' + gp_quote(line) + " at screen 0.5," +
          cv.sy(y + kParetoTextLinePx / 2.0) + " center\n";
    y += kParetoTextLinePx;
  }
  return gp;
}

// With zeros on the hit axis: a dashed break between the zeros and one wrong ray (halfway on the log axis), a "0"
// tick at the zeros and decade ticks only above the break, where errors are measured. Empty otherwise.
std::string zero_axis(const SceneRows& s, ParetoError e, double yhi) {
  if (e != ParetoError::kHitDisagreement || !s.hit_zeros) return std::string();
  const double brk = std::sqrt(s.hit_zero * s.one_ray);
  std::string z = "set ytics (\"0\" " + g(s.hit_zero);
  for (double dec = std::pow(10.0, std::ceil(std::log10(brk))); dec <= yhi; dec *= 10.0) z += ", " + g(dec);
  z += ")\nset arrow " + std::to_string(kZeroBreakTag) + " from graph 0, first " + g(brk) + " to graph 1, first " +
       g(brk) + " nohead dt 2 lw 1.5 lc rgb '#606060' back\n";
  return z;
}

// What one plot (a scene and an error) shares across its panels.
struct PlotFrame {
  const SceneRows& s;
  ParetoError e;
  std::string ename;  // "hit" or "terr", in the file names
  Canvas cv;
  int title_height = 0;         // pixels above the panels
  double ylo = 0.0, yhi = 0.0;  // the error axis
  std::string title, zero;      // title_labels, zero_axis
};

// A panel's points: those whose cost is known, at (cost, drawn error).
struct PanelPoints {
  std::vector<std::pair<double, double>> pts;
  std::vector<size_t> which;  // position in the scene's rows (the point's number - 1)
  Range xr;                   // the costs
};

PanelPoints panel_points(const std::vector<SweepRow>& rows, const PlotFrame& pf, ParetoCost cost) {
  PanelPoints p;
  for (size_t k = 0; k < pf.s.idx.size(); ++k) {
    const double x = pareto_cost(rows[pf.s.idx[k]], cost);
    if (x <= 0.0) continue;
    p.pts.emplace_back(x, pf.s.drawn_error(rows[pf.s.idx[k]], pf.e));
    p.which.push_back(k);
    p.xr.add(x);
  }
  return p;
}

// The front's points, cost, error and label, in front order (FRONT_FILE, which the panel draws as a staircase).
void write_front_file(const std::vector<SweepRow>& rows, const PlotFrame& pf, ParetoCost cost,
                      const PanelPoints& p, const std::vector<size_t>& front, const std::string& dir,
                      const std::string& front_file) {
  std::ofstream f(dir + "/" + front_file);
  f << "# the Pareto front: " << pareto_cost_name(cost) << ' ' << pareto_error_name(pf.e) << " label\n";
  for (size_t k : front)
    f << g(p.pts[k].first) << ' ' << g(p.pts[k].second) << ' '
      << label_field(pareto_label(rows[pf.s.idx[p.which[k]]].p)) << '\n';
  if (!f.flush()) throw Error("cannot write " + dir + "/" + front_file);
}

// The panel's place in the image and the scale of its axes, pixels y down.
struct PanelAxes {
  double x0 = 0.0, x1 = 0.0, y0 = 0.0, y1 = 0.0;  // the plot area
  bool logx = false;
  double xlo = 0.0, xhi = 0.0, ylo = 0.0, yhi = 0.0;
  double px(double x) const {
    const double f = logx ? std::log(x / xlo) / std::log(xhi / xlo) : (x - xlo) / (xhi - xlo);
    return x0 + f * (x1 - x0);
  }
  double py(double y) const { return y1 - std::log(y / ylo) / std::log(yhi / ylo) * (y1 - y0); }
};

// Panel c of the image (two per row): its plot area leaves margins for the error axis on the left, the panel
// title on top and the cost axis below. The cost axis is logarithmic over a wide range of costs, linear over a
// narrow one (a log axis would show no tick there).
PanelAxes panel_axes(const PlotFrame& pf, size_t c, const Range& xr) {
  PanelAxes a;
  const double width = pf.cv.width;
  const double cx = double(c % 2) * width / 2, cy = pf.title_height + double(c / 2) * kParetoPanelHeight;
  a.x0 = cx + 85;
  a.x1 = cx + width / 2 - 20;
  a.y0 = cy + 30;
  a.y1 = cy + kParetoPanelHeight - 60;
  a.logx = xr.hi >= 3.0 * xr.lo;
  if (a.logx) {
    a.xlo = xr.lo / 1.3;
    a.xhi = xr.hi * 1.3;
  } else {
    const double span = xr.hi > xr.lo ? xr.hi - xr.lo : 0.05 * xr.hi;
    a.xlo = std::max(0.0, xr.lo - 0.15 * span);
    a.xhi = xr.hi + 0.15 * span;
  }
  a.ylo = pf.ylo;
  a.yhi = pf.yhi;
  return a;
}

// One label per place: points drawn on the same spot (within 4 px, so that the eye cannot tell them apart; e.g.
// presets that differ only in timing, on the memory axis) share one, "3-5" or "1,4".
struct Place {
  double x, y;                  // pixels of the first point of the place
  std::vector<size_t> members;  // numbers - 1
  bool front = false;
};

// The places of the panel's points, those with a point of the front first (they are labelled first).
std::vector<Place> label_places(const PanelPoints& p, const std::vector<size_t>& front, const PanelAxes& a) {
  std::vector<Place> places;
  std::set<size_t> front_set(front.begin(), front.end());
  for (size_t k = 0; k < p.pts.size(); ++k) {
    const double mx = a.px(p.pts[k].first), my = a.py(p.pts[k].second);
    auto it = std::find_if(places.begin(), places.end(), [&](const Place& pl) {
      return std::abs(pl.x - mx) <= 4.0 && std::abs(pl.y - my) <= 4.0;
    });
    if (it == places.end()) {
      places.push_back(Place{mx, my, {}, false});
      it = places.end() - 1;
    }
    it->members.push_back(p.which[k]);
    it->front = it->front || front_set.count(k) > 0;
  }
  std::stable_sort(places.begin(), places.end(),
                   [](const Place& l, const Place& r) { return l.front && !r.front; });
  return places;
}

// Places the labels of the places without overlaps, writes them to LABEL_FILE (pixels of the PNG) and returns
// the script's lines that draw them; counts the labels that found no place in plot.unlabelled.
std::string write_labels(const std::vector<Place>& places, const PanelAxes& a, const PlotFrame& pf,
                         const std::string& dir, const std::string& label_file, ParetoPlot& plot) {
  std::vector<LabelRequest> requests;
  std::vector<LabelBox> markers;
  std::vector<std::string> texts;
  for (const Place& pl : places) {
    std::vector<size_t> numbers;
    for (size_t k : pl.members) numbers.push_back(k + 1);
    texts.push_back(number_list(numbers));
    // Glyphs of the 9 pt font are at most 8 px wide and 13 px high; 2 px of room on each side.
    requests.push_back(LabelRequest{pl.x, pl.y, 8.0 * double(texts.back().size()) + 4.0, 16.0});
    const double m = pl.front ? 9.0 : 6.0;  // the marker's half size (front: the red circle)
    markers.push_back(LabelBox{pl.x - m, pl.y - m, pl.x + m, pl.y + m});
  }
  const std::vector<LabelPlace> placed = place_labels(requests, markers, LabelBox{a.x0, a.y0, a.x1, a.y1});
  std::ostringstream labels_gp;
  std::ofstream f(dir + "/" + label_file);
  f << "# numbers point_x point_y box_x0 box_y0 box_x1 box_y1 leader (pixels of " << plot.png
    << ", y down; - when no free place was found)\n";
  for (size_t k = 0; k < places.size(); ++k) {
    const LabelPlace& p = placed[k];
    f << label_field(texts[k]) << ' ' << g(requests[k].x) << ' ' << g(requests[k].y);
    if (!p.placed) {
      f << " - - - - -\n";
      ++plot.unlabelled;
      continue;
    }
    f << ' ' << g(p.box.x0) << ' ' << g(p.box.y0) << ' ' << g(p.box.x1) << ' ' << g(p.box.y1) << ' '
      << (p.leader ? 1 : 0) << '\n';
    labels_gp << "set label " << k + 1 << ' ' << gp_quote(texts[k]) << " at screen " << pf.cv.sx(p.box.x0 + 2)
              << "," << pf.cv.sy((p.box.y0 + p.box.y1) / 2) << " left front boxed\n";
    if (p.leader) {
      // From the marker's edge to the nearest point of the box.
      const double bx = std::clamp(requests[k].x, p.box.x0, p.box.x1);
      const double by = std::clamp(requests[k].y, p.box.y0, p.box.y1);
      labels_gp << "set arrow " << k + 1 << " from screen " << pf.cv.sx(requests[k].x) << ","
                << pf.cv.sy(requests[k].y) << " to screen " << pf.cv.sx(bx) << "," << pf.cv.sy(by)
                << " nohead lc rgb '#909090' lw 1 back\n";
    }
  }
  if (!f.flush()) throw Error("cannot write " + dir + "/" + label_file);
  return labels_gp.str();
}

// The cost axis's ticks and their format: SI prefixes for counts (12k, 3M); plain numbers where `plain` (mm^2: a
// prefix would print half a square millimetre as 500m).
std::string cost_ticks(const PanelAxes& a, bool plain) {
  std::ostringstream gp;
  if (a.logx) {
    // Ticks at 1, 2 and 5 times the powers of ten in range (gnuplot's own log ticks are decades only).
    gp << "set logscale x\nset xtics (";
    bool first = true;
    for (double dec = std::pow(10.0, std::floor(std::log10(a.xlo))); dec <= a.xhi; dec *= 10.0)
      for (double m : {1.0, 2.0, 5.0})
        if (m * dec >= a.xlo && m * dec <= a.xhi) {
          gp << (first ? "" : ", ") << g(m * dec);
          first = false;
        }
    gp << ")\nset format x '" << (plain ? "%g" : "%.0s%c") << "'\n";
  } else if (plain) {
    const int decimals = std::clamp(int(std::ceil(-std::log10((a.xhi - a.xlo) / 5.0))), 0, 4);
    gp << "unset logscale x\nset xtics autofreq\nset format x '%." << decimals << "f'\n";
  } else {
    // Enough decimals of the mantissa (gnuplot's %s, scaled by the %c prefix) that ticks about a fifth of the
    // range apart print differently.
    const double unit = std::pow(1000.0, std::floor(std::log10(a.xhi) / 3.0));
    const int decimals = std::clamp(int(std::ceil(-std::log10((a.xhi - a.xlo) / unit / 5.0))), 0, 3);
    gp << "unset logscale x\nset xtics autofreq\nset format x '%." << decimals << "s%c'\n";
  }
  return gp.str();
}

// Panel c of the plot, against `cost`: its front (into plot.front), its front and label files, and its lines of
// the script.
std::string write_panel(const std::vector<SweepRow>& rows, const PlotFrame& pf, size_t c, ParetoCost cost,
                        const std::string& dir, ParetoPlot& plot) {
  const int ci = int(cost);  // index into plot.front and the data file's columns
  const PanelPoints p = panel_points(rows, pf, cost);
  const std::vector<size_t> front = pareto_front(p.pts);
  for (size_t f : front) plot.front[ci].push_back(pf.s.idx[p.which[f]]);
  const std::string stem = pf.s.base + "_" + pf.ename + "_" + pareto_cost_name(cost);
  const std::string front_file = stem + ".front";
  write_front_file(rows, pf, cost, p, front, dir, front_file);
  const PanelAxes a = panel_axes(pf, c, p.xr);
  const std::string labels_gp = write_labels(label_places(p, front, a), a, pf, dir, stem + ".labels", plot);
  std::ostringstream gp;
  gp << "unset label\nunset arrow\n"
     << (c == 0 ? pf.title : std::string()) << "set lmargin at screen " << pf.cv.sx(a.x0)
     << "\nset rmargin at screen " << pf.cv.sx(a.x1) << "\n"
     << "set tmargin at screen " << pf.cv.sy(a.y0) << "\nset bmargin at screen " << pf.cv.sy(a.y1) << "\n"
     << "set title " << gp_quote(std::string(cost_axis(cost))) << "\n"
     << "set xlabel " << gp_quote(pareto_cost_name(cost)) << "\n"
     << "set yrange [" << g(a.ylo) << ":" << g(a.yhi) << "]\n"
     << "set xrange [" << g(a.xlo) << ":" << g(a.xhi) << "]\n";
  gp << cost_ticks(a, cost == ParetoCost::kAreaMm2) << labels_gp << pf.zero;
  const int ycol = pf.e == ParetoError::kHitDisagreement ? 6 : 7;
  gp << "plot " << gp_quote(pf.s.base + ".dat") << " using " << ci + 1 << ":" << ycol
     << " with points pt 7 ps 1.2 lc rgb '#3060c0', \\\n"
     << "  " << gp_quote(front_file) << " using 1:2 with steps lw 2 lc rgb '#d03020', \\\n"
     << "  '' using 1:2 with points pt 6 ps 2 lw 2 lc rgb '#d03020'\n";
  return gp.str();
}

// Writes SCRIPT and runs gnuplot on it in dir; throws Error when it fails or makes no PNG. Its log is kept only
// when gnuplot said something.
void run_gnuplot(const std::string& gnuplot, const std::string& dir, const std::string& script,
                 const std::string& text, const std::string& png, const std::string& log) {
  {
    std::ofstream f(dir + "/" + script);
    f << text;
    if (!f.flush()) throw Error("cannot write " + dir + "/" + script);
  }
  const int st = run_in({gnuplot, script}, dir, log);
  std::error_code ec;
  if (st != 0 || !std::filesystem::exists(dir + "/" + png, ec))
    throw Error("pareto: gnuplot failed on " + dir + "/" + script + " (exit " + std::to_string(st) + "; see " +
                dir + "/" + log + ")");
  if (std::filesystem::file_size(dir + "/" + log, ec) == 0 && !ec) std::filesystem::remove(dir + "/" + log, ec);
}

// The scene's plot of error e against each panel's cost: a PNG of its panels, its script, data and label files.
ParetoPlot write_scene_plot(const std::vector<SweepRow>& rows, const SceneRows& s, const Panels& panels,
                            ParetoError e, const std::string& dir, const std::string& gnuplot) {
  const int panel_rows = int(panels.costs.size() + 1) / 2;
  const TitleLines title = title_lines(s, e);
  const Canvas cv{double(kParetoPlotWidth), double(title.height() + panel_rows * kParetoPanelHeight)};
  Range yr;
  for (size_t i : s.idx) yr.add(s.drawn_error(rows[i], e));
  const double yhi = yr.hi * 3;
  const PlotFrame pf{s,
                     e,
                     e == ParetoError::kHitDisagreement ? "hit" : "terr",
                     cv,
                     title.height(),
                     yr.lo / 3,
                     yhi,
                     title_labels(title, cv),
                     zero_axis(s, e, yhi)};
  ParetoPlot plot;
  plot.scene = s.scene;
  plot.error = e;
  plot.points = s.idx.size();
  plot.rows = s.idx;
  plot.title_height = title.height();
  plot.area_panel = panels.area;
  plot.dram_panel = panels.dram;
  plot.energy_panel = panels.energy;
  plot.png = s.base + "_" + pf.ename + ".png";
  const std::string script = s.base + "_" + pf.ename + ".gp";
  std::string gp = script_header(s, e, plot.png, script, pf.cv) + "set multiplot\n";
  for (size_t c = 0; c < panels.costs.size(); ++c) gp += write_panel(rows, pf, c, panels.costs[c], dir, plot);
  gp += "unset multiplot\n";
  run_gnuplot(gnuplot, dir, script, gp, plot.png, s.base + "_" + pf.ename + ".log");
  return plot;
}

}  // namespace

std::vector<ParetoPlot> write_pareto_plots(const std::vector<SweepRow>& rows, const std::string& dir,
                                           const std::string& gnuplot) {
  if (rows.empty()) throw Error("pareto: the sweep has no rows");
  if (gnuplot.empty()) throw Error("pareto: gnuplot not found (install the Debian package gnuplot-nox)");
  std::vector<ParetoPlot> plots;
  for (const SceneRows& s : rows_by_scene(rows)) {
    write_scene_data(rows, s, dir);
    const Panels panels = scene_panels(rows, s);
    for (ParetoError e : {ParetoError::kHitDisagreement, ParetoError::kTRelErrorMean})
      plots.push_back(write_scene_plot(rows, s, panels, e, dir, gnuplot));
  }
  return plots;
}

}  // namespace rtu::host
