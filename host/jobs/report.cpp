#include "host/jobs/report.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <utility>

#include "host/cost/timing_json.h"
#include "host/devices/device_settings.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/image.h"
#include "host/jobs/image_diff.h"
#include "host/jobs/pareto.h"
#include "host/jobs/render.h"
#include "host/jobs/stopwatch.h"
#include "host/jobs/stress.h"
#include "host/jobs/sweep.h"
#include "host/scene/ray_gen.h"
#include "host/scene/shading.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

namespace {

using Progress = std::function<void(const ReportStep&)>;

struct ReportSizes {
  int render_width, spp, max_depth;
  int render_zoom;  // the renders are shown this many times their size (pixelated), to be judged by eye
  uint64_t cycle_rays;
  std::vector<std::string> formats, configs;
  std::vector<int> widths;
  SweepOptions sweep;
  uint64_t stress_count;
};

ReportSizes sizes(bool quick) {
  ReportSizes s;
  if (quick) {
    s.render_width = 192;
    s.render_zoom = 2;
    s.spp = 1;
    s.max_depth = 2;
    s.cycle_rays = 5000;
    s.formats = {"default", "compact", "precise", "default:coord_bits=12", "default:coord_bits=16"};
    s.widths = {4};
    s.configs = {"rdna2"};
    s.sweep.rays = 2000;
    s.sweep.image_width = 32;
    s.stress_count = 200;
  } else {
    s.render_width = 640;
    s.render_zoom = 1;
    s.spp = 4;
    s.max_depth = 4;
    s.cycle_rays = 100000;
    s.formats = {"default",
                 "compact",
                 "precise",
                 "default:coord_bits=12",
                 "default:coord_bits=16",
                 "default:coord_bits=20",
                 "default:child_bits=4"};
    s.widths = {4, 8};
    s.configs = {"rdna2", "intel", "embedded"};
    s.sweep.rays = 20000;
    s.sweep.image_width = 96;
    s.stress_count = 5000;
  }
  return s;
}

std::string esc(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

// A path or a point's label for a table cell: escaped, with a line-break opportunity after every '/' and ':', so
// that a long mesh path wraps between its parts (the cell's class "path" lets a part longer than the column break
// too).
std::string esc_path(const std::string& s) {
  std::string o;
  for (char c : s) {
    o += esc(std::string(1, c));
    if (c == '/' || c == ':') o += "<wbr>";
  }
  return o;
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

// PSNR as text ("inf" when identical) and as JSON (null when identical, as `rtusim diff` writes it).
std::string psnr_text(const ImageDiff& d) {
  return d.identical() ? "inf (identical)" : fmt("%.2f", d.psnr_db);
}

void make_out_dir(const std::string& out) {
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw Error("--out " + out + ": cannot create the directory: " + ec.message());
  // Probe: a directory that exists but cannot be written fails here, before any work.
  const std::string probe = out + "/index.html";
  std::ofstream f(probe, std::ios::app);
  if (!f) throw Error("--out " + out + ": cannot write " + probe);
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream f = open_output(path);
  f << text;
  finish_output(f, path);
}

struct Html {
  std::ostringstream s;
  std::vector<std::string> images;  // every image the page embeds
  // An image at its natural size, or `width` x `height` CSS pixels when given (never wider than the page: the
  // style sheet sets max-width: 100% and height: auto).
  void img(const std::string& file, const std::string& alt, int width = 0, int height = 0,
           const char* cls = nullptr) {
    images.push_back(file);
    s << "<img src=\"" << esc(file) << "\" alt=\"" << esc(alt) << "\"";
    if (width > 0) s << " width=\"" << width << "\"";
    if (height > 0) s << " height=\"" << height << "\"";
    if (cls) s << " class=\"" << cls << "\"";
    s << ">";
  }
};

std::string css_rgb(const std::array<uint8_t, 3>& c) {
  return "rgb(" + std::to_string(c[0]) + "," + std::to_string(c[1]) + "," + std::to_string(c[2]) + ")";
}

// The heatmap's colour bar: a CSS gradient through the ramp's stops (CSS interpolates in sRGB, as the ramp does,
// so the bar shows exactly the heatmap's colours) and the differences at t = j / k, 2^j - 1 levels.
void colour_bar(Html& h, int full_scale, int width) {
  h.s << "<div class=\"colorbar\" style=\"width: " << width << "px\"><div class=\"ramp\" style=\"background: "
      << "linear-gradient(to right";
  for (const RampStop& r : kDiffRamp)
    h.s << ", " << css_rgb({r.r, r.g, r.b}) << " " << fmt("%.2f", 100.0 * r.t) << "%";
  h.s << ")\"></div><div class=\"ticks\">";
  const int k = int(std::lround(std::log2(full_scale + 1.0)));
  for (int j = 0; j <= k; ++j)
    h.s << "<span style=\"left: " << fmt("%.2f", 100.0 * j / k) << "%\">" << ((1 << j) - 1) << "</span>";
  h.s << "</div><div class=\"caption\">largest channel difference of a pixel, in levels of 255 (log scale"
      << (full_scale < 255 ? "; " + std::to_string(full_scale) + " or more at the dark end" : std::string())
      << ")</div></div>\n";
}

void step(const Progress& progress, ReportStage stage, uint64_t count, const std::string& message = "") {
  if (!progress) return;
  ReportStep s;
  s.stage = stage;
  s.count = count;
  s.message = message;
  progress(s);
}

// Renders of the first scene: float, fixed datapath on the timed device, the heatmap of their difference.
Json section_renders(const Scene& scene, const std::string& spec, const ReportOptions& a, const ReportSizes& z,
                     Html& h, const Progress& progress) {
  Json j;
  j["scene"] = spec;
  const int w = std::min(z.render_width, scene.camera.width);
  const int ht = std::max(1, int(std::lround(double(w) * scene.camera.height / scene.camera.width)));
  j["width"] = w;
  j["height"] = ht;
  j["spp"] = z.spp;
  j["max_depth"] = z.max_depth;
  j["config"] = "rdna2";
  std::vector<Image> images;
  // Named by datapath: "fixed" is the fixed datapath on the timed device.
  for (const auto& [name, kind] : {std::pair<std::string, hw::DeviceKind>{"float", hw::DeviceKind::kFloat},
                                   {"fixed", hw::DeviceKind::kTimed}}) {
    DeviceSettings da;
    da.config = "rdna2";
    da.flatten = a.flatten && kind != hw::DeviceKind::kFloat;  // the float device has one form
    RenderOptions ro;
    ro.device = da.options(kind);
    ro.threads = a.threads;
    ro.width = w;
    ro.height = ht;
    ro.spp = z.spp;
    ro.max_depth = z.max_depth;
    ro.background = Vec3(0.02f, 0.02f, 0.03f);
    const RenderResult r = render(scene, ro);
    images.push_back(to_image(r));
    const std::string file = "render_" + name + ".png";
    write_png(a.out + "/" + file, images.back());
    Json rj;
    rj["image"] = file;
    rj["device"] = hw::device_kind_name(ro.device.kind);
    rj["seconds"] = r.seconds;
    uint64_t rays = 0;
    for (int t = 0; t < hw::cmd::kRayTypeCount; ++t) rays += r.fw.rays[t];
    rj["rays"] = rays;
    if (r.timed) {
      rj["cycles_per_frame"] = r.device_clock;
      rj["trace_cycles"] = r.timing.cycles;
    }
    j[name] = rj;
    if (progress) {
      ReportStep s;
      s.stage = ReportStage::kRender;
      s.scene = spec;
      s.device = hw::device_kind_name(ro.device.kind);
      s.seconds = r.seconds;
      progress(s);
    }
  }
  const ImageDiff d = diff_images(images[0], images[1]);
  // A log scale up to the largest difference (rounded up to 2^k - 1), so that both a one-level difference and
  // the worst pixel are visible; the page shows the scale.
  const int full_scale = diff_ramp_full_scale(d.max_abs);
  write_png(a.out + "/render_heatmap.png", diff_heatmap_log(images[0], images[1], full_scale));
  j["heatmap"] = "render_heatmap.png";
  j["heatmap_full_scale"] = full_scale;
  j["heatmap_scale"] = "log2(1 + d) / log2(1 + full_scale) along the ramp of host/jobs/image_diff.h (kDiffRamp)";
  j["psnr_db"] = d.identical() ? Json(nullptr) : Json(d.psnr_db);
  j["max_abs"] = d.max_abs;
  j["mean_abs"] = d.mean_abs;
  j["pixels_differing"] = d.pixels_differing;
  j["frac_pixels_differing"] = d.frac_pixels_differing;

  h.s << "<h2>Renders: float reference, fixed datapath, difference</h2>\n<p>" << esc_path(spec) << ", " << w << "x"
      << ht << ", " << z.spp << " spp, depth " << z.max_depth << ", rendered by the firmware"
      << (z.render_zoom > 1 ? ", shown " + std::to_string(z.render_zoom) + " times their size" : std::string())
      << ". The fixed render runs on the timed device (rdna2 preset: its format and BVH width), whose hits equal "
         "the fixed device's bit for bit.</p>\n<div class=\"imgs\">\n";
  const int shown_w = w * z.render_zoom, shown_h = ht * z.render_zoom;
  for (const auto& [file, caption] :
       {std::pair<std::string, std::string>{"render_float.png", "float reference"},
        {"render_fixed.png", "fixed datapath (timed, rdna2)"},
        {"render_heatmap.png", "difference heatmap: light = equal, darker = larger difference"}}) {
    h.s << "<figure style=\"width: " << shown_w << "px\">";  // captions wrap within the image's width
    h.img(file, caption, shown_w, shown_h, "render");
    h.s << "<figcaption>" << esc(caption) << "</figcaption>";
    if (file == "render_heatmap.png") colour_bar(h, full_scale, std::min(shown_w, 400));
    h.s << "</figure>\n";
  }
  h.s << "</div>\n<p>Fixed against float: PSNR " << psnr_text(d) << " dB, largest difference " << d.max_abs
      << " levels, " << d.pixels_differing << " of " << d.width * d.height << " pixels differ. Cycles per frame "
      << "(every packet): " << j["fixed"].value("cycles_per_frame", uint64_t(0)) << " for "
      << j["fixed"]["rays"].get<uint64_t>() << " rays.</p>\n";
  return j;
}

// Cycles per scene for each timing preset: the scenes' primary rays, one TRACE packet on the timed device.
Json section_cycles(const std::vector<std::unique_ptr<Scene>>& scenes, const std::vector<std::string>& specs,
                    const ReportOptions& a, const ReportSizes& z, Html& h) {
  Json rows = Json::array();
  h.s << "<h2>Cycles per scene</h2>\n<p>" << z.cycle_rays
      << " primary rays of each scene's camera, traced as one TRACE packet (closest hit) on the timed device, "
         "per timing preset (its format and BVH width). <i>limited by</i>: the largest throughput bound (box "
         "tests / box rate, triangle tests / triangle rate, DRAM bytes / bandwidth); <i>cycles / bound</i>: how "
         "far above it. Area, energy per ray and power: the 45 nm estimate of docs/energy-model.md (units from "
         "their synthesized RTL, SRAM and DRAM from published "
         "tables).</p>\n<table>\n<tr><th>preset</th><th>scene</th><th>rays</th><th>cycles</th>"
         "<th>cycles/ray</th><th>rays/clock</th><th>limited by</th><th>cycles / bound</th>"
         "<th>cache hit rate</th><th>mm&sup2; (45 nm)</th><th>pJ/ray</th><th>W</th><th>wall s (build + "
         "trace)</th></tr>\n";
  for (const std::string& preset : hw::timing_preset_names()) {
    DeviceSettings da;
    da.config = preset;
    da.flatten = a.flatten;
    const DeviceOptions opt = da.options(hw::DeviceKind::kTimed);
    for (size_t i = 0; i < scenes.size(); ++i) {
      const std::vector<hw::Ray> rays = primary_rays(scenes[i]->camera, z.cycle_rays);
      const Stopwatch sw;
      const SceneAnyHit alpha(*scenes[i]);
      DeviceOptions sopt = opt;
      sopt.any_hit = alpha.stage();
      sopt.instances = &scenes[i]->instances;
      const auto dev = make_device(scenes[i]->geometry, sopt);
      std::vector<hw::Hit> hits(rays.size());
      hw::TraversalStats ts;
      dev->trace_batch(rays.data(), hits.data(), rays.size(), false, a.threads, ts);
      const double secs = sw.seconds();
      const Json t = timing_stats_json(dev->timed()->timing(), opt.timing, dev->timed()->format());
      Json r = {{"preset", preset},
                {"scene", specs[i]},
                {"rays", rays.size()},
                {"cycles", t["cycles"]},
                {"cycles_per_ray", t["cycles_per_ray"]},
                {"rays_per_clock", t["rays_per_clock"]},
                {"limited_by", t["lower_bound"]["limited_by"]},
                {"cycles_over_bound", t["lower_bound"]["cycles_over_bound"]},
                {"cache_hit_rate", t["cache"]["hit_rate"]},
                {"area_mm2", t["energy"]["area"]["total_mm2"]},
                {"pj_per_ray", t["energy"]["pj_per_ray"]},
                {"watts", t["energy"]["watts"]},
                {"hits", ts.hits},
                {"seconds", secs}};
      h.s << "<tr><td>" << esc(preset) << "</td><td class=\"path\">" << esc_path(specs[i])
          << "</td><td class=\"n\">" << rays.size() << "</td><td class=\"n\">" << t["cycles"].get<uint64_t>()
          << "</td><td class=\"n\">" << fmt("%.2f", t["cycles_per_ray"].get<double>()) << "</td><td class=\"n\">"
          << fmt("%.3f", t["rays_per_clock"].get<double>()) << "</td><td>"
          << esc(t["lower_bound"]["limited_by"].get<std::string>()) << "</td><td class=\"n\">"
          << fmt("%.2f", t["lower_bound"]["cycles_over_bound"].get<double>()) << "</td><td class=\"n\">"
          << fmt("%.3f", t["cache"]["hit_rate"].get<double>()) << "</td><td class=\"n\">"
          << fmt("%.2f", t["energy"]["area"]["total_mm2"].get<double>()) << "</td><td class=\"n\">"
          << fmt("%.0f", t["energy"]["pj_per_ray"].get<double>()) << "</td><td class=\"n\">"
          << fmt("%.2f", t["energy"]["watts"].get<double>()) << "</td><td class=\"n\">" << fmt("%.3f", secs)
          << "</td></tr>\n";
      rows.push_back(r);
    }
  }
  h.s << "</table>\n";
  return rows;
}

// What the page says about the areas of one scene: points without an area estimate (left out of the area panel,
// which plots area_mm2), and points whose box unit the area table has not synthesized (no RTL cells in the table).
void area_note(const std::vector<SweepRow>& rows, const std::vector<size_t>& idx, const std::string& area_source,
               Html& h) {
  std::vector<std::string> no_area, no_cells;
  for (size_t i : idx) {
    if (rows[i].area_mm2 <= 0.0) no_area.push_back(pareto_label(rows[i].p));
    if (rows[i].rtl_cells < 0) no_cells.push_back(pareto_label(rows[i].p));
  }
  const auto list = [&](const std::vector<std::string>& labels) {
    for (size_t k = 0; k < labels.size(); ++k) h.s << (k ? ", " : "") << esc(labels[k]);
  };
  if (no_area.size() == idx.size()) {
    h.s << "<p class=\"note\">No point of this scene has an area estimate (area_mm2 = 0 in the sweep), so the "
           "area panel is left out.</p>\n";
  } else if (!no_area.empty()) {
    h.s << "<p class=\"note\">" << no_area.size() << " of " << idx.size()
        << " points have no area estimate (area_mm2 = 0 in the sweep) and are left out of the area panel: ";
    list(no_area);
    h.s << ".</p>\n";
  }
  if (no_cells.empty()) return;
  if (no_cells.size() == idx.size()) {
    h.s << "<p class=\"note\">No point of this scene has RTL cells (rtl_cells = -1 in the sweep; their areas "
           "are the model's estimate). Cells are yosys syntheses of the RTL box unit per parameter set: "
           "<code>RTL_AREA_CSV=FILE bench/rtl_area.sh</code> writes such a table (the project ships <code>"
        << kShippedAreaTable << "</code>), and <code>rtusim sweep --area FILE</code> or <code>rtusim report "
        << "--area FILE</code> (for the sweep it runs) puts it into a sweep.</p>\n";
    return;
  }
  h.s << "<p class=\"note\">" << no_cells.size() << " of " << idx.size()
      << " points have no RTL cells (their areas are the model's estimate): the area table (" << esc(area_source)
      << ") has no synthesis of their box unit's parameters (";
  list(no_cells);
  h.s << "). <code>bench/rtl_area.sh</code> synthesizes more rows.</p>\n";
}

// The sweep (read or run) and its Pareto plots: per scene the two plots and the table of its numbered points.
Json section_pareto(const std::vector<SweepRow>& rows, const std::string& source, const std::string& area_source,
                    const ReportOptions& a, Html& h) {
  Json j;
  j["source"] = source;
  j["area_source"] = area_source;
  j["file"] = "sweep.csv";
  j["points"] = rows.size();
  h.s << "<h2>Run time against error: Pareto fronts</h2>\n<p>Sweep: " << esc(source) << ", " << rows.size()
      << " points (<a href=\"sweep.csv\">sweep.csv</a>); RTL areas: " << esc(area_source)
      << ". Error against cycles, memory (image bytes), DRAM traffic (bytes per ray, where the sweep has it) and "
         "area (mm^2, the 45 nm estimate) per scene; the red staircase is the Pareto front (points no "
         "other point beats in both error and cost). The numbers on the plots are the points of the table under "
         "them; points at the same place share one number list (\"3-5\").</p>\n";
  const std::string gnuplot = find_gnuplot();
  j["gnuplot"] = gnuplot.empty() ? Json(nullptr) : Json(gnuplot);
  Json plots = Json::array();
  std::vector<ParetoPlot> ps;
  if (gnuplot.empty()) {
    j["message"] = "gnuplot not found on PATH: no plots (install the Debian package gnuplot-nox)";
    h.s << "<p class=\"warn\">gnuplot was not found on PATH, so there are no Pareto plots here. Install the "
           "Debian package <code>gnuplot-nox</code> and run the report again (or <code>rtusim pareto --sweep "
           "sweep.csv --out DIR</code>).</p>\n";
  } else {
    try {
      ps = write_pareto_plots(rows, a.out, gnuplot);
      j["message"] = "ok";
    } catch (const Error& e) {
      j["message"] = e.what();
      h.s << "<p class=\"warn\">The plots failed: " << esc(e.what()) << "</p>\n";
    }
  }
  // Rows by scene, in the order scenes first appear (as write_pareto_plots numbers them).
  std::vector<std::pair<std::string, std::vector<size_t>>> scenes;
  for (size_t i = 0; i < rows.size(); ++i) {
    auto it =
        std::find_if(scenes.begin(), scenes.end(), [&](const auto& s) { return s.first == rows[i].p.scene; });
    if (it == scenes.end()) {
      scenes.push_back({rows[i].p.scene, {}});
      it = scenes.end() - 1;
    }
    it->second.push_back(i);
  }
  for (const auto& [scene, idx] : scenes) {
    h.s << "<h3>" << esc_path(scene) << "</h3>\n";
    for (const ParetoPlot& p : ps) {
      if (p.scene != scene) continue;
      Json pj = {{"scene", p.scene},
                 {"error", pareto_error_name(p.error)},
                 {"image", p.png},
                 {"points", p.points},
                 {"area_panel", p.area_panel},
                 {"dram_panel", p.dram_panel},
                 {"energy_panel", p.energy_panel},
                 {"unlabelled", p.unlabelled}};
      // A cost's panel is drawn when some point has it: cycles and bytes always, DRAM and area where known.
      const auto drawn = [&](int c) {
        return (c != int(ParetoCost::kAreaMm2) || p.area_panel) &&
               (c != int(ParetoCost::kDramBytesPerRay) || p.dram_panel) &&
               (c != int(ParetoCost::kPjPerRay) || p.energy_panel);
      };
      for (int c = 0; c < kParetoCostCount; ++c) {
        if (!drawn(c)) continue;
        Json f = Json::array();
        for (size_t i : p.front[c]) f.push_back(pareto_label(rows[i].p));
        pj["front"][pareto_cost_name(ParetoCost(c))] = f;
      }
      h.s << "<h4>" << (p.error == ParetoError::kHitDisagreement ? "hit disagreement" : "mean relative t error")
          << "</h4>\n<p>";
      h.img(p.png, p.scene + " Pareto plot", 0, 0, "plot");
      h.s << "</p>\n<p>On the front against";
      for (int c = 0; c < kParetoCostCount; ++c) {
        if (!drawn(c)) continue;
        h.s << (c ? "; " : " ") << pareto_cost_name(ParetoCost(c)) << ": ";
        const Json& f = pj["front"][pareto_cost_name(ParetoCost(c))];
        if (f.empty()) h.s << "(no points)";
        for (size_t k = 0; k < f.size(); ++k) h.s << (k ? ", " : "") << esc(f[k].get<std::string>());
      }
      h.s << ".";
      if (p.unlabelled > 0)
        h.s << " " << p.unlabelled << " places found no free spot for their number (too crowded); the table "
            << "gives every point's cost and error.";
      h.s << "</p>\n";
      plots.push_back(pj);
    }
    area_note(rows, idx, area_source, h);
    // The scene's points, numbered as on the plots.
    h.s << "<table>\n<tr><th>#</th><th>format/width/config</th><th>hit agreement</th><th>t error mean</th>"
           "<th>PSNR dB</th><th>cycles</th><th>cycles/ray</th><th>DRAM bytes/ray</th><th>BVH bytes</th>"
           "<th>bytes/prim</th><th>RTL cells</th><th>mm&sup2; (45 nm)</th><th>pJ/ray</th></tr>\n";
    for (size_t k = 0; k < idx.size(); ++k) {
      const SweepRow& r = rows[idx[k]];
      h.s << "<tr><td class=\"n\">" << k + 1 << "</td><td class=\"path\">" << esc_path(pareto_label(r.p))
          << "</td><td class=\"n\">" << fmt("%.4f%%", 100.0 * r.hit_agreement) << "</td><td class=\"n\">"
          << fmt("%.2g", r.t_rel_error_mean) << "</td><td class=\"n\">"
          << (!r.psnr_measured()      ? std::string("-")
              : std::isinf(r.psnr_db) ? std::string("inf")
                                      : fmt("%.1f", r.psnr_db))
          << "</td><td class=\"n\">" << r.cycles << "</td><td class=\"n\">" << fmt("%.2f", r.cycles_per_ray)
          << "</td><td class=\"n\">" << fmt("%.1f", r.dram_bytes_per_ray) << "</td><td class=\"n\">" << r.bvh_bytes
          << "</td><td class=\"n\">" << fmt("%.1f", r.bytes_per_prim) << "</td><td class=\"n\">"
          << (r.rtl_cells >= 0 ? std::to_string(r.rtl_cells) : std::string("-")) << "</td><td class=\"n\">"
          << fmt("%.2f", r.area_mm2) << "</td><td class=\"n\">" << fmt("%.0f", r.pj_per_ray) << "</td></tr>\n";
    }
    h.s << "</table>\n";
  }
  j["plots"] = plots;
  return j;
}

Json section_stress(const ReportOptions& a, const ReportSizes& z, Html& h, uint64_t& failures) {
  StressOptions o;
  o.count = z.stress_count;
  o.threads = a.threads;
  const std::vector<StressResult> results = run_stress(o);
  Json j;
  j["count"] = o.count;
  j["format"] = format_json(o.format);
  Json cats = Json::array();
  uint64_t cases = 0;
  failures = 0;
  h.s << "<h2>Stress suite</h2>\n<p><code>rtusim stress --count " << o.count
      << "</code> (default format): rays aimed where ray tracers break; a failure is a broken promise of "
         "docs/architecture.md.</p>\n<table>\n<tr><th>category</th><th>cases</th><th>failures</th><th>seconds</th>"
         "<th>what fails</th></tr>\n";
  for (const StressResult& r : results) {
    cases += r.cases;
    failures += r.failures;
    cats.push_back({{"name", r.name}, {"cases", r.cases}, {"failures", r.failures}, {"seconds", r.seconds}});
    h.s << "<tr" << (r.failures ? " class=\"fail\"" : "") << "><td>" << esc(r.name) << "</td><td class=\"n\">"
        << r.cases << "</td><td class=\"n\">" << r.failures << "</td><td class=\"n\">" << fmt("%.2f", r.seconds)
        << "</td><td>" << esc(r.failure_rule) << "</td></tr>\n";
  }
  h.s << "<tr><td><b>total</b></td><td class=\"n\">" << cases << "</td><td class=\"n\">" << failures
      << "</td><td></td><td></td></tr>\n</table>\n";
  j["cases"] = cases;
  j["failures"] = failures;
  j["categories"] = cats;
  return j;
}

}  // namespace

ReportResult write_report(ReportOptions a, const Progress& progress) {
  const Stopwatch total;
  if (a.scenes.empty()) a.scenes = {"builtin:seed", "builtin:cornell"};
  const ReportSizes z = sizes(a.quick);
  // Every input is checked before the first long step.
  make_out_dir(a.out);
  std::vector<SweepRow> rows;
  if (!a.sweep.empty()) {
    rows = read_sweep_csv(a.sweep);
    if (rows.empty()) throw Error("--sweep " + a.sweep + ": no rows (run rtusim sweep first)");
  }
  // The sweep run here takes its RTL areas from --area, else from the table the project ships.
  const AreaTable area = a.area.empty() ? AreaTable::shipped() : AreaTable::load(a.area);
  const std::string area_source = !a.sweep.empty() ? "as in the given sweep CSV"
                                  : a.area.empty() ? std::string(kShippedAreaTable) + " (shipped with rtusim)"
                                                   : a.area;
  std::vector<std::unique_ptr<Scene>> scenes;
  for (const std::string& s : a.scenes) scenes.push_back(std::make_unique<Scene>(load_scene(s)));
  step(progress, ReportStage::kStart, scenes.size());

  ReportResult res;
  Html h;
  Json& j = res.json;
  j["generated_by"] = "rtusim report";
  j["quick"] = a.quick;
  j["flatten"] = a.flatten;
  j["scenes"] = a.scenes;
  j["renders"] = section_renders(*scenes[0], a.scenes[0], a, z, h, progress);
  j["cycles"] = section_cycles(scenes, a.scenes, a, z, h);
  step(progress, ReportStage::kCycles, j["cycles"].size());

  std::string source;
  if (rows.empty()) {
    std::ostringstream src;
    src << "run by the report: " << z.sweep.rays << " primary + " << z.sweep.rays << " incoherent rays per point, "
        << z.formats.size() << " formats x " << z.widths.size() << " widths x " << z.configs.size()
        << " presets per scene";
    source = src.str();
    SweepOptions so = z.sweep;
    so.threads = a.threads;
    so.flatten = a.flatten;
    for (size_t i = 0; i < scenes.size(); ++i) {
      auto cache = make_sweep_cache();
      for (int w : z.widths)
        for (const std::string& f : z.formats)
          for (const std::string& c : z.configs)
            rows.push_back(run_sweep_point(*scenes[i], SweepPoint{a.scenes[i], f, w, c}, so, area, *cache));
    }
  } else {
    source = a.sweep;
  }
  {
    std::ostringstream csv;
    csv << sweep_csv_header() << '\n';
    for (const SweepRow& r : rows) csv << sweep_csv_line(r) << '\n';
    write_text(a.out + "/sweep.csv", csv.str());
  }
  j["sweep"] = section_pareto(rows, source, area_source, a, h);
  step(progress, ReportStage::kSweep, rows.size(), j["sweep"]["message"].get<std::string>());
  uint64_t& failures = res.stress_failures;
  j["stress"] = section_stress(a, z, h, failures);
  step(progress, ReportStage::kStress, failures);
  j["images"] = h.images;
  j["seconds"] = total.seconds();
  write_json(a.out + "/report.json", j);

  std::ostringstream page;
  page << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>rtu report</title>\n"
          // Nothing may be wider than the window: images shrink to the page (max-width), the renders wrap to the
          // next line when three do not fit, and paths and labels in table cells wrap (after '/' and ':', or
          // anywhere in a part too long for the column); numbers never break (nowrap), so the path takes the
          // breaks.
          "<style>\nbody { font-family: sans-serif; margin: 1.5em; max-width: 1400px; }\n"
          "img { max-width: 100%; height: auto; }\nimg.render { image-rendering: pixelated; }\n"
          "table { border-collapse: collapse; margin: 0.5em 0; }\n"
          "td, th { border: 1px solid #bbb; padding: 0.2em 0.5em; }\n"
          "td.n { text-align: right; white-space: nowrap; }\ntd.path { overflow-wrap: anywhere; }\n"
          "div.imgs { display: flex; flex-wrap: wrap; gap: 1em; align-items: flex-start; }\n"
          "div.imgs figure { margin: 0; max-width: 100%; text-align: center; }\n"
          ".colorbar { max-width: 100%; margin: 0.4em auto 0 auto; font-size: 0.85em; }\n"
          ".colorbar .ramp { height: 14px; border: 1px solid #888; }\n"
          ".colorbar .ticks { position: relative; height: 1.3em; }\n"
          ".colorbar .ticks span { position: absolute; transform: translateX(-50%); top: 0.1em; }\n"
          ".warn { color: #a00; font-weight: bold; }\n.note { color: #444; }\ntr.fail { background: #fdd; }\n"
          "</style>\n</head>\n<body>\n"
          "<h1>rtu report: run time against error</h1>\n<p>Written by <code>rtusim report"
       << (a.quick ? " --quick" : "") << "</code> in " << fmt("%.1f", j["seconds"].get<double>())
       << " s. Every figure is also in <a href=\"report.json\">report.json</a>.</p>\n"
       << h.s.str() << "</body>\n</html>\n";
  write_text(a.out + "/index.html", page.str());
  res.images = h.images;
  res.seconds = total.seconds();
  return res;
}

}  // namespace rtu::host
