#include "hwmodel/device/timed_engine.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include "hwmodel/datapath/batch.h"
#include "hwmodel/interface/regs.h"
#include "hwmodel/timing/prefetch/treelets.h"
#include "hwmodel/timing/ray_scheduler.h"

namespace rtu::hw {

namespace {

// Stops and joins a recording worker however the function that started it ends (it uses that frame's buffers).
struct WorkerJoiner {
  std::mutex& m;
  std::condition_variable& cv;
  bool& stop;
  std::thread& t;
  ~WorkerJoiner() {
    {
      const std::lock_guard<std::mutex> lock(m);
      stop = true;
    }
    cv.notify_all();
    if (t.joinable()) t.join();
  }
};

}  // namespace

TimedEngine::TimedEngine(const EngineOptions& o, const TimingConfig& c, std::unique_ptr<BoxUnit> unit,
                         std::unique_ptr<TriUnit> tri)
    : m_opt(o), m_c(c), m_box_unit(std::move(unit)), m_tri_unit(std::move(tri)) {
  m_c.validate();
  if (m_c.box_unit == "rtl" && !m_box_unit)
    throw std::invalid_argument("timing config " + m_c.name + ": box_unit = rtl, but no RTL box unit is attached");
  if (m_c.box_unit != "rtl" && m_box_unit)
    throw std::invalid_argument("timing config " + m_c.name +
                                ": a box unit is attached, but box_unit = " + m_c.box_unit);
  if (m_c.tri_unit == "rtl" && !m_tri_unit)
    throw std::invalid_argument("timing config " + m_c.name +
                                ": tri_unit = rtl, but no RTL triangle unit is attached");
  if (m_c.tri_unit != "rtl" && m_tri_unit)
    throw std::invalid_argument("timing config " + m_c.name +
                                ": a triangle unit is attached, but tri_unit = " + m_c.tri_unit);
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
         reg::kCapTimed;
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
  FixedTraceOptions to;
  to.max_steps = m_opt.max_steps;
  to.record_short_stack = m_c.stack_entries;  // the model charges only for entries beyond it
  to.record_stack_refs = prefetcher_wants_stack_refs(m_c);
  to.record_restart = m_c.stack_mode == "restart";
  to.box_unit = m_box_unit.get();
  to.tri_unit = m_tri_unit.get();
  to.any_hit = m_any_hit;
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
  to.record_restart = m_c.stack_mode == "restart";
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

void TimedEngine::make_models() {
  parse_gather_key(m_c.gather, m_gather);
  {
    const QuantFrame f = tracer().image().frame();
    const double step = f.step();
    for (int a = 0; a < 3; ++a) m_gather_lo[a] = double(f.origin[a]) * step;
    m_gather_extent = std::ldexp(step, f.bits);
  }
  TimingModel::Layout l =
      m_two ? TimingModel::layout_of(*m_two, uint64_t(m_c.layout_align), uint64_t(m_c.instance_bytes))
            : TimingModel::layout_of(*m_image, uint64_t(m_c.layout_align));
  // Checked at bind rather than by validate(), so that --set order does not matter.
  if (m_c.prefetcher == "treelet" && m_c.treelet_bytes == 0)
    throw std::invalid_argument("prefetcher = treelet needs treelet_bytes > 0 (the treelets it prefetches)");
  if (m_c.treelet_bytes > 0) {
    if (m_two)
      throw std::invalid_argument(
          "treelet_bytes: treelet layouts are for one-level scenes, and this scene is instanced (two levels): "
          "trace it flattened (--flatten; flatten=True in Python) or leave treelet_bytes at 0");
    const uint64_t stride = l.node_stride ? l.node_stride : l.node_bytes;
    l.treelets = std::make_shared<const Treelets>(form_treelets(*m_image, uint64_t(m_c.treelet_bytes), stride));
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

void TimedEngine::record(const Ray* rays, Hit* hits, size_t first, size_t count, bool any_hit, TraversalStats& s,
                         std::vector<std::vector<TraceEvent>>& events, size_t at) const {
  TraversalStats local;
  const int threads = has_units() ? 1 : m_opt.threads;  // a unit is not thread-safe (box_unit.h, tri_unit.h)
  run_batch(count, threads, local, [&](size_t i, TraversalStats& st) {
    std::vector<TraceEvent>& ev = events[at + i];
    begin_events(rays[first + i], ev);
    const Hit h = tracer().trace_recorded(rays[first + i], any_hit, st, ev);
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
                                uint64_t& bytes) const {
  TraversalStats local;
  std::atomic<uint64_t> total{0};
  std::atomic<bool> over{false};
  const int threads = has_units() ? 1 : m_opt.threads;  // a unit is not thread-safe (box_unit.h, tri_unit.h)
  run_batch(count, threads, local, [&](size_t i, TraversalStats& st) {
    std::vector<TraceEvent>& ev = events[i];
    ev.clear();
    if (over.load(std::memory_order_relaxed)) return;  // this attempt is lost anyway
    begin_events(rays[first + i], ev);
    const Hit h = tracer().trace_recorded(rays[first + i], any_hit, st, ev);
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
  TimingStats ts;
  uint64_t cycles;
  ++m_sample_stats.packets;
  m_sample_stats.rays += n;
  SlotTimeAccount& stream =
      m_slot_time[uint32_t(ray_type) << 8 | bounce];  // what this stream's rays showed so far
  const size_t per_unit = warmup_rays(stream, size_t(m_c.ray_slots), m_sample.warmup_rays) + m_sample.unit_rays +
                          2 * size_t(m_c.ray_slots);
  const size_t k = packet_step(n, m_sample.unit_rays, sample_step(m_sample.fraction), per_unit);
  RayPolicy policy = RayPolicy::kWaves;
  if (!parse_ray_policy(m_c.ray_policy, policy)) throw std::logic_error("ray_policy not validated");
  const bool dynamic = chip() && policy == RayPolicy::kDynamic;
  if (chip() && !dynamic && sample_step(m_sample.fraction) >= 2)
    throw std::invalid_argument(
        "sampled timing on a chip needs ray_policy = dynamic (--set ray_policy=dynamic): with " + m_c.ray_policy +
        " each unit's rays are fixed, the packet ends with its slowest unit, and no sample of them estimates that "
        "within the interval (docs/timing-model.md, sampled timing on a chip)");
  try {
    cycles = dynamic  ? trace_cycles_chip_dynamic(rays, hits, n, any_hit, s, ts, sample_step(m_sample.fraction))
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
    while (!record_within(rays, hits, first, count, any_hit, st, ev, count == 1 ? UINT64_MAX : cap, bytes)) {
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

std::vector<std::vector<uint32_t>> TimedEngine::chip_rays(size_t n) const {
  const size_t U = size_t(m_c.units);
  std::vector<std::vector<uint32_t>> mine(U);
  RayPolicy policy = RayPolicy::kWaves;
  if (!parse_ray_policy(m_c.ray_policy, policy)) throw std::logic_error("ray_policy not validated");
  for (size_t i = 0; i < n; ++i) mine[ray_unit(policy, i, n, U, size_t(m_c.ray_slots))].push_back(uint32_t(i));
  return mine;
}

uint64_t TimedEngine::trace_cycles_chip(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                        TimingStats& ts) {
  const size_t U = m_chip_units.size();
  const std::vector<std::vector<uint32_t>> mine = chip_rays(n);
  std::vector<TimingModel*> units;
  for (const auto& unit : m_chip_units) units.push_back(unit.get());
  std::vector<TimingStats> packet(U);
  const uint64_t cycles = run_chip(units, mine, rays, hits, any_hit, s, packet);
  for (size_t u = 0; u < U; ++u) {
    ts.add(packet[u]);
    m_unit_stats[u].add(packet[u]);
  }
  ts.packets = 1;
  ts.cycles = cycles;
  m_sample_stats.rays_simulated += n;
  return cycles;
}

uint64_t TimedEngine::run_chip(const std::vector<TimingModel*>& units,
                               const std::vector<std::vector<uint32_t>>& mine, const Ray* rays, Hit* hits,
                               bool any_hit, TraversalStats& s, std::vector<TimingStats>& packet,
                               std::vector<uint64_t>* ends) {
  const size_t U = units.size();
  // Each unit takes its rays a chunk at a time when it needs the next one (it has taken every ray given). A chunk
  // is recorded (traced by the datapath) into a unit's spare buffer: on a worker thread, in the order the units
  // will ask, while the model runs (with more than one host thread and no attached RTL unit), or when asked.
  // Either way each ray's events, hits and statistics are the same, and so is every cycle.
  //
  // A chunk is at most `chunk` rays and, unless it is one ray, at most m_chunk_event_bytes / U bytes of events,
  // so that the chunks given and recorded ahead hold at most twice m_chunk_event_bytes in all (a ray through
  // many overlapping instances records megabytes): as trace_cycles_full does, a chunk whose events pass that is
  // recorded again with half its rays, and the unit's next chunk tries as many rays as would fill it. The model
  // takes a unit's rays any number at a time, so the cycles do not depend on the bound.
  const size_t chunk = chip_chunk_rays(m_c);
  const uint64_t cap = std::max<uint64_t>(1, m_chunk_event_bytes / std::max<size_t>(1, U));
  struct Chunk {
    std::vector<std::vector<TraceEvent>> events;
    std::vector<Ray> rays;
    std::vector<Hit> hits;
    TraversalStats stats;
    size_t first = 0, count = 0;  // its rays: mine[u][first, first + count)
    std::exception_ptr error;
  };
  std::vector<Chunk> given(U), spare(U);
  std::vector<size_t> next(U, 0);        // the first ray of unit u not yet in a chunk
  std::vector<size_t> want(U, chunk);    // the rays unit u's next chunk tries
  auto fill = [&](size_t u, Chunk& c) {  // the next chunk of unit u's rays, recorded into c
    c.first = next[u];
    c.count = std::min(want[u], mine[u].size() - next[u]);
    c.rays.resize(c.count);
    c.hits.resize(c.count);
    for (size_t j = 0; j < c.count; ++j) c.rays[j] = rays[mine[u][c.first + j]];
    c.events.resize(std::max(c.events.size(), c.count));
    c.stats = TraversalStats{};
    c.error = nullptr;
    try {
      uint64_t bytes = 0;
      while (!record_within(c.rays.data(), c.hits.data(), 0, c.count, any_hit, c.stats, c.events,
                            c.count == 1 ? UINT64_MAX : cap, bytes)) {
        for (size_t i = c.count / 2; i < c.count; ++i) std::vector<TraceEvent>().swap(c.events[i]);
        c.count /= 2;
      }
      const uint64_t fits = bytes > 0 ? uint64_t(c.count) * cap / bytes : chunk;
      want[u] = size_t(std::max<uint64_t>(1, std::min<uint64_t>({chunk, 2 * uint64_t(c.count), fits})));
    } catch (...) {
      c.error = std::current_exception();
    }
    next[u] += c.count;
  };
  // The worker: fills spare[u] for the units in `jobs`, in order; done[u] once spare[u] holds the chunk.
  const bool background = m_opt.threads != 1 && !has_units() && U > 0;
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<size_t> jobs;
  std::vector<uint8_t> done(U, 0);
  bool stop = false;
  std::thread worker;
  auto enqueue = [&](size_t u) {
    if (next[u] >= mine[u].size()) return;  // no rays left for it
    {
      const std::lock_guard<std::mutex> lock(mutex);
      done[u] = 0;
      jobs.push_back(u);
    }
    cv.notify_all();
  };
  const WorkerJoiner joiner{mutex, cv, stop, worker};
  if (background) {
    worker = std::thread([&] {
      for (;;) {
        size_t u;
        {
          std::unique_lock<std::mutex> lock(mutex);
          cv.wait(lock, [&] { return stop || !jobs.empty(); });
          if (stop) return;
          u = jobs.front();
          jobs.pop_front();
        }
        fill(u, spare[u]);
        {
          const std::lock_guard<std::mutex> lock(mutex);
          done[u] = 1;
        }
        cv.notify_all();
      }
    });
    for (size_t u = 0; u < U; ++u) enqueue(u);
  }
  auto give = [&](size_t u) {
    Chunk& c = given[u];
    if (background) {
      {
        std::unique_lock<std::mutex> lock(mutex);
        cv.wait(lock, [&] { return done[u] != 0; });
      }
      std::swap(c, spare[u]);
      enqueue(u);  // the chunk after it, while the model runs this one
    } else {
      fill(u, c);
    }
    if (c.error) std::rethrow_exception(c.error);
    if (c.stats.first_invalid != UINT64_MAX) c.stats.first_invalid = mine[u][c.first + c.stats.first_invalid];
    s.add(c.stats);
    if (hits)
      for (size_t j = 0; j < c.count; ++j) hits[mine[u][c.first + j]] = c.hits[j];
    units[u]->add_rays(c.events.data(), c.count);
  };
  // Every unit starts the packet at the chip's clock; they act in the order of (cycle, unit).
  uint64_t base = 0;
  for (TimingModel* unit : units) base = std::max(base, unit->clock());
  for (size_t u = 0; u < U; ++u) {
    units[u]->advance_to(base);
    units[u]->begin(mine[u].size(), packet[u]);
  }
  const uint64_t end = run_units_in_step(units, base, give);
  for (size_t u = 0; u < U; ++u) packet[u].cycles = end - base;
  if (ends) {
    ends->resize(U);
    for (size_t u = 0; u < U; ++u) (*ends)[u] = std::max(units[u]->end_cycle(), base) - base;
  }
  return end - base;
}

uint64_t TimedEngine::run_chip_dynamic(const std::vector<ChipWave>& waves, const Ray* rays, Hit* hits,
                                       bool any_hit, TraversalStats& s, std::vector<TimingStats>& packet,
                                       std::vector<double>& work) {
  if (m_gather != GatherKey::kNone)
    throw std::invalid_argument("ray_policy = dynamic hands waves to the units; it does not model gather = " +
                                m_c.gather);
  const size_t U = m_chip_units.size(), W = waves.size();
  const double box_rate = double(m_c.box_rate) * m_c.box_units, tri_rate = double(m_c.tri_rate) * m_c.tri_units;
  work.assign(2 * W, 0.0);
  // A wave recorded (traced by the datapath): its events. Its warming rays are recorded when it is given, a
  // wave's worth at a time (below).
  struct Recorded {
    std::vector<std::vector<TraceEvent>> events;
    TraversalStats stats;
    std::exception_ptr error;
  };
  auto record_wave = [&](size_t w, Recorded& r) {
    const ChipWave& cw = waves[w];
    r.stats = TraversalStats{};
    r.error = nullptr;
    r.events.resize(std::max(r.events.size(), cw.count));
    try {
      record(rays, hits, cw.first, cw.count, any_hit, r.stats, r.events, 0);
    } catch (...) {
      r.error = std::current_exception();
    }
  };
  std::vector<std::vector<TraceEvent>> warm_events;  // one skipped wave's events at a time
  // Waves are recorded in order, on a worker thread up to `ahead` waves before the model (with more than one host
  // thread and no attached RTL unit), or when a unit asks. Either way every ray's events are the same, and so is
  // every cycle: which unit takes a wave depends on the model alone.
  const bool background = m_opt.threads != 1 && !has_units();
  const size_t ahead = 2 * U + 2;
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<std::unique_ptr<Recorded>> ready;  // recorded, in order
  std::vector<std::unique_ptr<Recorded>> pool;  // storage to record into
  size_t recorded = 0;
  bool stop = false;
  std::thread worker;
  const WorkerJoiner joiner{mutex, cv, stop, worker};
  if (background)
    worker = std::thread([&] {
      for (;;) {
        std::unique_ptr<Recorded> r;
        size_t w;
        {
          std::unique_lock<std::mutex> lock(mutex);
          cv.wait(lock, [&] { return stop || (recorded < W && ready.size() < ahead); });
          if (stop) return;
          w = recorded++;
          if (!pool.empty()) {
            r = std::move(pool.back());
            pool.pop_back();
          }
        }
        if (!r) r = std::make_unique<Recorded>();
        record_wave(w, *r);
        {
          const std::lock_guard<std::mutex> lock(mutex);
          ready.push_back(std::move(r));
        }
        cv.notify_all();
      }
    });
  std::vector<std::unique_ptr<Recorded>> held(U);  // the wave each unit takes its rays from
  size_t given = 0;
  auto give = [&](size_t u) {
    if (given == W) {
      m_chip_units[u]->close_input();
      return;
    }
    std::unique_ptr<Recorded> r;
    if (background) {
      std::unique_lock<std::mutex> lock(mutex);
      cv.wait(lock, [&] { return !ready.empty(); });
      r = std::move(ready.front());
      ready.pop_front();
    } else {
      r = held[u] ? std::move(held[u]) : std::make_unique<Recorded>();
      record_wave(given, *r);
    }
    cv.notify_all();
    const size_t w = given++;
    if (r->error) std::rethrow_exception(r->error);
    const ChipWave& cw = waves[w];
    // The skipped waves before it, a wave at a time (the events of thousands of waves need not fit at once): each
    // warms the chip's memory (the L2), and the node cache of the unit it would have gone to in turn (its number
    // mod the units), each unit's share under dynamic dispatch (sampler.h). The memory and the node caches are
    // apart, so each sees its lines in the order warming them all at once would.
    TraversalStats warm_stats;
    for (size_t f = cw.warm_first; f < cw.first;) {
      const size_t S = size_t(m_c.ray_slots), wave_no = f / S, c = std::min(cw.first, (wave_no + 1) * S) - f;
      warm_events.resize(std::max(warm_events.size(), c));
      record(rays, hits, f, c, any_hit, warm_stats, warm_events, 0);
      m_chip_units[u]->warm_memory(warm_events.data(), c);
      m_chip_units[wave_no % U]->warm(warm_events.data(), c);
      f += c;
    }
    s.add(warm_stats);
    s.add(r->stats);
    work[2 * w] =
        unit_work(double(cw.count), double(r->stats.box_tests), double(r->stats.prim_tests), box_rate, tri_rate);
    work[2 * w + 1] = unit_work(double(cw.first - cw.warm_first), double(warm_stats.box_tests),
                                double(warm_stats.prim_tests), box_rate, tri_rate);
    m_chip_units[u]->add_rays(r->events.data(), cw.count);
    if (held[u]) {  // the unit has taken every ray of its previous wave: its storage can be recorded into again
      const std::lock_guard<std::mutex> lock(mutex);
      pool.push_back(std::move(held[u]));
    }
    held[u] = std::move(r);
  };
  size_t total = 0;
  for (const ChipWave& cw : waves) total += cw.count;
  uint64_t base = 0;
  std::vector<TimingModel*> units;
  for (const auto& unit : m_chip_units) {
    base = std::max(base, unit->clock());
    units.push_back(unit.get());
  }
  for (size_t u = 0; u < U; ++u) {
    units[u]->advance_to(base);
    units[u]->begin(total, packet[u]);  // an upper bound: close_input() when the waves run out
  }
  const uint64_t end = run_units_in_step(units, base, give);
  for (size_t u = 0; u < U; ++u) packet[u].cycles = end - base;
  return end - base;
}

uint64_t TimedEngine::trace_cycles_chip_dynamic(const Ray* rays, Hit* hits, size_t n, bool any_hit,
                                                TraversalStats& s, TimingStats& ts, size_t k) {
  const size_t U = m_chip_units.size(), S = size_t(m_c.ray_slots), waves = (n + S - 1) / S;
  auto wave = [&](size_t w, size_t warm_first) {
    ChipWave cw;
    cw.first = w * S;
    cw.count = std::min(n, cw.first + S) - cw.first;
    cw.warm_first = std::min(warm_first, cw.first);
    return cw;
  };
  // The waves simulated (sampler.h, chip_thinning) and what each is for: kEdge the lead or the trail, kAside a
  // measured burst's warm-up or tail, else the number of the measured burst it belongs to.
  constexpr size_t kEdge = 0, kAside = 1, kBurst = 2;
  const ChipThinning th = chip_thinning(waves, U, k);
  std::vector<ChipWave> plan;
  std::vector<size_t> role;
  if (!th.sampled) {
    for (size_t w = 0; w < waves; ++w) plan.push_back(wave(w, w * S));
  } else {
    const size_t mid = waves - th.lead - th.trail, B = th.burst * U, bursts = mid / B;
    const size_t offset = size_t(packet_draw(m_sample.seed, m_sample_stats.packets_sampled) % k);
    size_t warm_from = 0;
    for (size_t w = 0; w < waves; ++w) {
      size_t r = kEdge;
      if (w >= th.lead && w < waves - th.trail) {
        const size_t b = (w - th.lead) / B, in = (w - th.lead) % B;
        const bool measured = b < bursts && b % k == offset;
        const bool warmup = b + 1 < bursts && (b + 1) % k == offset && in >= B - th.warm * U;
        const bool tail = b >= 1 && (b - 1) < bursts && (b - 1) % k == offset && in < th.tail * U;
        if (!measured && !warmup && !tail) continue;
        r = measured ? kBurst + b : kAside;
      }
      plan.push_back(wave(w, warm_from));
      role.push_back(r);
      warm_from = (w + 1) * S;
    }
  }
  std::vector<std::vector<uint64_t>> done(U);
  if (th.sampled)
    for (size_t u = 0; u < U; ++u) m_chip_units[u]->record_done(&done[u]);
  std::vector<TimingStats> packet(U);
  std::vector<double> work;
  uint64_t cycles;
  try {
    cycles = run_chip_dynamic(plan, rays, hits, any_hit, s, packet, work);
  } catch (...) {
    for (const auto& unit : m_chip_units) unit->record_done(nullptr);
    throw;
  }
  ts = TimingStats{};
  for (size_t u = 0; u < U; ++u) ts.add(packet[u]);
  if (!th.sampled) {
    for (size_t u = 0; u < U; ++u) m_unit_stats[u].add(packet[u]);
    ts.packets = 1;
    ts.cycles = cycles;
    m_sample_stats.rays_simulated += n;
    return cycles;
  }
  for (const auto& unit : m_chip_units) unit->record_done(nullptr);
  // Every hit written, in order. A burst's cost: the cycles from the last hit of the rays before it to the last of
  // its own (counted in order of writing, as a single unit's sample is). The lead: to the last hit of its rays;
  // the trail: from the last hit of the rays before it to the packet's end.
  std::vector<uint64_t> all;
  for (const auto& d : done) all.insert(all.end(), d.begin(), d.end());
  std::sort(all.begin(), all.end());
  const uint64_t base = m_chip_units[0]->clock() - cycles;  // the units' clocks stand at the thinned packet's end
  ChipSample cs;
  size_t before = 0, p = 0, simulated = 0;
  for (const ChipWave& cw : plan) simulated += cw.count;
  for (; p < plan.size() && role[p] == kEdge; ++p) before += plan[p].count;
  cs.lead_done = all[before - 1];
  for (; p < plan.size() && role[p] != kEdge; ++p) {
    cs.skipped_work += work[2 * p + 1];
    if (role[p] == kAside) {
      cs.skipped_work += work[2 * p];
    } else {
      if (role[p - 1] != role[p]) {
        cs.measured_c.push_back(-double(all[before - 1]));
        cs.measured_a.push_back(0.0);
        cs.sampled += double(th.burst * U);
      }
      cs.measured_a.back() += work[2 * p];
      if (role[p + 1] != role[p]) cs.measured_c.back() += double(all[before + plan[p].count - 1]);
    }
    before += plan[p].count;
  }
  cs.skipped_work += work[2 * p + 1];  // the waves skipped before the trail
  cs.mid_done = all[before - 1];
  cs.end = base + cycles;
  cs.population = double(waves - th.lead - th.trail);
  const CycleEstimate est = estimate_chip_cycles(cs, base);
  cycles = uint64_t(std::llround(est.cycles));
  for (const auto& unit : m_chip_units) unit->advance_to(base + cycles);
  scale_sampled(ts, double(n) / double(simulated));
  ts.packets = 1;
  ts.cycles = cycles;
  ts.rays = n;
  ++m_sample_stats.packets_sampled;
  m_sample_stats.rays_simulated += simulated;
  m_sample_stats.rays_warmed += n - simulated;
  m_sample_stats.units_measured += cs.measured_c.size();
  m_sample_stats.variance += est.variance;
  return cycles;
}

void TimedEngine::set_sampling(const SampleOptions& o) {
  if (!(o.fraction >= 0.0 && o.fraction <= 1.0))
    throw std::invalid_argument("sampled timing: the fraction must be in [0, 1]");
  if (o.unit_rays == 0) throw std::invalid_argument("sampled timing: a unit needs at least one ray");
  // Functional warming brings in the demand lines only; a sampled unit with a prefetcher would start from a cache
  // without the prefetched lines, an estimate of a different unit.
  if (sample_step(o.fraction) >= 2 && m_c.prefetcher != "none")
    throw std::invalid_argument("sampled timing: warming does not model prefetched lines; run prefetcher = " +
                                m_c.prefetcher + " unsampled (no --sample)");
  // The gathering unit reorders a packet's rays across the units sampling measures one by one.
  if (sample_step(o.fraction) >= 2 && m_c.gather != "none")
    throw std::invalid_argument("sampled timing: the units it measures do not model ray gathering; run gather = " +
                                m_c.gather + " unsampled (no --sample)");
  m_sample = o;
}

TimedEngine::UnitAux TimedEngine::probe_units(const Ray* rays, Hit* hits, size_t n, bool any_hit,
                                              TraversalStats& s, uint64_t draw, double box_rate, double tri_rate) {
  const size_t U = m_sample.unit_rays, units = (n + U - 1) / U;
  // The auxiliary per unit, from the datapath's test counts: every ray when hits are needed (they are traced for
  // their hits anyway), else one probed ray per block of kProbe (scaled up; the measured units' exact values
  // replace their estimates below).
  constexpr size_t kProbe = 32;
  const std::vector<size_t> probed = probe_rays(n, m_sample.need_hits ? 1 : kProbe, draw);
  const size_t probes = probed.size();
  std::vector<uint32_t> box(probes), prim(probes);
  TraversalStats probe_stats;
  run_batch(probes, has_units() ? 1 : m_opt.threads, m_sample.need_hits ? s : probe_stats,
            [&](size_t q, TraversalStats& st) {
              const size_t i = probed[q];
              // The hardware prefetcher follows a constant stride, not these: fetch a few rays ahead.
              if (q + 8 < probes) __builtin_prefetch(&rays[probed[q + 8]]);
              const uint64_t b0 = st.box_tests, p0 = st.prim_tests;
              const Hit h = tracer().trace(rays[i], any_hit, st);
              if (m_sample.need_hits) hits[i] = h;
              box[q] = uint32_t(st.box_tests - b0);
              prim[q] = uint32_t(st.prim_tests - p0);
            });
  const uint64_t stuck = m_sample.need_hits ? s.watchdog_rays : probe_stats.watchdog_rays;
  if (stuck > 0) throw WatchdogError(tracer().watchdog_report(rays, n, any_hit, stuck), 0);
  std::vector<double> unit_box(units), unit_prim(units), unit_probes(units);
  for (size_t q = 0; q < probes; ++q) {
    const size_t j = probed[q] / U;
    unit_box[j] += box[q];
    unit_prim[j] += prim[q];
    unit_probes[j] += 1.0;
  }
  UnitAux a;
  a.aux.resize(units);
  a.tests_prims.resize(units);  // the unit's probed rays test a primitive (the strata)
  for (size_t j = 0; j < units; ++j) {
    const double rays_in_unit = double(std::min(n, (j + 1) * U) - j * U),
                 scale = unit_probes[j] > 0.0 ? rays_in_unit / unit_probes[j] : 0.0;
    a.aux[j] = unit_work(rays_in_unit, unit_box[j] * scale, unit_prim[j] * scale, box_rate, tri_rate);
    a.tests_prims[j] = unit_prim[j] > 0.0;
  }
  return a;
}

uint64_t TimedEngine::trace_cycles_sampled(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s,
                                           TimingStats& ts, size_t k, SlotTimeAccount& slot_time) {
  const size_t U = m_sample.unit_rays, slots = size_t(m_c.ray_slots);
  const size_t units = (n + U - 1) / U;  // unit 0 is simulated from the packet's start; 1 .. units-1 sampled
  const uint64_t draw = packet_draw(m_sample.seed, m_sample_stats.packets_sampled);

  const double box_rate = double(m_c.box_rate) * m_c.box_units, tri_rate = double(m_c.tri_rate) * m_c.tri_units;
  UnitAux probed_units = probe_units(rays, hits, n, any_hit, s, draw, box_rate, tri_rate);
  std::vector<double>& aux = probed_units.aux;
  const std::vector<uint8_t>& tests_prims = probed_units.tests_prims;
  TraversalStats scratch;
  TraversalStats& seg_stats = m_sample.need_hits ? scratch : s;

  TimingStats sim;  // what the model simulated
  std::vector<std::vector<TraceEvent>> events;
  std::vector<uint64_t> done, entered, written;
  m_model->record_done(&written, &entered);
  uint64_t simulated = 0, warmed = 0;

  // Functional warming of the cache before ray `end` (a detailed warm-up's first), for the `sim` rays simulated
  // from there on (their events in events[0, sim)): the rays before it are walked backwards in chunks (each traced
  // forward, with recording) until at most kUndetermined of the lines the simulated rays touch are undetermined or
  // cache_warm_rays are walked, then installed as warming with them in forward order would. The lines left
  // undetermined belong to sets so rarely used that a few thousand rays do not fill them; the cache keeps what
  // earlier units left there. The walk stops at the ray with which the count reaches the bound, wherever it lies
  // in the chunk: the rays warmed do not depend on the chunks, which only decide how many rays are traced and not
  // used. Chunks double from 32 rays up to kWalkChunkMax.
  constexpr double kUndetermined = 0.10;
  constexpr size_t kWalkChunkMax = 64;
  const size_t CW = m_sample.cache_warm_rays;
  // One chunk's events at a time: the walk keeps the lines it saw, not the events (at most kWalkChunkMax rays'
  // events are held, not cache_warm_rays').
  std::vector<std::vector<TraceEvent>> walk_events(kWalkChunkMax);
  auto warm_before = [&](size_t end, size_t sim) {
    const size_t reach = std::min(CW, end);
    m_model->walk_begin(events.data(), sim);
    const size_t enough = size_t(kUndetermined * double(m_model->walk_lines()));
    size_t traced = 0, chunk = 32;
    while (traced < reach && m_model->walk_open() > enough) {
      const size_t c = std::min(chunk, reach - traced);
      TraversalStats other;
      record(rays, nullptr, end - traced - c, c, any_hit, other, walk_events, 0);
      const size_t taken = m_model->walk_add(walk_events.data(), c, enough);
      traced += c;
      if (taken < c) break;
      chunk = std::min<size_t>(2 * chunk, kWalkChunkMax);
    }
    m_model->walk_install();
    warmed += traced;
  };
  // Simulates w warm-up rays, the u rays from `first` on and t tail rays after them as one packet (done: the
  // sorted hit-write cycles); returns the datapath statistics of the u rays. The measured rays' cost is read
  // between the w-th and the (w + u)-th hit written: with rays in flight on both sides, in steady state. A full
  // measured unit adds its rays' slot time to the stream's account (the warm-up's length).
  auto segment = [&](size_t first, size_t w, size_t u, size_t t, bool warm) {
    events.resize(std::max(events.size(), w + u + t));
    TraversalStats other, st;
    record(rays, nullptr, first - w, w, any_hit, other, events, 0);
    record(rays, nullptr, first, u, any_hit, st, events, w);
    record(rays, nullptr, first + u, t, any_hit, other, events, w + u);
    if (warm) warm_before(first - w, w + u + t);
    done.clear();
    m_model->begin(w + u + t, sim);
    m_model->feed(events.data(), w + u + t);
    m_model->finish();
    done = written;
    std::sort(done.begin(), done.end());
    if (w > 0 && u == U && t > 0 && m_sample.warmup_rays == 0)
      account_slot_time(slot_time, done, written, entered, w, U, slots);
    written.clear();
    entered.clear();
    simulated += w + u + t;
    return st;
  };
  auto warmup = [&] { return warmup_rays(slot_time, slots, m_sample.warmup_rays); };
  // Tail rays: enough to keep every slot busy past the measured rays' last hit (once the last measured ray has
  // entered, at most ray_slots - 1 others are in flight), twice that for margin.
  const size_t tail = 2 * slots;
  const uint64_t start = m_model->clock();
  // The first unit, from the packet's start (its fill), and the last unit, to the packet's end (its drain),
  // exactly; the units between by the sample, measured in the order of the rays (each after its warm-up, the
  // cache carried from the one before).
  const size_t last = units - 1, u_last = n - last * U;
  seg_stats.add(segment(0, 0, U, std::min(tail, n - U), false));
  const uint64_t first_cycles = done[U - 1] - start;

  std::vector<Stratum> strata = choose_strata(aux, tests_prims, k, draw);
  std::vector<std::pair<size_t, size_t>> order;  // (unit, stratum)
  for (size_t h = 0; h < strata.size(); ++h)
    for (size_t j : strata[h].picked) order.push_back({j, h});
  std::sort(order.begin(), order.end());
  uint64_t warmup_total = 0;
  for (const auto& [j, h] : order) {
    const size_t u0 = j * U, w = std::min(warmup(), u0), t = std::min(tail, n - u0 - U);
    warmup_total += w;
    const TraversalStats st = segment(u0, w, U, t, true);
    seg_stats.add(st);
    strata[h].measured_c.push_back(double(done[w + U - 1] - done[w - 1]));
    // A measured unit's rays were all traced: its exact work replaces the probe's estimate of it (two-phase
    // sampling; the same where every ray is probed).
    const double exact = unit_work(double(U), double(st.box_tests), double(st.prim_tests), box_rate, tri_rate);
    strata[h].probe_error2 += (aux[j] - exact) * (aux[j] - exact);
    aux[j] = exact;
  }
  // The last unit, after the sampled ones (the cache as they and its functional warming leave it).
  const size_t w_last = std::min(warmup(), last * U);
  seg_stats.add(segment(last * U, w_last, u_last, 0, true));
  const uint64_t last_cycles = done.back() - done[w_last - 1];
  m_model->record_done(nullptr);

  const CycleEstimate estimate = estimate_cycles(strata, aux, double(first_cycles) + double(last_cycles));
  const uint64_t cycles = uint64_t(std::llround(estimate.cycles));
  m_model->advance_to(start + cycles);

  // The packet's statistics: the simulated rays' counters scaled to the packet, the estimated cycles.
  ts = sim;
  scale_sampled(ts, double(n) / double(simulated));
  ts.packets = 1;
  ts.cycles = cycles;
  ts.rays = n;
  ++m_sample_stats.packets_sampled;
  m_sample_stats.rays_simulated += simulated;
  m_sample_stats.rays_warmed += warmed;
  m_sample_stats.units_measured += order.size();
  m_sample_stats.warmup_rays += warmup_total;
  if (strata.size() > 1) ++m_sample_stats.packets_stratified;
  m_sample_stats.variance += estimate.variance;
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
