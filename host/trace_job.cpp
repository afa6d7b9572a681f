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

void Progress::update(uint64_t done, const std::string& where) {
  if (!m_enabled) return;
  // Padded with blanks: a shorter line than the last must cover it.
  std::fprintf(stderr, "\r%s: %3d%% (%s)   ", m_what, int(100.0 * double(done) / double(m_total)), where.c_str());
  std::fflush(stderr);
}

Progress::~Progress() {
  if (m_enabled) std::fprintf(stderr, "\r\033[K");
}

int resolved_threads(int threads) {
  return threads > 0 ? threads : std::max(1, int(std::thread::hardware_concurrency()));
}

double trace_with_progress(const DirectDevice& device, const std::vector<hw::Ray>& rays,
                           std::vector<hw::Hit>& hits, bool any_hit, int threads, hw::TraversalStats& stats) {
  hits.resize(rays.size());
  constexpr size_t kChunk = size_t(1) << 18;
  Progress progress("trace", rays.size());
  const auto start = std::chrono::steady_clock::now();
  for (size_t begin = 0; begin < rays.size(); begin += kChunk) {
    const size_t n = std::min(kChunk, rays.size() - begin);
    hw::TraversalStats chunk;
    device.trace_batch(rays.data() + begin, hits.data() + begin, n, any_hit, resolved_threads(threads), chunk);
    if (chunk.first_invalid != UINT64_MAX) chunk.first_invalid += begin;
    stats.add(chunk);
    progress.update(begin + n);
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

void report_invalid_rays(const hw::TraversalStats& stats, std::FILE* out) {
  if (stats.invalid_rays == 0) return;
  std::fprintf(out,
               "rtusim: warning: %llu invalid rays reported as misses; the first is ray %llu (%s). Invalid: NaN "
               "or Inf origin or direction, zero direction, NaN interval, origin out of the frame (fixed)\n",
               (unsigned long long)stats.invalid_rays, (unsigned long long)stats.first_invalid,
               hw::ray_status_name(stats.first_invalid_reason));
}

}  // namespace rtu::host
