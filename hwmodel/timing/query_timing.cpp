#include "hwmodel/timing/query_timing.h"

#include <algorithm>
#include <memory>

#include "hwmodel/format/node_kinds.h"
#include "hwmodel/timing/ray_scheduler.h"

namespace rtu::hw {

TimingModel::Layout box_index_layout(const BoxIndex& index, const FixedFormat& f) {
  TimingModel::Layout l;
  l.node_bytes = node_struct_bytes(NodeKindId::kQuantizedAabb, index.width(), f.offset_bytes());
  l.node_offset = 0;
  l.record_offset = l.plane_offset = l.total_bytes = (index.inner_nodes() + index.leaves()) * l.node_bytes;
  return l;
}

namespace {

// A chip (c.units > 1): the probes go to the units by c.ray_policy, as rays do; each unit's probes are recorded
// first, then the units replay them in step over their shared memory (run_units_in_step). The events of every
// probe are held at once: bench-sized sets (hundreds of thousands of probes).
ProbeTiming time_probes_chip(const BoxIndex& index, const FixedFormat& f, size_t n,
                             const std::function<void(size_t, QueryStats&, std::vector<TraceEvent>*)>& probe,
                             const TimingConfig& c) {
  const size_t U = size_t(c.units);
  std::vector<std::vector<std::vector<TraceEvent>>> events(U);
  ProbeTiming out;
  for (size_t i = 0; i < n; ++i) {
    std::vector<TraceEvent> ev;
    probe(i, out.queries, &ev);
    events[ray_unit(c.ray_policy, i, n, U, size_t(c.ray_slots))].push_back(std::move(ev));
  }
  const TimingModel::Layout layout = box_index_layout(index, f);
  MemorySystem mem(c);
  std::vector<std::unique_ptr<TimingModel>> units;
  std::vector<TimingStats> stats(U);
  std::vector<TimingModel*> ptrs;
  std::vector<size_t> given(U, 0);
  for (uint32_t u = 0; u < U; ++u) {
    units.push_back(std::make_unique<TimingModel>(c, layout, &mem, u));
    units.back()->begin(events[u].size(), stats[u]);
    ptrs.push_back(units.back().get());
  }
  const size_t chunk = std::max<size_t>(256, 2 * size_t(c.ray_slots));
  out.cycles = run_units_in_step(ptrs, 0, [&](size_t u) {
    const size_t m = std::min(chunk, events[u].size() - given[u]);
    units[u]->add_rays(events[u].data() + given[u], m);
    given[u] += m;
  });
  for (const TimingStats& s : stats) out.timing.add(s);
  return out;
}

}  // namespace

ProbeTiming time_probes(const BoxIndex& index, const FixedFormat& f, size_t n,
                        const std::function<void(size_t, QueryStats&, std::vector<TraceEvent>*)>& probe,
                        const TimingConfig& c) {
  if (c.units > 1) return time_probes_chip(index, f, n, probe, c);
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
