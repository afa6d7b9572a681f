// The cycles of neighbour queries (datapath/point_query.h) on one unit: each query's events replayed in the timing
// model (timing_model.h) as a ray's are. The index is laid out as nodes: its inner nodes, then one block per leaf
// holding the leaf's point boxes as a node holds its children's, each the format's node bytes (leaves hold at most
// width points); a candidate's distance check is a round trip to the shader (kAnyHit, any_hit_latency), as RTNN's
// intersection program.
#pragma once

#include <cstdint>
#include <vector>

#include "hwmodel/datapath/point_query.h"
#include "hwmodel/timing/timing_model.h"

namespace rtu::hw {

TimingModel::Layout query_layout(const PointIndex& index, const FixedFormat& f);

struct QueryTiming {
  uint64_t cycles = 0;
  TimingStats timing;
  QueryStats queries;
  std::vector<PointAnswer> answers;
};
// Runs the queries on one unit of configuration c; the answers are the datapath's (timing never changes one).
QueryTiming time_point_queries(const PointIndex& index, const FixedFormat& f, const std::vector<Vec3>& qs,
                               const PointQuery& what, const TimingConfig& c);

}  // namespace rtu::hw
