// The timed device's timing model: the events of each ray (what the fixed datapath did, in order: node fetch and
// box tests, record fetch and primitive test, plane tests, stack pushes and pops; fixed_tracer.h) are replayed in
// a ray slot of a cycle-approximate model of the unit, configured by TimingConfig. Components, what they model
// and the keys that set them (docs/timing-model.md has the full reference):
// - command processor: packet decode (packet_latency per packet); a FENCE completes fence_latency after the
//   previous packet, and its interrupt (with kFenceIrq) reaches the host irq_latency after that (the device
//   does not wait for it; DeviceCounters::last_irq_cycle); TRACE packets run one after another (no overlap
//   between packets).
// - ray fetch: rays stream from the ray buffer at one per clock with ray_fetch_latency, at most queue_depth rays
//   ahead of the slots (a bounded prefetch queue); ray setup issues one ray per clock, setup_latency deep. With
//   gathering (gather key, ray_gather.h) the rays wait in a gather buffer instead, binned by a key, and slots
//   take the rays of issued bins. Both are admissions (ray_admission.h), the seam of an in-unit ray scheduler.
// - ray slots: ray_slots rays in flight; a free slot takes the next ray (in order; lowest free slot first). Each
//   slot has a stack of stack_entries; deeper pushes spill 8 bytes to memory (bandwidth only) and pops of spilled
//   entries wait for a memory read (latency and bandwidth): through the L2 when there is one (l2_cache.h), else
//   to DRAM.
// - memory: node, record and plane fetches go through the node cache (node_cache.h) into the memory behind it
//   (memory_system.h: the DRAM channel of dram_channel.h, or an L2 and banked DRAM, shared by a chip's units). The
//   image is taken to start at a line boundary. Ray and hit buffers stream through their own port: counted
//   (stream_bytes), not in the DRAM channel. A fetch observer (prefetch/fetch_observer.h; prefetcher key, none by
//   default) sees each fetch and may fill lines into the node cache at the fetch's cycle.
// - units: box_units box units, box_rate box tests per clock each: a node of c children issues for
//   ceil(c / box_rate) clocks (at least one), its result comes box_latency after the first; or, with an RTL box
//   unit attached, the clocks that unit reported for the node (box_unit.h). tri_units triangle units of tri_rate
//   tests per clock (tri_units * tri_rate issue slots, one test per clock each; spheres and planes use the same
//   slots with their own latency). A request waits for the earliest free unit (first come, first served); waits
//   longer than queue_depth clocks count as queue stalls.
// - cluster engine (cluster_tri_rate > 0; triangle clusters, format/cluster_layout.h): a cluster is fetched whole
//   when a ray enters it (its root node), as a block is; its internal nodes are tested in the engine's box stage
//   (box_rate per clock, box_latency deep, one node at a time) and each of its leaves' triangles as one request
//   of ceil(triangles / cluster_tri_rate) issue clocks, tri_latency deep (the triangles the datapath tested: an
//   any-hit ray's leaf ends at its hit). Off: the box and triangle units test clusters as any nodes and triangles.
// - scheduler: traversal_latency from a unit result to the slot's next request; hit write-back one per clock,
//   writeback_latency deep; a slot is free again the clock after its hit is issued to write-back.
// - watchdog: a ray that stays in its slot more than watchdog_cycles stops the packet with a WatchdogError
//   (engine.h) whose text dumps the unit at that cycle: the ray, every busy slot (ray, entry cycle, events done,
//   stack entries spilled, what it waits for), the prefetch queue, the units' and DRAM's queued work, cache
//   figures.
// Every request is served in the order of its cycle (ties by slot number), so the result does not depend on the
// order in which the code evaluates components, and time jumps from event to event (idle cycles are skipped).
// Left out: overlap of consecutive TRACE packets, DRAM refresh, spills into the node cache (it holds nodes and
// records only).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/instanced_fixed.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/timing/memory/deferred_memory.h"
#include "hwmodel/timing/memory/memory_system.h"
#include "hwmodel/timing/memory/node_cache.h"
#include "hwmodel/timing/memory/port_limit.h"
#include "hwmodel/timing/node_cost.h"
#include "hwmodel/timing/prefetch/prefetchers.h"
#include "hwmodel/timing/ray_admission.h"
#include "hwmodel/timing/slot_queue.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

inline constexpr uint64_t kRayBytesStream = 32;  // a ray read from the ray buffer
inline constexpr uint64_t kHitBytesStream = 16;  // a hit written to the hit buffer

// Spans of pipeline activity in a window of cycles, for a Chrome/Perfetto trace (one track per ray slot).
struct PipelineTrace {
  struct Span {
    uint32_t unit;  // the unit's index on a chip (0 for one unit)
    uint32_t slot;
    const char* what;  // "setup", "node fetch", "box", "record fetch", "triangle", "sphere", "plane",
                       // "stack refill", "write-back"
    uint64_t start, end;
  };
  uint64_t from = 0, to = 0;  // window [from, to) in device cycles since bind
  size_t max_spans = 1000000;
  std::vector<Span> spans;
  void add(uint32_t unit, uint32_t slot, const char* what, uint64_t start, uint64_t end) {
    if (end > from && start < to && spans.size() < max_spans) spans.push_back(Span{unit, slot, what, start, end});
  }
};

// The micromap cache's configuration: c's node cache with omm_cache_kib KiB and no prefetch buffer.
TimingConfig omm_cache_config(const TimingConfig& c);

class TimingModel final : private PendingWaiter {
 public:
  // Where unit `unit` of a chip of `slots`-slot units spills its stacks: after `footprint` bytes of image (the
  // layout's total_bytes), kStackRegion bytes a slot (stack_addr). Shared with the RTL unit's testbench.
  static constexpr uint64_t kStackRegion = 4096;
  static uint64_t stack_base(uint64_t footprint, uint32_t unit, int slots) {
    return (footprint + kStackRegion - 1) / kStackRegion * kStackRegion +
           uint64_t(unit) * uint64_t(slots) * kStackRegion;
  }
  // Where the bound image keeps its sections (addresses are image offsets).
  // Where the fetched items lie: byte offsets of the sections and bytes from one item to the next. Each fetch
  // touches the lines of [offset + index * stride, + the item's size).
  struct Layout {
    uint64_t node_offset = 0, node_bytes = 56, record_offset = 0, plane_offset = 0;
    uint64_t node_stride = 0, record_stride = 0, plane_stride = 0;  // 0: the item's size (packed)
    uint64_t total_bytes = 0;  // the footprint of the sections so placed, from offset 0
    NodeCostClass node_cost = NodeCostClass::kAxisAligned;  // how the node kind's test is priced (node_cost.h)
    // Treelets (treelet_bytes > 0, prefetch/treelets.h): node i lies at node_offset + position[i] * node_stride.
    // Null: at i * node_stride. One level only.
    std::shared_ptr<const Treelets> treelets;
    // Primitive blocks (DeviceImage::record_spans): record i is fetched as the bytes of its span, which are the
    // whole block for a block's first record and none for the others. Empty: 40-byte records at the stride.
    std::vector<DeviceImage::Span> record_spans;
    // Triangle clusters (DeviceImage::cluster_node_spans): node cluster_node_begin + j is fetched as the bytes of
    // cluster_node_spans[j], the whole cluster for its root and none for its other nodes; cluster_record_flags
    // says which records a cluster holds and which start a leaf (the cluster engine's requests). Empty: none.
    uint64_t cluster_node_begin = 0;
    std::vector<DeviceImage::Span> cluster_node_spans;
    std::vector<uint8_t> cluster_record_flags;
    // Two levels (instanced_fixed.h), in the top level: an instance record is fetched with its stored transform
    // and bottom-level address, instance_bytes at record_offset + index * record_stride; bottoms[m] places mesh
    // m's image after the top level's sections (total_bytes then covers them all). Empty: one level.
    uint64_t instance_bytes = 0;
    std::vector<Layout> bottoms;
    // Opacity micromaps (one level, TimedEngine::set_micromaps): their states' section (MicromapSet::state_byte)
    // starts here, after the image's sections (total_bytes then covers it). A kOmm event fetches its state's line.
    uint64_t micromap_offset = 0;
  };
  // The image's own layout (packed), or with `align` > 0 every item padded to a multiple of it and every section
  // start aligned to it (TimingConfig::layout_align).
  static Layout layout_of(const DeviceImage& image, uint64_t align);
  // Both levels of a two-level scene: the top image, its instance records widened by their stored transforms
  // (or `instance_bytes` each, when > 0: TimingConfig::instance_bytes), then each mesh's image, every image
  // starting on a 64-byte boundary (or `align`, when larger).
  static Layout layout_of(const InstancedFixedTracer& t, uint64_t align, uint64_t instance_bytes = 0);
  // Places every mesh's image of t after `end` as layout_of(t, ...) does: bottoms and total_bytes of `top`.
  static void append_bottoms(Layout& top, const InstancedFixedTracer& t, uint64_t end, uint64_t align);
  // `shared`: the memory behind the node cache when several units share it (a chip: TimedEngine with units > 1,
  // timed_engine.h); null: the unit's own. `unit`: the unit's index on the chip (where its slots' stacks spill).
  TimingModel(const TimingConfig& c, const Layout& layout, MemorySystem* shared = nullptr, uint32_t unit = 0);
  // Bytes a unit of configuration c holds whatever its rays: its node cache (with `walk`, the backward walk's
  // scratch too: NodeCache::state_bytes), its slots, queues and gather buffer. Not the memory behind the cache
  // (MemorySystem::state_bytes), not the events of the rays in its slots, which depend on the scene.
  static uint64_t state_bytes(const TimingConfig& c, bool walk);

  // One TRACE packet of n rays: begin, then feed the rays' events in order (any number at a time; an empty list
  // is a ray rejected at setup), then finish, which returns the packet's cycles from its decode to the last hit
  // written. Memory stays bounded: a slot takes its ray's event list when it takes the ray, by swapping it with
  // the list of the slot's previous ray, so a fed list comes back with unspecified contents and its capacity for
  // the caller to record into again. The cache keeps its contents from packet to packet.
  void begin(size_t n, TimingStats& s);
  // Records pipeline spans into `trace` (null: none).
  void set_trace(PipelineTrace* trace) { m_trace = trace; }
  void feed(std::vector<TraceEvent>* events, size_t m);
  uint64_t finish();
  // A chip's units run in step (TimedEngine::run_chip, timed_engine_chip.cpp): begin() as above; add_rays()
  // gives the unit rays like feed() but does not simulate; run_until(t) does every action at a cycle <= t;
  // next_cycle() is the cycle of the next action (kNever when the packet's rays are all done), and starved() says
  // that action takes a ray not added yet (add rays first). end_packet(end) closes the packet at the chip's last
  // cycle `end`.
  static constexpr uint64_t kNever = ~uint64_t(0);
  void add_rays(std::vector<TraceEvent>* events, size_t m);
  // run_until also takes actions past `limit` that stay inside the unit (cache hits, unit tests, write-backs),
  // stopping before the first that reaches the shared memory (a miss, a stack spill or refill): the units'
  // requests still reach the memory in the order of (cycle, unit), and the unit's own state is what it would be
  // acting in step, so the cycles are the same; the units only change places less often.
  void run_until(uint64_t limit) { simulate(limit, m_ahead && !m_queued && !m_defer); }
  void set_run_ahead(bool on) { m_ahead = on; }  // off: strictly in step (the same cycles, slower; for tests)
  uint64_t next_cycle() const;
  bool starved() const;
  uint64_t end_cycle() const { return m_end; }
  // The unit takes no rays beyond those added so far (begin() was given an upper bound: a chip that hands rays to
  // whichever unit asks, ray_policy dynamic).
  void close_input() { m_n = std::min(m_n, m_feed.end()); }
  void end_packet(uint64_t end);
  // Functional warming: the cache takes the lines these rays' fetches touch, in order, with LRU updates, but no
  // time passes and nothing is counted. Sampled timing warms through the walk below (walk_install leaves the same
  // cache, in less time); this is the definition the tests hold walk_install to.
  void warm(const std::vector<TraceEvent>* events, size_t m);
  // The same for the memory behind the node cache (a chip's L2: memory_backend.h, warm_line): its levels take the
  // lines these rays' fetches touch, in order. The node cache is left alone.
  void warm_memory(const std::vector<TraceEvent>* events, size_t m);
  // How far back functional warming must reach. An LRU cache's contents at a point are, in each set, the
  // cache_ways most recent distinct lines touched before it, in that order. Of the lines that rays simulated after
  // the point touch, a line is in the cache at the point if it is among those of its set, and is not if its set
  // holds that many other lines; a set's older lines only matter if such a line is touched. walk_begin(events, m)
  // takes the rays to be simulated and starts a walk backwards from the point; walk_add() takes rays that come
  // before all rays given since walk_begin() and returns how many of the simulated rays' distinct lines are still
  // undetermined (neither seen nor in a full set). At 0, warming with the rays walked, in forward order, gives
  // the simulated rays the cache they would meet after warming with every earlier ray.
  void walk_begin(const std::vector<TraceEvent>* events, size_t m);
  // walk_add takes the rays backwards from the last and stops after the first (the last in order) with which at
  // most `enough` lines are undetermined; returns how many of the m rays it took (the last ones), m if it took
  // all. walk_install() then puts into the cache what warming forward with the rays taken since walk_begin()
  // would: the same contents and LRU order, in time proportional to the sets touched, not to the rays.
  size_t walk_add(const std::vector<TraceEvent>* events, size_t m, size_t enough = 0);
  size_t walk_open() const { return m_cache.walk_open(); }
  void walk_install() { m_cache.walk_install(); }
  size_t walk_lines() const { return m_cache.walk_needed(); }  // the simulated rays' distinct lines
  // Appends the cycle each ray's hit is written (absolute, see clock()) to `done` (null: not recorded), in the
  // order they are written, and the cycle the ray entered its slot to `entered` (if given), in the same order.
  void record_done(std::vector<uint64_t>* done, std::vector<uint64_t>* entered = nullptr) {
    m_done = done;
    m_entered = entered;
  }
  // The cycle the next packet starts at; advance_to() moves it forward (sampled simulation: the cycles a packet's
  // unsimulated rays are estimated to take).
  uint64_t clock() const { return m_base; }
  void advance_to(uint64_t cycle) { m_base = cycle > m_base ? cycle : m_base; }
  const Layout& layout() const { return m_layout; }
  const MemorySystem& memory() const { return *m_mem; }  // the unit's own, or the chip's it shares
  MemorySystem& memory() { return *m_mem; }
  // The memory is queued (dram_scheduler = frfcfs, memory/dram_scheduler.h): a line or stack read may answer a
  // pending cycle; the slot then leaves the queue and woken() queues it again at the cycle the memory decides. The
  // unit decides its own memory's requests in simulate() once its actions up to their cycle are done; a chip's
  // are decided by run_units_in_step. Unit requests wait for their own cycle (no early service) and a chip's
  // units run strictly in step (no run-ahead): a wake-up may come at any cycle after the decision.
  bool queued() const { return m_queued; }
  // The fetch observer (prefetch/fetch_observer.h): the configuration's prefetcher, or this one (null: none).
  void set_fetch_observer(std::unique_ptr<FetchObserver> observer);
  // Off: every unit request waits for a wake-up of its slot at its own cycle, none is served at its fetch
  // (simulate()); the same cycles, slower. For tests.
  void set_early_requests(bool on) { m_early = on && !m_queued; }
  // A chip's unit on a host thread of its own (run_units_in_step with threads > 1): while deferred, its requests
  // to the shared memory are held (memory/deferred_memory.h) and answered with pending cycles, its slots wait for
  // them as for a queued memory's (parked, woken), and it acts strictly in step, unit requests early only within
  // the window (the same cycles). can_defer(): the unit shares a memory with a known lookahead, and has no fetch
  // observer, no pipeline trace, no one-a-clock port and no queued memory, whose timing depends on the order it is
  // asked in.
  bool can_defer() const;
  uint64_t lookahead() const { return m_mem->min_answer_cycles(); }
  void defer(bool on);
  // The held requests (deferred_memory.h): serving one by the shared memory (its data cycle), and settling them
  // all once served (their answers wake the slots that wait for them).
  const std::vector<DeferredMemory::Request>& held() const { return m_defer->held(); }
  uint64_t serve_held(size_t i) { return m_defer->serve(i, *m_s); }
  void settle_held() { m_defer->settle(); }

 private:
  struct Slot {
    std::vector<TraceEvent> ev;
    size_t pos = 0;
    const Layout* layout = nullptr;  // the image its events address: the top level, or a bottom level
    int depth = 0;                   // stack entries (kPush, kPop events)
    int spilled = 0;                 // stack entries beyond the short stack, in memory
    bool unit_phase = false;         // the current event's data has arrived; its unit request is next
    uint64_t entered = 0;
    size_t ray = 0;  // index in the packet
    bool busy = false;
  };
  // The watchdog: fires when the oldest ray in a slot has been there more than watchdog_cycles at cycle t.
  void watchdog(uint64_t t);
  [[noreturn]] void fire(uint32_t k, uint64_t cycle);
  void admit(uint32_t k, uint64_t free_at);
  // Until done, until a free slot needs a ray not fed yet, or until the next action is after `limit` (`ahead`:
  // the next action after `limit` that touches the shared memory).
  void simulate(uint64_t limit = kNever, bool ahead = false);
  // simulate()'s steps (timing_model.cpp): free slots take rays, a slot's ray leaves, a slot passes an event the
  // units do not test. Always inlined: they are simulate()'s loop, and cost what it cost as one function.
  [[gnu::always_inline]] inline bool admit_rays(uint64_t limit, bool ahead);
  [[gnu::always_inline]] inline void write_back(Slot& sl, uint32_t k, uint64_t t);
  [[gnu::always_inline]] inline bool control_event(Slot& sl, uint32_t k, const TraceEvent& e, uint64_t t,
                                                   uint64_t& next_t, bool& waiting);
  // Whether slot sl's next event reaches the memory behind the node cache (a line the cache does not hold, a
  // stack entry beyond the short stack).
  bool touches_memory(const Slot& sl) const;
  // The unit request of event e of slot k at cycle t: when its result is there.
  uint64_t unit_request(const TraceEvent& e, uint32_t k, uint64_t t);
  // Its four kinds (timing_model_units.cpp): the cluster engine's stages, a node's box tests, and a primitive's
  // test priced by its kind's cost class (TestCost, prim_kind.h).
  uint64_t cluster_box_request(const TraceEvent& e, uint32_t k, uint64_t t);
  uint64_t cluster_tri_request(uint32_t k, uint64_t t);
  uint64_t box_request(const TraceEvent& e, uint32_t k, uint64_t t);
  uint64_t test_request(TestCost cost, const TraceEvent& e, uint32_t k, uint64_t t);
  void serve_waiting();    // serves the earliest waiting request now (its slot wakes after the result)
  uint64_t pop_waiting();  // removes and returns the earliest waiting request's key
  void spill(Slot& sl, uint32_t k, uint64_t t);       // one stack entry written to memory at t
  uint64_t refill(Slot& sl, uint32_t k, uint64_t t);  // one read back from t: when it is there
  // The byte address of slot k's spilled entry number i. A unit's stack region holds kStackRegion bytes per slot,
  // entry-major: entry i of every slot, then entry i + 1, so the spills of slots at one depth share lines and
  // consecutive lines spread over the L2's slices and DRAM's channels. Deeper than kStackRegion / 8 entries the
  // region wraps (only the L2 and banks see addresses).
  uint64_t stack_addr(uint32_t k, int i) const {
    return m_stack_base + ((uint64_t(i) % (kStackRegion / 8)) * uint64_t(m_c.ray_slots) + k) * 8;
  }
  uint64_t unit(std::vector<uint64_t>& next_free, uint64_t issue, uint64_t latency, uint64_t t);
  // A queued memory's answer for slot k: the last of `count` pending reads (pending.h), at the earliest `floor`.
  void woken(uint32_t k, uint64_t cycle, uint64_t wait) override;
  void park(uint32_t k, uint64_t ready, uint64_t floor);
  // Calls f(line) for every cache line the fetch of event e touches (none for stack events).
  template <bool Reverse, class F>
  void for_each_line(const Layout& l, const TraceEvent& e, F&& f) const;
  // Shows the fetch of event e by slot k at cycle t to the observer (which may fill lines at t).
  void observe(const Slot& sl, uint32_t k, const TraceEvent& e, uint64_t t, bool missed);
  void observe_push(const Slot& sl, uint32_t k, const TraceEvent& e, uint64_t t);
  // The first and last line event e fetches in layout l (first > last: none).
  std::pair<uint64_t, uint64_t> line_range(const Layout& l, const TraceEvent& e) const;
  void drain_prefetches(uint64_t t);
  class Port;
  // The layout a kEnter or kLeave event's mesh index names (std::logic_error for one the layout lacks).
  const Layout& bottom(uint32_t mesh) const;
  // A micromap state line through the micromap cache (omm_cache_kib > 0) at cycle t: when its data is there. Out
  // of line, so that the timing loop keeps one inlined copy of the cache's access, the node cache's.
  uint64_t omm_access(uint64_t line, uint64_t t);
  // Calls f(layout, event) for every event that fetches, with the layout it addresses (kEnter, kLeave followed);
  // Reverse: last event first.
  template <bool Reverse, class F>
  void for_each_fetch(const std::vector<TraceEvent>& ev, F&& f) const;  // Reverse: the event's lines last first

  TimingConfig m_c;
  Layout m_layout;
  NodeCache m_cache;
  NodeCache m_omm_cache;  // omm_cache_kib > 0: the micromaps' state lines (kOmm), else empty and unused
  PortLimit m_port;       // fetch_port_rate: one request and one answer a clock, or no limit
  std::unique_ptr<MemorySystem> m_own;        // the unit's own memory (null on a chip)
  MemorySystem* m_mem;                        // what the node cache fills from
  std::unique_ptr<FetchObserver> m_observer;  // null: none (the default)
  std::deque<uint64_t> m_pf_queue;            // lines a prefetcher asked for, waiting for idle memory
  std::unique_ptr<RayAdmission> m_admission;  // how free slots get their rays (ray_admission.h)
  uint32_t m_unit = 0;                        // index on the chip (pipeline trace spans, stack addresses)
  uint64_t m_stack_base = 0;                  // stack_base(): where the unit's slots spill their stacks
  int m_line_shift = 0;                       // log2(line_bytes)
  BoxCost m_box_cost;       // issue clocks and latency of a node test, by the node kind's cost class
  bool m_oriented = false;  // the image's nodes are oriented: each node test turns the ray (obb_rotations)
  std::vector<uint64_t> m_box_free, m_tri_free, m_curve_free;
  // The cluster engine (cluster_tri_rate > 0): its box stage and its triangle stage, one issue port each.
  std::vector<uint64_t> m_cluster_box_free, m_cluster_tri_free;
  // Whether event e (in layout l) is a cluster's internal node, or a triangle of a cluster; and whether it is a
  // triangle that follows the previous one of its leaf (tested in the leaf's request, at no time of its own).
  static bool cluster_node(const Layout& l, const TraceEvent& e) {
    return e.kind == TraceEvent::kNode && !l.cluster_node_spans.empty() && e.index >= l.cluster_node_begin;
  }
  static bool cluster_tri(const Layout& l, const TraceEvent& e) {
    return e.kind == TraceEvent::kPrim && e.count == uint8_t(RecordKind::kTriangle) &&
           e.index < l.cluster_record_flags.size() &&
           (l.cluster_record_flags[e.index] & DeviceImage::kRecordInCluster);
  }
  static bool leaf_follower(const Layout& l, const TraceEvent& prev, const TraceEvent& e) {
    return cluster_tri(l, e) && !(l.cluster_record_flags[e.index] & DeviceImage::kRecordLeafStart) &&
           cluster_tri(l, prev) && prev.index + 1 == e.index;
  }
  // Unit requests whose slot waits for its cycle (cycle << 12 | slot, a min-heap); the others went ahead at
  // their fetch (simulate()). m_min_fetch: the fewest cycles any fetch takes (a cache hit, or without a cache a
  // line from DRAM).
  std::vector<uint64_t> m_waiting;
  uint64_t m_min_fetch = 0;
  bool m_early = true;
  bool m_ahead = true;
  bool m_queued = false;  // memory/dram_scheduler.h
  struct Park {
    uint32_t count = 0;     // pending reads the slot waits for
    uint64_t ready = 0;     // the latest cycle known so far
    uint64_t unqueued = 0;  // deferred: the latest a line would have come without its wait (mem_wait_cycles)
  };
  std::vector<Park> m_park;  // per slot
  uint64_t m_base = 0;       // cycle the current packet started (resources carry absolute cycles)
  // Deferred (defer()): the shared memory, the unit's holding memory in front of which m_mem then points, and the
  // cycle of the action being taken (each held request's order).
  MemorySystem* m_shared = nullptr;
  std::unique_ptr<MemorySystem> m_held_memory;
  DeferredMemory* m_defer = nullptr;  // non-null while deferred
  uint64_t m_now = 0;

  PipelineTrace* m_trace = nullptr;
  std::vector<uint64_t>* m_done = nullptr;
  std::vector<uint64_t>* m_entered = nullptr;
  // The packet in flight.
  TimingStats* m_s = nullptr;
  size_t m_n = 0, m_next = 0;  // rays in the packet, next ray to admit
  RayFeed m_feed;              // the rays given so far (feed, add_rays)
  std::vector<Slot> m_slots;
  SlotQueue m_queue;  // busy slots waiting for a cycle, served by (cycle, slot); ray_slots <= 4096 (validate())
  std::vector<std::pair<uint64_t, uint32_t>> m_free_slots;  // (cycle free, slot): min-heap
  uint64_t m_t0 = 0, m_setup_free = 0, m_wb_free = 0, m_end = 0;
  std::deque<std::pair<uint64_t, uint32_t>> m_age;  // (entry cycle, slot) in admission order (entry cycles rise)
  // No ray can have outstayed the watchdog at a cycle <= this: the entry cycle of the oldest ray in m_age when
  // watchdog() last looked, plus watchdog_cycles (rays only leave, so the true oldest is no older). watchdog()
  // runs only past it.
  static constexpr uint64_t kNoDeadline = ~uint64_t(0);
  uint64_t m_watch_deadline = kNoDeadline;
};

// Runs one packet on a chip's units in step: every unit has begun (begin) and the units act in the order of
// (cycle, unit index). `give(u)` is called when unit u's next action takes a ray it has not been given: it must
// call add_rays on that unit with at least one more ray. Returns the cycle of the last action (the latest
// end_cycle), at least `start`; then closes the packet on every unit (end_packet).
//
// threads > 1: the units act on that many host threads (timing_model_threads.cpp) when every unit can_defer():
// windows of the shared memory's lookahead, the units in parallel inside each, their memory requests served
// after it in the order above; the same cycles and statistics as on one thread. `give` is then called on the
// calling thread only, between windows, earliest (cycle, unit) first, and must touch no unit but u and not the
// shared memory (a sampled chip's warming of other units' caches does: it runs on one thread).
uint64_t run_units_in_step(const std::vector<TimingModel*>& units, uint64_t start,
                           const std::function<void(size_t)>& give, int threads = 1);

}  // namespace rtu::hw
