// Shared pieces of the rtusim subcommands: options every tracing command takes, scene loading, progress,
// statistics as JSON.
#pragma once

#include <CLI/CLI.hpp>
#include <chrono>
#include <nlohmann/json.hpp>
#include <string>

#include "host/device.h"
#include "host/render.h"
#include "host/scene.h"
#include "hwmodel/timing_config.h"

namespace rtu::host::cmd {

using Json = nlohmann::ordered_json;

// Device, acceleration and number-format options shared by the tracing commands.
struct DeviceArgs {
  std::string device = "float";
  int bvh_width = 0;  // 0: the format's width (4 in the default format)
  int leaf_size = 8;
  std::string accel = "auto";
  std::string format = "default";
  // Overrides of the format preset's fields; -1 keeps the preset's value.
  int coord_bits = -1, child_bits = -1, guard_bits = -1, frac_bits = -1, dir_bits = -1, rcp_bits = -1,
      t_frac_bits = -1, t_bits = -1;
  // The timed device: a timing preset and key=value overrides. Its format preset and BVH width come from the
  // configuration (keys `format`, `bvh_width`); the per-field format options still apply on top.
  std::string config = "rdna2";
  std::vector<std::string> sets;
  // The timed device: simulate this fraction of each TRACE packet's rays in the timing model and extrapolate
  // (hw::SampleOptions); 0: every ray.
  double sample = 0.0;
  uint32_t sample_unit = 256, sample_warmup = 0;
  uint64_t sample_seed = 1;
  uint64_t watchdog_steps = 0;  // fixed, timed: node and leaf visits per ray before the watchdog (0: automatic)

  hw::FixedFormat fixed_format() const;  // preset + overrides + width; validated
  DeviceOptions options(const std::string& device_name) const;
};

// Adds --bvh-width, --leaf-size, --accel, --format and the per-field format options; --device too when
// `device_help` is not empty.
void add_device_args(CLI::App& app, DeviceArgs& o, const std::string& device_help);

class Stopwatch {
 public:
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
  }

 private:
  std::chrono::steady_clock::time_point m_start = std::chrono::steady_clock::now();
};

// Rays from a --rays argument: a ray file, or "primary" (the camera's image), "primary:N", "primary:WxH",
// "incoherent:N" (seeded by `seed`).
std::vector<hw::Ray> rays_from_spec(const std::string& spec, const Scene& scene, uint64_t seed);
inline constexpr const char* kRaySpecHelp =
    "a ray file, or primary | primary:N | primary:WxH (the scene camera) | incoherent:N (random, --seed)";

Json bvh_json(const TraceDevice& d);
Json format_json(const hw::FixedFormat& f);
// Bytes of the fixed device's image beside the float BVH's (nodes + leaf index) for the same tree.
Json image_json(const hw::DeviceImage& img, const hw::Bvh* bvh);
Json traversal_json(const hw::TraversalStats& s);
void write_json(const std::string& path, const Json& j);
// A render's statistics (rays by type, commands, what was skipped and why, the unit's counters) and its one-line
// summary on stdout.
Json render_json(const RenderResult& r, const RenderOptions& o);
void print_render_summary(const RenderResult& r, const RenderOptions& o);

// A timing preset with "key=value" overrides applied in order (the `--config P --set k=v` options); throws Error
// naming the override for a malformed one, an unknown preset or key, or a bad value.
hw::TimingConfig timing_config_from(const std::string& preset, const std::vector<std::string>& sets);
// {"preset": name, key: value, ...} in timing_keys() order: numbers as JSON numbers, text as strings.
Json timing_json(const hw::TimingConfig& c);
// What a timed run measured: cycles, cycles per ray, rays per clock, unit utilization, cache and DRAM figures,
// stack spills, queue stalls, and the lower bound max(box tests / box rate, triangle tests / triangle rate,
// DRAM bytes / bandwidth) with the cycles divided by it.
Json timing_stats_json(const hw::TimingStats& s, const hw::TimingConfig& c);
// The timed engine's statistics in total, by ray type and by bounce, with its configuration.
Json timed_json(const hw::TimedEngine& e);
// What sampled timing simulated (hw::SampleStats), with the 95% interval of the cycles.
Json sample_json(const hw::SampleStats& s);
// One line: cycles, cycles per ray, rays per clock, the lower bound and what limits it.
void print_timing_summary(const hw::TimingStats& s, const hw::TimingConfig& c);
// --pipeline-trace F.json and --trace-window FROM:TO (cycles) of the timed device's commands.
struct PipelineTraceArgs {
  std::string path, window = "0:100000";
  // The trace to pass to the device (null when no path was given); throws Error on a malformed window.
  hw::PipelineTrace* make();
  void write() const;  // Chrome/Perfetto JSON ("ts" and "dur" in cycles, shown as microseconds)
  hw::PipelineTrace trace;
};
void add_pipeline_trace_args(CLI::App& app, PipelineTraceArgs& a);

void add_info(CLI::App& app);
void add_rays(CLI::App& app);
void add_trace(CLI::App& app);
void add_demo(CLI::App& app);
void add_sweep(CLI::App& app);
void add_plan(CLI::App& app);
void add_report(CLI::App& app);  // and `pareto`
void add_compare(CLI::App& app);
void add_stress(CLI::App& app);
void add_render(CLI::App& app);
void add_diff(CLI::App& app);
void add_config(CLI::App& app);
void add_soak(CLI::App& app);

}  // namespace rtu::host::cmd
