// _rtu's design-space jobs (python/README.md): sweep, its manifests (write, run a shard, collect), plan and the
// Pareto front, each the host function rtusim calls with the GIL released and Ctrl-C checked between its steps.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "host/io/error.h"
#include "host/io/files.h"
#include "host/jobs/pareto.h"
#include "host/jobs/plan.h"
#include "host/jobs/sweep.h"
#include "host/jobs/sweep_manifest.h"
#include "python/rtu_module.h"

namespace rtu::pymod {
namespace {

host::SweepOptions sweep_options(uint64_t rays, uint64_t seed, int image_width, int threads, bool flatten) {
  if (rays < 1 || rays > (uint64_t(1) << 26)) fail("rays: " + std::to_string(rays) + " is not in 1..67108864");
  if (image_width < 0 || image_width > 4096) fail("image_width: not in 0..4096");
  host::SweepOptions o;
  o.rays = rays;
  o.seed = seed;
  o.image_width = image_width;
  o.threads = check_threads(threads);
  o.flatten = flatten;
  o.poll = check_signals;  // Ctrl-C between points and their stages
  return o;
}

// rtusim sweep: the CSV text of every point (the Python layer reads it into a DataFrame); with shards > 1, of
// shard `shard` of them only (1-based), as rtusim sweep --shard shard/shards: every shards-th point of the grid's
// order, starting at the shard-th.
std::string sweep(const std::vector<std::string>& scenes, const std::vector<std::string>& formats,
                  const std::vector<int>& widths, const std::vector<std::string>& configs, uint64_t rays,
                  uint64_t seed, int image_width, int threads, const std::string& area_path, bool flatten,
                  size_t shard, size_t shards) {
  if (shards < 1 || shard < 1 || shard > shards)
    fail("shard: expected (k, N) with 1 <= k <= N, got (" + std::to_string(shard) + ", " + std::to_string(shards) +
         ")");
  // An empty list would make an empty grid: no row, and no word of why.
  if (scenes.empty()) fail("scenes: empty (give at least one scene)");
  if (formats.empty()) fail("formats: empty (give at least one format spec)");
  if (widths.empty()) fail("bvh_widths: empty (give at least one of 2, 4, 6, 8)");
  if (configs.empty()) fail("configs: empty (give at least one timing preset)");
  host::SweepGrid g{scenes, formats, configs, widths};
  const host::SweepOptions o = sweep_options(rays, seed, image_width, threads, flatten);
  host::check_sweep_grid(g);
  py::gil_scoped_release nogil;
  const host::AreaTable area = area_path.empty() ? host::AreaTable::shipped() : host::AreaTable::load(area_path);
  std::string csv = host::sweep_csv_header() + "\n";
  host::run_sweep_grid(
      g, o, area, [&](size_t index, const host::SweepPoint&) { return index % shards == shard - 1; },
      [&](const host::Scene&, const host::SweepRow& r) { csv += host::sweep_csv_line(r) + "\n"; });
  return csv;
}

// rtusim sweep --write-manifest: the grid's manifest, priced with the area table at `area_path` (empty: the
// shipped one), written to `path`; (points, repeated points listed once, the manifest's text). A file already
// there listing other points is refused (a folder holds one sweep: resuming another's points would mix them).
// Concurrent calls on one path create it once: each writes its text to a name of its own and hard-links it to
// `path`, which fails when `path` exists, so exactly one call creates it, whole, and every other compares its own
// text with that one.
py::tuple write_manifest(const std::string& path, const std::vector<std::string>& scenes,
                         const std::vector<std::string>& formats, const std::vector<int>& widths,
                         const std::vector<std::string>& configs, uint64_t rays, uint64_t seed, int image_width,
                         bool flatten, const std::string& area_path) {
  const host::SweepGrid g{scenes, formats, configs, widths};
  const host::SweepOptions o = sweep_options(rays, seed, image_width, 1, flatten);
  host::check_sweep_grid(g);
  size_t points = 0, repeated = 0;
  std::string text;
  {
    py::gil_scoped_release nogil;
    const host::AreaTable area = area_path.empty() ? host::AreaTable::shipped() : host::AreaTable::load(area_path);
    const host::Manifest m = host::make_manifest(host::sweep_grid_points(g), o, area, &repeated);
    points = m.points.size();
    text = host::manifest_text(m);
    static std::atomic<unsigned> counter{0};
    const std::string tmp = path + ".tmp-" + std::to_string(getpid()) + "-" + std::to_string(counter++);
    {
      std::ofstream out = host::open_output(tmp, std::ios::binary | std::ios::trunc);
      out << text;
      host::finish_output(out, tmp);
    }
    const int linked = link(tmp.c_str(), path.c_str());
    const int err = errno;
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    if (linked != 0 && err != EEXIST) throw host::Error("cannot create " + path + ": " + std::strerror(err));
    if (linked != 0) {
      std::ifstream old(path, std::ios::binary);
      if (std::string((std::istreambuf_iterator<char>(old)), std::istreambuf_iterator<char>()) != text)
        throw host::Error(path +
                          " lists other points (another grid, or a scene or rtu changed since it was written); "
                          "use a new results folder");
    }
  }
  return py::make_tuple(points, repeated, text);
}

// rtusim plan: (the --json dict, the CSV text of every candidate measured, whether each met the budget, each one's
// rays per clock per mm^2).
py::tuple plan(const host::PlanOptions& o) {
  std::string csv = host::sweep_csv_header() + "\n";
  std::vector<bool> meets;
  std::vector<double> perf_per_mm2;
  host::PlanResult res;
  {
    py::gil_scoped_release nogil;
    res = host::plan_format(o, [&](const host::PlanStep& s) {
      if (s.stage != host::PlanStage::kCandidate) return;
      csv += host::sweep_csv_line(*s.row) + "\n";
      meets.push_back(s.meets);
      perf_per_mm2.push_back(host::plan_perf_per_area(*s.row));
    });
  }
  return py::make_tuple(to_python(res.json), csv, meets, perf_per_mm2);
}

}  // namespace

void register_sweep(py::module_& m) {
  m.def("sweep", &sweep, py::arg("scenes"), py::arg("formats"), py::arg("bvh_widths"), py::arg("configs"),
        py::arg("rays"), py::arg("seed"), py::arg("image_width"), py::arg("threads"), py::arg("area"),
        py::arg("flatten"), py::arg("shard") = 1, py::arg("shards") = 1);
  m.def("write_manifest", &write_manifest, py::arg("path"), py::arg("scenes"), py::arg("formats"),
        py::arg("bvh_widths"), py::arg("configs"), py::arg("rays"), py::arg("seed"), py::arg("image_width"),
        py::arg("flatten"), py::arg("area"));
  m.def(
      "run_manifest",
      [](const std::string& manifest, const std::string& results, size_t shard, size_t shards, int threads,
         const std::string& area_path) {
        if (shards < 1 || shard < 1 || shard > shards) fail("shard: expected 1 <= k <= N");
        const int t = check_threads(threads);
        py::gil_scoped_release nogil;
        const host::Manifest m = host::read_manifest(manifest);
        const host::AreaTable area =
            area_path.empty() ? host::AreaTable::shipped() : host::AreaTable::load(area_path);
        const host::ManifestRun r = host::run_manifest(m, results, shard, shards, t, area);
        return std::make_tuple(r.mine, r.ran, r.done);
      },
      py::arg("manifest"), py::arg("results"), py::arg("shard"), py::arg("shards"), py::arg("threads"),
      py::arg("area"), "Shard k/N of a manifest into a folder of point files: (points, run, already there)");
  m.def(
      "collect",
      [](const std::string& manifest, const std::string& results) {
        py::gil_scoped_release nogil;
        const host::CollectedSweep c = host::collect_manifest(host::read_manifest(manifest), results);
        std::string csv = host::sweep_csv_header() + "\n";
        for (const host::SweepRow& r : c.rows) csv += host::sweep_csv_line(r) + "\n";
        return std::make_pair(csv, c.provenance_csv);
      },
      py::arg("manifest"), py::arg("results"),
      "A manifest's point files as (the sweep CSV's text, the provenance CSV's text), as rtusim sweep --collect");
  m.def(
      "plan",
      [](const std::string& scene, double max_error, const std::string& metric, double min_psnr, double confidence,
         const std::string& config, const std::string& format, const std::string& minimise, double min_gain,
         double area_budget, const std::vector<int>& widths, const std::vector<int>& coord_bits,
         const std::vector<int>& child_bits, uint64_t rays, uint64_t seed, int image_width, int threads,
         const std::string& area, bool flatten) {
        // NaN would pass the range checks below (every comparison with it is false): refused by name first.
        for (const auto& [name, v] : {std::pair<const char*, double>{"max_error", max_error},
                                      {"min_psnr", min_psnr},
                                      {"confidence", confidence},
                                      {"min_gain", min_gain},
                                      {"area_budget", area_budget}})
          if (!std::isfinite(v)) fail(std::string(name) + ": " + std::to_string(v) + " is not a finite number");
        host::PlanOptions o;
        o.scene = scene;
        o.max_error = max_error;
        o.metric = metric;
        o.min_psnr = min_psnr;
        if (!(confidence >= 0.5 && confidence <= 0.999999)) fail("confidence: not in [0.5, 0.999999]");
        o.confidence = confidence;
        o.config = config;
        o.format = format;
        o.minimise = minimise;
        if (!(min_gain >= 0.0 && min_gain <= 100.0)) fail("min_gain: not in [0, 100] percent");
        o.min_gain_pct = min_gain;
        if (!(area_budget >= 0.0 && area_budget <= 1e6)) fail("area_budget: not in [0, 1e6] mm^2");
        o.area_budget = area_budget;
        for (int w : widths)
          if (w != 2 && w != 4 && w != 6 && w != 8)
            fail("bvh_widths: " + std::to_string(w) + " is not 2, 4, 6 or 8");
        for (int b : coord_bits)
          if (b < 2 || b > 30) fail("coord_bits: " + std::to_string(b) + " is not in 2..30");
        for (int b : child_bits)
          if (b < 1 || b > 16) fail("child_bits: " + std::to_string(b) + " is not in 1..16");
        if (widths.empty()) fail("bvh_widths: empty (give at least one of 2, 4, 6, 8)");
        if (coord_bits.empty()) fail("coord_bits: empty (give at least one width in 2..30)");
        if (child_bits.empty()) fail("child_bits: empty (give at least one width in 1..16)");
        o.widths = widths;
        o.coord_bits = coord_bits;
        o.child_bits = child_bits;
        o.sweep = sweep_options(rays, seed, image_width, threads, flatten);
        o.area = area;
        return plan(o);
      },
      py::arg("scene"), py::arg("max_error"), py::arg("metric"), py::arg("min_psnr"), py::arg("confidence"),
      py::arg("config"), py::arg("format"), py::arg("minimise"), py::arg("min_gain"), py::arg("area_budget"),
      py::arg("bvh_widths"), py::arg("coord_bits"), py::arg("child_bits"), py::arg("rays"), py::arg("seed"),
      py::arg("image_width"), py::arg("threads"), py::arg("area"), py::arg("flatten"));
  m.def(
      "pareto_front",
      [](const std::vector<std::pair<double, double>>& points) { return host::pareto_front(points); },
      py::arg("points"), "Indices of the (cost, error) points on the Pareto front, by cost ascending");
}

}  // namespace rtu::pymod
