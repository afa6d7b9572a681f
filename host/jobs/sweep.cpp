#include "host/jobs/sweep.h"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "host/cost/cost_model.h"
#include "host/devices/device_json.h"
#include "host/devices/direct_device.h"
#include "host/io/csv.h"
#include "host/io/error.h"
#include "host/io/limits.h"
#include "host/io/stats_json.h"
#include "host/jobs/compare.h"
#include "host/jobs/image_diff.h"
#include "host/jobs/model_identity.h"
#include "host/jobs/render.h"
#include "host/scene/ray_gen.h"
#include "host/scene/shading.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"
#include "rtl_sim/params/rtl_params.h"

namespace rtu::host {

namespace {

// Columns, in order; sweep_csv_line and read_sweep_csv follow it.
const char* const kColumns[] = {"scene",
                                "format",
                                "bvh_width",
                                "config",
                                "rays",
                                "seed",
                                "image_width",
                                "flatten",
                                "hit_agreement",
                                "prim_agreement",
                                "false_misses",
                                "false_hits",
                                "t_rel_error_mean",
                                "t_rel_error_max",
                                "node_visit_overhead",
                                "prim_test_overhead",
                                "box_false_negatives",
                                "psnr_db",
                                "cycles",
                                "cycles_per_ray",
                                "dram_bytes_per_ray",
                                "bvh_bytes",
                                "float_bvh_bytes",
                                "bytes_per_prim",
                                "rtl_cells",
                                "rtl_transistors",
                                "area_mm2",
                                "pj_per_ray",
                                "seconds",
                                "model"};
constexpr size_t kColumnCount = sizeof(kColumns) / sizeof(kColumns[0]);

// The header of the previous version (before dram_bytes_per_ray and bytes_per_prim), refused with a message that
// says what is missing: its rows measured no DRAM traffic, so they cannot stand beside this version's.
constexpr const char* kHeaderBeforeBytes =
    "scene,format,bvh_width,config,rays,seed,image_width,hit_agreement,prim_agreement,false_misses,false_hits,"
    "t_rel_error_mean,t_rel_error_max,node_visit_overhead,prim_test_overhead,box_false_negatives,psnr_db,cycles,"
    "cycles_per_ray,bvh_bytes,float_bvh_bytes,rtl_cells,rtl_transistors,seconds";
// The header before area_mm2 and pj_per_ray: its rows have no area or energy estimate.
constexpr const char* kHeaderBeforeEnergy =
    "scene,format,bvh_width,config,rays,seed,image_width,hit_agreement,prim_agreement,false_misses,false_hits,"
    "t_rel_error_mean,t_rel_error_max,node_visit_overhead,prim_test_overhead,box_false_negatives,psnr_db,cycles,"
    "cycles_per_ray,dram_bytes_per_ray,bvh_bytes,float_bvh_bytes,bytes_per_prim,rtl_cells,rtl_transistors,seconds";
// The header before model: its rows say not which build made them, so they read as model "" (another build's:
// resume runs their points again, merge keeps them apart).
constexpr const char* kHeaderBeforeModel =
    "scene,format,bvh_width,config,rays,seed,image_width,flatten,hit_agreement,prim_agreement,false_misses,"
    "false_hits,t_rel_error_mean,t_rel_error_max,node_visit_overhead,prim_test_overhead,box_false_negatives,"
    "psnr_db,cycles,cycles_per_ray,dram_bytes_per_ray,bvh_bytes,float_bvh_bytes,bytes_per_prim,rtl_cells,"
    "rtl_transistors,area_mm2,pj_per_ray,seconds";
// The header before flatten: that version traced instanced scenes over two levels only, so its rows read as
// flatten 0 (its columns are this version's but for flatten and model).
constexpr const char* kHeaderBeforeFlatten =
    "scene,format,bvh_width,config,rays,seed,image_width,hit_agreement,prim_agreement,false_misses,false_hits,"
    "t_rel_error_mean,t_rel_error_max,node_visit_overhead,prim_test_overhead,box_false_negatives,psnr_db,cycles,"
    "cycles_per_ray,dram_bytes_per_ray,bvh_bytes,float_bvh_bytes,bytes_per_prim,rtl_cells,rtl_transistors,area_"
    "mm2,"
    "pj_per_ray,seconds";

std::string num(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (std::isnan(v)) return "";  // not measured (a PSNR without a render)
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

// A text field: quoted when it holds a comma or a quote (RFC 4180).
std::string text(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q(1, '"');
  for (char c : s) {
    q += c;
    if (c == '"') q += c;
  }
  q += '"';
  return q;
}

void poll(const SweepOptions& o) {
  if (o.poll) o.poll();
}

double ratio_minus_one(uint64_t a, uint64_t b) {
  return b ? double(a) / double(b) - 1.0 : 0.0;
}

}  // namespace

std::string SweepPoint::key() const {
  std::string k = scene;
  k += '|';
  k += format;
  k += '|';
  k += std::to_string(bvh_width);
  k += '|';
  k += config;
  return k;
}

// The float reference of one scene at one BVH width: its hits on the sweep's rays and its render.
struct SweepCache {
  struct Reference {
    std::vector<hw::Hit> hits;
    hw::TraversalStats stats;
    uint64_t bvh_bytes = 0;
    Image render;
  };
  std::vector<hw::Ray> rays;
  std::map<int, Reference> by_width;
  // The scene's alpha-tested materials: the any-hit stage every device of the scene's points asks.
  std::unique_ptr<SceneAnyHit> alpha;
};

void SweepCacheDeleter::operator()(SweepCache* c) const {
  delete c;
}

std::unique_ptr<SweepCache, SweepCacheDeleter> make_sweep_cache() {
  return std::unique_ptr<SweepCache, SweepCacheDeleter>(new SweepCache);
}

namespace {

// The point's timed run on `rays` with `timing` (its cycles and DRAM bytes), the RTL unit's synthesis figures
// where the table has them, and the area and energy estimate.
void time_point(const Scene& scene, const hw::FixedFormat& format, const hw::TimingConfig& timing,
                const std::vector<hw::Ray>& rays, int threads, bool flatten, const AreaTable& area,
                const hw::AnyHitStage* any_hit, SweepRow& row) {
  DeviceOptions timed_opt;
  timed_opt.any_hit = any_hit;
  timed_opt.kind = hw::DeviceKind::kTimed;
  timed_opt.format = format;
  timed_opt.tracer.bvh.width = format.width;
  timed_opt.check_boxes = false;
  timed_opt.timing = timing;
  timed_opt.instances = &scene.instances;
  timed_opt.flatten = flatten;
  const auto timed = make_device(scene.geometry, timed_opt);
  const size_t n = rays.size();
  std::vector<hw::Hit> hits(n);
  hw::TraversalStats ts;
  timed->trace_batch(rays.data(), hits.data(), n, false, threads, ts);
  const hw::TimingStats& stats = timed->timed()->timing();
  row.cycles = stats.cycles;
  row.cycles_per_ray = n ? double(row.cycles) / double(n) : 0.0;
  row.dram_bytes_per_ray = n ? double(stats.dram_bytes) / double(n) : 0.0;
  row.rtl_cells = row.rtl_transistors = -1;
  try {
    const std::string params =
        rtl::verilator_args(rtl::box_unit_params(format, format.width, timing.box_rate, timing.box_latency));
    const auto a = area.by_params.find(params);
    if (a != area.by_params.end()) {
      row.rtl_cells = a->second.cells;
      row.rtl_transistors = a->second.transistors;
    }
  } catch (const std::invalid_argument&) {
    // A wide format: the RTL unit has no such datapath (no area).
  }
  static const ActivityTable activity = ActivityTable::shipped();
  const hw::CostInputs cost = cost_inputs(format, timing, area, activity);
  const hw::EnergyReport energy = hw::energy_report(stats, timing, cost);
  row.area_mm2 = energy.area.total_mm2;
  row.pj_per_ray = energy.pj_per_ray;
}

}  // namespace

hw::TimingConfig sweep_config(const std::string& spec) {
  try {
    return rtl::unit_config(spec);
  } catch (const std::invalid_argument& e) {
    throw Error("timing configuration " + spec + ": " + e.what());
  }
}

void check_sweep_grid(const SweepGrid& g) {
  for (const std::string& f : g.formats) {
    try {
      hw::format_from_spec(f);
    } catch (const std::invalid_argument& e) {
      throw Error(std::string("--formats: ") + e.what());
    }
  }
  for (int w : g.widths)
    if (w != 2 && w != 4 && w != 6 && w != 8)
      throw Error("--bvh-width: " + std::to_string(w) + " is not 2, 4, 6 or 8");
  for (const std::string& c : g.configs) {
    try {
      sweep_config(c);
    } catch (const Error& e) {
      throw Error(std::string("--config: ") + e.what());
    }
    // A point's format and BVH width are its own (--formats, --bvh-width): the configuration's keys of those names
    // would change the row's label but not what it measures.
    for (size_t colon = c.find(':'); colon != std::string::npos; colon = c.find(':', colon + 1)) {
      const std::string kv = c.substr(colon + 1, c.find(':', colon + 1) - colon - 1);
      const std::string key = kv.substr(0, kv.find('='));
      if (key == "format")
        throw Error("--config " + c + ": a sweep point's format is set by --formats (e.g. --formats " +
                    kv.substr(kv.find('=') + 1) + "), not by the configuration's key format");
      if (key == "bvh_width")
        throw Error("--config " + c + ": a sweep point's BVH width is set by --bvh-width (e.g. --bvh-width " +
                    kv.substr(kv.find('=') + 1) + "), not by the configuration's key bvh_width");
    }
  }
}

void run_sweep_grid(const SweepGrid& g, const SweepOptions& o, const AreaTable& area,
                    const std::function<bool(size_t, const SweepPoint&)>& want,
                    const std::function<void(const Scene&, const SweepRow&)>& row) {
  check_sweep_grid(g);
  check_sweep_rays("sweep", o.rays);
  size_t index = 0;
  for (const std::string& scene_spec : g.scenes) {
    std::unique_ptr<Scene> scene;  // loaded when a point of it runs
    auto cache = make_sweep_cache();
    for (int w : g.widths)
      for (const std::string& f : g.formats)
        for (const std::string& c : g.configs) {
          const SweepPoint p{scene_spec, f, w, c};
          if (!want(index++, p)) continue;
          poll(o);
          if (!scene) scene = std::make_unique<Scene>(load_scene(scene_spec));
          row(*scene, run_sweep_point(*scene, p, o, area, *cache));
        }
  }
}

SweepRow retime_sweep_point(const Scene& scene, const SweepRow& measured, const std::string& config,
                            const SweepOptions& o, const AreaTable& area, SweepCache& cache) {
  if (cache.rays.size() != measured.rays)
    throw Error("retime_sweep_point: the cache holds other rays than the row was measured on");
  const auto t0 = std::chrono::steady_clock::now();
  SweepRow row = measured;
  row.model = model_identity();  // its cycles are this build's
  row.p.config = config;
  hw::FixedFormat format;
  hw::TimingConfig timing;
  try {
    format = hw::format_from_spec(row.p.format);
    format.width = row.p.bvh_width;
    format.validate();
    timing = rtl::unit_config(config);
    hw::set_timing_key(timing, "bvh_width", std::to_string(row.p.bvh_width));
  } catch (const std::invalid_argument& e) {
    throw Error(std::string("sweep point ") + row.p.key() + ": " + e.what());
  }
  if (row.flatten != o.flatten)
    throw Error("retime_sweep_point: the row was measured with another --flatten than the options give");
  poll(o);
  if (!cache.alpha) cache.alpha = std::make_unique<SceneAnyHit>(scene);
  time_point(scene, format, timing, cache.rays, o.threads, o.flatten, area, cache.alpha->stage(), row);
  row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return row;
}

SweepRow run_sweep_point(const Scene& scene, const SweepPoint& p, const SweepOptions& o, const AreaTable& area,
                         SweepCache& cache) {
  const auto t0 = std::chrono::steady_clock::now();
  SweepRow row;
  row.p = p;
  row.model = model_identity();
  hw::FixedFormat format;
  hw::TimingConfig timing;
  try {
    format = hw::format_from_spec(p.format);
    format.width = p.bvh_width;
    format.validate();
    timing = rtl::unit_config(p.config);
    hw::set_timing_key(timing, "bvh_width", std::to_string(p.bvh_width));
  } catch (const std::invalid_argument& e) {
    throw Error(std::string("sweep point ") + p.key() + ": " + e.what());
  }
  poll(o);
  if (cache.rays.empty()) {
    cache.rays = primary_rays(scene.camera, o.rays);
    const std::vector<hw::Ray> inc = incoherent_rays(scene.geometry.bounds(), o.rays, o.seed);
    cache.rays.insert(cache.rays.end(), inc.begin(), inc.end());
    cache.alpha = std::make_unique<SceneAnyHit>(scene);
  }
  const std::vector<hw::Ray>& rays = cache.rays;
  const size_t n = rays.size();
  row.rays = n;
  row.seed = o.seed;
  row.image_width = o.image_width;
  row.flatten = o.flatten;
  const int threads = o.threads;

  DeviceOptions ref_opt;
  ref_opt.kind = hw::DeviceKind::kFloat;
  ref_opt.format.width = p.bvh_width;  // make_device builds every device's BVH at the format's width
  ref_opt.tracer.bvh.width = p.bvh_width;
  ref_opt.any_hit = cache.alpha->stage();
  ref_opt.instances = &scene.instances;  // float and fixed trace an instanced scene's two levels
  auto it = cache.by_width.find(p.bvh_width);
  const auto ref = make_device(scene.geometry, ref_opt);
  if (it == cache.by_width.end()) {
    SweepCache::Reference r;
    r.hits.resize(n);
    ref->trace_batch(rays.data(), r.hits.data(), n, false, threads, r.stats);
    if (const hw::Bvh* b = ref->bvh()) {
      const hw::BvhFigures f = b->figures();
      r.bvh_bytes = f.node_bytes + f.index_bytes;
    }
    r.bvh_bytes += ref->prim_bytes();
    if (o.image_width > 0) {
      RenderOptions ro;
      ro.device = ref_opt;
      ro.width = o.image_width;
      ro.height = std::max(1, int(std::lround(double(o.image_width) * scene.camera.height / scene.camera.width)));
      ro.max_depth = 2;
      ro.threads = threads;
      r.render = to_image(render(scene, ro));
    }
    it = cache.by_width.emplace(p.bvh_width, std::move(r)).first;
  }
  const SweepCache::Reference& refr = it->second;
  row.float_bvh_bytes = refr.bvh_bytes;
  poll(o);

  DeviceOptions fixed_opt;
  fixed_opt.kind = hw::DeviceKind::kFixed;
  fixed_opt.format = format;
  fixed_opt.tracer.bvh.width = p.bvh_width;
  fixed_opt.check_boxes = true;
  fixed_opt.any_hit = cache.alpha->stage();
  fixed_opt.instances = &scene.instances;
  fixed_opt.flatten = o.flatten;
  const auto fixed = make_device(scene.geometry, fixed_opt);
  std::vector<hw::Hit> hits(n);
  hw::TraversalStats fs;
  fixed->trace_batch(rays.data(), hits.data(), n, false, threads, fs);
  std::vector<bool> valid(n);
  for (size_t i = 0; i < n; ++i)
    valid[i] = ref->ray_status(rays[i]) == hw::RayStatus::kOk && fixed->ray_status(rays[i]) == hw::RayStatus::kOk;
  const HitComparison c = compare_hits(refr.hits, hits, valid, false);
  row.hit_agreement = c.hit_agreement();
  row.prim_agreement = c.prim_agreement();
  row.false_misses = c.false_misses;
  row.false_hits = c.false_hits;
  row.t_rel_error_mean = c.t_rel_mean;
  row.t_rel_error_max = c.t_rel_max;
  row.compared_rays = c.compared;
  row.t_compared_rays = c.t_compared;
  row.t_rel_error_sd = c.t_rel_sd;
  row.node_visit_overhead = ratio_minus_one(fs.nodes_visited, refr.stats.nodes_visited);
  row.prim_test_overhead = ratio_minus_one(fs.prim_tests, refr.stats.prim_tests);
  row.box_false_negatives = fs.box_false_negatives;
  const ImageBytes bytes = device_image_bytes(*fixed);
  row.bvh_bytes = bytes.total;
  row.bytes_per_prim = bytes.per_prim;

  if (o.image_width > 0) {
    poll(o);
    RenderOptions ro;
    ro.device = fixed_opt;
    ro.device.check_boxes = false;
    ro.width = refr.render.width;
    ro.height = refr.render.height;
    ro.max_depth = 2;
    ro.threads = threads;
    row.psnr_db = diff_images(refr.render, to_image(render(scene, ro))).psnr_db;
  }

  poll(o);
  time_point(scene, format, timing, rays, threads, o.flatten, area, cache.alpha->stage(), row);
  row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return row;
}

std::string sweep_run_params(const SweepRow& r) {
  // `rays` counts both kinds: --rays N made N camera and N incoherent rays.
  return "--rays " + std::to_string(r.rays / 2) + " --seed " + std::to_string(r.seed) + " --image-width " +
         std::to_string(r.image_width) + (r.flatten ? " --flatten" : "");
}

std::string sweep_run_params(const SweepOptions& o) {
  return "--rays " + std::to_string(o.rays) + " --seed " + std::to_string(o.seed) + " --image-width " +
         std::to_string(o.image_width) + (o.flatten ? " --flatten" : "");
}

std::string sweep_csv_header() {
  std::string s;
  for (size_t i = 0; i < kColumnCount; ++i) {
    if (i) s += ',';
    s += kColumns[i];
  }
  return s;
}

std::string sweep_csv_line(const SweepRow& r) {
  std::ostringstream o;
  o << text(r.p.scene) << ',' << text(r.p.format) << ',' << r.p.bvh_width << ',' << text(r.p.config) << ','
    << r.rays << ',' << r.seed << ',' << r.image_width << ',' << int(r.flatten) << ',' << num(r.hit_agreement)
    << ',' << num(r.prim_agreement) << ',' << r.false_misses << ',' << r.false_hits << ','
    << num(r.t_rel_error_mean) << ',' << num(r.t_rel_error_max) << ',' << num(r.node_visit_overhead) << ','
    << num(r.prim_test_overhead) << ',' << r.box_false_negatives << ',' << num(r.psnr_db) << ',' << r.cycles << ','
    << num(r.cycles_per_ray) << ',' << num(r.dram_bytes_per_ray) << ',' << r.bvh_bytes << ',' << r.float_bvh_bytes
    << ',' << num(r.bytes_per_prim) << ',' << r.rtl_cells << ',' << r.rtl_transistors << ',' << num(r.area_mm2)
    << ',' << num(r.pj_per_ray) << ',' << num(r.seconds) << ',' << text(r.model);
  return o.str();
}

std::vector<SweepRow> read_sweep_csv(const std::string& path, bool* header_is_current) {
  // The text, its copy split into lines and the rows parsed from it (a row's strings and numbers take about
  // what its line does): four times the file at most.
  return parse_sweep_csv(read_file_limited(path, 4), path, header_is_current);
}

namespace {

// A row's figures within what a measurement can give: a row edited by hand, or written by something else, is
// refused rather than averaged or plotted into a table.
void check_sweep_row(const SweepRow& r, const std::string& where) {
  auto check = [&](const char* column, double v, double lo, double hi, bool inf_allowed) {
    if (std::isnan(v) || (!inf_allowed && std::isinf(v)) || v < lo || v > hi)
      throw Error(where + ": " + column + " " + (std::isnan(v) ? "nan" : num(v)) + " is out of range (" +
                  (inf_allowed ? "" : "finite, ") + "from " + num(lo) + (std::isinf(hi) ? "" : " to " + num(hi)) +
                  ")");
  };
  const double inf = std::numeric_limits<double>::infinity();
  check("hit_agreement", r.hit_agreement, 0.0, 1.0, false);
  check("prim_agreement", r.prim_agreement, 0.0, 1.0, false);
  check("t_rel_error_mean", r.t_rel_error_mean, 0.0, inf, true);
  check("t_rel_error_max", r.t_rel_error_max, 0.0, inf, true);
  check("node_visit_overhead", r.node_visit_overhead, -1.0, inf, false);
  check("prim_test_overhead", r.prim_test_overhead, -1.0, inf, false);
  check("cycles_per_ray", r.cycles_per_ray, 0.0, inf, false);
  check("dram_bytes_per_ray", r.dram_bytes_per_ray, 0.0, inf, false);
  check("bytes_per_prim", r.bytes_per_prim, 0.0, inf, false);
  check("area_mm2", r.area_mm2, 0.0, inf, false);
  check("pj_per_ray", r.pj_per_ray, 0.0, inf, false);
  check("seconds", r.seconds, 0.0, inf, false);
}

}  // namespace

std::vector<SweepRow> parse_sweep_csv(const std::string& text, const std::string& path, bool* header_is_current) {
  std::istringstream in(text);
  std::vector<SweepRow> rows;
  std::string line;
  size_t n = 0;
  bool has_flatten = true, has_model = true;
  while (std::getline(in, line)) {
    ++n;
    const std::string where = path + ":" + std::to_string(n);
    // Spreadsheets and Windows editors save CRLF line ends and a UTF-8 byte order mark: both are read as LF, none.
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (n == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    if (n == 1) {
      if (line == kHeaderBeforeBytes)
        throw Error(where +
                    ": not a sweep file of this version: an earlier rtusim wrote it, without the columns "
                    "dram_bytes_per_ray and bytes_per_prim (its points measured no DRAM traffic); run the "
                    "sweep again into a new file");
      if (line == kHeaderBeforeEnergy)
        throw Error(where +
                    ": not a sweep file of this version: an earlier rtusim wrote it, without the columns area_mm2 "
                    "and pj_per_ray (its points have no area or energy estimate); run the sweep again into a new "
                    "file");
      has_flatten = line != kHeaderBeforeFlatten;
      has_model = has_flatten && line != kHeaderBeforeModel;
      if (has_model && line != sweep_csv_header())
        throw Error(where + ": not a sweep file of this version (expected the header " + sweep_csv_header() + ")");
      if (header_is_current) *header_is_current = has_model;
      continue;
    }
    if (line.empty()) continue;
    const std::vector<std::string> f = split_csv(line);
    const size_t columns = kColumnCount - (has_flatten ? 0 : 1) - (has_model ? 0 : 1);
    if (f.size() != columns)
      throw Error(where + ": " + std::to_string(f.size()) + " fields, expected " + std::to_string(columns) +
                  " (a row cut short? re-run the sweep to redo it)");
    SweepRow r;
    size_t k = 0;
    r.p.scene = f[k++];
    r.p.format = f[k++];
    r.p.bvh_width = parse_csv_int<int>(f[k++], where);
    r.p.config = f[k++];
    r.rays = parse_csv_int<uint64_t>(f[k++], where);
    r.seed = parse_csv_int<uint64_t>(f[k++], where);
    r.image_width = parse_csv_int<int>(f[k++], where);
    if (has_flatten) {
      const int flat = parse_csv_int<int>(f[k++], where);
      if (flat != 0 && flat != 1) throw Error(where + ": flatten must be 0 or 1, got '" + f[k - 1] + "'");
      r.flatten = flat == 1;
    }
    r.hit_agreement = parse_csv_double(f[k++], where);
    r.prim_agreement = parse_csv_double(f[k++], where);
    r.false_misses = parse_csv_int<uint64_t>(f[k++], where);
    r.false_hits = parse_csv_int<uint64_t>(f[k++], where);
    r.t_rel_error_mean = parse_csv_double(f[k++], where);
    r.t_rel_error_max = parse_csv_double(f[k++], where);
    r.node_visit_overhead = parse_csv_double(f[k++], where);
    r.prim_test_overhead = parse_csv_double(f[k++], where);
    r.box_false_negatives = parse_csv_int<uint64_t>(f[k++], where);
    // Empty: not measured (no render); a file of the version before wrote 0 for it when image_width was 0.
    r.psnr_db = f[k].empty() || r.image_width == 0 ? std::numeric_limits<double>::quiet_NaN()
                                                   : parse_csv_double(f[k], where);
    if (!f[k].empty() && r.image_width > 0 && std::isnan(r.psnr_db))  // "not measured" is an empty cell
      throw Error(where + ": psnr_db '" + f[k] + "' is not a measurement (an empty cell: no render)");
    ++k;
    r.cycles = parse_csv_int<uint64_t>(f[k++], where);
    r.cycles_per_ray = parse_csv_double(f[k++], where);
    r.dram_bytes_per_ray = parse_csv_double(f[k++], where);
    r.bvh_bytes = parse_csv_int<uint64_t>(f[k++], where);
    r.float_bvh_bytes = parse_csv_int<uint64_t>(f[k++], where);
    r.bytes_per_prim = parse_csv_double(f[k++], where);
    r.rtl_cells = parse_csv_int<int64_t>(f[k++], where);
    r.rtl_transistors = parse_csv_int<int64_t>(f[k++], where);
    r.area_mm2 = parse_csv_double(f[k++], where);
    r.pj_per_ray = parse_csv_double(f[k++], where);
    r.seconds = parse_csv_double(f[k++], where);
    if (has_model) r.model = f[k++];
    check_sweep_row(r, where);
    rows.push_back(r);
  }
  if (n == 0) throw Error(path + ": empty (no header)");
  return rows;
}

std::string sweep_results_difference(const SweepRow& a, const SweepRow& b) {
  // The CSV's fields compare every result as written (NaN, the PSNR not measured, as an empty cell equal to
  // itself); the wall time is the one column that differs between two runs of one point.
  SweepRow a0 = a, b0 = b;
  a0.seconds = b0.seconds = 0.0;
  const std::vector<std::string> fa = split_csv(sweep_csv_line(a0)), fb = split_csv(sweep_csv_line(b0));
  for (size_t i = 0; i < kColumnCount && i < fa.size() && i < fb.size(); ++i)
    if (fa[i] != fb[i])
      return std::string(kColumns[i]) + " " + (fa[i].empty() ? "(empty)" : fa[i]) + " against " +
             (fb[i].empty() ? "(empty)" : fb[i]);
  return "";
}

bool same_sweep_results(const SweepRow& a, const SweepRow& b) {
  return sweep_results_difference(a, b).empty();
}

void check_sweep_rays(const std::string& job, uint64_t rays) {
  // Per point: 2N rays, the float reference's hits (kept per BVH width), the fixed device's and the timed
  // device's; 160 bytes per N, as measured (sweep --rays 400000 peaks 55 MiB above --rays 50000).
  const uint64_t per = 2 * (sizeof(hw::Ray) + 3 * sizeof(hw::Hit));
  check_memory(job + " --rays " + std::to_string(rays) + ": " + std::to_string(rays) +
                   " camera and as many "
                   "incoherent rays with their hits",
               rays > UINT64_MAX / per ? UINT64_MAX : rays * per);
}

}  // namespace rtu::host
