#include "host/devices/direct_device.h"

#include <stdexcept>

#include "host/devices/box_units.h"
#include "host/io/limits.h"

namespace rtu::host {

namespace {

// What the float devices share: the float reference's tracer (Tracer: one level or two) with the job's any-hit
// stage, and its ray checks.
template <class Tracer>
class FloatDeviceOf : public DirectDevice {
 public:
  template <class... TracerArgs>
  explicit FloatDeviceOf(const hw::AnyHitStage* any_hit, const TracerArgs&... args) : m_tracer(args...) {
    m_tracer.set_any_hit(any_hit);
  }
  hw::DeviceKind kind() const override { return hw::DeviceKind::kFloat; }
  void trace_batch(const hw::Ray* rays, hw::Hit* hits, size_t n, bool any_hit, int threads,
                   hw::TraversalStats& s) const override {
    m_tracer.trace_batch(rays, hits, n, any_hit, threads, s);
  }
  void trace_all_batch(const hw::Ray* rays, size_t n, const hw::AllHitsOut& out, int threads,
                       hw::TraversalStats& s) const override {
    hw::all_hits_batch(n, threads, out, s, [&](size_t i, hw::HitList& l, hw::TraversalStats& st) {
      return m_tracer.trace_all(rays[i], l, st);
    });
  }
  hw::RayStatus ray_status(const hw::Ray& r) const override { return hw::validate_ray(r); }

 protected:
  Tracer m_tracer;
};

class FloatDevice final : public FloatDeviceOf<hw::FloatTracer> {
 public:
  FloatDevice(const hw::Geometry& g, const DeviceOptions& o) : FloatDeviceOf(o.any_hit, g, o.tracer) {}
  const hw::Bvh* bvh() const override { return m_tracer.bvh(); }
  double bvh_cost() const override { return m_tracer.bvh_cost(); }
  double brute_cost() const override { return m_tracer.brute_cost(); }
  uint64_t prim_bytes() const override { return m_tracer.leaf_prim_bytes(); }
};

// The float reference over two levels.
class InstancedFloatDevice final : public FloatDeviceOf<hw::InstancedFloatTracer> {
 public:
  InstancedFloatDevice(const hw::Geometry& g, const DeviceOptions& o)
      : FloatDeviceOf(o.any_hit, *o.instances, g, o.tracer) {}
  const hw::Bvh* bvh() const override { return &m_tracer.top(); }
  double bvh_cost() const override { return m_tracer.top().figures().sah_cost; }
  double brute_cost() const override { return 0.0; }
  uint64_t prim_bytes() const override { return m_tracer.bytes() - m_tracer.top().figures().node_bytes; }
};

// What the fixed and timed devices share: the float BVH (for figures; the datapath reads only the image), the
// encoded image, and a fixed tracer over it.
class ImageDevice : public DirectDevice {
 public:
  ImageDevice(const hw::Geometry& g, const DeviceOptions& o)
      : m_bvh(hw::choose_accel(g, o.tracer, &m_bvh_cost, &m_brute_cost)),
        m_image(hw::encode_scene(g, o.format, m_bvh ? &*m_bvh : nullptr)),
        m_tracer(m_image, hw::FixedTraceOptions{o.check_boxes, o.max_steps}) {
    m_tracer.set_any_hit(o.any_hit);
    m_tracer.set_micromaps(o.micromaps);
  }
  hw::RayStatus ray_status(const hw::Ray& r) const override {
    hw::FixedRay fr;
    return hw::setup_ray(r, m_tracer.frame(), m_tracer.format(), fr);
  }
  const hw::Bvh* bvh() const override { return m_bvh ? &*m_bvh : nullptr; }
  double bvh_cost() const override { return m_bvh_cost; }
  double brute_cost() const override { return m_brute_cost; }
  const hw::DeviceImage* image() const override { return &m_image; }
  uint64_t prim_bytes() const override { return m_image.records_size() + m_image.planes_size(); }

 protected:
  double m_bvh_cost = 0.0, m_brute_cost = 0.0;
  std::optional<hw::Bvh> m_bvh;
  hw::DeviceImage m_image;
  hw::FixedTracer m_tracer;
};

// A fixed tracer's batch; a ray the watchdog stopped is an error, with the tracer's report.
template <class Tracer>
void trace_watched(const Tracer& t, const hw::Ray* rays, hw::Hit* hits, size_t n, bool any_hit, int threads,
                   hw::TraversalStats& s) {
  hw::TraversalStats local;
  t.trace_batch(rays, hits, n, any_hit, threads, local);
  if (local.watchdog_rays > 0)
    throw hw::WatchdogError(t.watchdog_report(rays, n, any_hit, local.watchdog_rays), 0);
  s.add(local);
}

// A fixed tracer's all-hit batch, watched as trace_watched.
template <class Tracer>
void trace_all_watched(const Tracer& t, const hw::Ray* rays, size_t n, const hw::AllHitsOut& out, int threads,
                       hw::TraversalStats& s) {
  hw::TraversalStats local;
  hw::all_hits_batch(n, threads, out, local, [&](size_t i, hw::HitList& l, hw::TraversalStats& st) {
    return t.trace_all(rays[i], l, st);
  });
  if (local.watchdog_rays > 0) throw hw::WatchdogError(t.watchdog_report(rays, n, false, local.watchdog_rays), 0);
  s.add(local);
}

class FixedDevice final : public ImageDevice {
 public:
  using ImageDevice::ImageDevice;
  hw::DeviceKind kind() const override { return hw::DeviceKind::kFixed; }
  void trace_batch(const hw::Ray* rays, hw::Hit* hits, size_t n, bool any_hit, int threads,
                   hw::TraversalStats& s) const override {
    trace_watched(m_tracer, rays, hits, n, any_hit, threads, s);
  }
  void trace_all_batch(const hw::Ray* rays, size_t n, const hw::AllHitsOut& out, int threads,
                       hw::TraversalStats& s) const override {
    trace_all_watched(m_tracer, rays, n, out, threads, s);
  }
};

// The fixed datapath over two levels (instanced_fixed.h): a top-level image, a bottom-level image per mesh.
class InstancedFixedDevice final : public DirectDevice {
  static hw::FixedTraceOptions trace_options(const DeviceOptions& o) {
    hw::FixedTraceOptions t{o.check_boxes, o.max_steps};
    t.any_hit = o.any_hit;
    return t;
  }

 public:
  InstancedFixedDevice(const hw::Geometry& g, const DeviceOptions& o)
      : m_tracer(*o.instances, g, o.format, o.tracer, trace_options(o)) {}
  hw::DeviceKind kind() const override { return hw::DeviceKind::kFixed; }
  void trace_batch(const hw::Ray* rays, hw::Hit* hits, size_t n, bool any_hit, int threads,
                   hw::TraversalStats& s) const override {
    trace_watched(m_tracer, rays, hits, n, any_hit, threads, s);
  }
  void trace_all_batch(const hw::Ray* rays, size_t n, const hw::AllHitsOut& out, int threads,
                       hw::TraversalStats& s) const override {
    trace_all_watched(m_tracer.top_tracer(), rays, n, out, threads, s);
  }
  hw::RayStatus ray_status(const hw::Ray& r) const override {
    hw::FixedRay fr;
    return hw::setup_ray(r, m_tracer.top_tracer().frame(), m_tracer.top_tracer().format(), fr);
  }
  const hw::Bvh* bvh() const override { return &m_tracer.top_bvh(); }
  double bvh_cost() const override { return m_tracer.top_bvh().figures().sah_cost; }
  double brute_cost() const override { return 0.0; }
  // The top level's image; bytes() of the tracer counts the bottom levels too.
  const hw::DeviceImage* image() const override { return &m_tracer.top(); }
  uint64_t prim_bytes() const override { return m_tracer.bytes() - m_tracer.top().nodes_size(); }
  const hw::InstancedFixedTracer* instanced() const override { return &m_tracer; }

 private:
  hw::InstancedFixedTracer m_tracer;
};

// The fixed datapath with the timing model: the engine the command processor would run, called directly.
class TimedDevice final : public ImageDevice {
  static hw::EngineOptions engine_options(const DeviceOptions& o) {
    hw::EngineOptions e;
    e.max_steps = o.max_steps;
    return e;
  }

 public:
  TimedDevice(const hw::Geometry& g, const DeviceOptions& o)
      : ImageDevice(g, o),
        m_engine(engine_options(o), o.timing, make_box_unit(o.timing), make_tri_unit(o.timing)) {
    m_engine.set_sampling(o.sample);
    m_engine.set_any_hit(o.any_hit);
    m_engine.set_micromaps(o.micromaps);
    m_engine.bind(m_image.data(), m_image.size());
  }
  hw::DeviceKind kind() const override { return hw::DeviceKind::kTimed; }
  void trace_batch(const hw::Ray* rays, hw::Hit* hits, size_t n, bool any_hit, int threads,
                   hw::TraversalStats& s) const override {
    m_engine.set_threads(threads);
    if (n > 0) m_engine.trace_cycles(rays, hits, n, any_hit, s, uint8_t(hw::cmd::RayType::kOther), 0);
  }
  void trace_all_batch(const hw::Ray* rays, size_t n, const hw::AllHitsOut& out, int threads,
                       hw::TraversalStats& s) const override {
    m_engine.set_threads(threads);
    if (n > 0) m_engine.trace_all_cycles(rays, n, out, s, uint8_t(hw::cmd::RayType::kOther), 0);
  }
  const hw::TimedEngine* timed() const override { return &m_engine; }
  void set_pipeline_trace(hw::PipelineTrace* trace) override { m_engine.set_trace(trace); }

 private:
  mutable hw::TimedEngine m_engine;  // simulation state changes as it traces
};

// The timed device over two levels: the engine binds the instance set (TimedEngine::bind_instanced).
class InstancedTimedDevice final : public DirectDevice {
  static hw::EngineOptions engine_options(const DeviceOptions& o) {
    hw::EngineOptions e;
    e.max_steps = o.max_steps;
    return e;
  }

 public:
  InstancedTimedDevice(const hw::Geometry& g, const DeviceOptions& o) : m_engine(engine_options(o), o.timing) {
    m_engine.set_sampling(o.sample);
    m_engine.set_any_hit(o.any_hit);
    m_engine.bind_instanced(*o.instances, g, o.format, o.tracer);
  }
  hw::DeviceKind kind() const override { return hw::DeviceKind::kTimed; }
  void trace_batch(const hw::Ray* rays, hw::Hit* hits, size_t n, bool any_hit, int threads,
                   hw::TraversalStats& s) const override {
    m_engine.set_threads(threads);
    if (n > 0) m_engine.trace_cycles(rays, hits, n, any_hit, s, uint8_t(hw::cmd::RayType::kOther), 0);
  }
  void trace_all_batch(const hw::Ray* rays, size_t n, const hw::AllHitsOut& out, int threads,
                       hw::TraversalStats& s) const override {
    m_engine.set_threads(threads);
    if (n > 0) m_engine.trace_all_cycles(rays, n, out, s, uint8_t(hw::cmd::RayType::kOther), 0);
  }
  hw::RayStatus ray_status(const hw::Ray& r) const override {
    const hw::FixedTracer& t = m_engine.instanced()->top_tracer();
    hw::FixedRay fr;
    return hw::setup_ray(r, t.frame(), t.format(), fr);
  }
  const hw::Bvh* bvh() const override { return &m_engine.instanced()->top_bvh(); }
  double bvh_cost() const override { return bvh()->figures().sah_cost; }
  double brute_cost() const override { return 0.0; }
  const hw::DeviceImage* image() const override { return &m_engine.instanced()->top(); }
  uint64_t prim_bytes() const override { return m_engine.instanced()->bytes() - image()->nodes_size(); }
  const hw::InstancedFixedTracer* instanced() const override { return m_engine.instanced(); }
  const hw::TimedEngine* timed() const override { return &m_engine; }
  void set_pipeline_trace(hw::PipelineTrace* trace) override { m_engine.set_trace(trace); }

 private:
  mutable hw::TimedEngine m_engine;
};

// Two levels on the timed device: the C++ datapath only (co-simulated units trace the flattened image).
bool two_level(const DeviceOptions& o) {
  return o.instances && !o.instances->instances.empty() && !o.flatten;
}
bool timed_two_level(const DeviceOptions& o) {
  return two_level(o) && o.timing.box_unit == hw::UnitModel::kCpp && o.timing.tri_unit == hw::UnitModel::kCpp;
}

}  // namespace

GridCheck device_grid_check(const hw::Geometry& g, const DeviceOptions& o) {
  switch (o.kind) {
    case hw::DeviceKind::kFloat:
      return GridCheck{};
    case hw::DeviceKind::kFixed:
      return check_grid(g, o.instances, !two_level(o), o.format);
    case hw::DeviceKind::kTimed:
      return check_grid(g, o.instances, !timed_two_level(o), o.format);
  }
  return GridCheck{};
}

void check_timing_memory(const hw::TimingConfig& c, bool sampled, uint64_t beside) {
  const uint64_t state = hw::TimedEngine::state_bytes(c, sampled);
  check_memory("timing configuration " + c.name + " (units=" + std::to_string(c.units) +
                   " cache_kib=" + std::to_string(c.cache_kib) + " l2_kib=" + std::to_string(c.l2_kib) +
                   " ray_slots=" + std::to_string(c.ray_slots) + "): the timing model",
               state + beside);
}

std::unique_ptr<DirectDevice> make_device(const hw::Geometry& g, const DeviceOptions& o) {
  DeviceOptions opt = o;
  opt.tracer.bvh.width = o.format.width;
  switch (o.kind) {
    case hw::DeviceKind::kFloat:
      if (o.instances && !o.instances->instances.empty()) return std::make_unique<InstancedFloatDevice>(g, opt);
      return std::make_unique<FloatDevice>(g, opt);
    case hw::DeviceKind::kFixed:
      o.format.validate();
      device_grid_check(g, o);  // refuses a frame below the smallest normal float
      if (two_level(o)) return std::make_unique<InstancedFixedDevice>(g, opt);
      return std::make_unique<FixedDevice>(g, opt);
    case hw::DeviceKind::kTimed:
      o.format.validate();
      o.timing.validate();
      check_timing_memory(o.timing, hw::sample_step(o.sample.fraction) >= 2);
      device_grid_check(g, o);
      if (timed_two_level(o)) return std::make_unique<InstancedTimedDevice>(g, opt);
      return std::make_unique<TimedDevice>(g, opt);
  }
  throw std::invalid_argument("make_device: not a device kind");
}

}  // namespace rtu::host
