// The neighbour-query job behind `rtusim query` and `rtu.query` (docs/guide/queries.md): points and queries from
// files or generators, fixed-radius neighbours, counts or k nearest on the fixed unit (hwmodel/datapath/
// point_query.h), exact whatever the format, and on the timed device the cycles (hwmodel/timing/query_timing.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "host/io/stats_json.h"
#include "hwmodel/datapath/point_query.h"
#include "hwmodel/timing/query_timing.h"

namespace rtu::host {

// Points from a spec: a .ply or .csv file (read_points), or "uniform:N" (N points uniform in the cube [0, 100]^3)
// or "clustered:N" (N points in 16 clusters of random sizes in that cube), from `seed`. Throws Error.
std::vector<hw::Vec3> points_from_spec(const std::string& spec, uint64_t seed);

struct QueryJobOptions {
  std::vector<hw::Vec3> points, queries;  // queries empty: the points themselves
  float radius = 1.0f;
  hw::PointQuery what;
  hw::FixedFormat format;
  bool timed = false;  // also the cycles on one unit of `timing`
  // RTNN's query reordering: the queries issued in the Morton order of their positions (10 bits an axis in their
  // bounds; ties by index), so that neighbouring queries share the node cache; answers stay in input order.
  bool morton_order = false;
  hw::TimingConfig timing;
  int threads = 0;
};

struct QueryJobResult {
  std::vector<hw::PointAnswer> answers;
  hw::QueryStats stats;
  uint64_t cycles = 0;  // timed only
  hw::TimingStats timing;
  uint64_t index_bytes = 0;
};

QueryJobResult run_query_job(const QueryJobOptions& o);
// The order in which morton_order issues the queries: indices into qs.
std::vector<uint32_t> morton_query_order(const std::vector<hw::Vec3>& qs);
// The figures of probes on the timed unit into j: cycles, cycles a probe (per_key), probes a clock (rate_key),
// shader_calls (each candidate's exact check), dram_bytes, and "timing": the timing statistics of configuration c
// and format f as `rtusim trace --stats` gives them (slot time, caches, L2, DRAM, energy).
void probe_timing_json(Json& j, const char* per_key, const char* rate_key, uint64_t probes, uint64_t cycles,
                       const hw::TimingStats& t, const hw::TimingConfig& c, const hw::FixedFormat& f);
Json query_json(const QueryJobOptions& o, const QueryJobResult& r);
// The answers as CSV: "query,id" a neighbour a line (kNearest nearest first), or "query,count".
void write_answers_csv(const std::string& path, const QueryJobOptions& o, const QueryJobResult& r);

}  // namespace rtu::host
