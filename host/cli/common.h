// Shared pieces of the rtusim subcommands: the device options every tracing command takes, the pipeline-trace
// options, one-line summaries on stdout, and the subcommands themselves.
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <utility>

#include "host/devices/device_settings.h"
#include "host/devices/direct_device.h"
#include "host/io/pipeline_trace.h"
#include "host/io/stats_json.h"
#include "host/jobs/render.h"
#include "host/jobs/stopwatch.h"
#include "host/scene/ray_spec.h"
#include "host/scene/scene.h"
#include "hwmodel/device/device_kind.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host::cli {

// Device, acceleration and number-format options shared by the tracing commands (host::DeviceSettings), and the
// device's name.
struct DeviceArgs : DeviceSettings {
  std::string device = "float";
  hw::DeviceKind kind() const { return hw::parse_device_kind(device); }
};

// The device options come in pieces so that a command lists only the options it uses:
// - add_device_args: --leaf-size, --accel and the format options (add_format_args); --device too when
//   `device_help` is not empty;
// - add_format_args: --bvh-width, --format and the per-field format options (--coord-bits, ...);
// - add_timing_args: --config and --set, the timed device's timing configuration;
// - add_sampling_args: --sample, --sample-unit, --sample-warmup, --sample-seed, the timed device's sampled timing;
// - add_watchdog_args: --watchdog-steps, the fixed and timed devices' watchdog.
void add_device_args(CLI::App& app, DeviceArgs& o, const std::string& device_help);
void add_format_args(CLI::App& app, DeviceArgs& o);
void add_timing_args(CLI::App& app, DeviceArgs& o);
void add_sampling_args(CLI::App& app, DeviceArgs& o);
void add_watchdog_args(CLI::App& app, DeviceArgs& o);
// --omm-level (trace, render): opacity micromaps of a subdivision level, -1 none; `unchanged` names what the maps
// leave as it is ("hits", "image").
void add_omm_level_arg(CLI::App& app, int& level, const std::string& unchanged);

// For a command with --device: refuses (CLI::ValidationError, a usage error) each device option of `app` that was
// given on the command line (not left at its default) while the chosen device does not use it: the timing,
// sampling and pipeline-trace options on any device but timed, the watchdog and the per-field format options on
// float. Call it first thing in the command's callback.
void check_device_args(const CLI::App& app, const DeviceArgs& o);

inline constexpr const char* kRaySpecHelp =
    "a ray file, or primary | primary:N | primary:WxH (the scene camera) | incoherent | incoherent:N (random, "
    "--seed; without N as many as primary)";

// A render's one-line summary on stdout (and the rasterizer's in hybrid mode).
void print_render_summary(const RenderResult& r, const RenderOptions& o);
// A timed run's summary: cycles, cycles per ray, rays per clock, the lower bound and what limits it; the notes
// of timing_notes (stats_json.h); energy (the unit's own beside the total) and area, priced for the run's format
// `f`; the latency levers that are on. Lines after the first are prefixed by `indent`. `sampling` (or null):
// what sampled timing simulated; with a packet sampled the counters and the bound are estimates, and it says so.
void print_timing_summary(const hw::TimingStats& s, const hw::TimingConfig& c, const hw::FixedFormat& f,
                          const hw::SampleStats* sampling = nullptr, const char* indent = "");
// --pipeline-trace F.json and --trace-window FROM:TO (cycles) of the timed device's commands.
struct PipelineTraceArgs {
  std::string path, window = "0:100000";
  // The trace to pass to the device (null when no path was given); throws Error on a malformed window.
  hw::PipelineTrace* make();
  // Chrome/Perfetto JSON ("ts" and "dur" in cycles, shown as microseconds), with the memory's counter tracks.
  void write(const hw::MemoryTimeline* timeline) const;
  hw::PipelineTrace trace;
};
void add_pipeline_trace_args(CLI::App& app, PipelineTraceArgs& a);
// Every device option of a command that runs its job on any of the three devices (trace, render): the pipeline
// trace, --device and the options of add_device_args, add_timing_args, add_sampling_args and add_watchdog_args.
void add_any_device_args(CLI::App& app, DeviceArgs& o, PipelineTraceArgs& pipeline);

// Adds the subcommand `name` and the Options its `run(Options&, CLI::App& subcommand)` callback reads. CLI11 fills
// the options while it parses, after add_X has returned, so they live on the heap, owned by the callback.
template <class Options>
struct Command {
  CLI::App* sub;
  Options* o;
};
template <class Options, class Run>
Command<Options> add_command(CLI::App& app, std::string name, std::string description, Run run) {
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(std::move(name), std::move(description));
  sub->callback([o, sub, run] { run(*o, *sub); });
  return {sub, o.get()};
}

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
void add_motion(CLI::App& app);
void add_query(CLI::App& app);
void add_join(CLI::App& app);

}  // namespace rtu::host::cli
