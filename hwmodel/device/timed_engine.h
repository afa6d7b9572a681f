// The timed device's engine: the fixed datapath decides what happens, the timing model decides when.
//
// Each ray is traced by the fixed datapath (FixedTracer::trace_recorded), which records what it did in order; the
// hits are therefore the fixed device's, bit for bit, and extra work caused by precision costs cycles. The events
// are replayed by the timing model (timing_model.h) in chunks, recorded on worker threads while the model replays
// the previous chunk; the order in which the model sees them, and so every cycle, does not depend on the threads.
// With sampling (sampler.h) only part of each packet goes through the model. Statistics (timing_stats.h) are kept
// in total, by ray type and by bounce.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hwmodel/datapath/box_unit.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/instanced_fixed.h"
#include "hwmodel/datapath/tri_unit.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/timing/ray_gather.h"
#include "hwmodel/timing/sampler.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_model.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::hw {

class TimedEngine final : public TraceEngine {
 public:
  // `unit` answers the box tests when c.box_unit is "rtl" (required then: std::invalid_argument without one);
  // with "cpp" it must be null. `tri` answers the triangle tests likewise when c.tri_unit is "rtl".
  TimedEngine(const EngineOptions& o, const TimingConfig& c, std::unique_ptr<BoxUnit> unit = nullptr,
              std::unique_ptr<TriUnit> tri = nullptr);
  const char* name() const override { return "timed"; }
  uint32_t caps() const override;
  void bind(const uint8_t* data, size_t bytes) override;
  // A two-level scene (instanced_fixed.h), built from the instance set: the host's model of a device memory that
  // holds a top level, its stored transforms and a bottom level per mesh (the command processor's BIND_SCENE
  // names one image). Throws std::invalid_argument as InstancedFixedTracer does, and when a co-simulated unit is
  // attached (two-level traces run on the C++ datapath).
  void bind_instanced(const InstanceSet& set, const Geometry& flat, const FixedFormat& f,
                      const TracerOptions& opt);
  bool bound() const override { return m_tracer != nullptr || m_two != nullptr; }
  // The two levels when bind_instanced bound them, else null.
  const InstancedFixedTracer* instanced() const { return m_two.get(); }
  void unbind() override;
  void trace(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s) const override;
  // One level: the non-opaque triangles' opacity micromaps (fixed_tracer.h, FixedTraceOptions::micromaps). Their
  // states lie after the image in the timing layout (TimingModel::Layout::micromap_offset), so set them before
  // bind: set on a bound one-level engine, its timing models are made anew (their caches start cold).
  void set_micromaps(const MicromapSet* maps) override;
  void set_any_hit(const AnyHitStage* stage) override {
    m_any_hit = stage;
    if (m_tracer) m_tracer->set_any_hit(stage);
    if (m_two) m_two->set_any_hit(stage);
  }
  uint64_t packet_cycles(uint8_t opcode) const override;
  uint64_t irq_latency() const override { return uint64_t(m_c.irq_latency); }
  uint64_t trace_cycles(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s, uint8_t ray_type,
                        uint8_t bounce) override;
  // All-hit packets (FixedTracer::trace_all's events, kHitOut a kept hit's write) are timed as closest-hit packets
  // are, on one unit or a chip, but never sampled: every ray simulated (SampleStats::unthinned_why says so).
  uint64_t trace_all_cycles(const Ray* rays, size_t n, const AllHitsOut& out, TraversalStats& s, uint8_t ray_type,
                            uint8_t bounce) override;
  Geometry::Counts counts() const override;
  bool uses_bvh() const override;

  const TimingConfig& config() const { return m_c; }
  // Bytes an engine of configuration c holds for its timing model whatever the scene and the rays: every unit
  // (TimingModel::state_bytes; with `sampled` on one unit, its cache walk's scratch), the memory behind their
  // caches (MemorySystem::state_bytes) and the buffers rays are recorded into (a ray, its hit and its event
  // list's handle for every ray a chip's units are given ahead). Not the events themselves: they depend on the
  // scene, and are recorded in chunks of bounded bytes. The host holds it to its memory budget before making
  // the engine (host::check_timing_memory, host/devices/direct_device.h).
  static uint64_t state_bytes(const TimingConfig& c, bool sampled);
  // The bound image's format (a two-level scene's top level's; both levels share it): what the unit is built
  // for. Requires bound().
  FixedFormat format() const { return tracer().image().format(); }
  // The bound one-level image (null before a bind, or with two levels).
  const DeviceImage* image() const { return m_image.get(); }
  // Host threads for recording rays and, on a chip, for its units (run_units_in_step): 0 = all cores. Results do
  // not depend on it.
  void set_threads(int threads) { m_opt.threads = threads; }
  // Sampled timing of later TRACE packets (SampleOptions); throws std::invalid_argument for a fraction outside
  // [0, 1] or a unit of 0 rays.
  void set_sampling(const SampleOptions& o);
  const SampleStats& sampling() const { return m_sample_stats; }
  // Record pipeline spans of cycles [from, to) (cycles since bind); the trace must outlive the engine's use.
  // On a chip every unit records into it, each span naming its unit.
  void set_trace(PipelineTrace* trace) {
    m_trace = trace;
    if (m_model) m_model->set_trace(trace);
    for (const auto& u : m_chip_units) u->set_trace(trace);
  }
  // The memory's bytes over time since bind (memory_system.h; null before bind). Under sampled timing it holds
  // the simulated rays' traffic only, at their simulated cycles.
  const MemoryTimeline* timeline() const {
    return m_chip_memory ? &m_chip_memory->timeline() : m_model ? &m_model->memory().timeline() : nullptr;
  }
  // Timing statistics of every TRACE since bind, in total, by ray type and by bounce.
  const TimingStats& timing() const { return m_total; }
  const std::array<TimingStats, cmd::kRayTypeCount>& timing_by_type() const { return m_by_type; }
  const std::map<int, TimingStats>& timing_by_bounce() const { return m_by_bounce; }
  // Per unit of a chip (units > 1): every TRACE since bind; empty for one unit.
  const std::vector<TimingStats>& timing_by_unit() const { return m_unit_stats; }
  // Tests: a chip's units strictly in step, without running ahead of the next unit's action (TimingModel::
  // run_until; the same cycles, a test checks).
  void set_run_ahead(bool on) {
    m_run_ahead = on;
    for (const auto& u : m_chip_units) u->set_run_ahead(on);
  }
  // The events one chunk of rays may record before the model replays them (trace_cycles_full): a chunk is at
  // most 4096 rays and, unless it is one ray, at most this many bytes of events. Set smaller by tests (the
  // cycles do not depend on it: the model takes the rays' events any number at a time).
  static constexpr uint64_t kChunkEventBytes = uint64_t(32) << 20;
  void set_chunk_event_bytes(uint64_t bytes) { m_chunk_event_bytes = bytes; }
  // Tests: run one unit through the chip's code path (the same cycles as the single unit's, a test checks).
  void set_force_chip(bool on) {
    m_force_chip = on;
    if (bound()) make_models();
  }

 private:
  EngineOptions m_opt;
  TimingConfig m_c;
  std::unique_ptr<BoxUnit> m_box_unit;  // null: the C++ box test
  std::unique_ptr<TriUnit> m_tri_unit;  // null: the C++ triangle test
  std::unique_ptr<DeviceImage> m_image;
  std::shared_ptr<const Treelets> m_treelets;  // treelet_bytes > 0, one level: the layout's (and traversal's)
  std::unique_ptr<FixedTracer> m_tracer;
  std::unique_ptr<InstancedFixedTracer> m_two;  // bind_instanced: two levels (m_image and m_tracer are then null)
  const FixedTracer& tracer() const { return m_two ? m_two->top_tracer() : *m_tracer; }
  FixedTraceOptions two_level_options() const;  // the options two levels are traced with
  const AnyHitStage* m_any_hit = nullptr;       // set_any_hit
  const MicromapSet* m_micromaps = nullptr;     // set_micromaps
  std::unique_ptr<TimingModel> m_model;
  // A chip (units > 1): the memory the units share and the units (m_model is then null).
  std::unique_ptr<MemorySystem> m_chip_memory;
  std::vector<std::unique_ptr<TimingModel>> m_chip_units;
  std::vector<TimingStats> m_unit_stats;  // per unit, every TRACE since bind
  void make_models();
  // Gathering (ray_gather.h): the bin key of each ray, from the bound scene's frame (make_models).
  GatherKey m_gather = GatherKey::kNone;
  double m_gather_lo[3] = {0, 0, 0}, m_gather_extent = 1.0;
  // Starts a ray's events with its bin key when gathering; after the trace, a ray with no other event (rejected
  // at setup) has its key removed.
  void begin_events(const Ray& r, std::vector<TraceEvent>& ev) const;
  PipelineTrace* m_trace = nullptr;
  // What sampled packets' measured units showed of the time their rays hold slots, per stream (ray type << 8 |
  // bounce): the detailed warm-up's length (sampler.h, warmup_rays).
  std::map<uint32_t, SlotTimeAccount> m_slot_time;
  // One TRACE packet on a chip of c.units units sharing one memory (units > 1, or `force_chip`): every ray
  // simulated, the units in step (timing_model.h, add_rays and run_until), each action in the order of its cycle
  // (ties: lower unit first), so the cycles do not depend on the host's threads: of the engine's threads, the
  // units act on chip_threads().units (run_units_in_step) and rays are recorded on the others.
  struct ChipThreads {
    int units, recording;
  };
  ChipThreads chip_threads() const;
  uint64_t trace_cycles_chip(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                             TimingStats& ts);
  // A chip whose dispatcher hands each wave to whichever unit asks first (ray_policy dynamic): one TRACE packet,
  // every ray simulated (k < 2) or, with sampling, its waves thinned (sampler.h, chip sampling): the first and
  // last waves simulated, every k-th wave between, the skipped waves warming the chip's memory.
  uint64_t trace_cycles_chip_dynamic(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                     TimingStats& ts, size_t k);
  // A wave handed to the next unit that asks: rays [first, first + count), after the rays [warm_first, first)
  // have warmed the chip's memory (functional warming: their fetches' lines, no time).
  struct ChipWave {
    size_t first = 0, count = 0, warm_first = 0;
  };
  // Runs the chip's units on the waves in order, each to the unit that asks first; hits of every ray (simulated or
  // warming) to hits (null: nowhere), each unit's statistics to packet[u], each wave's work (sampler.h,
  // unit_work) to work[2w] and its warming rays' to work[2w + 1]. Returns the packet's cycles.
  uint64_t run_chip_dynamic(const std::vector<ChipWave>& waves, const Ray* rays, Hit* hits, bool any_hit,
                            TraversalStats& s, std::vector<TimingStats>& packet, std::vector<double>& work);
  // Warms with the rays [cw.warm_first, cw.first) (their recorded events), a wave at a time, the chip's memory
  // through unit u and the node caches of the units they would have gone to.
  void warm_chip(size_t u, const ChipWave& cw, const std::vector<std::vector<TraceEvent>>& events);
  // The rays a chip's unit is given at a time (run_chip): at least two slots' worth.
  static size_t chip_chunk_rays(const TimingConfig& c) { return std::max<size_t>(256, 2 * size_t(c.ray_slots)); }
  // The rays of a packet of n rays each of the chip's units takes, in the order it takes them (ray_policy).
  std::vector<std::vector<uint32_t>> chip_rays(size_t n) const;
  // Runs units[u] on the rays mine[u] in step, sharing their memory, from the latest of their clocks; hits of the
  // rays go to hits (null: nowhere), each unit's statistics to packet[u]. Returns the packet's cycles.
  uint64_t run_chip(const std::vector<TimingModel*>& units, const std::vector<std::vector<uint32_t>>& mine,
                    const Ray* rays, Hit* hits, bool any_hit, TraversalStats& s, std::vector<TimingStats>& packet,
                    std::vector<uint64_t>* ends = nullptr);
  // A chunk of a unit's rays recorded for run_chip (timed_engine_chip.cpp). record_chip_chunk records into c the
  // next chunk of the unit's rays `mine`, from `next` (advanced past it): at most `want` rays and, unless it is
  // one ray, at most `cap` bytes of events; it sets `want` for the unit's next chunk (at most `chunk` rays).
  struct ChipChunk;
  void record_chip_chunk(const std::vector<uint32_t>& mine, const Ray* rays, bool any_hit, size_t chunk,
                         uint64_t cap, size_t& next, size_t& want, ChipChunk& c) const;
  // One TRACE packet through the timing model, every ray simulated.
  uint64_t trace_cycles_full(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                             TimingStats& ts);
  // One TRACE packet through the timing model with sampling (sampler.h), every k-th unit measured (k >= 2).
  // Sampled timing's auxiliary variable per unit of unit_rays rays: the work its (probed) rays' box and primitive
  // tests give at the units' rates, and whether they test a primitive (the strata). With need_hits every ray is
  // traced and its hit written; a ray stopped by the watchdog throws WatchdogError.
  struct UnitAux {
    std::vector<double> aux;
    std::vector<uint8_t> tests_prims;
  };
  UnitAux probe_units(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s, uint64_t draw,
                      double box_rate, double tri_rate);
  uint64_t trace_cycles_sampled(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                TimingStats& ts, size_t k, SlotTimeAccount& slot_time);
  // The end of a sampled packet of n rays (a unit's or a chip's): its statistics ts, the `simulated` rays'
  // counters scaled to the packet with the estimated `cycles`, and the sampling statistics (rays simulated and
  // warmed, units measured, the estimate's variance).
  void finish_sampled_packet(TimingStats& ts, uint64_t n, uint64_t simulated, uint64_t warmed, uint64_t units,
                             uint64_t cycles, double variance);
  // A packet sampling was asked for but that was simulated in full, and why (SampleStats::unthinned_why).
  void unthinned(const std::string& why);
  // Functional warming of the cache before ray `end` for the `sim` rays simulated from there on (their events in
  // events[0, sim)), walking rays backwards from it, recorded a chunk at a time into walk_events (at least 64
  // lists). Returns the rays walked.
  size_t warm_cache_before(const Ray* rays, bool any_hit, size_t end, const std::vector<TraceEvent>* events,
                           size_t sim, std::vector<std::vector<TraceEvent>>& walk_events);
  // Traces rays [first, first + count) with recording; events[at + i] for ray first + i. Hits go to hits (or
  // nowhere when null).
  // During an all-hit packet (m_all) ray i's list goes to `all` at i (hits are then not written).
  void record(const Ray* rays, Hit* hits, size_t first, size_t count, bool any_hit, TraversalStats& s,
              std::vector<std::vector<TraceEvent>>& events, size_t at = 0) const;
  // As record() with at = 0, unless the rays' events pass `cap` bytes in all: then it stops early and returns
  // false, leaving statistics alone (the hits it wrote are the rays' own; the events are to be recorded again).
  // Whether it returns true depends on the rays alone, not on the threads. `bytes`: the events' bytes.
  bool record_within(const Ray* rays, Hit* hits, size_t first, size_t count, bool any_hit, TraversalStats& s,
                     std::vector<std::vector<TraceEvent>>& events, uint64_t cap, uint64_t& bytes,
                     const AllHitsOut* all) const;
  // Ray i of rays, recorded: its closest (or any) hit, or with `all` its hit list into all at i (a miss returned).
  Hit record_ray(const Ray* rays, size_t i, bool any_hit, TraversalStats& st, std::vector<TraceEvent>& ev,
                 const AllHitsOut* all) const;
  // The all-hit packet being traced (trace_all_cycles), else null: where record() puts the lists.
  const AllHitsOut* m_all = nullptr;
  // trace_cycles and trace_all_cycles: one packet, sampled when asked unless it is all-hit (m_all).
  uint64_t run_packet(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s, uint8_t ray_type,
                      uint8_t bounce);
  uint64_t m_chunk_event_bytes = kChunkEventBytes;
  // True when a unit other than the C++ datapath is attached (the engine then traces on one thread).
  bool has_units() const { return m_box_unit || m_tri_unit; }
  bool m_force_chip = false;
  bool m_run_ahead = true;
  bool chip() const { return m_c.units > 1 || m_force_chip; }
  SampleOptions m_sample;
  SampleStats m_sample_stats;
  TimingStats m_total;
  std::array<TimingStats, cmd::kRayTypeCount> m_by_type{};
  std::map<int, TimingStats> m_by_bounce;
};

std::unique_ptr<TraceEngine> make_timed_engine(const EngineOptions& o, const TimingConfig& c,
                                               std::unique_ptr<BoxUnit> unit = nullptr,
                                               std::unique_ptr<TriUnit> tri = nullptr);

}  // namespace rtu::hw
