#include "hwmodel/timing/query_timing.h"

#include <algorithm>

#include "hwmodel/format/node_kinds.h"

namespace rtu::hw {

TimingModel::Layout query_layout(const PointIndex& index, const FixedFormat& f) {
  TimingModel::Layout l;
  l.node_bytes = node_struct_bytes(NodeKindId::kQuantizedAabb, index.width(), f.offset_bytes());
  l.node_offset = 0;
  l.record_offset = l.plane_offset = l.total_bytes = (index.inner_nodes() + index.leaves()) * l.node_bytes;
  return l;
}

QueryTiming time_point_queries(const PointIndex& index, const FixedFormat& f, const std::vector<Vec3>& qs,
                               const PointQuery& what, const TimingConfig& c) {
  TimingModel model(c, query_layout(index, f));
  QueryTiming out;
  out.answers.resize(qs.size());
  constexpr size_t kChunk = 4096;
  std::vector<std::vector<TraceEvent>> events(kChunk);
  model.begin(qs.size(), out.timing);
  for (size_t first = 0; first < qs.size(); first += kChunk) {
    const size_t m = std::min(kChunk, qs.size() - first);
    for (size_t i = 0; i < m; ++i) {
      events[i].clear();
      out.answers[first + i] = index.query(qs[first + i], what, out.queries, &events[i]);
    }
    model.feed(events.data(), m);
  }
  out.cycles = model.finish();
  return out;
}

}  // namespace rtu::hw
