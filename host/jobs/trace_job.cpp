#include "host/jobs/trace_job.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "host/cost/timing_json.h"
#include "host/devices/device_json.h"
#include "host/io/error.h"
#include "host/io/limits.h"
#include "host/scene/micromap_bake.h"
#include "hwmodel/interface/commands.h"

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

namespace {

// Rays in packets of `packet` with a progress line: trace(begin, n, stats) for each, poll() before it. Returns
// the seconds of tracing.
template <class Fn>
double in_chunks(size_t rays, size_t packet, hw::TraversalStats& stats, const std::function<void()>& poll,
                 Fn&& trace) {
  if (packet == 0 || packet > kMaxTracePacketRays)
    throw Error("rays a packet: " + std::to_string(packet) + " is not in 1 .. " +
                std::to_string(kMaxTracePacketRays));
  Progress progress("trace", rays);
  const auto start = std::chrono::steady_clock::now();
  for (size_t begin = 0; begin < rays; begin += packet) {
    const size_t n = std::min(packet, rays - begin);
    if (poll) poll();
    hw::TraversalStats chunk;
    trace(begin, n, chunk);
    if (chunk.first_invalid != UINT64_MAX) chunk.first_invalid += begin;
    stats.add(chunk);
    progress.update(begin + n);
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

double trace_with_progress(const DirectDevice& device, std::span<const hw::Ray> rays, std::vector<hw::Hit>& hits,
                           bool any_hit, int threads, hw::TraversalStats& stats, const std::function<void()>& poll,
                           size_t packet_rays) {
  hits.resize(rays.size());
  return in_chunks(rays.size(), packet_rays, stats, poll, [&](size_t begin, size_t n, hw::TraversalStats& chunk) {
    device.trace_batch(rays.data() + begin, hits.data() + begin, n, any_hit, resolved_threads(threads), chunk);
  });
}

double trace_all_with_progress(const DirectDevice& device, std::span<const hw::Ray> rays, uint32_t k,
                               std::vector<hw::Hit>& lists, std::vector<uint64_t>& counts, int threads,
                               hw::TraversalStats& stats, const std::function<void()>& poll, size_t packet_rays) {
  check_memory("all-hit lists of " + std::to_string(rays.size()) + " rays keeping " + std::to_string(k),
               uint64_t(rays.size()) * (uint64_t(k) * sizeof(hw::Hit) + sizeof(uint64_t)));
  lists.assign(rays.size() * size_t(k), hw::Hit{});
  counts.assign(rays.size(), 0);
  return in_chunks(rays.size(), packet_rays, stats, poll, [&](size_t begin, size_t n, hw::TraversalStats& chunk) {
    const hw::AllHitsOut out{k, lists.data() + begin * size_t(k), counts.data() + begin};
    device.trace_all_batch(rays.data() + begin, n, out, resolved_threads(threads), chunk);
  });
}

std::string invalid_rays_message(const hw::TraversalStats& stats) {
  if (stats.invalid_rays == 0) return {};
  return std::to_string(stats.invalid_rays) + " invalid rays reported as misses; the first is ray " +
         std::to_string(stats.first_invalid) + " (" + hw::ray_status_name(stats.first_invalid_reason) +
         "). Invalid: NaN or Inf origin or direction, zero direction, NaN interval, origin out of the frame "
         "(fixed)";
}

void report_invalid_rays(const hw::TraversalStats& stats, std::FILE* out) {
  if (stats.invalid_rays == 0) return;
  std::fprintf(out, "rtusim: warning: %s\n", invalid_rays_message(stats).c_str());
}

TraceRun run_trace(const TraceRequest& req) {
  if (req.all_hits > int(hw::cmd::kMaxAllHits))
    throw Error("all-hit traversal keeps at most " + std::to_string(hw::cmd::kMaxAllHits) + " hits a ray, not " +
                std::to_string(req.all_hits));
  if (req.all_hits >= 0 && req.any_hit) throw Error("all-hit traversal and any-hit queries exclude each other");
  TraceRun run;
  const auto build_start = std::chrono::steady_clock::now();
  run.options = req.settings.options(req.kind);
  run.options.sample.need_hits = req.need_hits;
  run.options.instances = &req.scene->instances;
  run.alpha = std::make_unique<SceneAnyHit>(*req.scene);
  run.options.any_hit = run.alpha->stage();
  const bool one_level = req.scene->instances.instances.empty() || run.options.flatten;
  if (req.omm_level >= 0 && req.kind != hw::DeviceKind::kFloat && one_level && run.alpha->tables()) {
    run.micromaps = std::make_unique<hw::MicromapSet>(
        bake_micromaps(*run.alpha->tables(), req.scene->geometry.non_opaque, req.omm_level));
    run.options.micromaps = run.micromaps.get();
  }
  run.grid_warning = grid_warning(device_grid_check(req.scene->geometry, run.options));
  run.device = make_device(req.scene->geometry, run.options);
  run.device->set_pipeline_trace(req.pipeline);
  run.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - build_start).count();
  if (req.all_hits >= 0)
    run.trace_seconds = trace_all_with_progress(*run.device, req.rays, uint32_t(req.all_hits), run.lists,
                                                run.counts, req.threads, run.stats, req.poll, req.packet_rays);
  else
    run.trace_seconds = trace_with_progress(*run.device, req.rays, run.hits, req.any_hit, req.threads, run.stats,
                                            req.poll, req.packet_rays);
  return run;
}

Json all_hits_json(uint32_t k, const std::vector<uint64_t>& counts) {
  uint64_t found = 0, kept = 0, overflowed = 0, most = 0, with = 0;
  for (const uint64_t c : counts) {
    found += c;
    kept += std::min<uint64_t>(c, k);
    overflowed += c > k;
    most = std::max(most, c);
    with += c > 0;
  }
  return Json{{"k", k},
              {"found", found},
              {"kept", kept},
              {"rays_with_hits", with},
              {"rays_overflowed", overflowed},
              {"max_per_ray", most},
              {"mean_per_ray", counts.empty() ? 0.0 : double(found) / double(counts.size())}};
}

Json trace_stats_json(const TraceRequest& req, const TraceRun& run, const std::string& rays_name,
                      const std::string& device_name, double load_seconds) {
  const uint64_t n = req.rays.size();
  Json j;
  j["scene"] = req.scene->name;
  j["rays_file"] = rays_name;
  j["device"] = device_name;
  if (req.kind != hw::DeviceKind::kFloat) j["format"] = format_json(run.options.format);
  j["mode"] = req.all_hits >= 0 ? "all_hits" : req.any_hit ? "any_hit" : "closest_hit";
  if (req.all_hits >= 0) j["all_hits"] = all_hits_json(uint32_t(req.all_hits), run.counts);
  j["threads"] = resolved_threads(req.threads);
  j["packet_rays"] = req.packet_rays;
  j.update(traversal_json(run.stats));
  j["trace_seconds"] = run.trace_seconds;
  j["rays_per_second"] = run.trace_seconds > 0 ? double(n) / run.trace_seconds : 0.0;
  j["load_seconds"] = load_seconds;
  j["warnings"] = run.grid_warning.empty() ? Json::array() : Json::array({run.grid_warning});
  j["build_seconds"] = run.build_seconds;
  j["bvh"] = bvh_json(*run.device);
  if (const hw::TimedEngine* te = run.device->timed()) j["timing"] = timed_json(*te);
  return j;
}

}  // namespace rtu::host
