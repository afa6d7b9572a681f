// The timed engine (timed_engine.h): the binding of the timing model to the engine interface. Construction and
// the checks of the attached units, binding a scene (one image or two levels) and making its timing models,
// recording rays' events through the fixed datapath, and TRACE packets: trace_cycles picks the path a packet
// takes and keeps the statistics by ray type and bounce; one unit runs every ray through the model here
// (trace_cycles_full). A chip's packets are timed_engine_chip.cpp's, sampled packets timed_engine_sampled.cpp's.
#include "hwmodel/device/timed_engine.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <future>
#include <stdexcept>
#include <string>
#include <string_view>

#include "hwmodel/datapath/batch.h"
#include "hwmodel/interface/regs.h"
#include "hwmodel/timing/prefetch/treelets.h"
#include "hwmodel/timing/ray_scheduler.h"

namespace rtu::hw {

namespace {

// The treelets of a one-level image in the timing layout's node stride (treelet_bytes > 0).
std::shared_ptr<const Treelets> layout_treelets(const DeviceImage& image, const TimingConfig& c) {
  const TimingModel::Layout l = TimingModel::layout_of(image, uint64_t(c.layout_align));
  const uint64_t stride = l.node_stride ? l.node_stride : l.node_bytes;
  return std::make_shared<const Treelets>(form_treelets(image, uint64_t(c.treelet_bytes), stride));
}

}  // namespace

TimedEngine::TimedEngine(const EngineOptions& o, const TimingConfig& c, std::unique_ptr<BoxUnit> unit,
                         std::unique_ptr<TriUnit> tri)
    : m_opt(o), m_c(c), m_box_unit(std::move(unit)), m_tri_unit(std::move(tri)) {
  m_c.validate();
  if (m_c.box_unit == UnitModel::kRtl && !m_box_unit)
    throw std::invalid_argument("timing config " + m_c.name + ": box_unit = rtl, but no RTL box unit is attached");
  if (m_c.box_unit != UnitModel::kRtl && m_box_unit)
    throw std::invalid_argument("timing config " + m_c.name +
                                ": a box unit is attached, but box_unit = " + name_of(m_c.box_unit));
  if (m_c.tri_unit == UnitModel::kRtl && !m_tri_unit)
    throw std::invalid_argument("timing config " + m_c.name +
                                ": tri_unit = rtl, but no RTL triangle unit is attached");
  if (m_c.tri_unit != UnitModel::kRtl && m_tri_unit)
    throw std::invalid_argument("timing config " + m_c.name +
                                ": a triangle unit is attached, but tri_unit = " + name_of(m_c.tri_unit));
}

uint64_t TimedEngine::state_bytes(const TimingConfig& c, bool sampled) {
  constexpr uint64_t kList = sizeof(std::vector<TraceEvent>);
  const uint64_t units = uint64_t(c.units), slots = uint64_t(c.ray_slots);
  const uint64_t memory = MemorySystem::state_bytes(c);
  if (units == 1)  // trace_cycles_full: two chunks of at most 4096 rays' lists
    return TimingModel::state_bytes(c, sampled) + memory + 2 * 4096 * kList;
  // run_chip: per unit a chunk given and one recorded ahead, each ray with its copy, its hit and its list;
  // run_chip_dynamic: 2 units + 2 waves recorded ahead and one held per unit, a list per ray and per warming ray.
  const uint64_t chip = units * 2 * chip_chunk_rays(c) * (sizeof(Ray) + sizeof(Hit) + kList);
  const uint64_t dynamic = (3 * units + 2) * slots * 2 * kList;
  return units * TimingModel::state_bytes(c, false) + memory + std::max(chip, dynamic);
}

uint32_t TimedEngine::caps() const {
  return reg::kCapTriangles | reg::kCapSpheres | reg::kCapPlanes | reg::kCapAnyHit | reg::kCapFixed |
         reg::kCapTimed | reg::kCapAllHits;
}

void TimedEngine::bind(const uint8_t* data, size_t bytes) {
  unbind();
  if (is_two_level(data, bytes)) {  // an instanced scene's two levels (instanced_fixed.h)
    if (has_units())
      throw std::invalid_argument("two-level scenes are traced by the C++ datapath (box_unit and tri_unit cpp)");
    m_two = InstancedFixedTracer::from_bytes(data, bytes, two_level_options());
    make_models();
    m_slot_time.clear();
    return;
  }
  DeviceImage img = DeviceImage::from_bytes(data, bytes);
  if (img.header().flags & kImageTopLevel)  // its bottom levels are not in the image
    throw std::invalid_argument("scene image: a top level, whose bottom levels this engine does not hold");
  auto image = std::make_unique<DeviceImage>(std::move(img));
  if (m_c.treelet_bytes > 0) m_treelets = layout_treelets(*image, m_c);
  FixedTraceOptions to;
  if (m_c.traversal == TraversalOrder::kTreeletFirst && m_treelets && !m_treelets->id.empty())
    to.treelets = TreeletMap{m_treelets->id.data(), uint32_t(m_treelets->id.size())};
  to.slot_order = m_c.child_order == ChildOrder::kSlot;
  to.max_steps = m_opt.max_steps;
  to.record_short_stack = m_c.stack_entries;  // the model charges only for entries beyond it
  to.record_stack_refs = prefetcher_wants_stack_refs(m_c);
  to.record_leaf_refs = prefetcher_wants_leaf_refs(m_c);
  to.record_restart = m_c.stack_mode == StackMode::kRestart;
  to.box_unit = m_box_unit.get();
  to.tri_unit = m_tri_unit.get();
  to.any_hit = m_any_hit;
  to.micromaps = m_micromaps;
  auto tracer = std::make_unique<FixedTracer>(*image, to);  // throws when a unit cannot take the format
  m_image = std::move(image);
  m_tracer = std::move(tracer);
  make_models();
  m_slot_time.clear();  // another scene, other streams
}

FixedTraceOptions TimedEngine::two_level_options() const {
  FixedTraceOptions to;
  to.max_steps = m_opt.max_steps;
  to.record_short_stack = m_c.stack_entries;  // the model charges only for entries beyond it
  to.record_stack_refs = prefetcher_wants_stack_refs(m_c);
  to.record_leaf_refs = prefetcher_wants_leaf_refs(m_c);
  to.record_restart = m_c.stack_mode == StackMode::kRestart;
  to.any_hit = m_any_hit;
  return to;
}

void TimedEngine::bind_instanced(const InstanceSet& set, const Geometry& flat, const FixedFormat& f,
                                 const TracerOptions& opt) {
  unbind();
  if (has_units())
    throw std::invalid_argument("two-level scenes are traced by the C++ datapath (box_unit and tri_unit cpp)");
  m_two = std::make_unique<InstancedFixedTracer>(set, flat, f, opt, two_level_options());
  make_models();
  m_slot_time.clear();
}

void TimedEngine::set_micromaps(const MicromapSet* maps) {
  m_micromaps = maps;
  if (!m_tracer) return;
  m_tracer->set_micromaps(maps);
  if (!m_two) make_models();
}

void TimedEngine::make_models() {
  m_gather = m_c.gather;
  {
    const QuantFrame f = tracer().image().frame();
    const double step = f.step();
    for (int a = 0; a < 3; ++a) m_gather_lo[a] = double(f.origin[a]) * step;
    m_gather_extent = std::ldexp(step, f.bits);
  }
  TimingModel::Layout l =
      m_two ? TimingModel::layout_of(*m_two, uint64_t(m_c.layout_align), uint64_t(m_c.instance_bytes))
            : TimingModel::layout_of(*m_image, uint64_t(m_c.layout_align));
  if (m_micromaps && !m_two) {  // the maps' states after the image, on a line of their own
    l.micromap_offset = (l.total_bytes + 63) / 64 * 64;
    uint64_t states = 0;
    for (const Micromap& m : m_micromaps->maps) states += m.bytes();
    l.total_bytes = l.micromap_offset + states;
  }
  // Checked at bind rather than by validate(), so that --set order does not matter.
  if (std::string_view(name_of(m_c.prefetcher)) == "treelet" && m_c.treelet_bytes == 0)
    throw std::invalid_argument("prefetcher = treelet needs treelet_bytes > 0 (the treelets it prefetches)");
  if (m_c.child_order == ChildOrder::kSlot && m_two)
    throw std::invalid_argument(
        "child_order = slot: one-level scenes only, and this scene is instanced (two levels): trace it flattened "
        "(--flatten; flatten=True in Python)");
  if (m_c.traversal == TraversalOrder::kTreeletFirst && m_c.treelet_bytes == 0)
    throw std::invalid_argument("traversal = treelet_first needs treelet_bytes > 0 (the treelets it finishes)");
  if (m_c.treelet_bytes > 0) {
    if (m_two)
      throw std::invalid_argument(
          "treelet_bytes: treelet layouts are for one-level scenes, and this scene is instanced (two levels): "
          "trace it flattened (--flatten; flatten=True in Python) or leave treelet_bytes at 0");
    l.treelets = m_treelets;
  }
  m_model.reset();
  m_chip_units.clear();
  m_chip_memory.reset();
  m_unit_stats.clear();
  if (!chip()) {
    m_model = std::make_unique<TimingModel>(m_c, l);
    m_model->set_trace(m_trace);
    return;
  }
  m_chip_memory = std::make_unique<MemorySystem>(m_c);
  for (uint32_t u = 0; u < uint32_t(m_c.units); ++u) {
    m_chip_units.push_back(std::make_unique<TimingModel>(m_c, l, m_chip_memory.get(), u));
    m_chip_units.back()->set_trace(m_trace);
    m_chip_units.back()->set_run_ahead(m_run_ahead);
  }
  m_unit_stats.assign(size_t(m_c.units), TimingStats{});
}

void TimedEngine::unbind() {
  m_treelets.reset();
  m_model.reset();
  m_chip_units.clear();
  m_chip_memory.reset();
  m_tracer.reset();
  m_image.reset();
  m_two.reset();
}

void TimedEngine::trace(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s) const {
  TraversalStats local;
  tracer().trace_batch(rays, hits, n, any_hit, m_opt.threads, local);
  if (local.watchdog_rays > 0)
    throw WatchdogError(tracer().watchdog_report(rays, n, any_hit, local.watchdog_rays), 0);
  s.add(local);
}

uint64_t TimedEngine::packet_cycles(uint8_t opcode) const {
  const uint64_t p = uint64_t(m_c.packet_latency);
  return opcode == uint8_t(cmd::Opcode::kFence) ? p + uint64_t(m_c.fence_latency) : p;
}

void TimedEngine::begin_events(const Ray& r, std::vector<TraceEvent>& ev) const {
  ev.clear();
  if (m_gather != GatherKey::kNone)
    ev.push_back(TraceEvent{TraceEvent::kRayKey, 0, 0, 0,
                            gather_key(m_gather, m_c.gather_grid_bits, r, m_gather_lo, m_gather_extent)});
}

Hit TimedEngine::record_ray(const Ray* rays, size_t i, bool any_hit, TraversalStats& st,
                            std::vector<TraceEvent>& ev, const AllHitsOut* all) const {
  if (!all) return tracer().trace_recorded(rays[i], any_hit, st, ev);
  HitList list = all->list(i);
  all->counts[i] = tracer().trace_all(rays[i], list, st, &ev);
  return Hit{};
}

void TimedEngine::record(const Ray* rays, Hit* hits, size_t first, size_t count, bool any_hit, TraversalStats& s,
                         std::vector<std::vector<TraceEvent>>& events, size_t at) const {
  TraversalStats local;
  const int threads = has_units() ? 1 : m_opt.threads;  // a unit is not thread-safe (box_unit.h, tri_unit.h)
  run_batch(count, threads, local, [&](size_t i, TraversalStats& st) {
    std::vector<TraceEvent>& ev = events[at + i];
    begin_events(rays[first + i], ev);
    const Hit h = record_ray(rays, first + i, any_hit, st, ev, m_all);
    if (ev.size() == 1 && m_gather != GatherKey::kNone) ev.clear();
    if (hits) hits[first + i] = h;
  });
  if (local.watchdog_rays > 0)
    throw WatchdogError(tracer().watchdog_report(rays + first, count, any_hit, local.watchdog_rays), 0);
  if (local.first_invalid != UINT64_MAX) local.first_invalid += first;
  s.add(local);
}

bool TimedEngine::record_within(const Ray* rays, Hit* hits, size_t first, size_t count, bool any_hit,
                                TraversalStats& s, std::vector<std::vector<TraceEvent>>& events, uint64_t cap,
                                uint64_t& bytes, const AllHitsOut* all) const {
  TraversalStats local;
  std::atomic<uint64_t> total{0};
  std::atomic<bool> over{false};
  const int threads = has_units() ? 1 : m_opt.threads;  // a unit is not thread-safe (box_unit.h, tri_unit.h)
  run_batch(count, threads, local, [&](size_t i, TraversalStats& st) {
    std::vector<TraceEvent>& ev = events[i];
    ev.clear();
    if (over.load(std::memory_order_relaxed)) return;  // this attempt is lost anyway
    begin_events(rays[first + i], ev);
    const Hit h = record_ray(rays, first + i, any_hit, st, ev, all);
    if (ev.size() == 1 && m_gather != GatherKey::kNone) ev.clear();
    if (hits) hits[first + i] = h;
    // A list keeps the capacity of the longest ray it held (lists are swapped with the model's slots): trimmed,
    // so that what the lists hold stays near what the chunk recorded.
    if (ev.capacity() > 2 * ev.size() + 256) ev.shrink_to_fit();
    const uint64_t b = uint64_t(ev.size()) * sizeof(TraceEvent);
    if (total.fetch_add(b, std::memory_order_relaxed) + b > cap) over.store(true, std::memory_order_relaxed);
  });
  bytes = total.load();
  if (over.load()) return false;  // partial sums only grow: over iff all the rays' events pass cap
  if (local.watchdog_rays > 0)
    throw WatchdogError(tracer().watchdog_report(rays + first, count, any_hit, local.watchdog_rays), 0);
  if (local.first_invalid != UINT64_MAX) local.first_invalid += first;
  s.add(local);
  return true;
}

uint64_t TimedEngine::trace_cycles(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                   uint8_t ray_type, uint8_t bounce) {
  return run_packet(rays, hits, n, any_hit, s, ray_type, bounce);
}

uint64_t TimedEngine::trace_all_cycles(const Ray* rays, size_t n, const AllHitsOut& out, TraversalStats& s,
                                       uint8_t ray_type, uint8_t bounce) {
  struct Clear {
    const AllHitsOut*& p;
    ~Clear() { p = nullptr; }
  } clear{m_all};
  m_all = &out;
  return run_packet(rays, nullptr, n, false, s, ray_type, bounce);
}

uint64_t TimedEngine::run_packet(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                 uint8_t ray_type, uint8_t bounce) {
  TimingStats ts;
  uint64_t cycles;
  ++m_sample_stats.packets;
  m_sample_stats.rays += n;
  SlotTimeAccount& stream =
      m_slot_time[uint32_t(ray_type) << 8 | bounce];  // what this stream's rays showed so far
  const size_t per_unit = warmup_rays(stream, size_t(m_c.ray_slots), m_sample.warmup_rays) + m_sample.unit_rays +
                          2 * size_t(m_c.ray_slots);
  size_t asked = sample_step(m_sample.fraction);  // every asked-th unit; k: this packet's step
  if (m_all && asked >= 2) {
    unthinned("an all-hit packet is simulated in full (its rays' lists are not estimated)");
    asked = 1;
  }
  const size_t k = packet_step(n, m_sample.unit_rays, asked, per_unit);
  const RayPolicy policy = m_c.ray_policy;
  const bool dynamic = chip() && policy == RayPolicy::kDynamic;
  if (chip() && !dynamic && asked >= 2)
    throw std::invalid_argument(
        "sampled timing on a chip needs ray_policy = dynamic (--set ray_policy=dynamic): with " +
        std::string(name_of(m_c.ray_policy)) +
        " each unit's rays are fixed, the packet ends with its slowest unit, and no sample of them estimates that "
        "within the interval (docs/timing-model.md, sampled timing on a chip)");
  if (!chip() && asked >= 2 && k < 2)
    unthinned(
        "a packet of " + std::to_string(n) + " rays holds " + std::to_string(n / m_sample.unit_rays) +
        " units of " + std::to_string(m_sample.unit_rays) + " rays; at 1 in " + std::to_string(asked) +
        " that measures fewer than 10, and at a higher rate the measured units with their warm-up and tail (" +
        std::to_string(per_unit) + " rays each) would be over half the packet: use longer packets, a " +
        "shorter --sample-unit or no --sample");
  try {
    cycles = dynamic  ? trace_cycles_chip_dynamic(rays, hits, n, any_hit, s, ts, asked)
             : chip() ? trace_cycles_chip(rays, hits, n, any_hit, s, ts)
             : k >= 2 ? trace_cycles_sampled(rays, hits, n, any_hit, s, ts, k, stream)
                      : trace_cycles_full(rays, hits, n, any_hit, s, ts);
  } catch (const WatchdogError&) {
    // The packet never finished: fresh models (empty caches, clock at 0) for whatever comes after a reset.
    make_models();
    throw;
  }
  m_total.add(ts);
  if (ray_type < cmd::kRayTypeCount) m_by_type[ray_type].add(ts);
  m_by_bounce[bounce].add(ts);
  return cycles;
}

uint64_t TimedEngine::trace_cycles_full(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                        TimingStats& ts) {
  // Chunks of rays: traced (and recorded) on the worker threads, then replayed through the model in order. With
  // more than one thread the next chunk is recorded while the model replays this one (two event buffers): the
  // datapath and the model are independent work, so both cores run. The order in which the model sees the events,
  // and so every cycle, is the same either way.
  //
  // A chunk is at most kChunk rays and, unless it is one ray, at most m_chunk_event_bytes of events (a ray through
  // many overlapping instances records megabytes): a chunk whose events pass that is recorded again with half
  // its rays, and the next chunk tries as many rays as would fill it at this chunk's bytes per ray (at most twice
  // this chunk's). The chunks depend on the rays alone, and the model takes events any number of rays at a time,
  // so the cycles are the same for any bound and any thread count.
  constexpr size_t kChunk = 4096;
  const size_t buffers = m_opt.threads == 1 || n <= kChunk ? 1 : 2;
  std::vector<std::vector<TraceEvent>> events[2];
  for (size_t b = 0; b < buffers; ++b) events[b].resize(std::min(n, kChunk));
  TraversalStats next_stats;  // the chunk being recorded in the background
  const uint64_t cap = m_chunk_event_bytes;
  size_t want = kChunk;  // rays the next chunk tries; read and set by one recording at a time
  auto record_chunk = [&](size_t first, std::vector<std::vector<TraceEvent>>& ev, TraversalStats& st) {
    size_t count = std::min(want, n - first);
    uint64_t bytes = 0;
    while (
        !record_within(rays, hits, first, count, any_hit, st, ev, count == 1 ? UINT64_MAX : cap, bytes, m_all)) {
      for (size_t i = count / 2; i < count; ++i) std::vector<TraceEvent>().swap(ev[i]);  // not in the retry
      count /= 2;
    }
    const uint64_t fill = bytes > 0 ? uint64_t(count) * cap / bytes : kChunk;
    want = size_t(std::max<uint64_t>(1, std::min<uint64_t>({kChunk, 2 * uint64_t(count), fill})));
    return count;
  };
  m_model->begin(n, ts);
  size_t count = record_chunk(0, events[0], s);
  for (size_t first = 0, b = 0; first < n; b = (b + 1) % buffers) {
    const size_t after = first + count;
    std::future<size_t> next;  // the next chunk, recorded into the other buffer meanwhile
    if (after < n && buffers == 2)
      next = std::async(std::launch::async, record_chunk, after, std::ref(events[b ^ 1]), std::ref(next_stats));
    try {
      m_model->feed(events[b].data(), count);
    } catch (...) {
      if (next.valid()) next.wait();  // the recording thread uses this frame's buffers
      throw;
    }
    size_t next_count = 0;
    if (next.valid()) {
      next_count = next.get();  // rethrows a watchdog error of the datapath
      s.add(next_stats);
      next_stats = TraversalStats{};
    } else if (after < n) {
      // One buffer: the model is done with it (feed swapped out what it keeps).
      next_count = record_chunk(after, events[b], s);
    }
    first = after;
    count = next_count;
  }
  const uint64_t cycles = m_model->finish();
  m_sample_stats.rays_simulated += n;
  return cycles;
}

Geometry::Counts TimedEngine::counts() const {
  if (!bound()) return {};
  const ImageHeader& h = tracer().image().header();
  return {h.num_triangles, h.num_spheres, h.plane_count};
}

bool TimedEngine::uses_bvh() const {
  return bound() && !(tracer().image().header().flags & kImageNoBvh);
}

std::unique_ptr<TraceEngine> make_timed_engine(const EngineOptions& o, const TimingConfig& c,
                                               std::unique_ptr<BoxUnit> unit, std::unique_ptr<TriUnit> tri) {
  return std::make_unique<TimedEngine>(o, c, std::move(unit), std::move(tri));
}

}  // namespace rtu::hw
