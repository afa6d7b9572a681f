#include "host/pareto.h"

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

#include "host/error.h"

namespace rtu::host {

namespace {

constexpr ParetoCost kCosts[3] = {ParetoCost::kCycles, ParetoCost::kBvhBytes, ParetoCost::kRtlCells};

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

const char* cost_axis(ParetoCost c) {
  switch (c) {
    case ParetoCost::kCycles:
      return "simulated cycles (timed device, the sweep's rays)";
    case ParetoCost::kBvhBytes:
      return "memory: encoded BVH bytes (nodes + records)";
    case ParetoCost::kRtlCells:
      return "area: RTL box unit cells (yosys)";
  }
  return "";
}

const char* error_axis(ParetoError e) {
  return e == ParetoError::kHitDisagreement ? "hit disagreement (1 - hit agreement)" : "mean relative t error";
}

}  // namespace

const char* pareto_error_name(ParetoError e) {
  return e == ParetoError::kHitDisagreement ? "hit_disagreement" : "t_rel_error_mean";
}

const char* pareto_cost_name(ParetoCost c) {
  switch (c) {
    case ParetoCost::kCycles:
      return "cycles";
    case ParetoCost::kBvhBytes:
      return "bvh_bytes";
    case ParetoCost::kRtlCells:
      return "rtl_cells";
  }
  return "";
}

double pareto_error(const SweepRow& r, ParetoError e) {
  if (e == ParetoError::kHitDisagreement) {
    const double floor = r.rays ? 1.0 / double(r.rays) : 1e-9;
    return std::max(r.hit_disagreement(), floor);
  }
  return r.t_rel_error_mean > 0.0 ? r.t_rel_error_mean : kZeroTError;
}

double pareto_cost(const SweepRow& r, ParetoCost c) {
  switch (c) {
    case ParetoCost::kCycles:
      return double(r.cycles);
    case ParetoCost::kBvhBytes:
      return double(r.bvh_bytes);
    case ParetoCost::kRtlCells:
      return r.rtl_cells >= 0 ? double(r.rtl_cells) : -1.0;
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

std::vector<ParetoPlot> write_pareto_plots(const std::vector<SweepRow>& rows, const std::string& dir,
                                           const std::string& gnuplot) {
  if (rows.empty()) throw Error("pareto: the sweep has no rows");
  if (gnuplot.empty()) throw Error("pareto: gnuplot not found (install the Debian package gnuplot-nox)");
  // Rows by scene, in the order scenes first appear.
  std::vector<std::string> scenes;
  std::map<std::string, std::vector<size_t>> by_scene;
  for (size_t i = 0; i < rows.size(); ++i) {
    if (!by_scene.count(rows[i].p.scene)) scenes.push_back(rows[i].p.scene);
    by_scene[rows[i].p.scene].push_back(i);
  }
  std::set<std::string> tags;
  std::vector<ParetoPlot> plots;
  for (const std::string& scene : scenes) {
    std::string tag = scene_tag(scene);
    for (int k = 2; !tags.insert(tag).second; ++k) tag = scene_tag(scene) + "_" + std::to_string(k);
    const std::vector<size_t>& idx = by_scene[scene];
    const std::string base = "pareto_" + tag;
    const std::string data = base + ".dat";
    {
      std::ofstream f(dir + "/" + data);
      f << "# " << scene << ": cycles bvh_bytes rtl_cells hit_disagreement t_rel_error_mean label (? = unknown)\n";
      for (size_t i : idx) {
        const SweepRow& r = rows[i];
        f << r.cycles << ' ' << r.bvh_bytes << ' ' << (r.rtl_cells >= 0 ? std::to_string(r.rtl_cells) : "?") << ' '
          << g(pareto_error(r, ParetoError::kHitDisagreement)) << ' '
          << g(pareto_error(r, ParetoError::kTRelErrorMean)) << ' ' << label_field(pareto_label(r.p)) << '\n';
      }
      if (!f.flush()) throw Error("cannot write " + dir + "/" + data);
    }
    uint64_t rays = 0;
    for (size_t i : idx) rays = std::max(rays, rows[i].rays);
    for (ParetoError e : {ParetoError::kHitDisagreement, ParetoError::kTRelErrorMean}) {
      ParetoPlot plot;
      plot.scene = scene;
      plot.error = e;
      plot.points = idx.size();
      const std::string ename = e == ParetoError::kHitDisagreement ? "hit" : "terr";
      plot.png = base + "_" + ename + ".png";
      const std::string script = base + "_" + ename + ".gp";
      std::ostringstream gp;
      gp << "# Pareto plots of " << scene << " (rtusim pareto / rtusim report); run: gnuplot " << script << "\n"
         << "set terminal pngcairo noenhanced size 1950,800 font 'sans,10'\n"
         << "set output " << gp_quote(plot.png) << "\n"
         << "set datafile missing '?'\n"
         << "set grid\nset key top right\nset logscale y\nset format y '%.0e'\n"
         << "set ylabel " << gp_quote(error_axis(e)) << "\n";
      std::string title = scene + ": " + error_axis(e) + " against cost, " + std::to_string(idx.size()) +
                          " points (format/width/config); line: the Pareto front";
      title += e == ParetoError::kHitDisagreement ? "; 0 is drawn at 1/rays = " + g(rays ? 1.0 / double(rays) : 0)
                                                  : "; 0 is drawn at " + g(kZeroTError);
      gp << "set multiplot layout 1,3 title " << gp_quote(title) << "\n";
      Range yr;
      for (size_t i : idx) yr.add(pareto_error(rows[i], e));
      const int ycol = e == ParetoError::kHitDisagreement ? 4 : 5;
      for (int c = 0; c < 3; ++c) {
        const ParetoCost cost = kCosts[c];
        std::vector<std::pair<double, double>> pts;
        std::vector<size_t> which;
        Range xr;
        for (size_t i : idx) {
          const double x = pareto_cost(rows[i], cost);
          if (x <= 0.0) continue;
          pts.emplace_back(x, pareto_error(rows[i], e));
          which.push_back(i);
          xr.add(x);
        }
        const std::vector<size_t> front = pareto_front(pts);
        for (size_t f : front) plot.front[c].push_back(which[f]);
        const std::string front_file = base + "_" + ename + "_" + pareto_cost_name(cost) + ".front";
        {
          std::ofstream f(dir + "/" + front_file);
          f << "# the Pareto front: " << pareto_cost_name(cost) << ' ' << pareto_error_name(e) << " label\n";
          for (size_t k : front)
            f << g(pts[k].first) << ' ' << g(pts[k].second) << ' ' << label_field(pareto_label(rows[which[k]].p))
              << '\n';
          if (!f.flush()) throw Error("cannot write " + dir + "/" + front_file);
        }
        // One label per place: points at the same cost and error (e.g. presets that differ only in timing, on
        // the memory axis) share a label, "format/width/config+config; ...".
        const std::string label_file = base + "_" + ename + "_" + pareto_cost_name(cost) + ".labels";
        {
          std::map<std::pair<double, double>, std::vector<size_t>> at;
          for (size_t k = 0; k < pts.size(); ++k) at[pts[k]].push_back(which[k]);
          std::ofstream f(dir + "/" + label_file);
          for (const auto& [xy, members] : at) {
            std::vector<std::pair<std::string, std::string>> groups;  // format/width, configs
            for (size_t i : members) {
              const std::string fw = rows[i].p.format + "/" + std::to_string(rows[i].p.bvh_width);
              auto it = std::find_if(groups.begin(), groups.end(), [&](const auto& gr) { return gr.first == fw; });
              if (it == groups.end())
                groups.emplace_back(fw, rows[i].p.config);
              else
                it->second += "+" + rows[i].p.config;
            }
            std::string text;
            for (const auto& [fw, configs] : groups) text += (text.empty() ? "" : ";") + fw + "/" + configs;
            f << g(xy.first) << ' ' << g(xy.second) << ' ' << label_field(text) << '\n';
          }
          if (!f.flush()) throw Error("cannot write " + dir + "/" + label_file);
        }
        gp << "set title " << gp_quote(std::string(cost_axis(cost))) << "\n"
           << "set xlabel " << gp_quote(pareto_cost_name(cost)) << "\n"
           << "set yrange [" << g(yr.lo / 4) << ":" << g(yr.hi * 30) << "]\n";
        if (pts.empty()) {
          gp << "unset logscale x\nset xrange [0:1]\nunset xtics\n"
             << "set label 1 'no area known for these points (rtl_cells = -1; rtusim sweep --area TABLE)' at "
                "graph 0.5,0.5 center\n"
             << "plot '-' using 1:2 with points lc rgb 'white' notitle\n0.5 " << g(yr.lo) << "\ne\n"
             << "unset label 1\nset xtics autofreq\n";
          continue;
        }
        // A log axis over a wide range of costs; a linear one over a narrow range (a log axis would show no tick).
        if (xr.hi >= 3.0 * xr.lo) {
          // Ticks at 1, 2 and 5 times the powers of ten in range (gnuplot's own log ticks are decades only).
          const double lo = xr.lo / 1.15, hi = xr.hi * 1.6;
          gp << "set logscale x\nset xrange [" << g(lo) << ":" << g(hi) << "]\nset xtics (";
          bool first = true;
          for (double dec = std::pow(10.0, std::floor(std::log10(lo))); dec <= hi; dec *= 10.0)
            for (double m : {1.0, 2.0, 5.0})
              if (m * dec >= lo && m * dec <= hi) {
                gp << (first ? "" : ", ") << g(m * dec);
                first = false;
              }
          gp << ")\nset format x '%.0s%c'\n";
        } else {
          const double span = xr.hi > xr.lo ? xr.hi - xr.lo : 0.05 * xr.hi;
          gp << "unset logscale x\nset xrange [" << g(std::max(0.0, xr.lo - 0.08 * span)) << ":"
             << g(xr.hi + 0.45 * span) << "]\nset xtics autofreq\nset format x '%.2s%c'\n";
        }
        gp << "plot " << gp_quote(data) << " using " << c + 1 << ":" << ycol
           << " with points pt 7 ps 1.2 lc rgb '#3060c0' title 'sweep points', \\\n"
           << "  " << gp_quote(label_file)
           << " using 1:2:3 with labels left rotate by 25 offset char 0.5,0.3 font ',7' notitle, \\\n"
           << "  " << gp_quote(front_file)
           << " using 1:2 with steps lw 2 lc rgb '#d03020' title 'Pareto front', \\\n"
           << "  '' using 1:2 with points pt 6 ps 2 lw 2 lc rgb '#d03020' notitle\n";
      }
      gp << "unset multiplot\n";
      {
        std::ofstream f(dir + "/" + script);
        f << gp.str();
        if (!f.flush()) throw Error("cannot write " + dir + "/" + script);
      }
      const std::string log = base + "_" + ename + ".log";
      const int st = run_in({gnuplot, script}, dir, log);
      std::error_code ec;
      if (st != 0 || !std::filesystem::exists(dir + "/" + plot.png, ec))
        throw Error("pareto: gnuplot failed on " + dir + "/" + script + " (exit " + std::to_string(st) + "; see " +
                    dir + "/" + log + ")");
      if (std::filesystem::file_size(dir + "/" + log, ec) == 0 && !ec)
        std::filesystem::remove(dir + "/" + log, ec);
      plots.push_back(std::move(plot));
    }
  }
  return plots;
}

}  // namespace rtu::host
