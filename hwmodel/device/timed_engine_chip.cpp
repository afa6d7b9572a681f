// A chip's TRACE packets on the timed engine (timed_engine.h): units > 1 sharing one memory, run in step by
// run_units_in_step (timing_model.h). With a fixed ray policy each unit is given its rays a chunk at a time
// (trace_cycles_chip, run_chip); with ray_policy dynamic the dispatcher hands each wave to whichever unit asks
// first, every wave simulated or, sampled, the waves thinned (trace_cycles_chip_dynamic, run_chip_dynamic). The
// datapath records rays ahead of the model, on a worker thread when the host has more than one; the cycles do not
// depend on it.
#include "hwmodel/device/timed_engine.h"

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include "hwmodel/timing/ray_scheduler.h"

namespace rtu::hw {

namespace {

// Stops and joins the recording workers however the function that started them ends (they use that frame's
// buffers).
struct WorkerJoiner {
  std::mutex& m;
  std::condition_variable& cv;
  bool& stop;
  std::vector<std::thread>& t;
  ~WorkerJoiner() {
    {
      const std::lock_guard<std::mutex> lock(m);
      stop = true;
    }
    cv.notify_all();
    for (std::thread& w : t)
      if (w.joinable()) w.join();
  }
};

}  // namespace

std::vector<std::vector<uint32_t>> TimedEngine::chip_rays(size_t n) const {
  const size_t U = size_t(m_c.units);
  std::vector<std::vector<uint32_t>> mine(U);
  const RayPolicy policy = m_c.ray_policy;
  for (size_t i = 0; i < n; ++i) mine[ray_unit(policy, i, n, U, size_t(m_c.ray_slots))].push_back(uint32_t(i));
  return mine;
}

TimedEngine::ChipThreads TimedEngine::chip_threads() const {
  static const int hw = std::max(1, int(std::thread::hardware_concurrency()));
  const int T = m_opt.threads > 0 ? m_opt.threads : hw;
  if (T == 1 || has_units()) return {1, 0};  // an attached unit is not thread-safe (box_unit.h, tri_unit.h)
  // Recording a ray takes about half of what replaying it does on a unit (rdna2-chip, the atrium: 1.6 s against
  // 3.4 s of one thread, bench/results/simulator-speed.md): two threads of three replay, one records. Two host
  // threads keep one unit thread: deferring the units' memory requests costs more than a second unit thread
  // gains while the recording thread shares the two cores.
  const int units = std::max(1, 2 * T / 3);
  return {units, T - units};
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

// A chunk of one chip unit's rays, recorded for it (run_chip): copies of the rays, their hits and events, the
// datapath's statistics, or the error recording them threw.
struct TimedEngine::ChipChunk {
  std::vector<std::vector<TraceEvent>> events;
  std::vector<Ray> rays;
  std::vector<Hit> hits;
  std::vector<Hit> lists;  // an all-hit packet's lists (k per ray), counts below
  std::vector<uint64_t> counts;
  TraversalStats stats;
  size_t first = 0, count = 0;  // its rays: mine[u][first, first + count)
  std::exception_ptr error;
};

void TimedEngine::record_chip_chunk(const std::vector<uint32_t>& mine, const Ray* rays, bool any_hit, size_t chunk,
                                    uint64_t cap, size_t& next, size_t& want, ChipChunk& c) const {
  c.first = next;
  c.count = std::min(want, mine.size() - next);
  c.rays.resize(c.count);
  c.hits.resize(c.count);
  for (size_t j = 0; j < c.count; ++j) c.rays[j] = rays[mine[c.first + j]];
  c.events.resize(std::max(c.events.size(), c.count));
  c.stats = TraversalStats{};
  c.error = nullptr;
  AllHitsOut all;
  if (m_all) {
    c.lists.resize(c.count * size_t(m_all->k));
    c.counts.resize(c.count);
    all = AllHitsOut{m_all->k, c.lists.data(), c.counts.data()};
  }
  try {
    uint64_t bytes = 0;
    while (!record_within(c.rays.data(), c.hits.data(), 0, c.count, any_hit, c.stats, c.events,
                          c.count == 1 ? UINT64_MAX : cap, bytes, m_all ? &all : nullptr)) {
      for (size_t i = c.count / 2; i < c.count; ++i) std::vector<TraceEvent>().swap(c.events[i]);
      c.count /= 2;
    }
    const uint64_t fits = bytes > 0 ? uint64_t(c.count) * cap / bytes : chunk;
    want = size_t(std::max<uint64_t>(1, std::min<uint64_t>({chunk, 2 * uint64_t(c.count), fits})));
  } catch (...) {
    c.error = std::current_exception();
  }
  next += c.count;
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
  std::vector<ChipChunk> given(U), spare(U);
  std::vector<size_t> next(U, 0);            // the first ray of unit u not yet in a chunk
  std::vector<size_t> want(U, chunk);        // the rays unit u's next chunk tries
  auto fill = [&](size_t u, ChipChunk& c) {  // the next chunk of unit u's rays, recorded into c
    record_chip_chunk(mine[u], rays, any_hit, chunk, cap, next[u], want[u], c);
  };
  // The worker: fills spare[u] for the units in `jobs`, in order; done[u] once spare[u] holds the chunk.
  const bool background = m_opt.threads != 1 && !has_units() && U > 0;
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<size_t> jobs;
  std::vector<uint8_t> done(U, 0);
  bool stop = false;
  std::vector<std::thread> workers;
  auto enqueue = [&](size_t u) {
    if (next[u] >= mine[u].size()) return;  // no rays left for it
    {
      const std::lock_guard<std::mutex> lock(mutex);
      done[u] = 0;
      jobs.push_back(u);
    }
    cv.notify_all();
  };
  const WorkerJoiner joiner{mutex, cv, stop, workers};
  const ChipThreads threads = chip_threads();
  if (background) {
    // A unit has at most one chunk asked for at a time (enqueue after its spare is taken), so the workers never
    // record for the same unit at once.
    for (int w = 0; w < std::max(1, threads.recording); ++w)
      workers.emplace_back([&] {
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
    ChipChunk& c = given[u];
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
    if (m_all)
      for (size_t j = 0; j < c.count; ++j) {
        const size_t i = mine[u][c.first + j], k = m_all->k;
        m_all->counts[i] = c.counts[j];
        std::copy_n(c.lists.data() + j * k, std::min<uint64_t>(c.counts[j], k), m_all->lists + i * k);
      }
    units[u]->add_rays(c.events.data(), c.count);
  };
  // Every unit starts the packet at the chip's clock; they act in the order of (cycle, unit).
  uint64_t base = 0;
  for (TimingModel* unit : units) base = std::max(base, unit->clock());
  for (size_t u = 0; u < U; ++u) {
    units[u]->advance_to(base);
    units[u]->begin(mine[u].size(), packet[u]);
  }
  const uint64_t end = run_units_in_step(units, base, give, threads.units);
  for (size_t u = 0; u < U; ++u) packet[u].cycles = end - base;
  if (ends) {
    ends->resize(U);
    for (size_t u = 0; u < U; ++u) (*ends)[u] = std::max(units[u]->end_cycle(), base) - base;
  }
  return end - base;
}

// The skipped waves before wave cw (its warming rays, recorded by the datapath into `events`, one per ray from
// cw.warm_first), a wave at a time: each warms the chip's memory (the L2), and the node cache of the unit it would
// have gone to in turn (its number mod the units), each unit's share under dynamic dispatch (sampler.h). The
// memory and the node caches are apart, so each sees its lines in the order warming them all at once would.
void TimedEngine::warm_chip(size_t u, const ChipWave& cw, const std::vector<std::vector<TraceEvent>>& events) {
  const size_t U = m_chip_units.size();
  for (size_t f = cw.warm_first; f < cw.first;) {
    const size_t S = size_t(m_c.ray_slots), wave_no = f / S, c = std::min(cw.first, (wave_no + 1) * S) - f;
    const std::vector<TraceEvent>* ev = events.data() + (f - cw.warm_first);
    m_chip_units[u]->warm_memory(ev, c);
    m_chip_units[wave_no % U]->warm(ev, c);
    f += c;
  }
}

namespace {

// Whether a wave has warming rays: given, they warm other units' caches (warm_chip), so the units act on one
// thread.
template <class Waves>
bool warms_units(const Waves& waves) {
  return std::any_of(waves.begin(), waves.end(), [](const auto& cw) { return cw.warm_first < cw.first; });
}

}  // namespace

uint64_t TimedEngine::run_chip_dynamic(const std::vector<ChipWave>& waves, const Ray* rays, Hit* hits,
                                       bool any_hit, TraversalStats& s, std::vector<TimingStats>& packet,
                                       std::vector<double>& work) {
  if (m_gather != GatherKey::kNone)
    throw std::invalid_argument("ray_policy = dynamic hands waves to the units; it does not model gather = " +
                                std::string(name_of(m_c.gather)));
  const size_t U = m_chip_units.size(), W = waves.size();
  const double box_rate = double(m_c.box_rate) * m_c.box_units, tri_rate = double(m_c.tri_rate) * m_c.tri_units;
  work.assign(2 * W, 0.0);
  // A wave recorded (traced by the datapath): its events, and those of its warming rays (the skipped waves before
  // it, sampled: kept until the wave is given, then freed; only the first wave after each skip has them).
  struct Recorded {
    std::vector<std::vector<TraceEvent>> events, warm;
    TraversalStats stats, warm_stats;
    std::exception_ptr error;
  };
  auto record_wave = [&](size_t w, Recorded& r) {
    const ChipWave& cw = waves[w];
    r.stats = r.warm_stats = TraversalStats{};
    r.error = nullptr;
    r.events.resize(std::max(r.events.size(), cw.count));
    r.warm.resize(cw.first - cw.warm_first);
    try {
      if (!r.warm.empty()) record(rays, hits, cw.warm_first, r.warm.size(), any_hit, r.warm_stats, r.warm, 0);
      record(rays, hits, cw.first, cw.count, any_hit, r.stats, r.events, 0);
    } catch (...) {
      r.error = std::current_exception();
    }
  };
  // Waves are recorded in order, with their warming rays, on a worker thread up to `ahead` waves before the model
  // (with more than one host thread and no attached RTL unit), or when a unit asks. Either way every ray's events
  // are the same, and so is every cycle: which unit takes a wave depends on the model alone.
  const bool background = m_opt.threads != 1 && !has_units();
  const size_t ahead = 2 * U + 2;
  std::mutex mutex;
  std::condition_variable cv;
  std::deque<std::unique_ptr<Recorded>> ready;  // recorded, in order
  std::vector<std::unique_ptr<Recorded>> pool;  // storage to record into
  size_t recorded = 0;
  bool stop = false;
  std::vector<std::thread> worker;  // one: the waves come out in order
  const WorkerJoiner joiner{mutex, cv, stop, worker};
  if (background)
    worker.emplace_back([&] {
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
    warm_chip(u, cw, r->warm);
    std::vector<std::vector<TraceEvent>>().swap(r->warm);
    const TraversalStats& warm_stats = r->warm_stats;
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
  const uint64_t end = run_units_in_step(units, base, give, warms_units(waves) ? 1 : chip_threads().units);
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
    if (k >= 2) unthinned(th.why_not);
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
  finish_sampled_packet(ts, n, simulated, n - simulated, cs.measured_c.size(), cycles, est.variance);
  return cycles;
}

}  // namespace rtu::hw
