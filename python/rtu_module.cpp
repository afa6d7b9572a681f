// _rtu: the compiled part of the Python module rtu (python/README.md). Scenes, rays and hits as numpy arrays,
// tracing on every device, compare, render, sweep and plan. Every job calls the host function rtusim calls
// (host/jobs/trace_job.h, compare_job.h, render.h, sweep.h, plan.h) with the same settings (host::DeviceSettings),
// so its hits, cycles and statistics are the CLI's bit for bit; statistics are the CLI's JSON as Python dicts. The
// GIL is released while a job runs; sweep and plan check for Ctrl-C between their steps (check_signals) and stop
// with KeyboardInterrupt. Every error a job throws arrives as rtu.Error with the CLI's message; an argument of
// the wrong type is a TypeError naming the parameter. The sweep, manifest, plan and Pareto bindings are in
// rtu_sweep.cpp (register_sweep); what the two files share in rtu_module.h.
// python/rtu/__init__.py is the thin Python layer over it (keyword defaults, DataFrames).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstring>
#include <exception>
#include <memory>
#include <new>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "host/cost/timing_json.h"
#include "host/devices/device_settings.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/image.h"
#include "host/io/json_io.h"
#include "host/io/limits.h"
#include "host/io/ray_io.h"
#include "host/io/stats_json.h"
#include "host/jobs/ab.h"
#include "host/jobs/compare_job.h"
#include "host/jobs/image_diff.h"
#include "host/jobs/motion.h"
#include "host/jobs/render.h"
#include "host/jobs/trace_job.h"
#include "host/scene/ray_spec.h"
#include "host/scene/scene.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/timing_config.h"
#include "python/rtu_module.h"

namespace py = pybind11;
using namespace rtu;
using namespace rtu::pymod;

namespace {

PyObject* g_error = nullptr;  // rtu.Error, derived from RuntimeError and ValueError

// A keyword argument cast to T, or a TypeError naming the parameter and what it takes (pybind11's own cast error
// names neither).
template <class T>
T arg(const py::handle& v, const std::string& name, const char* expected) {
  try {
    if constexpr (std::is_same_v<T, std::string>) {
      if (!py::isinstance<py::str>(v)) throw py::cast_error();
    } else if constexpr (std::is_same_v<T, bool>) {
      if (!py::isinstance<py::bool_>(v)) throw py::cast_error();
    } else if constexpr (std::is_integral_v<T>) {
      if (py::isinstance<py::bool_>(v) || !py::isinstance<py::int_>(v)) throw py::cast_error();
    }
    return v.cast<T>();
  } catch (const py::cast_error&) {
    throw py::type_error(name + ": expected " + expected + ", got " +
                         (v.is_none() ? std::string("None") : std::string(py::repr(v))));
  }
}

// A loaded scene, shared by the jobs that use it (immutable once loaded).
struct PyScene {
  std::shared_ptr<const host::Scene> scene;
};

PyScene load_scene(const std::string& spec) {
  py::gil_scoped_release nogil;  // mesh import and BVH-free loading can take seconds
  return PyScene{std::make_shared<const host::Scene>(host::load_scene(spec))};
}

// A scene description as JSON text (the Python layer dumps a dict): parsed as a scene file is, depth-bounded and
// strict, named `name` in messages; relative mesh paths are relative to `base_dir`.
PyScene load_scene_text(const std::string& text, const std::string& name, const std::string& base_dir) {
  py::gil_scoped_release nogil;
  host::Scene s = host::load_scene_json(host::parse_json_limited(text, name), name, base_dir);
  s.name = name;
  host::finish_scene(s);
  return PyScene{std::make_shared<const host::Scene>(std::move(s))};
}

py::tuple vec3(const hw::Vec3& v) {
  return py::make_tuple(v.x, v.y, v.z);
}

// --- rays and hits as numpy arrays ---

// Rays as an (N, 8) float32 array: ox oy oz tmin dx dy dz tmax, the ray file's record.
py::array rays_to_numpy(std::vector<hw::Ray>&& rays) {
  const py::ssize_t n = py::ssize_t(rays.size());
  return give(std::move(rays), py::dtype::of<float>(), {n, 8}, {py::ssize_t(sizeof(hw::Ray)), 4});
}

// Hits as a structured array of (t float32, prim uint32, u float32, v float32): the hit file's record.
py::array hits_to_numpy(std::vector<hw::Hit>&& hits) {
  const py::ssize_t n = py::ssize_t(hits.size());
  return give(std::move(hits), py::dtype::of<hw::Hit>(), {n}, {py::ssize_t(sizeof(hw::Hit))});
}

// Rays given by the user: an (N, 8) array of floats. A C-contiguous float32 array is traced in place (no copy);
// other float arrays are converted once. `keep` holds the array the span points into.
struct RaysIn {
  py::array keep;
  std::span<const hw::Ray> rays;
};

RaysIn rays_from_numpy(const py::handle& obj) {
  py::array a = py::array::ensure(obj);
  if (!a)
    fail("rays: expected a numpy array of shape (N, 8) (ox oy oz tmin dx dy dz tmax), got " +
         std::string(py::str(py::type::of(obj).attr("__name__"))));
  if (a.ndim() != 2 || a.shape(1) != 8) {
    std::string shape;
    for (py::ssize_t i = 0; i < a.ndim(); ++i) shape += (i ? ", " : "") + std::to_string(a.shape(i));
    fail("rays: expected an array of shape (N, 8) (ox oy oz tmin dx dy dz tmax), got shape (" + shape + ")");
  }
  if (a.dtype().kind() != 'f')
    fail("rays: expected a float array (float32 is traced without a copy), got dtype " +
         std::string(py::str(a.dtype())));
  using F32 = py::array_t<float, py::array::c_style | py::array::forcecast>;
  RaysIn in;
  in.keep = F32::ensure(a);  // the same array when it is float32 and C-contiguous
  if (!in.keep) fail("rays: cannot convert the array to float32");
  in.rays = {reinterpret_cast<const hw::Ray*>(in.keep.data()), size_t(in.keep.shape(0))};
  return in;
}

std::vector<hw::Hit> hits_from_numpy(const py::handle& obj) {
  py::array a = py::array::ensure(obj);
  if (!a || a.ndim() != 1 || !a.dtype().equal(py::dtype::of<hw::Hit>()))
    fail("hits: expected a 1-D structured array of dtype rtu.HIT_DTYPE (t, prim, u, v)");
  py::array c = py::array::ensure(a, py::array::c_style);
  std::vector<hw::Hit> hits(size_t(c.shape(0)));
  if (!hits.empty()) std::memcpy(hits.data(), c.data(), hits.size() * sizeof(hw::Hit));
  return hits;
}

// --- a device as the user names it: the options of rtusim's tracing commands ---

std::string value_text(const py::handle& v) {
  if (py::isinstance<py::bool_>(v)) return v.cast<bool>() ? "true" : "false";
  if (py::isinstance<py::str>(v)) return v.cast<std::string>();
  if (py::isinstance<py::int_>(v) || py::isinstance<py::float_>(v)) return std::string(py::str(v));
  fail("timing key value " + std::string(py::repr(v)) + ": expected a number, a string or a bool");
}

// Settings of a device from the keyword arguments; refuses what the device would ignore, as rtusim does.
struct DeviceArgs {
  std::string device = "float";
  py::object config, set, format, format_fields;
  int bvh_width = 0, leaf_size = 8;
  std::string accel = "auto";
  double sample = 0.0;
  uint32_t sample_unit = 256, sample_warmup = 0;
  uint64_t sample_seed = 1, watchdog_steps = 0;
  bool flatten = false;  // fixed, timed: an instanced scene in one image
  int omm_level = -1;    // trace, render on fixed and timed devices: opacity micromaps of this level (-1: none)

  hw::DeviceKind kind() const { return hw::parse_device_kind(device); }

  host::DeviceSettings settings(bool timing_allowed = true) const {
    const hw::DeviceKind k = kind();
    const bool timed = k == hw::DeviceKind::kTimed;
    auto refuse = [&](bool given, const char* name, const char* which) {
      if (given) fail(std::string(name) + " applies to device='" + which + "' only (not " + device + ")");
    };
    refuse(!timed && !config.is_none(), "config", "timed");
    refuse(!timed && !set.is_none(), "set", "timed");
    refuse(!timed && sample != 0.0, "sample", "timed");
    refuse(!timed && (sample_unit != 256 || sample_warmup != 0 || sample_seed != 1), "sample_unit/warmup/seed",
           "timed");
    refuse(k == hw::DeviceKind::kFloat && watchdog_steps != 0, "watchdog_steps", "fixed' or 'timed");
    refuse(k == hw::DeviceKind::kFloat && flatten, "flatten", "fixed' or 'timed");
    refuse(k == hw::DeviceKind::kFloat && !format_fields.is_none(), "format_fields", "fixed' or 'timed");
    if (!timing_allowed && sample != 0.0) fail("sample: this job reports no cycles");
    host::DeviceSettings s;
    if (bvh_width != 0 && bvh_width != 2 && bvh_width != 4 && bvh_width != 6 && bvh_width != 8)
      fail("bvh_width: " + std::to_string(bvh_width) + " is not 2, 4, 6 or 8");
    s.bvh_width = bvh_width;
    if (leaf_size < 1 || leaf_size > hw::kMaxLeafSize)
      fail("leaf_size: " + std::to_string(leaf_size) + " is not in 1.." + std::to_string(hw::kMaxLeafSize));
    s.leaf_size = leaf_size;
    if (accel != "auto" && accel != "bvh" && accel != "brute")
      fail("accel: '" + accel + "' is not auto, bvh or brute");
    s.accel = accel;
    if (!format.is_none()) {
      s.format = arg<std::string>(format, "format", "a format spec such as 'default' or 'packed:coord_bits=16'");
      hw::format_from_spec(s.format);  // a malformed spec is named now, as rtusim's option check does
    }
    if (!format_fields.is_none()) {
      if (!py::isinstance<py::dict>(format_fields)) fail("format_fields: expected a dict of field: bits");
      for (const auto& [key, value] : format_fields.cast<py::dict>()) {
        const std::string k2 = py::str(key);
        if (!py::isinstance<py::int_>(value) || value.cast<long long>() < 0 || value.cast<long long>() > 1 << 20)
          fail("format_fields: " + k2 + " must be a non-negative int");
        s.format_fields[k2] = value.cast<int>();
      }
    }
    // config: a preset name, or a dict {"preset": NAME, key: value, ...}; set: {key: value} or ["key=value"].
    if (py::isinstance<py::str>(config)) {
      s.config = config.cast<std::string>();
    } else if (py::isinstance<py::dict>(config)) {
      for (const auto& [key, value] : config.cast<py::dict>()) {
        const std::string k2 = py::str(key);
        if (k2 == "preset")
          s.config = arg<std::string>(value, "config[\"preset\"]", "a timing preset name such as 'rdna2'");
        else
          s.sets.push_back(k2 + "=" + value_text(value));
      }
    } else if (!config.is_none()) {
      fail("config: expected a preset name or a dict {\"preset\": NAME, key: value}");
    }
    if (py::isinstance<py::dict>(set)) {
      for (const auto& [key, value] : set.cast<py::dict>())
        s.sets.push_back(std::string(py::str(key)) + "=" + value_text(value));
    } else if (py::isinstance<py::list>(set) || py::isinstance<py::tuple>(set)) {
      for (const auto& item : set) s.sets.push_back(arg<std::string>(item, "set", "\"key=value\" strings"));
    } else if (!set.is_none()) {
      fail("set: expected a dict {key: value} or a list of \"key=value\"");
    }
    if (!(sample >= 0.0 && sample <= 1.0)) fail("sample: " + std::to_string(sample) + " is not in [0, 1]");
    if (sample_unit < 1 || sample_unit > (1u << 20)) fail("sample_unit: not in 1..1048576");
    if (sample_warmup > (1u << 20)) fail("sample_warmup: not in 0..1048576");
    s.sample = sample;
    s.sample_unit = sample_unit;
    s.sample_warmup = sample_warmup;
    s.sample_seed = sample_seed;
    s.watchdog_steps = watchdog_steps;
    s.flatten = flatten;
    // Resolve now (with the GIL held, before any work): bad keys, values and formats are reported here.
    (void)s.options(k);
    return s;
  }
};

DeviceArgs device_args(const py::dict& kw) {
  DeviceArgs d;
  d.config = py::none();
  d.set = py::none();
  d.format = py::none();
  d.format_fields = py::none();
  for (const auto& [key, value] : kw) {
    const std::string k = py::str(key);
    if (k == "device") {
      d.device = arg<std::string>(value, "device", "'float', 'fixed' or 'timed'");
      if (d.device != "float" && d.device != "fixed" && d.device != "timed")
        fail("device: '" + d.device + "' is not 'float', 'fixed' or 'timed'");
    } else if (k == "config")
      d.config = py::reinterpret_borrow<py::object>(value);
    else if (k == "set")
      d.set = py::reinterpret_borrow<py::object>(value);
    else if (k == "format")
      d.format = py::reinterpret_borrow<py::object>(value);
    else if (k == "format_fields")
      d.format_fields = py::reinterpret_borrow<py::object>(value);
    else if (k == "bvh_width")
      d.bvh_width = arg<int>(value, k, "an int: 2, 4, 6 or 8 (0: the device's)");
    else if (k == "leaf_size")
      d.leaf_size = arg<int>(value, k, "an int");
    else if (k == "accel")
      d.accel = arg<std::string>(value, k, "'auto', 'bvh' or 'brute'");
    else if (k == "sample")
      d.sample = arg<double>(value, k, "a number in [0, 1]");
    else if (k == "sample_unit")
      d.sample_unit = arg<uint32_t>(value, k, "a positive int");
    else if (k == "sample_warmup")
      d.sample_warmup = arg<uint32_t>(value, k, "a non-negative int");
    else if (k == "sample_seed")
      d.sample_seed = arg<uint64_t>(value, k, "a non-negative int");
    else if (k == "watchdog_steps")
      d.watchdog_steps = arg<uint64_t>(value, k, "a non-negative int");
    else if (k == "flatten")
      d.flatten = arg<bool>(value, k, "True or False");
    else if (k == "omm_level") {
      d.omm_level = arg<int>(value, k, "an int in -1..10");
      if (d.omm_level < -1 || d.omm_level > hw::kMaxMicromapLevel)
        fail("omm_level: " + std::to_string(d.omm_level) + " is not in -1..10 (-1: no micromaps)");
    } else
      fail("unknown keyword argument '" + k +
           "' (device options: device, config, set, format, format_fields, bvh_width, leaf_size, accel, sample, "
           "sample_unit, sample_warmup, sample_seed, watchdog_steps, flatten, omm_level)");
  }
  return d;
}

// --- the jobs ---

// rtusim trace: (hits, stats dict, invalid-ray message or "").
// rtusim trace: (hits, stats, invalid message); with all_hits >= 0 (rtusim trace --all-hits) the hits are the
// (N, all_hits) lists, unkept slots misses, and a fourth item the (N,) uint64 counts.
py::tuple trace(const PyScene& scene, const py::handle& rays_obj, bool any_hit, int threads, bool need_hits,
                const std::string& rays_name, int all_hits, size_t packet_rays, const py::kwargs& kw) {
  const DeviceArgs d = device_args(kw);
  host::TraceRequest req;
  req.scene = scene.scene.get();
  req.settings = d.settings();
  req.kind = d.kind();
  req.any_hit = any_hit;
  req.threads = check_threads(threads);
  req.omm_level = d.omm_level;
  req.need_hits = need_hits;
  req.all_hits = all_hits;
  req.packet_rays = packet_rays;
  if (all_hits >= 0 && !need_hits) fail("hits=False does not apply to all_hits");
  if (!need_hits && !(req.kind == hw::DeviceKind::kTimed && d.sample > 0.0))
    fail("hits=False is allowed only with device='timed' and sample > 0 (cycles only)");
  const RaysIn in = rays_from_numpy(rays_obj);
  req.rays = in.rays;
  host::Json stats;
  std::vector<hw::Hit> hits;
  std::vector<uint64_t> counts;
  std::string invalid;
  req.poll = check_signals;  // Ctrl-C between chunks of rays
  {
    py::gil_scoped_release nogil;
    host::TraceRun run = host::run_trace(req);
    stats = host::trace_stats_json(req, run, rays_name, d.device, 0.0);
    invalid = host::invalid_rays_message(run.stats);
    hits = std::move(all_hits >= 0 ? run.lists : run.hits);
    counts = std::move(run.counts);
  }
  if (all_hits < 0) return py::make_tuple(hits_to_numpy(std::move(hits)), to_python(stats), invalid);
  const py::ssize_t n = py::ssize_t(counts.size()), k = all_hits;
  const py::ssize_t hb = py::ssize_t(sizeof(hw::Hit));
  py::array lists = give(std::move(hits), py::dtype::of<hw::Hit>(), {n, k}, {k * hb, hb});
  py::array c = give(std::move(counts), py::dtype::of<uint64_t>(), {n}, {py::ssize_t(sizeof(uint64_t))});
  return py::make_tuple(lists, to_python(stats), invalid, c);
}

// rtusim trace --against-*: two timed runs of one ray set and host::ab_json of them: (A/B dict, A's stats, B's
// stats). `a_kw` and `b_kw` are each side's device options, the common ones already merged in.
py::tuple ab(const PyScene& scene, const py::handle& rays_obj, bool any_hit, int threads, bool need_hits,
             const std::string& rays_name, const py::dict& a_kw, const py::dict& b_kw) {
  const DeviceArgs da = device_args(a_kw), db = device_args(b_kw);
  if (da.omm_level >= 0 || db.omm_level >= 0) fail("omm_level applies to trace and render only");
  if (da.kind() != hw::DeviceKind::kTimed || db.kind() != hw::DeviceKind::kTimed)
    fail("ab: compares two runs of the timed device (device='timed')");
  if (!need_hits && !(da.sample > 0.0 && db.sample > 0.0))
    fail("hits=False is allowed only with sample > 0 (cycles only)");
  host::TraceRequest ra;
  ra.scene = scene.scene.get();
  ra.settings = da.settings();
  ra.kind = hw::DeviceKind::kTimed;
  ra.any_hit = any_hit;
  ra.threads = check_threads(threads);
  ra.need_hits = need_hits;
  ra.poll = check_signals;
  host::TraceRequest rb = ra;
  rb.settings = db.settings();
  const RaysIn in = rays_from_numpy(rays_obj);
  ra.rays = rb.rays = in.rays;
  host::Json ab, sa, sb;
  {
    py::gil_scoped_release nogil;
    const host::TraceRun a = host::run_trace(ra);
    sa = host::trace_stats_json(ra, a, rays_name, "timed", 0.0);
    const host::TraceRun b = host::run_trace(rb);
    sb = host::trace_stats_json(rb, b, rays_name, "timed", 0.0);
    // Cycles only (hits=False): the hit arrays hold no answers to compare.
    const std::span<const hw::Hit> ha = need_hits ? std::span<const hw::Hit>(a.hits) : std::span<const hw::Hit>(),
                                   hb = need_hits ? std::span<const hw::Hit>(b.hits) : std::span<const hw::Hit>();
    ab = host::ab_json({host::settings_label(ra.settings), &sa, ha}, {host::settings_label(rb.settings), &sb, hb});
  }
  return py::make_tuple(to_python(ab), to_python(sa), to_python(sb));
}

// rtusim compare: the --json dict and the disagreeing rays.
py::tuple compare(const PyScene& scene, const py::handle& rays_obj, const std::string& rays_name, bool any_hit,
                  int threads, size_t max_list, const py::kwargs& kw) {
  DeviceArgs d = device_args(kw);
  if (d.omm_level >= 0) fail("omm_level applies to trace and render only");
  if (!kw.contains("device")) d.device = "fixed";
  host::CompareRequest req;
  req.scene = scene.scene.get();
  req.settings = d.settings(false);
  req.kind = d.kind();
  req.rays_name = rays_name;
  req.any_hit = any_hit;
  req.threads = check_threads(threads);
  req.max_list = max_list;
  const RaysIn in = rays_from_numpy(rays_obj);
  if (in.rays.empty()) fail("rays: no rays given (an empty array): nothing to compare");
  const std::vector<hw::Ray> rays(in.rays.begin(), in.rays.end());
  req.rays = &rays;
  host::Json json;
  std::vector<hw::Ray> replay;
  req.poll = check_signals;
  {
    py::gil_scoped_release nogil;
    host::CompareRun run = host::compare_devices(req);
    host::check_compared(run);
    host::check_box_false_negatives(run);
    json = std::move(run.json);
    replay = std::move(run.replay);
  }
  return py::make_tuple(to_python(json), rays_to_numpy(std::move(replay)));
}

// An 8-bit RGB image (H, W, 3) from numpy, as host::Image.
host::Image image_from_numpy(const py::handle& obj, const char* what) {
  py::array a = py::array::ensure(obj);
  if (!a || a.ndim() != 3 || a.shape(2) != 3 || a.dtype().kind() != 'u' || a.dtype().itemsize() != 1)
    fail(std::string(what) + ": expected a uint8 array of shape (height, width, 3)");
  py::array c = py::array::ensure(a, py::array::c_style);
  host::Image img;
  img.height = int(c.shape(0));
  img.width = int(c.shape(1));
  img.rgb.resize(size_t(c.nbytes()));
  if (!img.rgb.empty()) std::memcpy(img.rgb.data(), c.data(), img.rgb.size());
  return img;
}

py::array image_to_numpy(host::Image&& img) {
  const py::ssize_t h = img.height, w = img.width;
  return give(std::move(img.rgb), py::dtype::of<uint8_t>(), {h, w, 3}, {w * 3, 3, 1});
}

// rtusim render: (image uint8 (H, W, 3), radiance float32 (H, W, 3), stats dict, warnings).
py::tuple render(const PyScene& scene, const std::string& mode, int width, int height, int spp, int max_depth,
                 uint32_t seed, bool indirect, bool ao, float ao_distance, std::vector<float> background,
                 int threads, const py::kwargs& kw) {
  const DeviceArgs d = device_args(kw);
  host::RenderOptions o;
  o.device = d.settings().options(d.kind());
  if (mode != "raytrace" && mode != "hybrid") fail("mode: '" + mode + "' is not raytrace or hybrid");
  o.hybrid = mode == "hybrid";
  o.omm_level = d.omm_level;
  if (width < 0 || width > 16384 || height < 0 || height > 16384)
    fail("width, height: not in 1..16384 (0: the scene camera's)");
  if (spp < 1 || spp > 65536) fail("spp: " + std::to_string(spp) + " is not in 1..65536");
  if (max_depth < 0 || max_depth > 64) fail("max_depth: " + std::to_string(max_depth) + " is not in 0..64");
  if (ao_distance != 0.0f && !ao) fail("ao_distance applies with ao=True only");
  if (!(ao_distance >= 0.0f) || !std::isfinite(ao_distance)) fail("ao_distance: not a positive number");
  if (ao && !indirect) fail("indirect=False applies without ao only (ambient occlusion has no indirect light)");
  if (background.size() != 3) fail("background: expected 3 values (R, G, B)");
  for (float b : background)
    if (!(b >= 0.0f && b <= 1e6f)) fail("background: values must be in [0, 1e6]");
  o.threads = check_threads(threads);
  o.width = width;
  o.height = height;
  o.spp = spp;
  o.max_depth = max_depth;
  o.seed = seed;
  o.ao = ao;
  o.indirect = indirect;
  o.ao_distance = ao_distance;
  o.background = hw::Vec3(background[0], background[1], background[2]);
  host::Json stats;
  host::Image img;
  std::vector<float> rgb;
  std::vector<std::string> warnings;
  int w = 0, h = 0;
  o.poll = check_signals;  // Ctrl-C at the firmware's doorbells
  {
    py::gil_scoped_release nogil;
    host::RenderResult r = host::render(*scene.scene, o);
    stats = host::render_json(r, o);
    stats["scene"] = scene.scene->name;
    img = host::to_image(r);
    warnings = host::render_warnings(r);
    w = r.width;
    h = r.height;
    rgb = std::move(r.rgb);
  }
  py::array radiance = give(std::move(rgb), py::dtype::of<float>(), {h, w, 3}, {py::ssize_t(w) * 12, 12, 4});
  return py::make_tuple(image_to_numpy(std::move(img)), radiance, to_python(stats), warnings);
}

// rtusim diff's figures of two images.
py::dict diff(const py::handle& a, const py::handle& b) {
  // One after the other, so that a bad `a` is named before `b` (argument order of evaluation is unspecified).
  const host::Image ia = image_from_numpy(a, "a");
  const host::Image ib = image_from_numpy(b, "b");
  const host::ImageDiff d = host::diff_images(ia, ib);
  py::dict j;
  j["width"] = d.width;
  j["height"] = d.height;
  j["identical"] = d.identical();
  j["mse"] = d.mse;
  j["psnr_db"] = std::isfinite(d.psnr_db) ? py::object(py::float_(d.psnr_db)) : py::object(py::none());
  j["max_abs"] = d.max_abs;
  j["mean_abs"] = d.mean_abs;
  j["pixels_differing"] = d.pixels_differing;
  j["frac_pixels_differing"] = d.frac_pixels_differing;
  return j;
}

// rtu.motion: the job of rtusim motion; scene None is the built-in moving scene.
py::tuple motion(const py::object& scene, std::vector<float> move, int width, int height, int samples, int level,
                 float motion_scale, int time_bits, int box_time_bits, uint64_t seed, int threads,
                 const std::string& format, const std::string& config, const std::vector<std::string>& sets,
                 const py::object& rays, const py::object& times, bool instances) {
  host::MotionJobOptions o;
  if (instances && !scene.is_none()) fail("instances chooses the built-in moving instances (scene=None)");
  o.instances = instances;
  if (rays.is_none() != times.is_none()) fail("rays and times go together (a shutter time for every ray)");
  if (!rays.is_none()) {
    const RaysIn in = rays_from_numpy(rays);
    o.rays.assign(in.rays.begin(), in.rays.end());
    using F32 = py::array_t<float, py::array::c_style | py::array::forcecast>;
    const F32 t = F32::ensure(times);
    if (!t || t.ndim() != 1 || size_t(t.shape(0)) != o.rays.size())
      fail("times: expected a 1-D array of " + std::to_string(o.rays.size()) + " shutter times, one a ray");
    o.times.assign(t.data(), t.data() + t.shape(0));
    try {
      hw::validate_shutter_times(o.times, o.rays.size());
    } catch (const std::invalid_argument& e) {
      fail(std::string("times: ") + e.what());
    }
  }
  std::shared_ptr<const host::Scene> keep;
  if (!scene.is_none()) {
    keep = scene.cast<PyScene>().scene;
    o.loaded = keep.get();
  } else if (move != std::vector<float>{0.0f, 0.0f, 0.0f}) {
    fail("move applies to a scene only (scene=None is the built-in moving scene)");
  }
  if (!scene.is_none() && (level != 4 || motion_scale != 1.0f))
    fail("level and motion_scale apply to the built-in scene only (scene=None)");
  if (move.size() != 3) fail("move: expected 3 numbers (x, y, z)");
  if (width < 1 || height < 1 || width > 8192 || height > 8192) fail("width, height: must be in 1..8192");
  if (samples < 1 || samples > 1024) fail("samples: must be in 1..1024");
  if (level < 0 || level > 7) fail("level: must be in 0..7");
  if (!(motion_scale >= 0.0f && motion_scale <= 1.0f)) fail("motion_scale: must be in [0, 1]");
  o.move = hw::Vec3(move[0], move[1], move[2]);
  o.width = width;
  o.height = height;
  o.samples = samples;
  o.level = level;
  o.motion_scale = motion_scale;
  o.motion = hw::MotionFormat{time_bits, box_time_bits};
  o.seed = seed;
  o.threads = check_threads(threads);
  o.format = hw::format_from_spec(format);
  o.timing = host::timing_config_from(config, sets);
  host::MotionJobResult r;
  {
    py::gil_scoped_release nogil;
    r = host::run_motion_job(o);
  }
  if (!o.rays.empty())
    return py::make_tuple(py::none(), py::none(), to_python(host::motion_json(o, r)),
                          hits_to_numpy(std::move(r.hits)));
  return py::make_tuple(image_to_numpy(std::move(r.float_image)), image_to_numpy(std::move(r.fixed_image)),
                        to_python(host::motion_json(o, r)));
}

}  // namespace

PYBIND11_MODULE(_rtu, m) {
  m.doc() = "rtu's compiled core (use the package rtu; python/README.md)";
  PYBIND11_NUMPY_DTYPE(hw::Hit, t, prim, u, v);  // the hit file's record: t, prim, u, v (4 bytes each)

  // rtu.Error: every error of a job, with rtusim's message. Both a RuntimeError and a ValueError, so that code
  // catching either sees bad input.
  py::tuple bases = py::make_tuple(py::handle(PyExc_RuntimeError), py::handle(PyExc_ValueError));
  g_error = PyErr_NewExceptionWithDoc("rtu.Error", "An rtu error: bad input or a failed job (rtusim's message)",
                                      bases.ptr(), nullptr);
  m.attr("Error") = py::handle(g_error);
  // trace(packet_rays=...): the default and the largest, as rtusim trace --packet-rays.
  m.attr("TRACE_PACKET_RAYS") = host::kTracePacketRays;
  m.attr("MAX_TRACE_PACKET_RAYS") = host::kMaxTracePacketRays;
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const py::error_already_set&) {
      throw;  // a Python exception passing through
    } catch (const py::builtin_exception&) {
      throw;  // pybind11's own (type errors of arguments)
    } catch (const std::bad_alloc&) {
      // MemoryError, with what bounds memory instead of the bare "std::bad_alloc".
      PyErr_SetString(PyExc_MemoryError, host::out_of_memory_message("rtu").c_str());
    } catch (const std::exception& e) {
      PyErr_SetString(g_error, e.what());
    }
  });

  py::class_<PyScene>(m, "Scene", "A loaded scene (rtu.load_scene)")
      .def_property_readonly("name", [](const PyScene& s) { return s.scene->name; })
      .def_property_readonly("triangles", [](const PyScene& s) { return s.scene->geometry.triangles.size(); })
      .def_property_readonly("spheres", [](const PyScene& s) { return s.scene->geometry.spheres.size(); })
      .def_property_readonly("curves", [](const PyScene& s) { return s.scene->geometry.curves.size(); })
      .def_property_readonly("planes", [](const PyScene& s) { return s.scene->geometry.planes.size(); })
      .def_property_readonly("primitives", [](const PyScene& s) { return s.scene->geometry.num_prims(); })
      .def_property_readonly("lights", [](const PyScene& s) { return s.scene->lights.size(); })
      .def_property_readonly("materials", [](const PyScene& s) { return s.scene->materials.size(); })
      .def_property_readonly("instanced", [](const PyScene& s) { return s.scene->instanced(); })
      .def_property_readonly("bounds",
                             [](const PyScene& s) {
                               const hw::Aabb b = s.scene->geometry.bounds();
                               return py::make_tuple(vec3(b.lo), vec3(b.hi));
                             })
      .def_property_readonly("camera",
                             [](const PyScene& s) {
                               const host::Camera& c = s.scene->camera;
                               py::dict d;
                               d["position"] = vec3(c.position);
                               d["look_at"] = vec3(c.look_at);
                               d["up"] = vec3(c.up);
                               d["fov_y_deg"] = c.fov_y_deg;
                               d["width"] = c.width;
                               d["height"] = c.height;
                               d["framed"] = !s.scene->has_camera;
                               return d;
                             })
      .def("__repr__", [](const PyScene& s) {
        return "<rtu.Scene " + s.scene->name + ": " + std::to_string(s.scene->geometry.num_prims()) +
               " primitives>";
      });

  m.def("load_scene", &load_scene, py::arg("spec"));
  m.def("load_scene_text", &load_scene_text, py::arg("text"), py::arg("name"), py::arg("base_dir"));
  m.def("builtin_scenes", &host::builtin_scene_names);
  m.def("hit_dtype", [] { return py::dtype::of<hw::Hit>(); });

  m.def(
      "rays",
      [](const PyScene& s, const std::string& spec, uint64_t seed) {
        std::vector<hw::Ray> r;
        {
          py::gil_scoped_release nogil;
          r = host::rays_from_spec(spec, *s.scene, seed);
        }
        return rays_to_numpy(std::move(r));
      },
      py::arg("scene"), py::arg("spec"), py::arg("seed"));
  m.def(
      "read_rays", [](const std::string& path) { return rays_to_numpy(host::read_rays(path)); }, py::arg("path"));
  m.def(
      "write_rays",
      [](const std::string& path, const py::handle& rays) {
        const RaysIn in = rays_from_numpy(rays);
        host::write_rays(path, std::vector<hw::Ray>(in.rays.begin(), in.rays.end()));
      },
      py::arg("path"), py::arg("rays"));
  m.def(
      "read_hits", [](const std::string& path) { return hits_to_numpy(host::read_hits(path)); }, py::arg("path"));
  m.def(
      "write_hits",
      [](const std::string& path, const py::handle& hits) { host::write_hits(path, hits_from_numpy(hits)); },
      py::arg("path"), py::arg("hits"));

  m.def("trace", &trace, py::arg("scene"), py::arg("rays"), py::arg("any_hit"), py::arg("threads"),
        py::arg("need_hits"), py::arg("rays_name"), py::arg("all_hits"), py::arg("packet_rays"));
  m.def("ab", &ab, py::arg("scene"), py::arg("rays"), py::arg("any_hit"), py::arg("threads"), py::arg("need_hits"),
        py::arg("rays_name"), py::arg("a"), py::arg("b"));
  m.def("compare", &compare, py::arg("scene"), py::arg("rays"), py::arg("rays_name"), py::arg("any_hit"),
        py::arg("threads"), py::arg("max_list"));
  m.def("render", &render, py::arg("scene"), py::arg("mode"), py::arg("width"), py::arg("height"), py::arg("spp"),
        py::arg("max_depth"), py::arg("seed"), py::arg("indirect"), py::arg("ao"), py::arg("ao_distance"),
        py::arg("background"), py::arg("threads"));
  m.def("diff", &diff, py::arg("a"), py::arg("b"));
  m.def("motion", &motion, py::arg("scene"), py::arg("move"), py::arg("width"), py::arg("height"),
        py::arg("samples"), py::arg("level"), py::arg("motion_scale"), py::arg("time_bits"),
        py::arg("box_time_bits"), py::arg("seed"), py::arg("threads"), py::arg("format"), py::arg("config"),
        py::arg("sets"), py::arg("rays"), py::arg("times"), py::arg("instances"));
  m.def(
      "read_png", [](const std::string& path) { return image_to_numpy(host::read_png(path)); }, py::arg("path"));
  m.def(
      "write_png",
      [](const std::string& path, const py::handle& img) {
        host::write_png(path, image_from_numpy(img, "image"));
      },
      py::arg("path"), py::arg("image"));

  m.def(
      "config",
      [](const std::string& preset, const std::vector<std::string>& sets) {
        return to_python(host::timing_json(host::timing_config_from(preset, sets)));
      },
      py::arg("preset"), py::arg("sets"));
  m.def("presets", &hw::timing_preset_names);
  // The I/O layer's checks of a file name, for the files the Python layer reads and writes itself (rtu.Error
  // naming the path: a directory, a missing file or folder).
  m.def("check_input_file", &host::check_input_file, py::arg("path"));
  m.def("check_output_file", &host::check_output_file, py::arg("path"));
  m.def("formats", [] {
    std::vector<std::string> names;
    for (const hw::FixedFormat& f : hw::format_presets()) names.push_back(f.name);
    return names;
  });
  m.def(
      "format", [](const std::string& spec) { return to_python(host::format_json(hw::format_from_spec(spec))); },
      py::arg("spec"));

  register_queries(m);
  register_sweep(m);
}
