// The timed device: the fixed datapath decides what happens, a cycle-approximate model of the unit decides when.
//
// Function: each ray is traced by the fixed device (FixedTracer::trace_recorded), which records what the datapath
// did in order (node fetch + box tests, record fetch + primitive test, plane tests, stack pushes and pops). The
// hits are therefore the fixed device's, bit for bit, and extra work caused by precision costs cycles.
//
// Timing (TimingModel below, configured by TimingConfig): the events of each ray are replayed in a ray slot.
// Components and what they model:
// - command processor: packet decode (packet_latency per packet); a FENCE completes fence_latency after the
//   previous packet, and its interrupt (with kFenceIrq) reaches the host irq_latency after that (the device
//   does not wait for it; DeviceCounters::last_irq_cycle); TRACE packets run one after another (no overlap
//   between packets).
// - ray fetch: rays stream from the ray buffer at one per clock with ray_fetch_latency, at most queue_depth rays
//   ahead of the slots (a bounded prefetch queue); ray setup issues one ray per clock, setup_latency deep.
// - ray slots: ray_slots rays in flight; a free slot takes the next ray (in order; lowest free slot first). Each
//   slot has a stack of stack_entries; deeper pushes spill 8 bytes to DRAM (bandwidth only) and pops of spilled
//   entries wait for a DRAM read (latency and bandwidth).
// - memory: node, record and plane fetches go through one set-associative LRU cache (cache_kib, cache_ways,
//   line_bytes; hit after cache_latency; a line in flight is waited for, not fetched twice) into a DRAM channel
//   with dram_latency and dram_bytes_per_cycle (one transfer at a time, ceil(bytes / bandwidth) cycles each).
//   The image is taken to start at a line boundary. Ray and hit buffers stream through their own port: counted
//   (stream_bytes), not in the DRAM channel.
// - units: box_units box units, box_rate box tests per clock each: a node of c children issues for
//   ceil(c / box_rate) clocks, its result comes box_latency after the first; tri_units triangle units of tri_rate
//   tests per clock (tri_units * tri_rate issue slots, one test per clock each; spheres and planes use the same
//   slots with their own latency). A request waits for the
//   earliest free unit (first come, first served); waits longer than queue_depth clocks count as queue stalls.
// - scheduler: traversal_latency from a unit result to the slot's next request; hit write-back one per clock,
//   writeback_latency deep; a slot is free again the clock after its hit is issued to write-back.
// - watchdog: a ray that stays in its slot more than watchdog_cycles stops the packet with a WatchdogError
//   (engine.h) whose text dumps the unit at that cycle: the ray, every busy slot (ray, entry cycle, events done,
//   stack entries spilled, what it waits for), the prefetch queue, the units' and DRAM's queued work, cache
//   figures.
// Every request is served in the order of its cycle (ties by slot number), so the result does not depend on the
// order in which the code evaluates components, and time jumps from event to event (idle cycles are skipped).
// Left out: overlap of consecutive TRACE packets, DRAM banks and refresh, write-allocate of spills into the
// cache, the area of each unit.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <iterator>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hwmodel/commands.h"
#include "hwmodel/engine.h"
#include "hwmodel/fixed_tracer.h"
#include "hwmodel/slot_queue.h"
#include "hwmodel/timing_config.h"

namespace rtu::hw {

inline constexpr uint64_t kRayBytesStream = 32;  // a ray read from the ray buffer
inline constexpr uint64_t kHitBytesStream = 16;  // a hit written to the hit buffer

struct TimingStats {
  uint64_t packets = 0;  // TRACE packets simulated
  uint64_t cycles = 0;   // cycles of those packets
  uint64_t rays = 0;     // rays through the slots (including rays rejected at setup)
  uint64_t box_tests = 0, tri_tests = 0, sphere_tests = 0, plane_tests = 0;
  uint64_t box_issue_cycles = 0, tri_issue_cycles = 0;  // unit issue slots used, summed over the units
  uint64_t node_fetches = 0, prim_fetches = 0;
  uint64_t cache_hits = 0, cache_misses = 0;  // line accesses
  uint64_t dram_bytes = 0, dram_busy_cycles = 0;
  uint64_t stream_bytes = 0;  // ray and hit buffers
  uint64_t stack_spills = 0, stack_refills = 0;
  uint64_t queue_stall_cycles = 0;
  uint64_t slot_busy_cycles = 0;  // sum over rays of the cycles from entering a slot to leaving it

  void add(const TimingStats& o);
};

// Spans of pipeline activity in a window of cycles, for a Chrome/Perfetto trace (one track per ray slot).
struct PipelineTrace {
  struct Span {
    uint32_t slot;
    const char* what;  // "setup", "node fetch", "box", "record fetch", "triangle", "sphere", "plane",
                       // "stack refill", "write-back"
    uint64_t start, end;
  };
  uint64_t from = 0, to = 0;  // window [from, to) in device cycles since bind
  size_t max_spans = 1000000;
  std::vector<Span> spans;
  void add(uint32_t slot, const char* what, uint64_t start, uint64_t end) {
    if (end > from && start < to && spans.size() < max_spans) spans.push_back(Span{slot, what, start, end});
  }
};

class TimingModel {
 public:
  // Where the bound image keeps its sections (addresses are image offsets).
  struct Layout {
    uint64_t node_offset = 0, node_bytes = 56, record_offset = 0, plane_offset = 0;
  };
  TimingModel(const TimingConfig& c, const Layout& layout);

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
  // Functional warming: the cache takes the lines these rays' fetches touch, in order, with LRU updates, but no
  // time passes and nothing is counted. Sampled timing warms through the walk below (walk_install leaves the same
  // cache, in less time); this is the definition the tests hold walk_install to.
  void warm(const std::vector<TraceEvent>* events, size_t m);
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
  size_t walk_open() const { return m_walk_undetermined; }
  void walk_install();
  size_t walk_lines() const { return m_walk_need.size(); }  // the simulated rays' distinct lines
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
  // Off: every unit request waits for a wake-up of its slot at its own cycle, none is served at its fetch
  // (simulate()); the same cycles, slower. For tests.
  void set_early_requests(bool on) { m_early = on; }

 private:
  struct Line {
    uint64_t tag = ~uint64_t(0);
    uint64_t stamp = 0;  // LRU
    uint64_t ready = 0;  // cycle the data is in the cache
  };
  struct Slot {
    std::vector<TraceEvent> ev;
    size_t pos = 0;
    int depth = 0;            // stack entries (kPush, kPop events)
    int spilled = 0;          // stack entries beyond the short stack, in memory
    bool unit_phase = false;  // the current event's data has arrived; its unit request is next
    uint64_t entered = 0;
    size_t ray = 0;  // index in the packet
    bool busy = false;
  };
  // The watchdog: fires when the oldest ray in a slot has been there more than watchdog_cycles at cycle t.
  void watchdog(uint64_t t);
  [[noreturn]] void fire(uint32_t k, uint64_t cycle);
  void admit(uint32_t k, uint64_t free_at);
  void simulate();  // until done or until a free slot needs a ray not fed yet
  // The unit request of event e of slot k at cycle t: when its result is there.
  uint64_t unit_request(const TraceEvent& e, uint32_t k, uint64_t t);
  void serve_waiting();              // serves the earliest waiting request now (its slot wakes after the result)
  uint64_t pop_waiting();            // removes and returns the earliest waiting request's key
  void spill(Slot& sl, uint64_t t);  // one stack entry written to memory at t
  uint64_t refill(Slot& sl, uint32_t k, uint64_t t);  // one read back from t: when it is there
  uint64_t line_access(uint64_t line, uint64_t t);
  int find_way(const Line* ways, uint64_t line) const;  // the way of a set holding line, or -1
  Line* lru_way(Line* ways) const;                      // the set's least recently used way
  uint64_t dram(uint64_t bytes, uint64_t t);
  uint64_t xfer_cycles(uint64_t bytes) const;  // ceil(bytes / bandwidth)
  uint64_t unit(std::vector<uint64_t>& next_free, uint64_t issue, uint64_t latency, uint64_t t);
  uint64_t set_of(uint64_t line) const { return m_set_mask ? line & m_set_mask : line % m_sets; }
  // Calls f(line) for every cache line the fetch of event e touches (none for stack events).
  template <bool Reverse, class F>
  void for_each_line(const TraceEvent& e, F&& f) const;  // Reverse: the event's lines last first

  TimingConfig m_c;
  Layout m_layout;
  std::vector<Line> m_cache;
  uint64_t m_sets = 0, m_stamp = 0;
  uint64_t m_set_mask = 0;                    // m_sets - 1 when m_sets is a power of two (else 0: a division)
  int m_line_shift = 0;                       // log2(line_bytes)
  uint64_t m_line_xfer = 0, m_word_xfer = 0;  // DRAM cycles of a line and of an 8-byte stack entry
  std::array<uint64_t, 256> m_box_issue{};    // ceil(children / box_rate)
  uint64_t m_dram_free = 0;
  std::vector<uint64_t> m_box_free, m_tri_free;
  // Unit requests whose slot waits for its cycle (cycle << 12 | slot, a min-heap); the others went ahead at
  // their fetch (simulate()). m_min_fetch: the fewest cycles any fetch takes (a cache hit, or without a cache a
  // line from DRAM).
  std::vector<uint64_t> m_waiting;
  uint64_t m_min_fetch = 0;
  bool m_early = true;
  uint64_t m_base = 0;  // cycle the current packet started (resources carry absolute cycles)
  // The backward walk (walk_begin): per set the distinct lines seen so far (at most cache_ways) and how many; the
  // simulated rays' distinct lines, per set how many of them are undetermined, and in all.
  std::vector<uint64_t> m_walk_lines;
  std::vector<uint8_t> m_walk_count;
  std::vector<uint64_t> m_walk_need;  // in the order first touched
  std::vector<uint8_t> m_walk_mark;   // by line index: 1 for the lines in m_walk_need
  std::vector<uint32_t> m_walk_open;
  std::vector<uint32_t> m_walk_sets;  // the sets the walk has seen a line of
  std::vector<Line> m_walk_fresh;     // walk_install's scratch: a set's new contents
  size_t m_walk_undetermined = 0;

  PipelineTrace* m_trace = nullptr;
  std::vector<uint64_t>* m_done = nullptr;
  std::vector<uint64_t>* m_entered = nullptr;
  // The packet in flight.
  TimingStats* m_s = nullptr;
  size_t m_n = 0, m_next = 0;                 // rays in the packet, next ray to admit
  std::vector<TraceEvent>* m_feed = nullptr;  // the rays of the current feed() call
  size_t m_feed_first = 0, m_feed_count = 0;  // their indices in the packet
  std::vector<Slot> m_slots;
  SlotQueue m_queue;  // busy slots waiting for a cycle, served by (cycle, slot); ray_slots <= 4096 (validate())
  std::vector<uint64_t> m_recent;                           // admission cycles of the last queue_depth rays
  std::vector<std::pair<uint64_t, uint32_t>> m_free_slots;  // (cycle free, slot): min-heap
  uint64_t m_t0 = 0, m_setup_free = 0, m_wb_free = 0, m_end = 0;
  std::deque<std::pair<uint64_t, uint32_t>> m_age;  // (entry cycle, slot) in admission order (entry cycles rise)
  // No ray can have outstayed the watchdog at a cycle <= this: the entry cycle of the oldest ray in m_age when
  // watchdog() last looked, plus watchdog_cycles (rays only leave, so the true oldest is no older). watchdog()
  // runs only past it.
  static constexpr uint64_t kNoDeadline = ~uint64_t(0);
  uint64_t m_watch_deadline = kNoDeadline;
};

// Sampled timing (SMARTS-style sampling, Wunderlich et al., ISCA 2003): a TRACE packet is cut into units of
// unit_rays consecutive rays. The first unit is simulated from the packet's start (its fill) and the last to the
// packet's end (its drain); of the units between, about one in k (k = round(1 / fraction)) is simulated after rays
// whose fetches only warm the cache (functional warming, as SMARTS does; walked backwards until they fix the
// cache state the simulated rays meet, TimingModel::walk_add, at most cache_warm_rays) and a detailed warm-up of
// rays simulated but not measured (slots and queues; as long as the stream's slowest rays need, warmup_rays()),
// and before 2 x ray_slots tail rays, so that its cost, the cycles between the hit of the warm-up's last ray and
// the unit's last hit counted in order of writing, is measured in steady state. The units between are sampled in
// strata where there are two large ones (units whose rays test no primitive and units whose rays do: camera rays'
// sky and geometry), the sample shared by sqrt(units x auxiliary total) of each stratum (Neyman's allocation with
// costs) and spread evenly over its units; otherwise systematically, every k-th from a seeded offset. Each
// stratum's cycles are a ratio estimate (Cochran, "Sampling Techniques", ch. 6): measured cycles / measured
// auxiliary times the auxiliary of all its units, with the jackknife variance of the ratio (finite-population
// corrected); the packet's 95% interval is from their sum. The auxiliary is each unit's work from the datapath's
// test counts, rays + box tests / box rate + primitive tests / test rate: of every ray when hits are needed (the
// datapath then traces every ray anyway; only the timing model is sampled), else of one ray in each block of 32,
// at a seeded random place in the block, scaled up for the units not measured (cycles only: a cheap functional
// probe that estimates the auxiliary's total) and of all rays for the measured ones (two-phase sampling). Measured
// units and probed rays are drawn afresh for each packet (from the seed and the packet's number). A packet too
// short for 10 measured units at every k-th is sampled at the largest k that gives 10 (a short last packet of a
// ray file), provided the measured units' rays with their warm-up and tail are still at most half of its rays;
// otherwise it is simulated in full. Timing counters (cache, DRAM, tests) are those of the simulated rays scaled
// to the packet.
struct SampleOptions {
  double fraction = 0.0;  // 0 (or >= 1): simulate every ray
  uint32_t unit_rays = 256;
  // Detailed warm-up before each measured unit; 0: chosen for each stream from how long its rays hold their slots
  // (TimedEngine::warmup_rays; a fixed 256 measured AC14-FZK-Haus incoherent units 3% low, 512 0.6%, 1024 0.0%).
  uint32_t warmup_rays = 0;
  // At most this many rays before the detailed warm-up warm the cache functionally (fetches only): as many as it
  // takes to fix the cache state the simulated rays meet (a few hundred incoherent rays; camera rays find their
  // lines in the previous image row, more than a detailed warm-up can afford).
  uint32_t cache_warm_rays = 4096;
  uint64_t seed = 1;
  bool need_hits = true;
};
struct SampleStats {
  uint64_t packets = 0, packets_sampled = 0;  // TRACE packets, and those estimated from a sample
  uint64_t rays = 0, rays_simulated = 0;      // rays in them, and rays through the timing model (with warm-up)
  uint64_t rays_warmed = 0;                   // rays traced only to warm the cache (functional warming)
  uint64_t units_measured = 0;
  uint64_t warmup_rays = 0;         // detailed warm-up rays simulated before the measured units, in all
  uint64_t packets_stratified = 0;  // sampled in two strata: units testing no primitive, units testing some
  double variance = 0.0;            // of the summed cycle estimate (0 for fully simulated packets)
  double ci95() const;              // half-width of the 95% confidence interval of the cycles, 1.96 sqrt(variance)
};

class TimedEngine final : public TraceEngine {
 public:
  // `unit` answers the box tests when c.box_unit is "rtl" (required then: std::invalid_argument without one);
  // with "cpp" it must be null.
  TimedEngine(const EngineOptions& o, const TimingConfig& c, std::unique_ptr<BoxUnit> unit = nullptr);
  const char* name() const override { return "timed"; }
  uint32_t caps() const override;
  void bind(const uint8_t* data, size_t bytes) override;
  bool bound() const override { return m_tracer != nullptr; }
  void unbind() override;
  void trace(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s) const override;
  uint64_t packet_cycles(uint8_t opcode) const override;
  uint64_t irq_latency() const override { return uint64_t(m_c.irq_latency); }
  uint64_t trace_cycles(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s, uint8_t ray_type,
                        uint8_t bounce) override;
  Geometry::Counts counts() const override;
  bool uses_bvh() const override;

  const TimingConfig& config() const { return m_c; }
  void set_threads(int threads) { m_opt.threads = threads; }
  // Sampled timing of later TRACE packets (SampleOptions); throws std::invalid_argument for a fraction outside
  // [0, 1] or a unit of 0 rays.
  void set_sampling(const SampleOptions& o);
  const SampleStats& sampling() const { return m_sample_stats; }
  // Record pipeline spans of cycles [from, to) (cycles since bind); the trace must outlive the engine's use.
  void set_trace(PipelineTrace* trace) {
    m_trace = trace;
    if (m_model) m_model->set_trace(trace);
  }
  // Timing statistics of every TRACE since bind, in total, by ray type and by bounce.
  const TimingStats& timing() const { return m_total; }
  const std::array<TimingStats, cmd::kRayTypeCount>& timing_by_type() const { return m_by_type; }
  const std::map<int, TimingStats>& timing_by_bounce() const { return m_by_bounce; }

 private:
  EngineOptions m_opt;
  TimingConfig m_c;
  std::unique_ptr<BoxUnit> m_box_unit;  // null: the C++ box test
  std::unique_ptr<DeviceImage> m_image;
  std::unique_ptr<FixedTracer> m_tracer;
  std::unique_ptr<TimingModel> m_model;
  PipelineTrace* m_trace = nullptr;
  // What sampled packets' measured units showed of the time their rays hold slots, per ray type and bounce (the
  // detailed warm-up's length, trace_cycles_sampled): the time in slots, and of it the part beyond the time
  // kWarmupGrid[g] x ray_slots + unit_rays / 2 rays take to pass.
  static constexpr size_t kWarmupGrid[] = {8,  10, 12, 14, 16, 18, 20, 22,
                                           24, 28, 32, 40, 48, 56, 64};  // x ray_slots
  struct SlotTime {
    std::array<double, std::size(kWarmupGrid)> late{};
    double held = 0.0;
    uint64_t rays = 0;
  };
  std::map<uint32_t, SlotTime> m_slot_time;
  // One TRACE packet through the timing model with sampling (SampleOptions).
  uint64_t trace_cycles_sampled(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                TimingStats& ts, size_t k,
                                SlotTime& slot_time);  // every k-th unit measured (k >= 2)
  size_t warmup_rays(const SlotTime& st) const;        // the detailed warm-up for a stream that showed st
  // Traces rays [first, first + count) with recording; events[at + i] for ray first + i. Hits go to hits (or
  // nowhere when null).
  void record(const Ray* rays, Hit* hits, size_t first, size_t count, bool any_hit, TraversalStats& s,
              std::vector<std::vector<TraceEvent>>& events, size_t at = 0) const;
  SampleOptions m_sample;
  SampleStats m_sample_stats;
  TimingStats m_total;
  std::array<TimingStats, cmd::kRayTypeCount> m_by_type{};
  std::map<int, TimingStats> m_by_bounce;
};

std::unique_ptr<TraceEngine> make_timed_engine(const EngineOptions& o, const TimingConfig& c,
                                               std::unique_ptr<BoxUnit> unit = nullptr);

}  // namespace rtu::hw
