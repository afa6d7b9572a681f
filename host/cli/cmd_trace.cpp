// rtusim trace: ray file in, hit file out, on a device.
#include <cstdio>
#include <cstring>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "host/cli/common.h"
#include "host/devices/trav_units.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/ray_io.h"
#include "host/jobs/ab.h"
#include "host/jobs/trace_job.h"
#include "host/scene/ray_spec.h"
#include "hwmodel/interface/commands.h"

namespace rtu::host::cli {

namespace {

struct TraceOptions {
  std::string scene, rays, out, stats;
  uint64_t seed = 1;
  bool any_hit = false;
  bool rtl_unit = false;  // --rtl-unit: the packet on the RTL traversal unit too
  int threads = 0;
  int omm_level = -1;  // --omm-level: opacity micromaps of this level (-1: none)
  int all_hits = -1;   // --all-hits K: every intersection, K kept a ray (-1: closest or any hit)
  size_t packet_rays = kTracePacketRays;  // --packet-rays: rays a TRACE packet
  DeviceArgs dev;
  PipelineTraceArgs pipeline;
  AgainstSpec against;  // --against-*: design point B of an A/B
};

// --rtl-unit: the same rays in one packet on the Verilated traversal unit of the timed device's configuration,
// its cycles beside the model's and its hits against the device's; a line on stdout and the JSON section.
Json rtl_unit_run(const hw::TimedEngine& te, const std::vector<hw::Ray>& rays, bool any_hit,
                  std::span<const hw::Hit> hits, bool cycles_only) {
  if (!te.image()) throw Error("--rtl-unit: the RTL traversal unit traces one level (add --flatten)");
  const RtlTravRun r = run_rtl_trav_unit(te.config(), *te.image(), rays.data(), rays.size(), any_hit);
  const hw::TimingStats& s = te.timing();
  uint64_t differ = 0;
  if (!cycles_only)
    for (size_t i = 0; i < rays.size(); ++i) differ += std::memcmp(&r.hits[i], &hits[i], sizeof(hw::Hit)) != 0;
  const double error = r.cycles ? (double(s.cycles) - double(r.cycles)) / double(r.cycles) : 0.0;
  std::printf(
      "RTL traversal unit %s: %llu cycles; the model %llu in %llu packet(s) (%+.3f%%); %s\n", r.unit.c_str(),
      (unsigned long long)r.cycles, (unsigned long long)s.cycles, (unsigned long long)s.packets, 100.0 * error,
      cycles_only
          ? "hits not compared (no --out)"
          : (differ ? std::to_string(differ) + " hits differ from the device's" : "the same hits").c_str());
  return Json{{"unit", r.unit},           {"cycles", r.cycles},
              {"model_cycles", s.cycles}, {"model_packets", s.packets},
              {"error", error},           {"hits_differing", cycles_only ? Json(nullptr) : Json(differ)}};
}

void run_trace(const TraceOptions& o) {
  check_output_files({o.out, o.stats, o.pipeline.path});
  Stopwatch load_timer;
  const Scene scene = load_scene(o.scene);
  const double load_s = load_timer.seconds();
  const std::vector<hw::Ray> rays = rays_from_spec(o.rays, scene, o.seed);

  const hw::DeviceKind kind = o.dev.kind();
  // Without --out the statistics alone; sampled timing then traces only the sampled rays.
  const bool cycles_only = o.out.empty() && kind == hw::DeviceKind::kTimed && o.dev.sample > 0.0;
  PipelineTraceArgs pt = o.pipeline;
  TraceRequest req;
  req.scene = &scene;
  req.rays = rays;
  req.settings = o.dev;
  req.kind = kind;
  req.any_hit = o.any_hit;
  req.threads = o.threads;
  req.omm_level = o.omm_level;
  req.all_hits = o.all_hits;
  req.need_hits = !cycles_only;
  req.packet_rays = o.packet_rays;
  req.pipeline = pt.make();
  const TraceRun run = host::run_trace(req);
  if (!run.grid_warning.empty()) std::fprintf(stderr, "rtusim: warning: %s\n", run.grid_warning.c_str());
  const hw::TraversalStats& stats = run.stats;
  const double trace_s = run.trace_seconds;
  if (!o.out.empty() && o.all_hits >= 0)
    write_hit_lists(o.out, uint32_t(o.all_hits), run.lists, run.counts);
  else if (!o.out.empty())
    write_hits(o.out, run.hits);

  report_invalid_rays(stats, stderr);
  const uint64_t n = rays.size();
  // A chip traces every ray (the skipped ones warm its caches), so its counts are every ray's.
  const bool chip = run.device->timed() && run.device->timed()->config().units > 1;
  if (cycles_only && !chip)
    std::printf("cycles only (--sample without --out): the counts below are the sampled rays'\n");
  std::printf("traced %llu rays on %s: %llu hits, %llu invalid, %.3f s, %.2f MRays/s\n", (unsigned long long)n,
              o.dev.device.c_str(), (unsigned long long)stats.hits, (unsigned long long)stats.invalid_rays,
              trace_s, trace_s > 0 ? double(n) / trace_s * 1e-6 : 0.0);
  if (o.all_hits >= 0) {
    const Json a = all_hits_json(uint32_t(o.all_hits), run.counts);
    std::printf(
        "all hits: %llu intersections (%.2f a ray, at most %llu), %llu kept (at most %d a ray), %llu rays "
        "overflowed\n",
        (unsigned long long)a["found"].get<uint64_t>(), a["mean_per_ray"].get<double>(),
        (unsigned long long)a["max_per_ray"].get<uint64_t>(), (unsigned long long)a["kept"].get<uint64_t>(),
        o.all_hits, (unsigned long long)a["rays_overflowed"].get<uint64_t>());
  }
  std::printf("per ray: %.2f nodes, %.2f box tests, %.2f primitive tests\n",
              stats.rays ? double(stats.nodes_visited) / double(stats.rays) : 0.0,
              stats.rays ? double(stats.box_tests) / double(stats.rays) : 0.0,
              stats.rays ? double(stats.prim_tests) / double(stats.rays) : 0.0);
  if (stats.any_hit_calls > 0)
    std::printf("any-hit: %llu candidate hits on alpha-tested triangles, %llu ignored\n",
                (unsigned long long)stats.any_hit_calls, (unsigned long long)stats.any_hit_ignored);
  if (stats.omm_opaque + stats.omm_transparent > 0)
    std::printf("micromaps: %llu candidate hits resolved in the unit (%llu opaque, %llu transparent)\n",
                (unsigned long long)(stats.omm_opaque + stats.omm_transparent),
                (unsigned long long)stats.omm_opaque, (unsigned long long)stats.omm_transparent);
  if (const hw::TimedEngine* te = run.device->timed()) {
    print_timing_summary(te->timing(), te->config(), te->format(), &te->sampling());
    pt.write(te->timeline());
  }

  Json json;
  if (!o.stats.empty() || !o.against.empty()) json = trace_stats_json(req, run, o.rays, o.dev.device, load_s);
  if (o.rtl_unit) json["rtl_unit"] = rtl_unit_run(*run.device->timed(), rays, o.any_hit, run.hits, cycles_only);
  if (!o.against.empty()) {
    // B: the same scene, rays and options but the configuration and format --against-* name.
    TraceRequest breq = req;
    breq.settings = against_settings(o.dev, o.against);
    breq.pipeline = nullptr;
    const TraceRun brun = host::run_trace(breq);
    const Json bjson = trace_stats_json(breq, brun, o.rays, o.dev.device, 0.0);
    // Cycles only (--sample without --out): the hit arrays hold no answers to compare.
    const std::span<const hw::Hit> ha = cycles_only ? std::span<const hw::Hit>() : run.hits,
                                   hb = cycles_only ? std::span<const hw::Hit>() : brun.hits;
    const Json ab = ab_json({settings_label(o.dev), &json, ha}, {settings_label(breq.settings), &bjson, hb});
    for (const std::string& line : ab_lines(ab)) std::printf("%s\n", line.c_str());
    json["against"] = bjson;
    json["ab"] = ab;
  }
  if (!o.stats.empty()) write_json(o.stats, json);
}

}  // namespace

void add_trace(CLI::App& app) {
  const auto [sub, o] = add_command<TraceOptions>(
      app, "trace", "Trace a ray file on a device and write the hit file", [](TraceOptions& o, CLI::App& sub) {
        check_device_args(sub, o.dev);
        if (!o.against.empty() && o.dev.kind() != hw::DeviceKind::kTimed)
          throw CLI::ValidationError(
              "--against-config, --against-set and --against-format compare two runs of the "
              "timed device (--device timed)");
        if (sub.count("--seed") > 0 && o.rays.rfind("incoherent", 0) != 0)
          throw CLI::ValidationError("--seed applies to --rays incoherent[:N] only");
        if (o.all_hits >= 0 && (o.any_hit || o.rtl_unit || !o.against.empty()))
          throw CLI::ValidationError("--all-hits is not with --any-hit, --rtl-unit or --against-*");
        if (o.rtl_unit && (o.dev.kind() != hw::DeviceKind::kTimed || o.dev.sample > 0.0))
          throw CLI::ValidationError(
              "--rtl-unit runs the timed device's packet on the RTL traversal unit: "
              "--device timed, without --sample");
        run_trace(o);
      });
  sub->add_option("--scene", o->scene, "scene file, mesh file, or builtin:NAME")->required();
  sub->add_option("--rays", o->rays, kRaySpecHelp)->required();
  sub->add_option("--seed", o->seed, "seed of generated incoherent rays")->capture_default_str();
  sub->add_option("--out", o->out,
                  "hit file to write (16-byte binary records, or .csv); without it only the statistics (with "
                  "--sample on the timed device, only the sampled rays are traced)");
  sub->add_flag("--any-hit", o->any_hit, "any-hit queries (stop at the first hit, as shadow rays do)");
  sub->add_option("--all-hits", o->all_hits,
                  "all-hit queries: every intersection in [tmin, tmax] counted, the first K a ray (in the unit's "
                  "order) kept; --out then writes hit lists (docs/file-formats.md); 0: counts only")
      ->check(CLI::Range(0, int(hw::cmd::kMaxAllHits)));
  add_omm_level_arg(*sub, o->omm_level, "hits are");
  sub->add_flag("--rtl-unit", o->rtl_unit,
                "timed device: also run the rays in one packet on the Verilated RTL traversal unit of the "
                "configuration (rtl_sim/trav/; builds with Verilator) and print its cycles beside the model's");
  sub->add_option("--threads", o->threads, "worker threads (0 = all cores); results do not depend on it")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->add_option("--packet-rays", o->packet_rays,
                  "rays a TRACE packet: the rays go to the device in packets of this many, each filling and "
                  "draining the timed device's ray slots (its cycles depend on it, the hits do not); a chip's "
                  "--sample thins only packets long enough (docs/timing-model.md)")
      ->check(CLI::Range(size_t(1), kMaxTracePacketRays))
      ->capture_default_str();
  sub->add_option("--stats", o->stats, "write statistics as JSON to this file");
  add_any_device_args(*sub, o->dev, o->pipeline);
  sub->add_option("--against-config", o->against.config,
                  "timed device, A/B: also trace with this timing preset (its own keys, without --set) and print "
                  "B against A: speed-up, rays per clock, limiter, area, energy, performance per mm^2, hits")
      ->check(CLI::IsMember(hw::timing_preset_names()));
  sub->add_option("--against-set", o->against.sets,
                  "timed device, A/B: a timing key of B, KEY=VALUE (repeatable; on --against-config's preset, or "
                  "else on A's configuration)");
  sub->add_option("--against-format", o->against.format, "timed device, A/B: B's format preset");
}

}  // namespace rtu::host::cli
