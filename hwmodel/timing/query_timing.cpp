#include "hwmodel/timing/query_timing.h"

#include <algorithm>

#include "hwmodel/format/node_kinds.h"

namespace rtu::hw {

TimingModel::Layout box_index_layout(const BoxIndex& index, const FixedFormat& f) {
  TimingModel::Layout l;
  l.node_bytes = node_struct_bytes(NodeKindId::kQuantizedAabb, index.width(), f.offset_bytes());
  l.node_offset = 0;
  l.record_offset = l.plane_offset = l.total_bytes = (index.inner_nodes() + index.leaves()) * l.node_bytes;
  return l;
}

ProbeTiming time_probes(const BoxIndex& index, const FixedFormat& f, size_t n,
                        const std::function<void(size_t, QueryStats&, std::vector<TraceEvent>*)>& probe,
                        const TimingConfig& c) {
  TimingModel model(c, box_index_layout(index, f));
  ProbeTiming out;
  constexpr size_t kChunk = 4096;
  std::vector<std::vector<TraceEvent>> events(kChunk);
  model.begin(n, out.timing);
  for (size_t first = 0; first < n; first += kChunk) {
    const size_t m = std::min(kChunk, n - first);
    for (size_t i = 0; i < m; ++i) {
      events[i].clear();
      probe(first + i, out.queries, &events[i]);
    }
    model.feed(events.data(), m);
  }
  out.cycles = model.finish();
  return out;
}

QueryTiming time_point_queries(const PointIndex& index, const FixedFormat& f, const std::vector<Vec3>& qs,
                               const PointQuery& what, const TimingConfig& c) {
  QueryTiming out;
  out.answers.resize(qs.size());
  ProbeTiming t = time_probes(
      index.index(), f, qs.size(),
      [&](size_t i, QueryStats& s, std::vector<TraceEvent>* rec) {
        out.answers[i] = index.query(qs[i], what, s, rec);
      },
      c);
  out.cycles = t.cycles;
  out.timing = t.timing;
  out.queries = t.queries;
  return out;
}

}  // namespace rtu::hw
