#include "host/trace_job.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>

namespace rtu::host {

Progress::Progress(const char* what, uint64_t total)
    : m_what(what), m_total(total), m_enabled(isatty(STDERR_FILENO) != 0 && total > 0) {}

void Progress::update(uint64_t done) {
  if (!m_enabled) return;
  std::fprintf(stderr, "\r%s: %3d%% (%llu/%llu)", m_what, int(100.0 * double(done) / double(m_total)),
               (unsigned long long)done, (unsigned long long)m_total);
  std::fflush(stderr);
}

Progress::~Progress() {
  if (m_enabled) std::fprintf(stderr, "\r\033[K");
}

int resolved_threads(int threads) {
  return threads > 0 ? threads : std::max(1, int(std::thread::hardware_concurrency()));
}

double trace_with_progress(const hw::FloatTracer& tracer, const std::vector<hw::Ray>& rays,
                           std::vector<hw::Hit>& hits, bool any_hit, int threads, hw::TraversalStats& stats) {
  hits.resize(rays.size());
  constexpr size_t kChunk = size_t(1) << 18;
  Progress progress("trace", rays.size());
  const auto start = std::chrono::steady_clock::now();
  for (size_t begin = 0; begin < rays.size(); begin += kChunk) {
    const size_t n = std::min(kChunk, rays.size() - begin);
    tracer.trace_batch(rays.data() + begin, hits.data() + begin, n, any_hit, resolved_threads(threads), stats);
    progress.update(begin + n);
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

uint64_t report_invalid_rays(const std::vector<hw::Ray>& rays, std::FILE* out) {
  uint64_t count = 0;
  size_t first = 0;
  hw::RayStatus first_status = hw::RayStatus::kOk;
  for (size_t i = 0; i < rays.size(); ++i) {
    const hw::RayStatus s = hw::validate_ray(rays[i]);
    if (s == hw::RayStatus::kOk) continue;
    if (count++ == 0) {
      first = i;
      first_status = s;
    }
  }
  if (count > 0) {
    std::fprintf(out,
                 "rtusim: warning: %llu invalid rays reported as misses; the first is ray %zu (%s). Invalid: "
                 "NaN or Inf origin or direction, zero direction, NaN interval\n",
                 (unsigned long long)count, first, hw::ray_status_name(first_status));
  }
  return count;
}

}  // namespace rtu::host
