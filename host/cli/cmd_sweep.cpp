// rtusim sweep: run time against error over a grid of scenes, formats, BVH widths and timing presets
// (host/jobs/sweep.h), one CSV row per point. Resumable (points already in --out made by this build with the same
// --rays, --seed, --image-width and --flatten are skipped), shardable (--shard k/N runs every N-th point, so
// independent jobs split a large sweep) and mergeable (--merge, of rows made by one build with the same run
// parameters).
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/limits.h"
#include "host/jobs/model_identity.h"
#include "host/jobs/point_key.h"
#include "host/jobs/suite.h"
#include "host/jobs/sweep.h"
#include "host/jobs/sweep_manifest.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host::cli {

namespace {

struct SweepArgs {
  SweepGrid grid;
  std::vector<std::string> merge, sets;
  std::string out, shard = "1/1", area, suite;
  std::string write_manifest, manifest, results, collect, points;
  SweepOptions opt;
};

// --set KEY=V1,V2,...: every configuration with each value of each key (in the order given, the last key varying
// fastest), as sweep_config specs "preset:KEY=V".
std::vector<std::string> expand_sets(const std::vector<std::string>& configs,
                                     const std::vector<std::string>& sets) {
  std::vector<std::string> out = configs;
  for (const std::string& s : sets) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == s.size())
      throw Error("--set: expected KEY=V1,V2,... (a timing key and its values), got '" + s + "'");
    const std::string key = s.substr(0, eq);
    // The grid's own axes: as timing keys they would relabel rows without changing them.
    if (key == "format")
      throw Error("--set " + s + ": a sweep's formats are given by --formats (e.g. --formats " + s.substr(eq + 1) +
                  "), not by the timing key format");
    if (key == "bvh_width")
      throw Error("--set " + s + ": a sweep's BVH widths are given by --bvh-width (e.g. --bvh-width " +
                  s.substr(eq + 1) + "), not by the timing key bvh_width");
    std::vector<std::string> values;
    for (size_t start = eq + 1;;) {
      const size_t comma = s.find(',', start);
      values.push_back(s.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
    std::vector<std::string> next;
    for (const std::string& c : out)
      for (const std::string& v : values) {
        if (v.empty()) throw Error("--set " + s + ": an empty value");
        next.push_back(c + ":" + key + "=" + v);
      }
    out = std::move(next);
  }
  return out;
}

// --shard auto: the task's share from its scheduler: a Slurm array task (SLURM_ARRAY_TASK_ID counted from
// SLURM_ARRAY_TASK_MIN, of SLURM_ARRAY_TASK_COUNT), or RTU_SHARD=k/N (GNU parallel, HTCondor, a shell loop).
std::string shard_from_env() {
  const char* id = std::getenv("SLURM_ARRAY_TASK_ID");
  const char* count = std::getenv("SLURM_ARRAY_TASK_COUNT");
  if (id && count) {
    const char* min = std::getenv("SLURM_ARRAY_TASK_MIN");
    try {
      const long k = std::stol(id) - (min ? std::stol(min) : 0) + 1;
      return std::to_string(k) + "/" + count;
    } catch (const std::exception&) {
      throw Error(std::string("--shard auto: SLURM_ARRAY_TASK_ID '") + id + "' is not a number");
    }
  }
  if (const char* s = std::getenv("RTU_SHARD")) return s;
  throw Error(
      "--shard auto: neither a Slurm array task (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_COUNT) nor RTU_SHARD=k/N "
      "in the environment");
}

// "k/N" with 1 <= k <= N.
std::pair<size_t, size_t> parse_shard(const std::string& s) {
  const size_t slash = s.find('/');
  try {
    if (slash != std::string::npos) {
      size_t a = 0, b = 0;
      const size_t k = std::stoul(s.substr(0, slash), &a), n = std::stoul(s.substr(slash + 1), &b);
      if (a == slash && b == s.size() - slash - 1 && k >= 1 && k <= n) return {k, n};
    }
  } catch (const std::exception&) {
  }
  throw Error("--shard: expected k/N with 1 <= k <= N, got '" + s + "'");
}

void write_rows(const std::string& path, const std::vector<SweepRow>& rows) {
  std::ofstream out = open_output(path);
  out << sweep_csv_header() << '\n';
  for (const SweepRow& r : rows) out << sweep_csv_line(r) << '\n';
  finish_output(out, path);
}

void run_merge(const SweepArgs& a) {
  std::vector<SweepRow> all;
  std::map<std::string, std::pair<size_t, std::string>> first;  // point key: its row in `all`, and its file
  size_t duplicates = 0, conflicts = 0;
  std::string params, params_file;  // the run parameters of the first row, and its file
  std::string model, model_file;    // the model identity of the first row, and its file
  const auto model_name = [](const std::string& m) {
    return m.empty() ? std::string("none (a file written before rows carried the model)") : m;
  };
  for (const std::string& f : a.merge)
    for (const SweepRow& r : read_sweep_csv(f)) {
      // Rows of two builds are results of two models: one table would mix them.
      if (model_file.empty()) {
        model = r.model;
        model_file = f;
      } else if (r.model != model) {
        throw Error("--merge: rows of different models, " + model_name(model) + " (in " + model_file + ") and " +
                    model_name(r.model) + " (in " + f +
                    "): only rows of one build merge (rtusim --version names a build's model)");
      }
      // Rows made with other rays or another render are not parts of one sweep.
      const std::string p = sweep_run_params(r);
      if (params.empty()) {
        params = p;
        params_file = f;
      } else if (p != params) {
        throw Error("--merge: rows made with different run parameters, " + params + " (in " + params_file +
                    ") and " + p + " (in " + f + "): only rows made with the same run parameters merge");
      }
      const auto it = first.find(r.p.key());
      if (it == first.end()) {
        first.emplace(r.p.key(), std::make_pair(all.size(), f));
        all.push_back(r);
        continue;
      }
      ++duplicates;
      // The same point measured twice with the same run parameters gives the same results (the model is
      // deterministic); other results mean another rtusim made one of them: the first is kept, and the user told.
      const std::string diff = sweep_results_difference(all[it->second.first], r);
      if (!diff.empty()) {
        ++conflicts;
        std::fprintf(stderr,
                     "rtusim: warning: --merge: point %s: %s gives other results than %s (%s); keeping the row of "
                     "%s\n",
                     r.p.key().c_str(), f.c_str(), it->second.second.c_str(), diff.c_str(),
                     it->second.second.c_str());
      }
    }
  write_rows(a.out, all);
  std::printf("merged %zu files: %zu points (%zu duplicates dropped, %zu of them with other results) -> %s\n",
              a.merge.size(), all.size(), duplicates, conflicts, a.out.c_str());
}

void run_sweep_points(const SweepArgs& a);
void write_manifest(const SweepArgs& a);
void run_manifest(const SweepArgs& a);
void collect_points(const SweepArgs& a);

void run_sweep(const SweepArgs& a) {
  if (!a.merge.empty()) return run_merge(a);
  if (!a.collect.empty()) return collect_points(a);
  if (!a.manifest.empty()) return run_manifest(a);
  SweepArgs args = a;
  args.grid.configs = expand_sets(a.grid.configs, a.sets);
  if (!a.suite.empty()) {  // the suite's available scenes after --scene's; skipped ones named on stderr
    for (const std::string& spec : suite_scenes(a.suite, [](const std::string& line) {
           std::fprintf(stderr, "rtusim: warning: %s\n", line.c_str());
         }))
      args.grid.scenes.push_back(spec);
    if (args.grid.scenes.empty()) throw Error("sweep: " + a.suite + ": no scene of the suite is available");
  }
  if (!a.write_manifest.empty()) return write_manifest(args);
  if (!a.points.empty())
    throw Error("sweep: --points needs --write-manifest (its points then run from the manifest)");
  if (a.out.empty())
    throw Error("sweep: --out is required (or --write-manifest FILE, --manifest FILE --results DIR)");
  run_sweep_points(args);
}

// The text, its copy split into lines and what is parsed from it: four times the file at most.
std::string read_text(const std::string& path) {
  return read_file_limited(path, 4);
}

// --points FILE: one point per line, "scene<TAB>format<TAB>width<TAB>config" (or the same with commas), as a
// script writes them (Latin-hypercube samples, a table of configurations); # starts a comment line.
std::vector<SweepPoint> read_points(const std::string& path) {
  std::vector<SweepPoint> out;
  std::istringstream in(read_text(path));
  std::string line;
  for (size_t n = 1; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    const char sep = line.find('\t') != std::string::npos ? '\t' : ',';
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string x; std::getline(ss, x, sep);) f.push_back(x);
    const std::string where = path + ":" + std::to_string(n);
    if (f.size() != 4)
      throw Error(where + ": expected scene, format, BVH width, configuration; got '" + line + "'");
    SweepPoint p{f[0], f[1], 0, f[3]};
    try {
      size_t used = 0;
      p.bvh_width = std::stoi(f[2], &used);
      if (used != f[2].size()) throw std::invalid_argument("trailing");
    } catch (const std::exception&) {
      throw Error(where + ": BVH width '" + f[2] + "' is not an integer");
    }
    SweepGrid one;
    one.formats = {p.format};
    one.configs = {p.config};
    one.widths = {p.bvh_width};
    try {
      check_sweep_grid(one);
    } catch (const Error& e) {
      throw Error(where + ": " + e.what());
    }
    out.push_back(p);
  }
  if (out.empty()) throw Error(path + ": no point");
  return out;
}

void write_manifest(const SweepArgs& a) {
  std::vector<SweepPoint> points;
  if (!a.points.empty()) {
    points = read_points(a.points);
  } else {
    if (a.grid.scenes.empty()) throw Error("sweep: --scene, --suite or --points is required");
    check_sweep_grid(a.grid);
    points = sweep_grid_points(a.grid);
  }
  size_t repeated = 0;  // the same computation under another spelling: it runs once
  // The area table prices every point: its digest is part of each key, and the run must give the same table.
  const AreaTable area = a.area.empty() ? AreaTable::shipped() : AreaTable::load(a.area);
  const Manifest m = make_manifest(points, a.opt, area, &repeated);
  std::ofstream out = open_output(a.write_manifest, std::ios::binary | std::ios::trunc);
  out << manifest_text(m);
  finish_output(out, a.write_manifest);
  std::printf("manifest: %zu points (%zu repeated points listed once) with %s -> %s\n", m.points.size(), repeated,
              m.params.c_str(), a.write_manifest.c_str());
}

void run_manifest(const SweepArgs& a) {
  if (a.results.empty()) throw Error("sweep --manifest: --results DIR is required (the folder of point files)");
  const Manifest m = read_manifest(a.manifest);
  const auto [shard, shards] = parse_shard(a.shard == "auto" ? shard_from_env() : a.shard);
  const AreaTable area = a.area.empty() ? AreaTable::shipped() : AreaTable::load(a.area);
  const ManifestRun run = run_manifest(
      m, a.results, shard, shards, a.opt.threads, area, [](const ManifestPoint& mp, const SweepRow& r) {
        std::printf("%s %s %s w%d %s: %llu cycles, %.1f s\n", mp.key.c_str(), mp.point.scene.c_str(),
                    mp.point.format.c_str(), mp.point.bvh_width, mp.point.config.c_str(),
                    (unsigned long long)r.cycles, r.seconds);
        std::fflush(stdout);
      });
  std::printf("sweep: %zu points in this shard (%zu/%zu), %zu run, %zu already in %s\n", run.mine, shard, shards,
              run.ran, run.done, a.results.c_str());
}

// True when `a` and `b` name one file (b need not exist).
bool same_file(const std::string& a, const std::string& b) {
  std::error_code ec;
  if (std::filesystem::exists(a, ec) && std::filesystem::exists(b, ec))
    return std::filesystem::equivalent(a, b, ec);
  return std::filesystem::weakly_canonical(a, ec) == std::filesystem::weakly_canonical(b, ec);
}

void collect_points(const SweepArgs& a) {
  if (a.manifest.empty() || a.out.empty())
    throw Error("sweep --collect DIR: --manifest FILE (which points, in which order) and --out CSV are required");
  const Manifest m = parse_manifest(read_text(a.manifest), a.manifest);
  // --out and its provenance file are written: neither may be one of the inputs, the manifest or a point file.
  for (const std::string& out : {a.out, a.out + ".provenance.csv"}) {
    if (same_file(out, a.manifest))
      throw Error("sweep --collect: --out " + a.out + " would overwrite the manifest " + a.manifest +
                  "; name another file");
    const std::filesystem::path path(out);
    const std::string name = path.filename().string();
    if (name.size() == 37 && name.ends_with(".json") &&
        same_file(path.parent_path().empty() ? "." : path.parent_path().string(), a.collect))
      for (const ManifestPoint& mp : m.points)
        if (name == mp.key + ".json")
          throw Error("sweep --collect: --out " + a.out + " would overwrite the point file of " + mp.key + " in " +
                      a.collect + "; name another file");
  }
  const CollectedSweep c = collect_manifest(m, a.collect);
  write_rows(a.out, c.rows);
  const std::string prov_path = a.out + ".provenance.csv";
  std::ofstream prov = open_output(prov_path, std::ios::binary | std::ios::trunc);
  prov << c.provenance_csv;
  finish_output(prov, prov_path);
  std::printf("collected %zu points -> %s (provenance: %s); %.1f s of point time, %.0f points per worker-hour\n",
              c.rows.size(), a.out.c_str(), prov_path.c_str(), c.seconds,
              c.seconds > 0 ? 3600.0 * c.rows.size() / c.seconds : 0.0);
}

void run_sweep_points(const SweepArgs& a) {
  if (a.grid.scenes.empty()) throw Error("sweep: --scene or --suite is required (or --merge FILES)");
  // Named variables, not a structured binding: the lambda below captures them (clang 14 cannot capture bindings).
  const auto shard_of = parse_shard(a.shard);
  const auto shard = shard_of.first, shards = shard_of.second;
  // Every point's format and configuration is checked before the first one runs.
  check_sweep_grid(a.grid);
  const AreaTable area = a.area.empty() ? AreaTable::shipped() : AreaTable::load(a.area);

  // Resume: the points already in --out with this sweep's run parameters and this build's model are done; rows
  // made with others stay in the file, beside the new ones. A last line without its newline is a row an
  // interrupted sweep did not finish writing: it is dropped (and run again).
  std::set<std::string> done;
  check_output_file(a.out);
  std::error_code ec;
  bool exists = std::filesystem::exists(a.out, ec) && std::filesystem::file_size(a.out, ec) > 0 && !ec;
  if (exists) {
    const std::string text = read_text(a.out);
    if (text.back() != '\n') {
      const size_t keep = text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1;
      std::fprintf(stderr, "rtusim: warning: %s ends in an unfinished row; dropping it\n", a.out.c_str());
      std::filesystem::resize_file(a.out, keep);
      exists = keep > 0;
    }
  }
  const std::string params = sweep_run_params(a.opt);
  if (exists) {
    size_t others = 0;
    std::string other;
    bool current = true;
    const std::vector<SweepRow> old = read_sweep_csv(a.out, &current);
    if (!current) {
      // A file of a version before the flatten or model column: rewritten in this version (its rows kept, flatten
      // 0, model none) so that the rows appended below match its header.
      write_rows(a.out, old);
      std::fprintf(stderr,
                   "rtusim: warning: %s was written by an earlier rtusim (no flatten or model column); rewritten "
                   "in this version, its rows kept\n",
                   a.out.c_str());
    }
    size_t other_models = 0;
    for (const SweepRow& r : old) {
      if (sweep_run_params(r) != params) {
        ++others;
        other = sweep_run_params(r);
      } else if (r.model != model_identity()) {
        ++other_models;  // another build's results of the point: this build measures it again
      } else {
        done.insert(r.p.key());
      }
    }
    if (others > 0)
      std::fprintf(stderr,
                   "rtusim: warning: %s holds %zu rows made with other run parameters (e.g. %s); they are kept, "
                   "and this sweep's points run again with %s beside them (--merge refuses such a file)\n",
                   a.out.c_str(), others, other.c_str(), params.c_str());
    if (other_models > 0)
      std::fprintf(stderr,
                   "rtusim: warning: %s holds %zu rows of another model (another build, or written before rows "
                   "carried the model); they are kept, and their points run again with model %s (--merge "
                   "refuses such a file)\n",
                   a.out.c_str(), other_models, model_identity());
  }
  std::ofstream out = open_output(a.out, std::ios::app);
  if (!exists) out << sweep_csv_header() << '\n' << std::flush;

  size_t ran = 0, skipped = 0;
  const auto want = [&](size_t index, const SweepPoint& p) {
    if (index % shards != shard - 1) return false;
    if (done.count(p.key())) {
      ++skipped;
      return false;
    }
    return true;
  };
  run_sweep_grid(a.grid, a.opt, area, want, [&](const Scene& scene, const SweepRow& r) {
    out << sweep_csv_line(r) << '\n' << std::flush;  // a row at a time: an interrupted sweep resumes
    if (!out) throw Error("cannot write " + a.out);
    ++ran;
    char psnr[32] = "no render";
    if (r.psnr_measured()) std::snprintf(psnr, sizeof psnr, "PSNR %.1f dB", r.psnr_db);
    std::printf(
        "%s %s w%d %s%s: hit agreement %.5f%%, t err %.2g, %s, %llu cycles, %.1f DRAM bytes/ray, "
        "%llu bytes (%.1f per primitive), %.1f s\n",
        scene.name.c_str(), r.p.format.c_str(), r.p.bvh_width, r.p.config.c_str(), r.flatten ? " flattened" : "",
        100.0 * r.hit_agreement, r.t_rel_error_mean, psnr, (unsigned long long)r.cycles, r.dram_bytes_per_ray,
        (unsigned long long)r.bvh_bytes, r.bytes_per_prim, r.seconds);
    std::fflush(stdout);
  });
  std::printf("sweep: %zu points in this shard (%zu/%zu), %zu run, %zu already in %s\n", ran + skipped, shard,
              shards, ran, skipped, a.out.c_str());
}

}  // namespace

void add_sweep(CLI::App& app) {
  const auto [sub, a] = add_command<SweepArgs>(
      app, "sweep",
      "Run time against error over scenes x formats x BVH widths x timing presets; one CSV row per point",
      [](SweepArgs& a, CLI::App&) { run_sweep(a); });
  sub->add_option("--scene", a->grid.scenes, "scene file, mesh file or builtin:NAME (repeatable)");
  sub->add_option(
      "--suite", a->suite,
      "benchmark suite manifest (scenes/suite.json): its scenes after --scene's; scenes whose files are "
      "missing are skipped with a warning");
  sub->add_option("--formats", a->grid.formats,
                  "format specs, comma-separated: a preset, or a preset with changes, e.g. "
                  "default:coord_bits=16:child_bits=6; storage layouts are presets (packed, cwbvh) or keys "
                  "(node_layout, node_align, prim_layout), e.g. packed:coord_bits=16 (rtusim info --formats)")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_option("--bvh-width", a->grid.widths, "BVH widths, comma-separated (2, 4, 6, 8)")
      ->delimiter(',')
      ->capture_default_str();
  std::string presets;
  for (const std::string& p : hw::timing_preset_names()) presets += (presets.empty() ? "" : ",") + p;
  sub->add_option("--config", a->grid.configs,
                  "timing configurations, comma-separated: a preset (" + presets +
                      ") or a preset with keys changed, e.g. rdna2:cache_kib=16:box_units=2")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_option("--set", a->sets,
                  "KEY=V1,V2,...: each configuration with each value of the timing key (repeatable: every "
                  "combination)");
  sub->add_option("--write-manifest", a->write_manifest,
                  "write the grid's points, each with its content key, to this manifest and run none");
  sub->add_option("--points", a->points,
                  "with --write-manifest: the points of this file instead of a grid, one per line: scene, format, "
                  "BVH width, configuration (tab- or comma-separated; # comments)")
      ->check(CLI::ExistingFile);
  sub->add_option("--manifest", a->manifest,
                  "run this manifest's points (or --shard k/N of them, --shard auto from a Slurm array or "
                  "RTU_SHARD) into --results, one file per point; with --collect: the points to collect")
      ->check(CLI::ExistingFile);
  sub->add_option("--results", a->results,
                  "folder of point files (KEY.json, each written whole); points whose file is there are skipped");
  sub->add_option("--collect", a->collect,
                  "collect this folder's point files for --manifest's points into --out (a sweep CSV) and "
                  "--out.provenance.csv")
      ->check(CLI::ExistingDirectory);
  sub->add_option("--rays", a->opt.rays, "camera rays and as many incoherent rays per point")
      ->check(CLI::Range(uint64_t(1), uint64_t(1) << 26))
      ->capture_default_str();
  sub->add_option("--seed", a->opt.seed, "seed of the incoherent rays")->capture_default_str();
  sub->add_option("--image-width", a->opt.image_width, "width of the PSNR render (0: none)")
      ->check(CLI::Range(0, 4096))
      ->capture_default_str();
  sub->add_option("--threads", a->opt.threads, "worker threads (0 = all cores); results do not depend on it")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->add_flag("--flatten", a->opt.flatten,
                "fixed and timed devices: trace an instanced scene's flattened geometry in one image instead of "
                "its two levels (the float reference keeps them); a run parameter, in the CSV's flatten column");
  sub->add_option("--area", a->area,
                  "RTL area table (CSV params,cells,flip_flops,transistors; bench/rtl_area.sh writes it; default: "
                  "the shipped bench/data/rtl_area.csv); part of a manifest's keys: run it with the table it was "
                  "written with")
      ->check(CLI::ExistingFile);
  sub->add_option("--shard", a->shard,
                  "run every N-th point, starting at the k-th: k/N; with --manifest also auto (a Slurm array "
                  "task's, or RTU_SHARD's)")
      ->capture_default_str();
  CLI::Option* merge =
      sub->add_option("--merge", a->merge,
                      "merge these sweep CSVs into --out (no points run; their rows must share --rays, --seed and "
                      "--image-width)")
          ->check(CLI::ExistingFile);
  // Merging runs no point: the options of a run would be ignored, so they are refused with it.
  for (const char* name : {"--scene", "--suite", "--formats", "--bvh-width", "--config", "--rays", "--seed",
                           "--image-width", "--threads", "--area", "--shard", "--flatten", "--set",
                           "--write-manifest", "--manifest", "--results", "--collect", "--points"})
    merge->excludes(sub->get_option(name));
  // A manifest fixes the grid and the run parameters: the grid's options would be ignored.
  for (const char* name : {"--scene", "--suite", "--formats", "--bvh-width", "--config", "--rays", "--seed",
                           "--image-width", "--flatten", "--set", "--write-manifest", "--points"})
    sub->get_option("--manifest")->excludes(sub->get_option(name));
  for (const char* name : {"--scene", "--suite", "--formats", "--bvh-width", "--config", "--set"})
    sub->get_option("--points")->excludes(sub->get_option(name));
  sub->add_option("--out", a->out,
                  "CSV to write; points already in it made with the same --rays, --seed and --image-width are "
                  "skipped (resume)");
}

}  // namespace rtu::host::cli
