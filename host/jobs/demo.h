// The main job on a scene, as the README's first command (rtusim demo) runs it: traces the camera's primary rays
// on the float reference and on the fixed device (default format) and compares them ray by ray; renders the scene
// with the firmware renderer on the float reference and on the timed device (the fixed device's hits, plus cycles
// per frame), and again on the timed device in hybrid mode (primary visibility rasterized by the firmware), and
// compares the images (PSNR, heatmap). Writes images, hit files and report.json into the output directory.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "host/io/stats_json.h"
#include "host/jobs/compare.h"
#include "host/jobs/image_diff.h"
#include "host/jobs/render.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/device/device_kind.h"

namespace rtu::host {

struct DemoOptions {
  std::string scene = "builtin:seed";
  std::string out = "out/demo";  // output directory (created)
  int threads = 0;               // 0: all cores
  int spp = 4, max_depth = 4;    // the renders
  std::string config = "rdna2";  // timing preset of the timed device's renders
};

// The camera's primary rays on one device (files primary_NAME.png and .hits).
struct DemoTrace {
  hw::DeviceKind device = hw::DeviceKind::kFloat;
  hw::TraversalStats stats;
  double seconds = 0.0;  // tracing alone
  bool bvh = false;      // false: brute force
};

// One firmware render (file render_NAME.png).
struct DemoRender {
  std::string name;  // float, fixed (on the timed device) or hybrid (the timed device in hybrid mode)
  RenderOptions options;
  RenderResult result;
};

struct DemoResult {
  std::string scene;  // its name
  size_t triangles = 0, spheres = 0, planes = 0, lights = 0;
  int width = 0, height = 0;         // the camera's image: one primary ray per pixel
  std::vector<DemoTrace> traces;     // float, fixed
  HitComparison fixed_vs_float;      // the primary rays, valid on both devices
  std::vector<DemoRender> renders;   // float, fixed, hybrid
  ImageDiff render_fixed_vs_float;   // the float and fixed renders (render_heatmap.png)
  std::vector<std::string> written;  // every file written, report.json last
  Json report;                       // report.json
};

// What the demo finished last: the loaded scene, a trace, the comparison of the traces, a ray-traced render, the
// hybrid render, the comparison of the renders.
enum class DemoStage { kLoaded, kTraced, kCompared, kRendered, kHybrid, kRenderDiff };

// Runs the demo; `progress`, when given, sees the result so far after each stage. Throws Error when the output
// directory cannot be created or a file cannot be written.
DemoResult run_demo(const DemoOptions& o, const std::function<void(DemoStage, const DemoResult&)>& progress = {});

}  // namespace rtu::host
