// rtusim query: fixed-radius neighbours, counts or k nearest of query points among data points, on the fixed unit
// (exact answers) or the timed one (and cycles) (host/jobs/query.h).
#include <cstdio>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/jobs/query.h"

namespace rtu::host::cli {

namespace {

struct QueryArgs {
  DeviceArgs dev;
  std::string points, queries, kind = "radius", out, json;
  float radius = 0.0f;
  uint32_t k = 0, max_results = 64;
  uint64_t seed = 1;
  int threads = 0;
  std::string order = "input";
};

void run_query(const CLI::App& sub, const QueryArgs& a) {
  if (a.dev.device == "float") throw CLI::ValidationError("--device: queries run on the fixed or timed unit");
  if (a.kind == "nearest" && a.k == 0) throw CLI::ValidationError("--kind nearest needs --k K (K >= 1)");
  if (a.kind != "nearest" && sub.count("--k") > 0)
    throw CLI::ValidationError("--k applies to --kind nearest only");
  if (a.kind != "radius" && sub.count("--max-results") > 0)
    throw CLI::ValidationError("--max-results applies to --kind radius only");
  QueryJobOptions o;
  o.points = points_from_spec(a.points, a.seed);
  if (!a.queries.empty()) o.queries = points_from_spec(a.queries, a.seed + 1);
  o.radius = a.radius;
  o.what.kind = a.kind == "radius"  ? hw::PointQuery::kRadius
                : a.kind == "count" ? hw::PointQuery::kCount
                                    : hw::PointQuery::kNearest;
  o.what.max_results = a.kind == "nearest" ? a.k : a.max_results;
  o.format = a.dev.fixed_format();
  o.timed = a.dev.device == "timed";
  if (o.timed) o.timing = timing_config_from(a.dev.config, a.dev.sets);
  o.threads = a.threads;
  o.morton_order = a.order == "morton";
  check_output_files({a.out, a.json});
  const QueryJobResult r = run_query_job(o);
  const double q = double(std::max<uint64_t>(1, r.stats.queries));
  std::printf("points       %zu, radius %g, %s on the %s unit (%s)\n", o.points.size(), double(o.radius),
              a.kind.c_str(), a.dev.device.c_str(), o.format.describe().c_str());
  std::printf(
      "queries      %llu: %llu results (%.2f a query), %llu candidates checked in the shader, %llu over "
      "the bound\n",
      (unsigned long long)r.stats.queries, (unsigned long long)r.stats.results, double(r.stats.results) / q,
      (unsigned long long)r.stats.candidates, (unsigned long long)r.stats.overflows);
  std::printf("traversal    %.2f nodes and leaf blocks, %.2f box tests a query; index %llu bytes\n",
              double(r.stats.nodes_visited) / q, double(r.stats.box_tests) / q, (unsigned long long)r.index_bytes);
  if (o.timed)
    std::printf("cycles       %llu: %.1f a query, %.4f queries a clock (%s)\n", (unsigned long long)r.cycles,
                double(r.cycles) / q, q / double(std::max<uint64_t>(1, r.cycles)), a.dev.config.c_str());
  if (!a.out.empty()) write_answers_csv(a.out, o, r);
  if (!a.json.empty()) {
    Json j = query_json(o, r);
    if (o.timed) j["config"] = a.dev.config;
    write_json(a.json, j);
  }
}

}  // namespace

void add_query(CLI::App& app) {
  const auto [sub, a] = add_command<QueryArgs>(
      app, "query",
      "Neighbour queries on the unit: every data point within a radius of each query point (exact), their "
      "count, or the k nearest; cycles on the timed device",
      [](QueryArgs& a, CLI::App& sub) { run_query(sub, a); });
  sub->add_option("--points", a->points, "data points: a .ply or .csv file, or uniform:N or clustered:N")
      ->required();
  sub->add_option("--queries", a->queries, "query points, as --points (default: the data points)");
  sub->add_option("--radius", a->radius, "the search radius (> 0)")
      ->required()
      ->check(CLI::Range(1e-30f, 4.6e18f));
  sub->add_option("--kind", a->kind,
                  "radius (the neighbours), count, or nearest (the k nearest within the radius)")
      ->check(CLI::IsMember({"radius", "count", "nearest"}))
      ->capture_default_str();
  sub->add_option("--k", a->k, "nearest: how many")->check(CLI::Range(1u, 1u << 16));
  sub->add_option("--max-results", a->max_results, "radius: the output bound a query (more: counted, flagged)")
      ->check(CLI::Range(1u, 1u << 24))
      ->capture_default_str();
  sub->add_option("--device", a->dev.device, "fixed (answers) or timed (and cycles)")
      ->check(CLI::IsMember({"fixed", "timed"}))
      ->capture_default_str();
  a->dev.device = "fixed";
  add_format_args(*sub, a->dev);
  add_timing_args(*sub, a->dev);
  sub->add_option("--seed", a->seed, "seed of uniform: and clustered: points")->capture_default_str();
  sub->add_option("--threads", a->threads, "host threads of the fixed unit (0: all); answers do not depend on it")
      ->check(CLI::Range(0, 1024))
      ->capture_default_str();
  sub->add_option("--order", a->order,
                  "the order the unit takes the queries in: input, or morton (RTNN's reordering: by the Morton "
                  "code of their positions, so neighbours share the node cache); answers stay in input order")
      ->check(CLI::IsMember({"input", "morton"}))
      ->capture_default_str();
  sub->add_option("--out", a->out, "write the answers as CSV (query,id or query,count)");
  sub->add_option("--json", a->json, "write the figures as JSON");
}

}  // namespace rtu::host::cli
