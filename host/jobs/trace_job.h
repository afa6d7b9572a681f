// Tracing a whole ray set on the host: in chunks, with a progress line on a terminal, and a report of the
// rays the unit rejected.
#pragma once

#include <cstdio>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "host/devices/device_settings.h"
#include "host/devices/direct_device.h"
#include "host/io/stats_json.h"
#include "host/scene/scene.h"
#include "host/scene/shading.h"
#include "hwmodel/format/micromap.h"

namespace rtu::host {

// A one-line progress display on stderr, only when stderr is a terminal.
class Progress {
 public:
  Progress(const char* what, uint64_t total);
  void update(uint64_t done);                            // "what: P% (done/total)"
  void update(uint64_t done, const std::string& where);  // "what: P% (where)"
  ~Progress();

 private:
  const char* m_what;
  uint64_t m_total;
  bool m_enabled;
};

int resolved_threads(int threads);

// The rays of one TRACE packet (one trace_batch) when a ray set is traced in packets: on the timed device each
// packet fills and drains the unit's slots, so the cycles depend on it; the hits do not.
inline constexpr size_t kTracePacketRays = size_t(1) << 18;
// The largest packet `rtusim trace --packet-rays` takes.
inline constexpr size_t kMaxTracePacketRays = size_t(1) << 30;

// Traces rays into hits (same size), in packets of `packet_rays` rays; returns the wall-clock seconds of tracing
// alone. `poll`, when set, is called before each packet: an exception it throws stops the job.
double trace_with_progress(const DirectDevice& device, std::span<const hw::Ray> rays, std::vector<hw::Hit>& hits,
                           bool any_hit, int threads, hw::TraversalStats& stats,
                           const std::function<void()>& poll = nullptr, size_t packet_rays = kTracePacketRays);

// trace_with_progress for all-hit traversal keeping k hits a ray: lists (rays * k) and counts (rays).
double trace_all_with_progress(const DirectDevice& device, std::span<const hw::Ray> rays, uint32_t k,
                               std::vector<hw::Hit>& lists, std::vector<uint64_t>& counts, int threads,
                               hw::TraversalStats& stats, const std::function<void()>& poll = nullptr,
                               size_t packet_rays = kTracePacketRays);

// "N invalid rays reported as misses; the first is ray i (reason). Invalid: ..." when the device rejected any ray;
// empty otherwise.
std::string invalid_rays_message(const hw::TraversalStats& stats);
// Prints "rtusim: warning: " and that message to `out` when the device rejected any ray.
void report_invalid_rays(const hw::TraversalStats& stats, std::FILE* out);

// The job of `rtusim trace` (and of the Python module's trace): a device of `kind` made from `settings` over the
// scene (two levels on the float device), the rays traced in packets with progress.
struct TraceRequest {
  const Scene* scene = nullptr;
  std::span<const hw::Ray> rays;  // not copied: the Python module traces a numpy array in place
  DeviceSettings settings;
  hw::DeviceKind kind = hw::DeviceKind::kFloat;
  bool any_hit = false;
  int threads = 0;
  int omm_level = -1;  // fixed and timed devices, one level: opacity micromaps of this level (-1: none)
  // >= 0: all-hit traversal keeping up to this many hits a ray (at most hw::cmd::kMaxAllHits; 0: counts only);
  // the lists go to TraceRun::lists and counts, not hits. Not with any_hit.
  int all_hits = -1;
  bool need_hits = true;  // false: sampled timing traces only the sampled rays (cycles only; hits not meaningful)
  hw::PipelineTrace* pipeline = nullptr;  // timed device: record pipeline spans here (or null)
  size_t packet_rays = kTracePacketRays;  // rays a TRACE packet, 1 .. kMaxTracePacketRays
  // Called between packets of rays (trace_with_progress); an exception it throws stops the job (Python: Ctrl-C).
  std::function<void()> poll;
};
struct TraceRun {
  DeviceOptions options;
  std::unique_ptr<SceneAnyHit> alpha;  // alpha-tested materials: the any-hit stage the device asks (outlives it)
  std::unique_ptr<hw::MicromapSet> micromaps;  // TraceRequest::omm_level: the maps the device reads (outlive it)
  std::unique_ptr<DirectDevice> device;
  std::vector<hw::Hit> hits;
  std::vector<hw::Hit> lists;    // all_hits: ray i's kept hits at lists[i * all_hits ...]
  std::vector<uint64_t> counts;  // all_hits: ray i's intersections found
  hw::TraversalStats stats;
  double build_seconds = 0.0, trace_seconds = 0.0;
  std::string grid_warning;  // primitives below the fixed-point grid step (grid_check.h), or ""
};
// Throws as make_device and DirectDevice::trace_batch do, and Error for an all_hits bound above kMaxAllHits or
// with any_hit.
TraceRun run_trace(const TraceRequest& req);

// An all-hit trace's figures (counts per ray, k kept): k, found, kept, rays_with_hits, rays_overflowed,
// max_per_ray, mean_per_ray.
Json all_hits_json(uint32_t k, const std::vector<uint64_t>& counts);

// The statistics of a trace as `rtusim trace --stats` writes them: scene, rays, device, format, mode, threads,
// traversal counters, seconds, the BVH and on the timed device its timing. `rays_name` names the ray set (the
// ray file), `device_name` the device as the user spelled it.
Json trace_stats_json(const TraceRequest& req, const TraceRun& run, const std::string& rays_name,
                      const std::string& device_name, double load_seconds);

}  // namespace rtu::host
