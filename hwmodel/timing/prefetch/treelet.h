// Treelet prefetching (Chou, Nowicki and Aamodt, "Treelet Prefetching for Ray Tracing", MICRO 2023): when a ray
// fetches the root of a treelet (treelets.h: the layout places each treelet's nodes contiguously), the treelet's
// other lines are filled, so the nodes the ray visits next in that treelet are on their way.
// Modelled: the trigger (any fetch of a treelet root, hit or miss: a hardware prefetcher sees the visit), the
// fill of every line of the treelet not already held (filtered by the cache's tags: counted prefetch_redundant).
// Left out: the paper's two-stack, treelet-based traversal order (per its abstract: a ray finishes the treelet it
// is in before it leaves it, so a prefetched treelet is used before it is evicted; here traversal stays
// depth-first, nearest child first). Fills go to memory at the trigger's cycle, or wait for an idle memory with
// prefetch_queue > 0.
#pragma once

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/timing/prefetch/fetch_observer.h"

namespace rtu::hw {

class TreeletPrefetcher final : public FetchObserver {
 public:
  TreeletPrefetcher(const TimingConfig&, const FetchContext& ctx) : m_ctx(ctx) {}
  void on_fetch(const LineFetch& f, LinePort& port) override {
    const Treelets* t = m_ctx.treelets;
    if (!t || f.kind != TraceEvent::kNode || f.index >= t->size.size() || t->size[f.index] == 0) return;
    const uint64_t first = m_ctx.node_offset + uint64_t(t->position[f.index]) * m_ctx.node_stride;
    const uint64_t end = first + uint64_t(t->size[f.index] - 1) * m_ctx.node_stride + m_ctx.node_bytes;
    for (uint64_t line = first / m_ctx.line_bytes; line <= (end - 1) / m_ctx.line_bytes; ++line)
      if (line < f.first_line || line > f.last_line) port.fill(line);
  }

 private:
  FetchContext m_ctx;
};

}  // namespace rtu::hw
