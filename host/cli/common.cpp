#include "host/cli/common.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/cost/cost_model.h"
#include "host/cost/timing_json.h"
#include "hwmodel/cost/energy_model.h"
#include "hwmodel/format/micromap.h"
#include "hwmodel/timing/timing_stats.h"

namespace rtu::host::cli {

namespace {

// The option of a format field: --coord-bits for coord_bits, ...
std::string format_field_flag(const hw::FormatField& f) {
  std::string flag = std::string("--") + f.key;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

// The timed device's options that only it uses (add_timing_args, add_sampling_args, add_pipeline_trace_args).
const char* const kTimedOnly[] = {"--config",        "--set",         "--sample",         "--sample-unit",
                                  "--sample-warmup", "--sample-seed", "--pipeline-trace", "--trace-window"};

}  // namespace

void add_device_args(CLI::App& app, DeviceArgs& o, const std::string& device_help) {
  if (!device_help.empty())
    app.add_option("--device", o.device, device_help)
        ->check(CLI::IsMember(hw::device_kind_names()))
        ->capture_default_str();
  app.add_option("--leaf-size", o.leaf_size, "maximum primitives per BVH leaf")
      ->check(CLI::Range(1, hw::kMaxLeafSize))
      ->capture_default_str();
  app.add_option("--accel", o.accel,
                 "acceleration: bvh, brute (for each primitive), or auto (brute force when a BVH costs more)")
      ->check(CLI::IsMember({"auto", "bvh", "brute"}))
      ->capture_default_str();
  add_format_args(app, o);
}

void add_timing_args(CLI::App& app, DeviceArgs& o) {
  app.add_option("--config", o.config, "timed device: timing preset (rtusim config --list)")
      ->check(CLI::IsMember(hw::timing_preset_names()))
      ->capture_default_str();
  app.add_option("--set", o.sets, "timed device: override a timing key, KEY=VALUE (repeatable)");
}

void add_sampling_args(CLI::App& app, DeviceArgs& o) {
  app.add_option("--sample", o.sample,
                 "timed device: simulate this fraction of each packet's rays in the timing model (units of rays "
                 "sampled in strata or systematically, each after functional cache warming and a warm-up) and "
                 "estimate the cycles with a 95% interval; on a chip (units > 1) with --set ray_policy=dynamic, "
                 "bursts of waves on every unit; 0: all")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--sample-unit", o.sample_unit, "timed device, --sample: rays per measured unit")
      ->check(CLI::Range(1u, 1u << 20))
      ->capture_default_str();
  app.add_option("--sample-warmup", o.sample_warmup,
                 "timed device, --sample: rays simulated in detail before each unit (0: chosen per packet from "
                 "how long the simulated rays hold their slots)")
      ->check(CLI::Range(0u, 1u << 20))
      ->capture_default_str();
  app.add_option("--sample-seed", o.sample_seed,
                 "timed device, --sample: seed of the measured units' offsets (another seed, another sample: "
                 "how far the estimate moves from seed to seed is its error)")
      ->capture_default_str();
}

void add_omm_level_arg(CLI::App& app, int& level, const std::string& unchanged) {
  app.add_option("--omm-level", level,
                 "fixed and timed devices, one-level scenes: opacity micromaps of this subdivision level (0..10: "
                 "4^level micro-triangles) for alpha-masked triangles, resolved in the unit without the any-hit "
                 "stage where their state is known; the " +
                     unchanged + " the same (-1: none)")
      ->check(CLI::Range(-1, hw::kMaxMicromapLevel))
      ->capture_default_str();
}

void add_watchdog_args(CLI::App& app, DeviceArgs& o) {
  app.add_option("--watchdog-steps", o.watchdog_steps,
                 "fixed and timed devices: node and leaf visits one ray may make before the watchdog stops the "
                 "trace with an error (0: the image's own bound, which a valid BVH never reaches)")
      ->capture_default_str();
  app.add_flag(
      "--flatten", o.flatten,
      "fixed and timed devices: trace an instanced scene's flattened geometry in one image instead of its "
      "two levels (the float reference keeps them)");
}

void add_format_args(CLI::App& app, DeviceArgs& o) {
  // A format spec, as sweep --formats takes it: checked whole here, so that a malformed one is a usage error
  // naming the option.
  const CLI::Validator spec(
      [](std::string& s) {
        try {
          (void)hw::format_from_spec(s);
          return std::string();
        } catch (const std::invalid_argument& e) {
          return std::string(e.what());
        }
      },
      "SPEC");
  app.add_option(
         "--format", o.format,
         "fixed-point format: a preset (rtusim info --formats lists them), optionally with changes of its fields, "
         "e.g. packed:coord_bits=16 (the same as --format packed --coord-bits 16); default: default, on the "
         "timed device the --config's format, which this replaces as --set format=SPEC does")
      ->check(spec);
  // One option per field of the format table (width has --bvh-width): --coord-bits for coord_bits, ...
  for (const hw::FormatField& f : hw::format_fields()) {
    if (f.member == &hw::FixedFormat::width) continue;
    const std::string flag = format_field_flag(f);
    const std::string help = std::string(*f.symbol ? f.symbol : "") + (*f.symbol ? ": " : "") + f.description +
                             " (" + std::to_string(f.lo) + ".." + std::to_string(f.hi) + ")";
    const std::string key = f.key;
    app.add_option_function<int>(
           flag, [&o, key](int v) { o.format_fields[key] = v; }, help)
        ->check(CLI::NonNegativeNumber)
        ->group("Fixed-point format (overrides)");
  }
  app.add_option("--bvh-width", o.bvh_width, "BVH children per node (default: the format's width, 4)")
      ->check(CLI::IsMember({2, 4, 6, 8}));
}

void check_device_args(const CLI::App& app, const DeviceArgs& o) {
  const hw::DeviceKind kind = o.kind();
  auto given = [&](const std::string& name) {
    const CLI::Option* opt = app.get_option_no_throw(name);
    return opt != nullptr && opt->count() > 0;
  };
  if (kind != hw::DeviceKind::kTimed)
    for (const char* name : kTimedOnly)
      if (given(name))
        throw CLI::ValidationError(std::string(name) + " applies to --device timed only (not " + o.device + ")");
  if (kind == hw::DeviceKind::kFloat) {
    // The float reference has no watchdog and no fixed-point format (its BVH width is --bvh-width's).
    std::vector<std::string> fixed_only{"--watchdog-steps"};
    for (const hw::FormatField& f : hw::format_fields())
      if (f.member != &hw::FixedFormat::width) fixed_only.push_back(format_field_flag(f));
    for (const std::string& name : fixed_only)
      if (given(name)) throw CLI::ValidationError(name + " applies to --device fixed or timed only (not float)");
  }
}

}  // namespace rtu::host::cli

namespace rtu::host::cli {

void print_timing_summary(const hw::TimingStats& s, const hw::TimingConfig& c, const hw::FixedFormat& f,
                          const hw::SampleStats* sampling, const char* indent) {
  // The figures of the stats JSON's timing object (timing_stats_json), from the statistics themselves.
  const auto ratio = [](double a, double b) { return b > 0 ? a / b : 0.0; };
  const bool sampled = sampling != nullptr && sampling->packets_sampled > 0;
  const hw::LowerBound bound = hw::lower_bound(s, c);
  const hw::CostInputs in = cost_inputs(f, c);
  const hw::EnergyReport e = hw::energy_report(s, c, in);
  std::string limit = bound.limited_by;
  if (limit == "latency") {
    // Little's law: what the slots hold and how long each ray holds one, so the cure (more slots, less latency)
    // is in the line.
    char why[160];
    std::snprintf(why, sizeof why, ": %d ray slots%s, a ray's mean lifetime %.0f cycles without queueing",
                  c.ray_slots * c.units, c.units > 1 ? " over the units" : "",
                  s.rays > 0 ? bound.latency * c.ray_slots * c.units / double(s.rays) : 0.0);
    limit += why;
  }
  std::printf(
      "timed (%s): %s%llu cycles, %.1f cycles per ray, %.3f rays per clock; cache hit rate %.3f, DRAM %.1f "
      "B/clock; lower bound %s%.0f cycles (%s%s), cycles / bound %.2f\n",
      c.name.c_str(), sampled ? "~" : "", (unsigned long long)s.cycles, ratio(double(s.cycles), double(s.rays)),
      ratio(double(s.rays), double(s.cycles)), ratio(double(s.cache_hits), double(s.cache_hits + s.cache_misses)),
      ratio(double(s.dram_bytes), double(s.cycles)), sampled ? "~" : "", bound.cycles, limit.c_str(),
      sampled ? ", estimated from the sample" : "", bound.cycles_over_bound);
  for (const std::string& line : timing_notes(s, c, sampling)) std::printf("%s%s\n", indent, line.c_str());
  std::printf(
      "%senergy (%s estimate, docs/energy-model.md): %.0f pJ per ray (%.0f in the unit, the rest DRAM and the "
      "ray and hit streams), %.3g rays per joule, %.2f W at %g GHz; area %.2f mm^2\n",
      indent, hw::nangate45().name, e.pj_per_ray, e.unit_pj_per_ray, e.rays_per_joule, e.watts, c.clock_ghz,
      e.area.total_mm2);
  // The latency levers that are on (docs/timing-model.md), each with what it did.
  std::string levers;
  char part[200];
  if (c.prefetcher != hw::PrefetcherId::kNone) {
    std::snprintf(part, sizeof part, "; prefetcher %s: %llu lines filled, accuracy %.3f, %llu dropped",
                  hw::name_of(c.prefetcher), (unsigned long long)s.prefetch_fills,
                  ratio(double(s.prefetch_useful), double(s.prefetch_fills)),
                  (unsigned long long)s.prefetch_dropped);
    levers += part;
  }
  if (c.stack_mode == hw::StackMode::kRestart) {
    std::snprintf(part, sizeof part, "; restart trail (%d entries): %.3f restarts and %.2f nodes again per ray",
                  c.stack_entries, ratio(double(s.restarts), double(s.rays)),
                  ratio(double(s.restart_nodes), double(s.rays)));
    levers += part;
  }
  if (c.gather != hw::GatherKey::kNone) {
    std::snprintf(part, sizeof part,
                  "; gather %s: %llu bins of %.1f rays (%llu full, %llu by timeout), %.0f cycles' wait per ray",
                  hw::name_of(c.gather), (unsigned long long)s.gather_bins,
                  ratio(double(s.rays), double(s.gather_bins)), (unsigned long long)s.gather_bins_full,
                  (unsigned long long)s.gather_bins_timeout, ratio(double(s.gather_wait_cycles), double(s.rays)));
    levers += part;
  }
  if (!levers.empty()) std::printf("%slatency levers:%s\n", indent, levers.c_str() + 1);
}

}  // namespace rtu::host::cli

namespace rtu::host::cli {

hw::PipelineTrace* PipelineTraceArgs::make() {
  if (path.empty()) return nullptr;
  trace = pipeline_trace_window(window);
  return &trace;
}

void PipelineTraceArgs::write(const hw::MemoryTimeline* timeline) const {
  if (path.empty()) return;
  write_pipeline_trace(path, trace, timeline);
}

void add_pipeline_trace_args(CLI::App& app, PipelineTraceArgs& a) {
  app.add_option(
      "--pipeline-trace", a.path,
      "timed device: write a Chrome/Perfetto trace (a track per ray slot, a group per unit, the memory's "
      "bandwidth) of --trace-window");
  app.add_option("--trace-window", a.window,
                 "cycles FROM:TO of the pipeline trace (the timing model's cycles: TRACE packets back to back "
                 "since the scene was bound)")
      ->capture_default_str();
}

void add_any_device_args(CLI::App& app, DeviceArgs& o, PipelineTraceArgs& pipeline) {
  add_pipeline_trace_args(app, pipeline);
  add_device_args(app, o,
                  "device: float (the reference), fixed (bit-accurate fixed point) or timed (fixed point with the "
                  "cycle-approximate timing model; --config, --set)");
  add_timing_args(app, o);
  add_sampling_args(app, o);
  add_watchdog_args(app, o);
}

}  // namespace rtu::host::cli
