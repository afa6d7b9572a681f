// Runs a batch of independent rays over threads. Work is handed out in fixed chunks; statistics are summed per
// chunk and then over threads, so results and totals do not depend on the thread count.
#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include "hwmodel/datapath/stats.h"

namespace rtu::hw {

// Calls fn(i, stats) for i in [0, n) on `threads` threads (0 = all cores). Notes the index of the first ray
// that fn counted as invalid. When fn throws, the remaining chunks are skipped, every thread is joined and the
// first exception is rethrown (s is then left unchanged).
template <class Fn>
void run_batch(size_t n, int threads, TraversalStats& s, Fn&& fn) {
  constexpr size_t kChunk = 1024;
  // Asked once: std::thread::hardware_concurrency() reads /sys on every call (6 us here), and sampled timing
  // runs batches of a few dozen rays.
  static const int hw = std::max(1, int(std::thread::hardware_concurrency()));
  const int nt = std::max(1, std::min(threads > 0 ? threads : hw, int((n + kChunk - 1) / kChunk)));
  std::atomic<size_t> next{0};
  std::vector<TraversalStats> per(static_cast<size_t>(nt));
  std::exception_ptr error;  // the first exception fn threw, on any thread; rethrown after every thread joined
  std::mutex error_mutex;
  auto work = [&](int id) {
    try {
      for (;;) {
        const size_t begin = next.fetch_add(kChunk);
        if (begin >= n) break;
        const size_t end = std::min(n, begin + kChunk);
        TraversalStats local;  // per chunk, so threads do not share cache lines in the hot loop
        for (size_t i = begin; i < end; ++i) {
          const uint64_t invalid = local.invalid_rays;
          fn(i, local);
          if (local.invalid_rays != invalid && i < local.first_invalid) {
            local.first_invalid = i;
            for (size_t r = 0; r < local.invalid_by_reason.size(); ++r)
              if (local.invalid_by_reason[r]) local.first_invalid_reason = RayStatus(r);
          }
        }
        per[size_t(id)].add(local);
      }
    } catch (...) {
      next.store(n);  // the other threads stop at their next chunk
      const std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (int i = 1; i < nt; ++i) pool.emplace_back(work, i);
  work(0);
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  for (const TraversalStats& p : per) s.add(p);
}

}  // namespace rtu::hw
