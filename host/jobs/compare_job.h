// The job of `rtusim compare` (and of the Python module's compare): the float reference and a device trace
// identical rays; per-ray agreement, t error, the fixed device's exact box checks and the traversal overheads, as
// the JSON `rtusim compare --json` writes.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "host/devices/device_settings.h"
#include "host/devices/direct_device.h"
#include "host/io/stats_json.h"
#include "host/jobs/compare.h"
#include "host/scene/scene.h"
#include "host/scene/shading.h"

namespace rtu::host {

struct CompareRequest {
  const Scene* scene = nullptr;
  const std::vector<hw::Ray>* rays = nullptr;
  std::string rays_name;  // the ray spec as the user gave it (JSON key rays_spec)
  DeviceSettings settings;
  hw::DeviceKind kind = hw::DeviceKind::kFixed;  // the device compared with the float reference
  bool any_hit = false;
  int threads = 0;
  size_t max_list = 1000;      // disagreeing rays listed in the JSON
  std::function<void()> poll;  // as TraceRequest::poll
};

struct CompareRun {
  DeviceOptions dut_options;
  std::unique_ptr<SceneAnyHit> alpha;  // alpha-tested materials: both devices ask the same stage (outlives them)
  std::unique_ptr<DirectDevice> ref, dut;
  std::vector<hw::Hit> ref_hits, dut_hits;
  hw::TraversalStats ref_stats, dut_stats;
  double ref_seconds = 0.0, dut_seconds = 0.0;
  HitComparison t;
  uint64_t invalid_either = 0;  // rays either device rejected (not compared)
  double grid_step = 0.0;       // the device's quantization step (0: float)
  bool boxes_checked = false;   // the fixed device repeated its box tests exactly
  std::vector<hw::Ray> replay;  // every disagreeing ray, in ray order
  Json json;                    // rtusim compare --json
};

// Traces and compares. Throws as make_device and trace_batch do; a run that compared nothing or found box false
// negatives is returned (check_compare throws for those).
CompareRun compare_devices(const CompareRequest& req);

// The Errors `rtusim compare` ends with: no ray valid on both devices (`nothing_compared`), or a fixed box test
// that rejected a box exact arithmetic accepts (`box_false_negatives`).
void check_compared(const CompareRun& run);
void check_box_false_negatives(const CompareRun& run);

}  // namespace rtu::host
