// The cycles of neighbour queries (datapath/point_query.h) and joins on one unit or a chip: each query's events
// replayed in the timing model (timing_model.h) as a ray's are. The index is laid out as nodes: its inner nodes,
// then one block per leaf holding the leaf's point boxes as a node holds its children's, each the format's node
// bytes (leaves hold at most width points); a candidate's distance check is a round trip to the shader (kAnyHit,
// any_hit_latency), as RTNN's intersection program.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "hwmodel/datapath/box_index.h"
#include "hwmodel/datapath/point_query.h"
#include "hwmodel/timing/timing_model.h"

namespace rtu::hw {

// A box index (datapath/box_index.h) laid out as nodes: its inner nodes, then its leaf blocks, each the format's
// node bytes.
TimingModel::Layout box_index_layout(const BoxIndex& index, const FixedFormat& f);
inline TimingModel::Layout query_layout(const PointIndex& index, const FixedFormat& f) {
  return box_index_layout(index.index(), f);
}

// n probes of a box index on one unit: probe(i, stats, events) runs probe i, adding its statistics and recording
// its events (the index's, and a kAnyHit for each candidate's exact check in the shader); the events are replayed
// in the timing model in chunks. On a chip (c.units > 1) the probes go to the units by ray_policy (dynamic taken
// as waves) and the units replay them in step over their shared memory.
struct ProbeTiming {
  uint64_t cycles = 0;
  TimingStats timing;
  QueryStats queries;
};
ProbeTiming time_probes(const BoxIndex& index, const FixedFormat& f, size_t n,
                        const std::function<void(size_t, QueryStats&, std::vector<TraceEvent>*)>& probe,
                        const TimingConfig& c);

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
