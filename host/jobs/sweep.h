// Run time against error: one point of a design sweep is a scene, a fixed-point format, a BVH width and a timing
// preset. For each point the sweep measures accuracy against the float reference (the `compare` figures on
// identical primary and incoherent rays, and the PSNR of a small firmware render), the simulated cycles of the
// same rays on the timed device and the DRAM bytes they fetched, the encoded BVH's bytes (in the format's storage
// layouts, so a sweep over layouts is a sweep over formats: "packed:coord_bits=16"), the RTL box unit's area where
// a synthesis table knows its parameters, and the simulator's own wall time. Rows go to a CSV that `rtusim sweep`
// resumes, shards and merges and that `rtusim plan` and the plots read.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "host/cost/area_tables.h"
#include "host/scene/scene.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

struct SweepPoint {
  std::string scene;   // load_scene spec
  std::string format;  // hw::format_from_spec spec, e.g. "default", "default:coord_bits=16", "packed:child_bits=4"
  int bvh_width = 4;
  std::string config;       // timing preset, or a preset with keys changed ("rdna2:box_units=2:tri_units=3")
  std::string key() const;  // scene|format|width|config: identifies a row
};

struct SweepRow {
  SweepPoint p;
  uint64_t rays = 0;  // compared and simulated (primary + incoherent)
  // With `rays`, the run parameters the row was made with (SweepOptions): the same point made with others measures
  // other rays or another render, so resume and merge tell them apart (sweep_run_params).
  uint64_t seed = 1;
  int image_width = 0;
  bool flatten = false;  // the fixed and timed devices traced an instanced scene flattened (SweepOptions)
  double hit_agreement = 1.0, prim_agreement = 1.0;
  uint64_t false_misses = 0, false_hits = 0;
  double t_rel_error_mean = 0.0, t_rel_error_max = 0.0;
  // For confidence bounds (host/jobs/plan.h), not in the CSV: rays valid on both devices, of them the rays hitting
  // the same primitive (the t error's sample), and the t error's sample standard deviation.
  uint64_t compared_rays = 0, t_compared_rays = 0;
  double t_rel_error_sd = 0.0;
  double node_visit_overhead = 0.0, prim_test_overhead = 0.0;
  uint64_t box_false_negatives = 0;
  // Fixed render against float render (inf when identical); NaN when not measured (image_width 0), which the CSV
  // writes as an empty cell.
  double psnr_db = std::numeric_limits<double>::quiet_NaN();
  bool psnr_measured() const { return !std::isnan(psnr_db); }
  uint64_t cycles = 0;  // the rays on the timed device (closest hit)
  double cycles_per_ray = 0.0;
  double dram_bytes_per_ray = 0.0;  // the timed run's DRAM bytes (its cache's line fills: TimingStats) / rays
  // The encoded image (header, nodes, primitives, planes); the float BVH's nodes + indices.
  uint64_t bvh_bytes = 0, float_bvh_bytes = 0;
  double bytes_per_prim = 0.0;  // the image's node and primitive bytes / its bounded primitives (0: none)
  int64_t rtl_cells = -1, rtl_transistors = -1;  // -1: no synthesis result for this unit
  // The estimate of hwmodel/cost/energy_model.h for the point's units (host/cost/cost_model.h: synthesized or
  // fitted size, measured activity): the unit's area, and the timed run's energy over its rays.
  double area_mm2 = 0.0, pj_per_ray = 0.0;
  double seconds = 0.0;  // wall time of the point
  // The model identity of the build that made the row (model_identity.h); "" in a file written before rows carried
  // it. Rows of two models are results of two models: resume runs the point again, merge refuses to mix them.
  std::string model;

  double hit_disagreement() const { return 1.0 - hit_agreement; }
};

struct SweepOptions {
  uint64_t rays = 20000;  // per kind: camera rays and as many incoherent rays (seed)
  uint64_t seed = 1;
  int image_width = 128;  // the PSNR render (1 sample per pixel, two bounces); 0: no render
  int threads = 0;
  // Fixed and timed devices trace an instanced scene's flattened geometry in one image instead of its two levels
  // (rtusim --flatten; the float reference keeps them). A run parameter: rows made with it measure other bytes.
  bool flatten = false;
  // Called between points and between the stages of a point (never from a worker thread); it may throw to stop
  // the job, e.g. the Python module's check for Ctrl-C. Empty: never called.
  std::function<void()> poll;
};

// Measures one point. `scene` must be the loaded p.scene. Caches the float reference per scene and width in
// `cache` (opaque; keep one per scene).
struct SweepCache;
SweepRow run_sweep_point(const Scene& scene, const SweepPoint& p, const SweepOptions& o, const AreaTable& area,
                         SweepCache& cache);

// The same point's timing on another configuration (`config`: a preset or a preset with keys changed, e.g. more
// units): `measured`'s error figures (they do not depend on the timing), its cycles, DRAM bytes, area and energy
// measured again on the rays `cache` holds, which must be those `measured` was made with (Error otherwise).
SweepRow retime_sweep_point(const Scene& scene, const SweepRow& measured, const std::string& config,
                            const SweepOptions& o, const AreaTable& area, SweepCache& cache);
// A sweep point's configuration from its spec (a preset, or "preset:key=value:..."); Error naming the spec.
hw::TimingConfig sweep_config(const std::string& spec);

struct SweepCacheDeleter {
  void operator()(SweepCache* c) const;
};
std::unique_ptr<SweepCache, SweepCacheDeleter> make_sweep_cache();

// A sweep's grid: every scene x BVH width x format x configuration, in this order (the order of the rows and of
// the shards of `rtusim sweep`). Configurations are sweep_config specs: a preset or "preset:key=value:...".
struct SweepGrid {
  std::vector<std::string> scenes, formats{"default"}, configs{"rdna2"};
  std::vector<int> widths{4};
};
// Checks every format spec, BVH width and configuration of the grid before the first point runs; throws Error
// naming the option (--formats, --bvh-width, --config) and the problem. A configuration that sets the timing keys
// format or bvh_width is refused, naming --formats or --bvh-width: a point's own format and width are what it
// runs.
void check_sweep_grid(const SweepGrid& g);
// The rays of a sweep or plan job (--rays N camera rays and N incoherent) and their hits on the float, fixed and
// timed devices, held at once, against the memory limit: throws the budget's Error naming `job` and N.
void check_sweep_rays(const std::string& job, uint64_t rays);
// Runs the grid's points in order (check_sweep_grid first): `want(index, point)` says whether point `index` runs
// (a shard, a resumed sweep); a scene is loaded only when one of its points runs, with one SweepCache per scene.
// `row(scene, row)` sees each row as soon as it is measured.
void run_sweep_grid(const SweepGrid& g, const SweepOptions& o, const AreaTable& area,
                    const std::function<bool(size_t, const SweepPoint&)>& want,
                    const std::function<void(const Scene&, const SweepRow&)>& row);

// The run parameters of a row, or of the rows a sweep with these options makes, as rtusim sweep's options spell
// them: "--rays N --seed S --image-width W" (and " --flatten" when set). Rows are interchangeable (resume, merge)
// only when these are equal.
std::string sweep_run_params(const SweepRow& r);
std::string sweep_run_params(const SweepOptions& o);

// CSV: one header line, one row per point, in a fixed column order; numbers round-trip; a PSNR not measured is an
// empty cell.
std::string sweep_csv_header();
std::string sweep_csv_line(const SweepRow& r);
// Reads a sweep CSV (throws Error naming the line for a wrong header or a malformed row). LF or CRLF line ends,
// with or without a UTF-8 byte order mark. A file of the version before the `flatten` column is read as rows
// that traced two levels (flatten 0), as that version did; `header_is_current`, when given, says whether the file
// has this version's header (a resumed sweep rewrites an older one before appending).
std::vector<SweepRow> read_sweep_csv(const std::string& path, bool* header_is_current = nullptr);
// The same from the file's text (`path` names it in errors).
std::vector<SweepRow> parse_sweep_csv(const std::string& text, const std::string& path,
                                      bool* header_is_current = nullptr);
// True when two rows of one point give the same results: every column but the wall time (`seconds`).
bool same_sweep_results(const SweepRow& a, const SweepRow& b);
// The first column whose value differs between two rows of one point, as "name a against b" (empty: none but
// the wall time).
std::string sweep_results_difference(const SweepRow& a, const SweepRow& b);

}  // namespace rtu::host
