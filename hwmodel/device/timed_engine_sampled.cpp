// Sampled timing on the timed engine (timed_engine.h, sampler.h): set_sampling, and a TRACE packet of one unit of
// which only some units of rays go through the timing model. Every ray's work is estimated from a probe of the
// datapath (probe_units), the units are stratified and sampled, each measured unit is simulated after a detailed
// warm-up with the cache warmed functionally before it (warm_cache_before), and the packet's cycles are estimated
// with their interval. A chip's sampled packets are timed_engine_chip.cpp's (trace_cycles_chip_dynamic).
#include "hwmodel/device/timed_engine.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "hwmodel/datapath/batch.h"

namespace rtu::hw {

namespace {

// Functional warming (warm_cache_before): the walk stops once at most kUndetermined of the lines the simulated
// rays touch are undetermined; it traces chunks of rays doubling from 32 up to kWalkChunkMax.
constexpr double kUndetermined = 0.10;
constexpr size_t kWalkChunkMax = 64;

}  // namespace

void TimedEngine::set_sampling(const SampleOptions& o) {
  if (!(o.fraction >= 0.0 && o.fraction <= 1.0))
    throw std::invalid_argument("sampled timing: the fraction must be in [0, 1]");
  if (o.unit_rays == 0) throw std::invalid_argument("sampled timing: a unit needs at least one ray");
  // Functional warming brings in the demand lines only; a sampled unit with a prefetcher would start from a cache
  // without the prefetched lines, an estimate of a different unit.
  if (sample_step(o.fraction) >= 2 && m_c.prefetcher != PrefetcherId::kNone)
    throw std::invalid_argument("sampled timing: warming does not model prefetched lines; run prefetcher = " +
                                std::string(name_of(m_c.prefetcher)) + " unsampled (no --sample)");
  // The backward walk determines the node cache's lines only.
  if (sample_step(o.fraction) >= 2 && m_c.omm_cache_kib > 0)
    throw std::invalid_argument(
        "sampled timing: its warming does not model the micromap cache; run omm_cache_kib = " +
        std::to_string(m_c.omm_cache_kib) + " unsampled (no --sample)");
  // The gathering unit reorders a packet's rays across the units sampling measures one by one.
  if (sample_step(o.fraction) >= 2 && m_c.gather != GatherKey::kNone)
    throw std::invalid_argument("sampled timing: the units it measures do not model ray gathering; run gather = " +
                                std::string(name_of(m_c.gather)) + " unsampled (no --sample)");
  // A queued DRAM's decisions wait for every request up to their cycle; the units sampling measures are not
  // the whole packet's (memory/dram_scheduler.h).
  if (sample_step(o.fraction) >= 2 && m_c.dram_scheduler != DramScheduler::kFcfs)
    throw std::invalid_argument("sampled timing: dram_scheduler = " + std::string(name_of(m_c.dram_scheduler)) +
                                " is not built for it; run it unsampled (no --sample)");
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

// Functional warming of the cache before ray `end` (a detailed warm-up's first), for the `sim` rays simulated from
// there on (their events in events[0, sim)): the rays before it are walked backwards in chunks (each traced
// forward, with recording) until at most kUndetermined of the lines the simulated rays touch are undetermined or
// cache_warm_rays are walked, then installed as warming with them in forward order would. The lines left
// undetermined belong to sets so rarely used that a few thousand rays do not fill them; the cache keeps what
// earlier units left there. The walk stops at the ray with which the count reaches the bound, wherever it lies in
// the chunk: the rays warmed do not depend on the chunks, which only decide how many rays are traced and not
// used. Chunks double from 32 rays up to kWalkChunkMax. Returns the rays walked.
size_t TimedEngine::warm_cache_before(const Ray* rays, bool any_hit, size_t end,
                                      const std::vector<TraceEvent>* events, size_t sim,
                                      std::vector<std::vector<TraceEvent>>& walk_events) {
  const size_t CW = m_sample.cache_warm_rays;
  const size_t reach = std::min(CW, end);
  m_model->walk_begin(events, sim);
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
  return traced;
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

  // Functional warming's walk (warm_cache_before) takes one chunk's events at a time: the walk keeps the lines it
  // saw, not the events (at most kWalkChunkMax rays' events are held, not cache_warm_rays').
  std::vector<std::vector<TraceEvent>> walk_events(kWalkChunkMax);
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
    if (warm) warmed += warm_cache_before(rays, any_hit, first - w, events.data(), w + u + t, walk_events);
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
  finish_sampled_packet(ts, n, simulated, warmed, order.size(), cycles, estimate.variance);
  m_sample_stats.warmup_rays += warmup_total;
  if (strata.size() > 1) ++m_sample_stats.packets_stratified;
  return cycles;
}

void TimedEngine::finish_sampled_packet(TimingStats& ts, uint64_t n, uint64_t simulated, uint64_t warmed,
                                        uint64_t units, uint64_t cycles, double variance) {
  scale_sampled(ts, double(n) / double(simulated));
  ts.packets = 1;
  ts.cycles = cycles;
  ts.rays = n;
  ++m_sample_stats.packets_sampled;
  m_sample_stats.rays_simulated += simulated;
  m_sample_stats.rays_warmed += warmed;
  m_sample_stats.units_measured += units;
  m_sample_stats.variance += variance;
}

void TimedEngine::unthinned(const std::string& why) {
  ++m_sample_stats.packets_unthinned;
  if (m_sample_stats.unthinned_why.empty()) m_sample_stats.unthinned_why = why;
}

}  // namespace rtu::hw
