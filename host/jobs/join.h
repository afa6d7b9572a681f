// The spatial-join job behind `rtusim join` (docs/guide/queries.md, "Spatial joins"): segment intersection or
// point in polygon on the fixed unit, exact (hwmodel/datapath/spatial_join.h), and on the timed device the cycles
// of the probes (hwmodel/timing/query_timing.h).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "host/io/stats_json.h"
#include "hwmodel/datapath/spatial_join.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::host {

// Inputs from CSV files (a first line that is not numbers is a header) or generators, from `seed`:
// - segments: lines "x0,y0,x1,y1", or "random:N" (N segments of length up to 2 in [0, 100]^2);
// - polygons: lines "polygon,x,y", a polygon's vertices in order on consecutive lines with the same polygon
// number,
//   or "stars:N" (N star-shaped polygons of 3 to 12 vertices in [0, 100]^2);
// - points: lines "x,y", or "uniform:N" (N points in [0, 100]^2).
// Throw Error naming the file and line, or the spec.
std::vector<hw::Segment2> segments_from_spec(const std::string& spec, uint64_t seed);
std::vector<hw::Polygon2> polygons_from_spec(const std::string& spec, uint64_t seed);
std::vector<hw::Point2> points2_from_spec(const std::string& spec, uint64_t seed);

struct JoinJobOptions {
  bool polygons = false;  // point in polygon (polys, points); else segment intersection (a, b)
  std::vector<hw::Segment2> a, b;
  std::vector<hw::Polygon2> polys;
  std::vector<hw::Point2> points;
  hw::FixedFormat format;
  bool timed = false;
  hw::TimingConfig timing;
  int threads = 0;
};

struct JoinJobResult {
  std::vector<std::pair<uint32_t, uint32_t>> pairs;  // (a, b) or (point, polygon), sorted
  hw::QueryStats stats;
  uint64_t cycles = 0;  // timed only
  hw::TimingStats timing;
  uint64_t index_bytes = 0;
};

JoinJobResult run_join_job(const JoinJobOptions& o);
Json join_json(const JoinJobOptions& o, const JoinJobResult& r);
// The pairs as CSV: "a,b" or "point,polygon".
void write_pairs_csv(const std::string& path, const JoinJobOptions& o, const JoinJobResult& r);

}  // namespace rtu::host
