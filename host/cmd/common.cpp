#include "host/cmd/common.h"

#include <algorithm>

#include <charconv>
#include <cstdio>
#include <fstream>
#include <stdexcept>

#include "host/error.h"
#include "host/limits.h"
#include "host/ray_gen.h"
#include "host/ray_io.h"

namespace rtu::host::cmd {

hw::FixedFormat DeviceArgs::fixed_format() const {
  hw::FixedFormat f = hw::format_preset(format);
  std::string changed;
  auto set = [&](int& field, int value, const char* key) {
    if (value < 0) return;
    field = value;
    changed += std::string(changed.empty() ? "+" : ",") + key + "=" + std::to_string(value);
  };
  set(f.coord_bits, coord_bits, "coord_bits");
  set(f.child_bits, child_bits, "child_bits");
  set(f.guard_bits, guard_bits, "guard_bits");
  set(f.frac_bits, frac_bits, "frac_bits");
  set(f.dir_bits, dir_bits, "dir_bits");
  set(f.rcp_bits, rcp_bits, "rcp_bits");
  set(f.t_frac_bits, t_frac_bits, "t_frac_bits");
  set(f.t_bits, t_bits, "t_bits");
  set(f.width, bvh_width > 0 ? bvh_width : -1, "width");
  f.name += changed;
  f.validate();
  return f;
}

DeviceOptions DeviceArgs::options(const std::string& device_name) const {
  DeviceOptions d;
  d.name = device_name;
  if (device_name == "timed") {
    d.timing = timing_config_from(config, sets);
    d.sample.fraction = sample;
    d.sample.unit_rays = sample_unit;
    d.sample.warmup_rays = sample_warmup;
    d.sample.seed = sample_seed;
    DeviceArgs a = *this;
    a.format = d.timing.format;
    if (a.bvh_width <= 0) a.bvh_width = d.timing.bvh_width;
    d.format = a.fixed_format();
  } else {
    d.format = fixed_format();
  }
  d.tracer.bvh.width = d.format.width;
  d.tracer.bvh.max_leaf_size = leaf_size;
  d.max_steps = watchdog_steps;
  d.tracer.accel =
      accel == "bvh" ? hw::AccelMode::kBvh : (accel == "brute" ? hw::AccelMode::kBrute : hw::AccelMode::kAuto);
  return d;
}

void add_device_args(CLI::App& app, DeviceArgs& o, const std::string& device_help) {
  if (!device_help.empty())
    app.add_option("--device", o.device, device_help)->check(CLI::IsMember(device_names()))->capture_default_str();
  app.add_option("--bvh-width", o.bvh_width, "BVH children per node (default: the format's width, 4)")
      ->check(CLI::IsMember({2, 4, 8}));
  app.add_option("--leaf-size", o.leaf_size, "maximum primitives per BVH leaf")
      ->check(CLI::Range(1, hw::kMaxLeafSize))
      ->capture_default_str();
  app.add_option("--accel", o.accel,
                 "acceleration: bvh, brute (for each primitive), or auto (brute force when a BVH costs more)")
      ->check(CLI::IsMember({"auto", "bvh", "brute"}))
      ->capture_default_str();
  app.add_option("--config", o.config, "timed device: timing preset (rtusim config --list)")
      ->check(CLI::IsMember(hw::timing_preset_names()))
      ->capture_default_str();
  app.add_option("--set", o.sets, "timed device: override a timing key, KEY=VALUE (repeatable)");
  app.add_option("--sample", o.sample,
                 "timed device: simulate this fraction of each packet's rays in the timing model (units of rays "
                 "sampled in strata or systematically, each after functional cache warming and a warm-up) and "
                 "estimate the cycles with a 95% interval; 0: all")
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
  app.add_option("--watchdog-steps", o.watchdog_steps,
                 "fixed and timed devices: node and leaf visits one ray may make before the watchdog stops the "
                 "trace with an error (0: the image's own bound, which a valid BVH never reaches)")
      ->capture_default_str();
  std::vector<std::string> presets;
  for (const hw::FixedFormat& f : hw::format_presets()) presets.push_back(f.name);
  app.add_option("--format", o.format, "fixed-point format preset (rtusim info --formats lists them)")
      ->check(CLI::IsMember(presets))
      ->capture_default_str();
  auto field = [&](const char* flag, int& v, const char* help) {
    app.add_option(flag, v, help)->check(CLI::NonNegativeNumber)->group("Fixed-point format (overrides)");
  };
  field("--coord-bits", o.coord_bits, "B: grid bits of scene coordinates (2..30)");
  field("--child-bits", o.child_bits, "k: bits of child box offsets (1..16)");
  field("--guard-bits", o.guard_bits, "G: ray origins may lie 2^G scene extents out (1..16)");
  field("--frac-bits", o.frac_bits, "F: fraction bits of origins, sphere centers/radii, plane offsets (0..24)");
  field("--dir-bits", o.dir_bits, "D: fraction bits of the scaled direction (4..30)");
  field("--rcp-bits", o.rcp_bits, "R: fraction bits of the reciprocal (4..40)");
  field("--t-frac-bits", o.t_frac_bits, "T: fraction bits of t (0..32)");
  field("--t-bits", o.t_bits, "magnitude bits of the t register (8..62)");
}

std::vector<hw::Ray> rays_from_spec(const std::string& spec, const Scene& scene, uint64_t seed) {
  auto number = [&](const std::string& text) {
    size_t used = 0;
    unsigned long long v = 0;
    try {
      v = std::stoull(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != text.size() || v == 0 || text[0] == '-')
      throw Error("--rays " + spec + ": bad count '" + text + "'");
    return uint64_t(v);
  };
  auto fits = [&](uint64_t n) {  // a ray and its hit per ray
    check_memory("--rays " + spec + ": " + std::to_string(n) + " rays", n * (sizeof(hw::Ray) + sizeof(hw::Hit)));
    return n;
  };
  if (spec == "primary") {
    fits(uint64_t(scene.camera.width) * uint64_t(scene.camera.height));
    return primary_rays(scene.camera, scene.camera.width, scene.camera.height);
  }
  if (spec.rfind("primary:", 0) == 0) {
    const std::string arg = spec.substr(8);
    const size_t x = arg.find('x');
    if (x == std::string::npos) return primary_rays(scene.camera, fits(number(arg)));
    const uint64_t w = number(arg.substr(0, x)), h = number(arg.substr(x + 1));
    if (w > 65536 || h > 65536) throw Error("--rays " + spec + ": image larger than 65536 x 65536");
    fits(w * h);
    return primary_rays(scene.camera, int(w), int(h));
  }
  if (spec.rfind("incoherent:", 0) == 0)
    return incoherent_rays(scene.geometry.bounds(), fits(number(spec.substr(11))), seed);
  return read_rays(spec);
}

Json bvh_json(const TraceDevice& d) {
  Json j;
  j["accel"] = d.bvh() ? "bvh" : "brute";
  j["brute_cost"] = d.brute_cost();
  if (const hw::Bvh* b = d.bvh()) {
    const hw::BvhFigures f = b->figures();
    j["width"] = f.width;
    j["inner_nodes"] = f.inner_nodes;
    j["leaves"] = f.leaves;
    j["prims"] = f.prims;
    j["depth"] = f.depth;
    j["leaf_size_min"] = f.min_leaf;
    j["leaf_size_max"] = f.max_leaf;
    j["leaf_size_mean"] = f.mean_leaf;
    j["node_fill"] = f.mean_fill;
    j["sah_cost"] = f.sah_cost;
    j["node_bytes"] = f.node_bytes;
    j["index_bytes"] = f.index_bytes;
    j["bytes_per_prim"] = f.prims ? double(f.node_bytes + f.index_bytes) / double(f.prims) : 0.0;
  }
  j["prim_bytes"] = d.prim_bytes();
  if (const hw::DeviceImage* img = d.image()) j["image"] = image_json(*img, d.bvh());
  return j;
}

Json format_json(const hw::FixedFormat& f) {
  Json j;
  j["name"] = f.name;
  j["width"] = f.width;
  j["coord_bits"] = f.coord_bits;
  j["child_bits"] = f.child_bits;
  j["guard_bits"] = f.guard_bits;
  j["frac_bits"] = f.frac_bits;
  j["dir_bits"] = f.dir_bits;
  j["rcp_bits"] = f.rcp_bits;
  j["t_frac_bits"] = f.t_frac_bits;
  j["t_bits"] = f.t_bits;
  j["box_product_bits"] = f.box_product_bits();
  j["edge_function_bits"] = f.edge_function_bits();
  return j;
}

Json image_json(const hw::DeviceImage& img, const hw::Bvh* bvh) {
  const hw::ImageHeader& h = img.header();
  Json j;
  j["bytes_per_node"] = img.node_bytes();
  j["nodes"] = h.node_count;
  j["node_bytes"] = img.nodes_size();
  j["records"] = h.record_count;
  j["record_bytes"] = img.records_size();
  j["plane_bytes"] = img.planes_size();
  j["total_bytes"] = img.size();
  j["frame"] = {{"coord_bits", h.coord_bits},
                {"step_exp", h.step_exp},
                {"origin", {h.frame_origin[0], h.frame_origin[1], h.frame_origin[2]}}};
  if (bvh) {
    const hw::BvhFigures f = bvh->figures();
    j["float_node_bytes"] = f.node_bytes;
    j["float_index_bytes"] = f.index_bytes;
    // Nodes against nodes (the strict figure); the image also needs no leaf index array (its records carry
    // their primitive index), which the second figure credits.
    j["node_bytes_ratio"] = f.node_bytes ? double(img.nodes_size()) / double(f.node_bytes) : 0.0;
    j["bvh_bytes_ratio"] = f.node_bytes ? double(img.nodes_size()) / double(f.node_bytes + f.index_bytes) : 0.0;
  }
  return j;
}

Json traversal_json(const hw::TraversalStats& s) {
  Json j;
  j["rays"] = s.rays + s.invalid_rays;
  j["valid_rays"] = s.rays;
  j["hits"] = s.hits;
  j["invalid_rays"] = s.invalid_rays;
  Json reasons = Json::object();
  for (size_t i = 1; i < s.invalid_by_reason.size(); ++i)
    if (s.invalid_by_reason[i]) reasons[hw::ray_status_name(hw::RayStatus(i))] = s.invalid_by_reason[i];
  j["invalid_by_reason"] = reasons;
  j["nodes_visited"] = s.nodes_visited;
  j["leaves_visited"] = s.leaves_visited;
  j["box_tests"] = s.box_tests;
  j["prim_tests"] = s.prim_tests;
  j["saturations"] = s.saturations;
  if (s.box_checks) {
    j["box_checks"] = s.box_checks;
    j["box_false_negatives"] = s.box_false_negatives;
    j["box_false_positives"] = s.box_false_positives;
  }
  const double n = s.rays ? double(s.rays) : 1.0;
  j["nodes_per_ray"] = double(s.nodes_visited) / n;
  j["box_tests_per_ray"] = double(s.box_tests) / n;
  j["prim_tests_per_ray"] = double(s.prim_tests) / n;
  return j;
}

void write_json(const std::string& path, const Json& j) {
  std::ofstream out(path);
  if (!out) throw Error(path + ": cannot open for writing");
  out << j.dump(2) << '\n';
  if (!out.flush()) throw Error(path + ": write error");
}

hw::TimingConfig timing_config_from(const std::string& preset, const std::vector<std::string>& sets) {
  hw::TimingConfig c;
  try {
    c = hw::timing_preset(preset);
  } catch (const std::invalid_argument& e) {
    throw Error(e.what());
  }
  for (const std::string& s : sets) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos) throw Error("--set '" + s + "' is not key=value");
    try {
      hw::set_timing_key(c, s.substr(0, eq), s.substr(eq + 1));
    } catch (const std::invalid_argument& e) {
      throw Error("--set " + s + ": " + e.what());
    }
  }
  return c;
}

Json timing_json(const hw::TimingConfig& c) {
  Json j;
  j["preset"] = c.name;
  for (const hw::TimingKey& k : hw::timing_keys(c)) {
    // The value text is an integer, a double in its round-trip form, or text (the format's name).
    const char* first = k.value.data();
    const char* last = first + k.value.size();
    long long i = 0;
    double d = 0;
    if (auto r = std::from_chars(first, last, i); !k.value.empty() && r.ec == std::errc() && r.ptr == last)
      j[k.key] = i;
    else if (auto r2 = std::from_chars(first, last, d); !k.value.empty() && r2.ec == std::errc() && r2.ptr == last)
      j[k.key] = d;
    else
      j[k.key] = k.value;
  }
  return j;
}

}  // namespace rtu::host::cmd

namespace rtu::host::cmd {

Json timing_stats_json(const hw::TimingStats& s, const hw::TimingConfig& c) {
  Json j;
  const double cyc = double(s.cycles), rays = double(s.rays);
  j["cycles"] = s.cycles;
  j["packets"] = s.packets;
  j["rays"] = s.rays;
  j["cycles_per_ray"] = rays > 0 ? cyc / rays : 0.0;
  j["rays_per_clock"] = cyc > 0 ? rays / cyc : 0.0;
  j["seconds_at_clock"] = cyc / (c.clock_ghz * 1e9);
  j["box_tests"] = s.box_tests;
  j["triangle_tests"] = s.tri_tests;
  j["sphere_tests"] = s.sphere_tests;
  j["plane_tests"] = s.plane_tests;
  j["utilization"] = {
      {"box_units", cyc > 0 ? double(s.box_issue_cycles) / (cyc * c.box_units) : 0.0},
      {"triangle_units", cyc > 0 ? double(s.tri_issue_cycles) / (cyc * c.tri_units * c.tri_rate) : 0.0},
      {"dram", cyc > 0 ? double(s.dram_busy_cycles) / cyc : 0.0},
      {"ray_slots", cyc > 0 ? double(s.slot_busy_cycles) / (cyc * c.ray_slots) : 0.0}};
  const double accesses = double(s.cache_hits + s.cache_misses);
  j["cache"] = {{"line_accesses", s.cache_hits + s.cache_misses},
                {"hits", s.cache_hits},
                {"misses", s.cache_misses},
                {"hit_rate", accesses > 0 ? double(s.cache_hits) / accesses : 0.0}};
  j["node_fetches"] = s.node_fetches;
  j["prim_fetches"] = s.prim_fetches;
  j["dram_bytes"] = s.dram_bytes;
  j["dram_bytes_per_cycle"] = cyc > 0 ? double(s.dram_bytes) / cyc : 0.0;
  j["dram_gb_per_s"] = cyc > 0 ? double(s.dram_bytes) / cyc * c.clock_ghz : 0.0;
  j["stream_bytes"] = s.stream_bytes;
  j["stack_spills"] = s.stack_spills;
  j["stack_refills"] = s.stack_refills;
  j["queue_stall_cycles"] = s.queue_stall_cycles;
  // The unit cannot be faster than its busiest resource. Box tests count in whole clocks per node (a node of
  // c children issues for ceil(c / box_rate) clocks), so the bound is the issue clocks over the units.
  const double box = double(s.box_issue_cycles) / double(c.box_units);
  const double tri = double(s.tri_tests + s.sphere_tests + s.plane_tests) / double(c.tri_rate * c.tri_units);
  const double mem = double(s.dram_bytes) / c.dram_bytes_per_cycle;
  const double bound = std::max({box, tri, mem});
  j["lower_bound"] = {{"cycles", bound},
                      {"box", box},
                      {"triangle", tri},
                      {"dram", mem},
                      {"limited_by", bound == box ? "box" : (bound == tri ? "triangle" : "dram")},
                      {"cycles_over_bound", bound > 0 ? cyc / bound : 0.0}};
  return j;
}

void print_timing_summary(const hw::TimingStats& s, const hw::TimingConfig& c) {
  const Json j = timing_stats_json(s, c);
  std::printf(
      "timed (%s): %llu cycles, %.1f cycles per ray, %.3f rays per clock; cache hit rate %.3f, DRAM %.1f B/clock; "
      "lower bound %.0f cycles (%s), cycles / bound %.2f\n",
      c.name.c_str(), (unsigned long long)s.cycles, j["cycles_per_ray"].get<double>(),
      j["rays_per_clock"].get<double>(), j["cache"]["hit_rate"].get<double>(),
      j["dram_bytes_per_cycle"].get<double>(), j["lower_bound"]["cycles"].get<double>(),
      j["lower_bound"]["limited_by"].get<std::string>().c_str(),
      j["lower_bound"]["cycles_over_bound"].get<double>());
}

Json timed_json(const hw::TimedEngine& e) {
  Json j = timing_stats_json(e.timing(), e.config());
  Json by_type = Json::object();
  for (int t = 0; t < hw::cmd::kRayTypeCount; ++t)
    if (e.timing_by_type()[size_t(t)].rays > 0)
      by_type[hw::cmd::ray_type_name(hw::cmd::RayType(t))] =
          timing_stats_json(e.timing_by_type()[size_t(t)], e.config());
  j["by_ray_type"] = by_type;
  Json by_bounce = Json::object();
  for (const auto& [b, s] : e.timing_by_bounce()) by_bounce[std::to_string(b)] = timing_stats_json(s, e.config());
  j["by_bounce"] = by_bounce;
  j["config"] = timing_json(e.config());
  j["sample"] = sample_json(e.sampling());
  return j;
}

Json sample_json(const hw::SampleStats& s) {
  Json j;
  j["packets"] = s.packets;
  j["packets_sampled"] = s.packets_sampled;
  j["rays"] = s.rays;
  j["rays_simulated"] = s.rays_simulated;
  j["rays_warmed"] = s.rays_warmed;
  j["simulated_fraction"] = s.rays > 0 ? double(s.rays_simulated) / double(s.rays) : 0.0;
  j["units_measured"] = s.units_measured;
  j["warmup_rays_mean"] = s.units_measured > 0 ? double(s.warmup_rays) / double(s.units_measured) : 0.0;
  j["packets_stratified"] = s.packets_stratified;
  j["cycles_ci95"] = s.ci95();
  return j;
}

}  // namespace rtu::host::cmd

namespace rtu::host::cmd {

hw::PipelineTrace* PipelineTraceArgs::make() {
  if (path.empty()) return nullptr;
  const size_t colon = window.find(':');
  uint64_t from = 0, to = 0;
  auto parse = [&](const std::string& t, uint64_t& v) {
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    return r.ec == std::errc() && r.ptr == t.data() + t.size() && !t.empty();
  };
  if (colon == std::string::npos || !parse(window.substr(0, colon), from) ||
      !parse(window.substr(colon + 1), to) || from >= to)
    throw Error("--trace-window: expected FROM:TO in cycles with FROM < TO, got '" + window + "'");
  trace.from = from;
  trace.to = to;
  return &trace;
}

void PipelineTraceArgs::write() const {
  if (path.empty()) return;
  Json events = Json::array();
  for (const hw::PipelineTrace::Span& s : trace.spans)
    events.push_back(
        {{"name", s.what}, {"ph", "X"}, {"ts", s.start}, {"dur", s.end - s.start}, {"pid", 0}, {"tid", s.slot}});
  std::vector<bool> used;  // slots with a span, named once each
  for (const hw::PipelineTrace::Span& s : trace.spans) {
    if (s.slot >= used.size()) used.resize(size_t(s.slot) + 1, false);
    used[s.slot] = true;
  }
  for (uint32_t k = 0; k < used.size(); ++k) {
    if (!used[k]) continue;
    events.push_back({{"name", "thread_name"},
                      {"ph", "M"},
                      {"pid", 0},
                      {"tid", k},
                      {"args", {{"name", "ray slot " + std::to_string(k)}}}});
  }
  Json j;
  j["traceEvents"] = events;
  j["displayTimeUnit"] = "ns";
  j["otherData"] = {{"time_unit", "1 us in the viewer = 1 cycle"},
                    {"window", {trace.from, trace.to}},
                    {"spans", trace.spans.size()}};
  write_json(path, j);
}

void add_pipeline_trace_args(CLI::App& app, PipelineTraceArgs& a) {
  app.add_option("--pipeline-trace", a.path,
                 "timed device: write a Chrome/Perfetto trace (one track per ray slot) of --trace-window");
  app.add_option("--trace-window", a.window,
                 "cycles FROM:TO of the pipeline trace (the timing model's cycles: TRACE packets back to back "
                 "since the scene was bound)")
      ->capture_default_str();
}

}  // namespace rtu::host::cmd
