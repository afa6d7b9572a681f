// rtusim join: a spatial join on the unit, exact: segment intersection (--segments, --probes) or point in polygon
// (--polygons, --points); cycles on the timed device (host/jobs/join.h).
#include <cstdio>

#include "host/cli/common.h"
#include "host/io/files.h"
#include "host/jobs/join.h"

namespace rtu::host::cli {

namespace {

struct JoinArgs {
  DeviceArgs dev;
  std::string segments, probes, polygons, points, out, json;
  uint64_t seed = 1;
  int threads = 0;
};

void run_join(const JoinArgs& a) {
  const bool seg = !a.segments.empty() || !a.probes.empty(), poly = !a.polygons.empty() || !a.points.empty();
  if (seg == poly)
    throw CLI::ValidationError(
        "give --segments and --probes (segment intersection) or --polygons and --points "
        "(point in polygon)");
  if (seg && (a.segments.empty() || a.probes.empty()))
    throw CLI::ValidationError("segment intersection needs both --segments and --probes");
  if (poly && (a.polygons.empty() || a.points.empty()))
    throw CLI::ValidationError("point in polygon needs both --polygons and --points");
  JoinJobOptions o;
  o.polygons = poly;
  if (seg) {
    o.a = segments_from_spec(a.segments, a.seed);
    o.b = segments_from_spec(a.probes, a.seed + 1);
  } else {
    o.polys = polygons_from_spec(a.polygons, a.seed);
    o.points = points2_from_spec(a.points, a.seed + 1);
  }
  o.format = a.dev.fixed_format();
  o.timed = a.dev.device == "timed";
  if (o.timed) o.timing = timing_config_from(a.dev.config, a.dev.sets);
  o.threads = a.threads;
  check_output_files({a.out, a.json});
  const JoinJobResult r = run_join_job(o);
  const double q = double(std::max<uint64_t>(1, r.stats.queries));
  if (seg)
    std::printf("join         segment intersection: %zu segments, %zu probes on the %s unit (%s)\n", o.a.size(),
                o.b.size(), a.dev.device.c_str(), o.format.describe().c_str());
  else
    std::printf("join         point in polygon: %zu polygons, %zu points on the %s unit (%s)\n", o.polys.size(),
                o.points.size(), a.dev.device.c_str(), o.format.describe().c_str());
  std::printf("pairs        %zu (exact); %llu candidates decided exactly, %.2f a probe; %.2f nodes a probe\n",
              r.pairs.size(), (unsigned long long)r.stats.candidates, double(r.stats.candidates) / q,
              double(r.stats.nodes_visited) / q);
  if (o.timed)
    std::printf("cycles       %llu: %.1f a probe, %.4f probes a clock (%s)\n", (unsigned long long)r.cycles,
                double(r.cycles) / q, q / double(std::max<uint64_t>(1, r.cycles)), a.dev.config.c_str());
  if (!a.out.empty()) write_pairs_csv(a.out, o, r);
  if (!a.json.empty()) {
    Json j = join_json(o, r);
    if (o.timed) j["config"] = a.dev.config;
    write_json(a.json, j);
  }
}

}  // namespace

void add_join(CLI::App& app) {
  const auto [sub, a] = add_command<JoinArgs>(
      app, "join",
      "A spatial join on the unit, exact: every pair of meeting segments, or the polygons that hold each point; "
      "cycles on the timed device",
      [](JoinArgs& a, CLI::App&) { run_join(a); });
  sub->add_option("--segments", a->segments, "the indexed segments: a CSV of x0,y0,x1,y1, or random:N");
  sub->add_option("--probes", a->probes, "the probe segments, as --segments");
  sub->add_option("--polygons", a->polygons, "the polygons: a CSV of polygon,x,y (vertices in order), or stars:N");
  sub->add_option("--points", a->points, "the points: a CSV of x,y, or uniform:N");
  sub->add_option("--device", a->dev.device, "fixed (pairs) or timed (and cycles)")
      ->check(CLI::IsMember({"fixed", "timed"}))
      ->capture_default_str();
  a->dev.device = "fixed";
  add_format_args(*sub, a->dev);
  add_timing_args(*sub, a->dev);
  sub->add_option("--seed", a->seed, "seed of the generators")->capture_default_str();
  sub->add_option("--threads", a->threads, "host threads of the fixed unit (0: all); pairs do not depend on it")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  sub->add_option("--out", a->out, "write the pairs as CSV (a,b or point,polygon)");
  sub->add_option("--json", a->json, "write the figures as JSON");
}

}  // namespace rtu::host::cli
