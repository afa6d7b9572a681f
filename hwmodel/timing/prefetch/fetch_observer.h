// The seam at the one place the timed unit fetches node, primitive record and plane lines (TimingModel's fetch of
// a slot's event): a fetch observer sees each fetch as it is made and may fill lines into the node cache through
// a LinePort. A prefetcher is such an observer. Off by default (prefetcher = none): no observer, today's cycles.
//
// The rules an observer keeps, so that the timing model's arguments stay true (timing_model.h):
// - it fills at the fetch's cycle only (the port has no other cycle): memory requests stay in the order of their
//   cycles, and a unit on a chip may still run ahead of the others (with an observer every fetch counts as
//   touching the shared memory, so run-ahead stops before each);
// - a fill is not a demand access: it counts neither a hit nor a miss, it brings the line in as the most recent
//   of its set, and the cache counts it (prefetch_fills, prefetch_redundant; a demand hit on a line a fill brought
//   that no demand has touched yet counts prefetch_useful);
// - it never changes what is fetched, only when data is there: hits stay the datapath's.
// Sampled timing warms the cache with the demand lines only (node_cache.h): with a prefetcher its estimate is of
// a unit whose warm cache holds no prefetched lines.
//
// To add a prefetcher: a class derived from FetchObserver in its own file here (next_line.h is the smallest),
// and one line in prefetchers.h's table with its name and description; its keys go into timing_config.h.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hwmodel/timing/prefetch/treelets.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

// One fetch of a ray slot: what it fetched and the lines it touched.
struct LineFetch {
  uint64_t cycle;                  // when the fetch is made (the port fills at this cycle)
  uint32_t slot;                   // the ray slot
  uint8_t kind;                    // TraceEvent::Kind: kNode, kPrim or kPlane
  uint32_t index;                  // the node, record or plane index in the image it addresses
  uint64_t first_line, last_line;  // the lines the fetch touched (line = byte address / line_bytes)
  bool missed;                     // whether any of them missed in the node cache
};

// What an observer may do to the node cache, at the fetch's cycle.
class LinePort {
 public:
  virtual ~LinePort() = default;
  virtual void fill(uint64_t line) = 0;         // brings the line in unless it is there or on its way
  virtual bool holds(uint64_t line) const = 0;  // whether it is there or on its way
};

// A node a ray pushed on its traversal stack (only for a prefetcher that asks for them,
// PrefetcherInfo::stack_refs): seen at the cycle of the push, after the node test whose result it is.
struct StackPush {
  uint64_t cycle;
  uint32_t slot;
  uint32_t rank;                   // in pop order: 0 is popped first
  uint64_t first_line, last_line;  // the node's lines, or the leaf's records'
  uint32_t index;                  // the node, or the leaf's first record
  bool leaf = false;               // a leaf (PrefetcherInfo::leaf_refs)
};

class FetchObserver {
 public:
  virtual ~FetchObserver() = default;
  virtual void on_fetch(const LineFetch& f, LinePort& port) = 0;
  virtual void on_push(const StackPush&, LinePort&) {}
  virtual void on_ray(uint32_t /*slot*/) {}  // a new ray entered the slot
};

// What an observer may know of the unit's layout when it is made: where the nodes lie, and the treelets when the
// layout has them (treelet_bytes > 0, treelets.h). One level only: a two-level scene has no treelets.
struct FetchContext {
  uint64_t node_offset = 0, node_stride = 0, node_bytes = 0;  // node i at node_offset + position * node_stride
  uint64_t line_bytes = 64;
  const Treelets* treelets = nullptr;  // null: node i at position i
};

// A prefetcher a configuration may name (prefetcher = name): the table is prefetchers.h.
struct PrefetcherInfo {
  const char* name;
  const char* description;
  std::unique_ptr<FetchObserver> (*make)(const TimingConfig& c, const FetchContext& ctx);  // null for "none"
  bool stack_refs = false;  // the tracer records the nodes rays push (on_push), which costs trace bytes
  bool leaf_refs = false;   // with stack_refs: the leaves they push too
};

}  // namespace rtu::hw
