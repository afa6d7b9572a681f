// run_units_in_step on several host threads (timing_model.h): a conservative parallel simulation of a chip's
// units, whose only shared part is the memory behind their caches. Every read of it answers at least the memory's
// lookahead (MemoryBackend::min_answer_cycles) after its request, so in a window of that many cycles no unit acts
// on anything another unit did in it: the units act on their threads to the window's end with their requests held
// (defer(), memory/deferred_memory.h), then the calling thread serves the held requests in the order of (action
// cycle, unit, request), which is the order in which the units acting in step on one thread make them, and their
// answers wake the slots that wait for them, after the window. Units that need rays inside a window are given them
// on the calling thread, earliest (cycle, unit) first as on one thread, and finish the window there. So the cycles
// and every statistic are those of the units acting in step on one thread, whatever the number of threads.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <functional>
#include <stdexcept>
#include <thread>
#include <utility>
#include <vector>

#include "hwmodel/timing/timing_model.h"

namespace rtu::hw {

namespace {

// Waits until done(a's value), spinning briefly (a window's work on the other threads is short) and then
// sleeping in the kernel (a host thread may be busy recording rays, or the host has fewer cores than threads).
template <class T, class Done>
void await(const std::atomic<T>& a, Done done) {
  for (int i = 0; i < 512; ++i) {
    if (done(a.load(std::memory_order_acquire))) return;
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  }
  for (;;) {
    const T v = a.load(std::memory_order_acquire);
    if (done(v)) return;
    a.wait(v, std::memory_order_acquire);
  }
}

// The calling thread and n - 1 workers: round() has every thread j run work(j) once, the caller's share (j = 0)
// on the calling thread, and returns when all are done.
class Crew {
 public:
  Crew(int n, std::function<void(int)> work) : m_n(n), m_work(std::move(work)) {
    for (int j = 1; j < n; ++j) m_threads.emplace_back([this, j] { serve(j); });
  }
  ~Crew() {
    m_stop.store(true, std::memory_order_release);
    m_round.fetch_add(1, std::memory_order_acq_rel);
    m_round.notify_all();
    for (std::thread& t : m_threads) t.join();
  }
  Crew(const Crew&) = delete;
  Crew& operator=(const Crew&) = delete;
  void round() {
    m_left.store(m_n - 1, std::memory_order_release);
    m_round.fetch_add(1, std::memory_order_acq_rel);
    m_round.notify_all();
    m_work(0);
    await(m_left, [](int left) { return left == 0; });
  }

 private:
  void serve(int j) {
    uint32_t seen = 0;
    for (;;) {
      await(m_round, [&](uint32_t r) { return r != seen; });
      seen = m_round.load(std::memory_order_acquire);
      if (m_stop.load(std::memory_order_acquire)) return;
      m_work(j);
      if (m_left.fetch_sub(1, std::memory_order_acq_rel) == 1) m_left.notify_one();
    }
  }
  int m_n;
  std::function<void(int)> m_work;
  std::atomic<uint32_t> m_round{0};
  std::atomic<int> m_left{0};
  std::atomic<bool> m_stop{false};
  std::vector<std::thread> m_threads;
};

// The held requests of every unit in the window [from, limit], served in the order of (action cycle, unit,
// request): a counting sort by the action's cycle in the window, taking the units in order and each unit's
// requests in order. Returns the earliest data cycle of a read served (no slot wakes before it once the units
// settle them).
class Server {
 public:
  uint64_t serve(const std::vector<TimingModel*>& units, uint64_t from, uint64_t limit) {
    const uint64_t span = limit - from + 1;
    if (span > (uint64_t(1) << 20)) throw std::logic_error("timing model: a window too long to sort");
    m_count.assign(size_t(span) + 1, 0);
    size_t total = 0;
    for (const TimingModel* unit : units) {
      for (const DeferredMemory::Request& r : unit->held()) {
        if (r.action < from || r.action > limit)
          throw std::logic_error("timing model: a request outside its window");
        ++m_count[size_t(r.action - from) + 1];
      }
      total += unit->held().size();
    }
    for (size_t i = 1; i < m_count.size(); ++i) m_count[i] += m_count[i - 1];
    m_order.resize(total);
    for (size_t u = 0; u < units.size(); ++u) {
      const std::vector<DeferredMemory::Request>& held = units[u]->held();
      for (size_t i = 0; i < held.size(); ++i)
        m_order[m_count[size_t(held[i].action - from)]++] = {uint32_t(u), uint32_t(i)};
    }
    uint64_t first = TimingModel::kNever;
    for (const auto& [u, i] : m_order) first = std::min(first, units[u]->serve_held(i));
    return first;
  }

 private:
  std::vector<uint32_t> m_count;
  std::vector<std::pair<uint32_t, uint32_t>> m_order;  // (unit, request)
};

// Which units each thread runs: thread j the units [first(j), first(j + 1)), the same units round after round,
// whose state then stays in its core's caches (units handed to whichever thread was free ran no faster here,
// their state moving between cores). Every kBalance rounds the split follows the time each thread took (host
// cores may differ in speed or share with recording threads): each thread's share moves halfway to what its
// speed (units per second of its rounds) earns. Which thread runs a unit changes no result.
class Split {
 public:
  static constexpr uint64_t kBalance = 64;
  Split(size_t units, size_t threads) : m_units(units), m_first(threads + 1), m_busy(threads, 0.0) {
    for (size_t j = 0; j <= threads; ++j) m_first[j] = j * units / threads;
  }
  size_t first(size_t j) const { return m_first[j]; }
  void add_busy(size_t j, double seconds) { m_busy[j] += seconds; }  // on thread j
  void round_done() {
    if (++m_rounds % kBalance != 0) return;
    const size_t n = m_busy.size();
    std::vector<double> rate(n);
    double total = 0;
    for (size_t j = 0; j < n; ++j)
      total += rate[j] = double(m_first[j + 1] - m_first[j]) / std::max(m_busy[j], 1e-9);
    double cum = 0;
    for (size_t j = 1; j < n; ++j) {
      cum += rate[j - 1];
      const double target = double(m_units) * cum / total;
      const size_t b = size_t(0.5 * double(m_first[j]) + 0.5 * target + 0.5);
      m_first[j] = std::clamp(b, m_first[j - 1] + 1, m_units - (n - j));
    }
    std::fill(m_busy.begin(), m_busy.end(), 0.0);
  }

 private:
  size_t m_units;
  std::vector<size_t> m_first;
  std::vector<double> m_busy;
  uint64_t m_rounds = 0;
};

// Every unit goes back to the shared memory however run_units_threaded ends, its held requests served (unless
// they were) and settled (after an error too, so that no pending cycle is left in a cache).
struct Undefer {
  const std::vector<TimingModel*>& units;
  Server& server;
  const uint64_t& from;
  const uint64_t& limit;
  const bool& unserved;
  ~Undefer() {
    try {
      if (unserved) server.serve(units, from, limit);
      for (TimingModel* unit : units) unit->settle_held();
    } catch (...) {
    }
    for (TimingModel* unit : units) unit->defer(false);
  }
};

}  // namespace

uint64_t run_units_threaded(const std::vector<TimingModel*>& units, uint64_t start,
                            const std::function<void(size_t)>& give, int threads) {
  const size_t U = units.size();
  const size_t n = std::min(size_t(threads), U);
  uint64_t lookahead = TimingModel::kNever;
  for (const TimingModel* unit : units) lookahead = std::min(lookahead, unit->lookahead());
  std::vector<std::exception_ptr> errors(U);
  uint64_t from = 0, limit = 0;  // the window's first and last cycle
  bool unserved = false;         // requests held since the last serve
  // A unit settles the answers served after the last window (on a round; given units have) and acts to the
  // window's end; what it throws is kept for the calling thread.
  auto run = [&](size_t u, bool settle) {
    try {
      if (settle) units[u]->settle_held();
      units[u]->run_until(limit);
    } catch (...) {
      errors[u] = std::current_exception();
    }
  };
  auto rethrow = [&] {
    for (const std::exception_ptr& e : errors)
      if (e) std::rethrow_exception(e);
  };
  Server server;
  for (TimingModel* unit : units) unit->defer(true);
  const Undefer undefer{units, server, from, limit, unserved};
  // A round: each unit settles the answers served after the last window, then acts to this window's end.
  Split split(U, n);
  Crew crew(int(n), [&](int j) {
    const auto t0 = std::chrono::steady_clock::now();
    for (size_t u = split.first(size_t(j)); u < split.first(size_t(j) + 1); ++u) run(u, true);
    split.add_busy(size_t(j), std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  });
  uint64_t answered = TimingModel::kNever;  // the earliest answer not settled yet
  for (;;) {
    // The window starts at the earliest action: of a unit, or of a slot its settling will wake (a lower bound).
    uint64_t t = answered;
    for (const TimingModel* unit : units) t = std::min(t, unit->next_cycle());
    if (t == TimingModel::kNever) break;
    from = t;
    limit = t < TimingModel::kNever - lookahead ? t + lookahead - 1 : TimingModel::kNever - 1;
    unserved = true;
    crew.round();
    rethrow();
    split.round_done();
    // Units whose next action in the window takes a ray they lack: given it, earliest (cycle, unit) first, each
    // then acting to the window's end (it may need rays again).
    for (;;) {
      size_t u = U;
      uint64_t at = limit + 1;
      for (size_t i = 0; i < U; ++i)
        if (units[i]->next_cycle() < at && units[i]->starved()) {
          at = units[i]->next_cycle();
          u = i;
        }
      if (u == U) break;
      give(u);
      run(u, false);
      rethrow();
    }
    answered = server.serve(units, from, limit);
    unserved = false;
  }
  uint64_t end = start;
  for (const TimingModel* unit : units) end = std::max(end, unit->end_cycle());
  for (TimingModel* unit : units) unit->end_packet(end);
  return end;
}

}  // namespace rtu::hw
