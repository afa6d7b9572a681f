#include "host/jobs/render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <functional>
#include <optional>
#include <utility>

#include "firmware/render_scene.h"
#include "host/cost/cost_model.h"
#include "host/cost/timing_json.h"
#include "host/devices/firmware_device.h"
#include "host/devices/grid_check.h"
#include "host/io/error.h"
#include "host/io/limits.h"
#include "host/jobs/trace_job.h"
#include "host/scene/shading.h"
#include "hwmodel/datapath/instanced_fixed.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/format/device_image.h"

namespace rtu::host {

namespace {

fw::F3 f3(const Vec3& v) {
  return fw::F3{v.x, v.y, v.z};
}

// The device as the firmware sees it, with a progress line (RenderOptions::progress): every doorbell (a write of
// the ring's tail) redraws the line from the firmware's own counters (fw::RenderStats: the batch of camera paths
// and the bounce it is at), so the firmware needs no hook. Progress is counted in bounces of batches, at most
// max_depth + 1 per batch; a batch whose first bounce submits nothing counts its first doorbell as bounce 0.
// Every doorbell also calls the poll (RenderOptions::poll): when it throws, the doorbell is not rung and the unit
// reads as stopped on an error from then on, so the firmware (which has no exceptions) returns; the exception is
// kept for render() to rethrow.
class ProgressHal final : public fw::Hal {
 public:
  ProgressHal(FirmwareDevice& dev, const fw::RenderStats& stats, int max_depth, bool progress,
              std::function<void()> poll)
      : m_dev(dev), m_stats(stats), m_steps(uint64_t(max_depth) + 1), m_show(progress), m_poll(std::move(poll)) {}

  uint32_t read32(uint32_t offset) override {
    const uint32_t v = m_dev.read32(offset);
    return m_stopped && offset == hw::reg::kStatus ? v | hw::reg::kStatusError : v;
  }
  void write32(uint32_t offset, uint32_t value) override {
    if (offset == hw::reg::kRingTail) {
      if (m_stopped) return;
      if (m_poll) {
        try {
          m_poll();
        } catch (...) {
          m_stop = std::current_exception();
          m_stopped = true;
          return;
        }
      }
      if (m_show) update();
    }
    m_dev.write32(offset, value);
  }
  // What the poll threw, or null.
  std::exception_ptr stopped() const { return m_stop; }
  void barrier() override { m_dev.barrier(); }
  uint8_t* mem() override { return m_dev.mem(); }
  uint64_t mem_size() override { return m_dev.mem_size(); }
  void set_any_hit(const hw::AnyHitStage* stage) override { m_dev.set_any_hit(stage); }

 private:
  void update() {
    if (m_stats.batches == 0 || m_stats.batch_paths == 0) return;  // the ring's setup, before the first batch
    if (m_stats.batches != m_batch) {
      m_batch = m_stats.batches;
      m_first_bounce = m_stats.bounces;
    }
    const uint64_t batches = (m_stats.paths + m_stats.batch_paths - 1) / m_stats.batch_paths;
    const uint64_t bounce = std::min(m_stats.bounces - m_first_bounce, m_steps - 1);
    const uint64_t done = (m_batch - 1) * m_steps + bounce;
    if (m_progress && done == m_shown) return;  // several doorbells per bounce: drawn once
    if (!m_progress) m_progress.emplace("render", batches * m_steps);
    m_shown = done;
    m_progress->update(done, "batch " + std::to_string(m_batch) + "/" + std::to_string(batches) + ", bounce " +
                                 std::to_string(bounce));
  }

  FirmwareDevice& m_dev;
  const fw::RenderStats& m_stats;
  const uint64_t m_steps;
  const bool m_show;
  const std::function<void()> m_poll;
  uint64_t m_batch = 0, m_first_bounce = 0, m_shown = 0;
  std::optional<Progress> m_progress;  // made at the first batch, when the firmware has chosen the batch size
  bool m_stopped = false;
  std::exception_ptr m_stop;
};

}  // namespace

hw::RasterWork raster_work(const fw::RasterStats& s) {
  hw::RasterWork w;
  w.passes = s.passes;
  w.prims_read = s.prims_read;
  w.setups = s.setups;
  w.samples_tested = s.samples_tested;
  w.fragments = s.fragments;
  w.depth_writes = s.depth_writes;
  w.clears = s.clears;
  return w;
}

hw::SortWork sort_work(const fw::SortStats& s) {
  hw::SortWork w;
  w.sorts = s.sorts;
  w.rays = s.rays;
  w.passes = s.passes;
  w.pass_rays = s.pass_rays;
  return w;
}

namespace {

uint64_t align64(uint64_t x) {
  return (x + 63) & ~uint64_t(63);
}

// Refuses an image the firmware cannot render.
void check_render_size(const RenderResult& res, const RenderOptions& o) {
  if (o.spp < 1 || o.spp > 65536) throw Error("render: spp must be in [1, 65536]");
  if (o.max_depth < 0 || o.max_depth > 64) throw Error("render: max depth must be in [0, 64]");
  if (uint64_t(res.width) * uint64_t(res.height) > (uint64_t(1) << 28))
    throw Error("render: image too large (at most 2^28 pixels)");
  if (o.hybrid && (uint32_t(res.width) > fw::kMaxRasterSide || uint32_t(res.height) > fw::kMaxRasterSide))
    throw Error("render: hybrid mode rasterizes images of at most " + std::to_string(fw::kMaxRasterSide) +
                " pixels a side");
}

// What the user should know before the render: primitives below the fixed-point grid step, nothing to light the
// scene.
void add_scene_warnings(const Scene& scene, const RenderOptions& o, bool two_level, RenderResult& res) {
  if (o.device.kind != hw::DeviceKind::kFloat) {  // refuses a frame below the smallest normal float
    const std::string w = grid_warning(check_grid(scene.geometry, &scene.instances, !two_level, o.device.format));
    if (!w.empty()) res.warnings.push_back(w);
  }
  // Light comes from lights, emitters, and the background (which is also ambient occlusion's ambient light).
  bool lit = !scene.lights.empty() || o.background != Vec3(0.0f);
  for (const Material& m : scene.materials)
    lit = lit || (m.type == MaterialType::kEmissive && m.emission != Vec3(0.0f));
  if (!lit)
    res.warnings.push_back(
        "the scene has no light, no emissive material and the background is black: the image is black (give "
        "the scene a light, or --background R G B)");
}

// The unit's scene image on this device: two levels, one fixed-point image or the float scene. Raises
// res.offset_abs to what spawned rays need on the fixed-point grid; sets the tracer's BVH width to the format's.
std::vector<uint64_t> encode_scene_image(const Scene& scene, const RenderOptions& o, bool two_level,
                                         hw::TracerOptions& tracer, RenderResult& res) {
  const hw::Geometry& g = scene.geometry;
  std::vector<uint64_t> image_words;
  if (two_level) {
    tracer.bvh.width = o.device.format.width;
    const hw::InstancedFixedTracer two(scene.instances, g, o.device.format, tracer);
    image_words = two.encode();
    // As below, in the top level's frame: the coarsest of the two levels' (a mesh's own frame is finer).
    res.offset_abs = std::max(res.offset_abs, float(std::ldexp(4.0, two.top().frame().step_exp)));
  } else if (o.device.kind != hw::DeviceKind::kFloat) {
    tracer.bvh.width = o.device.format.width;
    const std::optional<hw::Bvh> bvh = hw::choose_accel(g, tracer);
    const hw::DeviceImage img = hw::encode_scene(g, o.device.format, bvh ? &*bvh : nullptr);
    image_words.assign(img.size() / 8, 0);
    std::memcpy(image_words.data(), img.data(), img.size());
    // Fixed: vertices round to the nearest grid point, so the unit's surface lies within sqrt(3)/2 grid steps
    // of the float one, and hit t rounds to nearest in ray units; 4 grid steps clear both.
    res.offset_abs = std::max(res.offset_abs, float(std::ldexp(4.0, img.frame().step_exp)));
  } else {
    image_words = hw::encode_float_scene(g);
  }
  return image_words;
}

std::vector<fw::LightRecord> light_records(const Scene& scene) {
  std::vector<fw::LightRecord> lights;
  for (const Light& l : scene.lights) {
    fw::LightRecord r{};
    r.kind = uint32_t(l.type == LightType::kPoint ? fw::LightKind::kPoint : fw::LightKind::kArea);
    r.position = f3(l.position);
    r.edge_u = f3(l.edge_u);
    r.edge_v = f3(l.edge_v);
    r.power = f3(l.intensity);
    lights.push_back(r);
  }
  return lights;
}

// The render job's settings, camera and counts (its addresses are placed by lay_out_memory).
fw::RenderJob render_job(const Scene& scene, const RenderOptions& o, const RenderResult& res,
                         const ShadingRecords& shading, size_t num_lights, float extent) {
  fw::RenderJob job{};
  job.width = uint32_t(res.width);
  job.height = uint32_t(res.height);
  job.spp = uint32_t(o.spp);
  job.max_depth = uint32_t(o.max_depth);
  job.flags =
      (o.indirect ? fw::kRenderIndirect : 0u) | (o.ao ? fw::kRenderAo : 0u) | (o.hybrid ? fw::kRenderHybrid : 0u);
  job.seed = o.seed;
  {
    const Camera& cam = scene.camera;
    const glm::dvec3 eye(cam.position);
    const glm::dvec3 fwd = glm::normalize(glm::dvec3(cam.look_at) - eye);
    const glm::dvec3 right = glm::normalize(glm::cross(fwd, glm::dvec3(cam.up)));
    const glm::dvec3 up = glm::cross(right, fwd);
    const double ty = std::tan(double(cam.fov_y_deg) * 3.141592653589793 / 360.0);
    const double tx = ty * double(res.width) / double(res.height);
    job.eye = f3(Vec3(eye));
    job.forward = f3(Vec3(fwd));
    job.right = f3(Vec3(right * tx));
    job.up = f3(Vec3(up * ty));
  }
  job.background = f3(o.background);
  const hw::Aabb bounds = scene.geometry.bounds();
  const float diag = bounds.empty() ? 1.0f : glm::length(bounds.extent());
  job.ao_distance = o.ao_distance > 0.0f ? o.ao_distance : 0.25f * diag;
  // The rasterizer's near plane: geometry nearer to the eye than 2^-20 of the scene's size is clipped (the ray
  // tracer would see it); small enough to lose nothing in any scene whose camera is not inside a surface.
  job.raster_near = std::ldexp(extent, -20);
  job.offset_abs = res.offset_abs;
  job.offset_rel = res.offset_rel;
  job.num_prims = scene.geometry.num_prims();
  job.num_materials = uint32_t(shading.materials.size());
  job.num_lights = uint32_t(num_lights);
  job.scene_bytes = res.scene_image_bytes;
  return job;
}

// Ray sorting's record (the job's kRenderRaySort): on the timed device, when the ray_sort key names a key.
std::optional<fw::RaySortJob> ray_sort_job(const Scene& scene, const RenderOptions& o) {
  const hw::TimingConfig& c = o.device.timing;
  if (o.device.kind != hw::DeviceKind::kTimed || c.ray_sort == hw::RaySort::kNone) return std::nullopt;
  fw::RaySortJob r{};
  r.key = uint32_t(c.ray_sort);  // an index of kRaySortKeys, whose order is fw::RaySortKey's
  r.radix_bits = uint32_t(c.sort_radix_bits);
  const hw::Aabb b = scene.geometry.bounds();
  if (!b.empty()) {
    r.lo = f3(b.lo);
    r.hi = f3(b.hi);
  }
  // The termination key's distance: a quarter of the scene's diagonal, as the occlusion rays' default length.
  r.distance = b.empty() ? 1.0f : 0.25f * glm::length(b.extent());
  return r;
}

// Where the job's parts lie in device memory beside the addresses in the job itself.
struct MemoryLayout {
  uint64_t texels = 0;      // the textures' texels
  uint64_t job_addr = 0;    // the job record
  uint64_t arena_base = 0;  // the firmware's arena: the ring and the renderer's working buffers
  uint64_t arena_bytes = 0;
  uint64_t paths = 0;  // camera paths: pixels x samples
};

// Device memory layout: scene image, renderer records, framebuffer, then the firmware's arena. Sets the job's
// addresses, rebases the textures' texel offsets and sets res.device_memory_bytes; throws Error beyond the
// memory budget.
MemoryLayout lay_out_memory(fw::RenderJob& job, ShadingRecords& shading, size_t num_lights, const RenderOptions& o,
                            const std::optional<fw::RaySortJob>& sort, RenderResult& res) {
  MemoryLayout m;
  uint64_t top = 0;
  auto place = [&](uint64_t bytes) {
    const uint64_t at = top;
    top = align64(top + bytes);
    return at;
  };
  job.scene_image = place(res.scene_image_bytes);
  job.surfaces = place(shading.surfaces.size() * sizeof(fw::SurfaceRecord));
  job.materials = place(shading.materials.size() * sizeof(fw::MaterialRecord));
  job.lights = place(num_lights * sizeof(fw::LightRecord));
  job.num_uvs = uint32_t(shading.uvs.size());
  job.uvs = place(shading.uvs.size() * sizeof(fw::UvRecord));
  job.num_textures = uint32_t(shading.textures.size());
  job.textures = place(shading.textures.size() * sizeof(fw::TextureRecord));
  m.texels = place(shading.texels.size());
  for (fw::TextureRecord& t : shading.textures) t.texels += m.texels;
  job.framebuffer = place(uint64_t(res.width) * res.height * 3 * sizeof(float));
  m.paths = uint64_t(res.width) * res.height * uint64_t(o.spp);
  if (o.keep_primary) job.primary_hits = place(m.paths * sizeof(hw::Hit));
  // The job, and ray sorting's record right behind it (only with sorting: otherwise the layout is as before).
  m.job_addr = place(sizeof job + (sort ? sizeof(fw::RaySortJob) : 0));
  // The arena: the ring and up to 2^18 paths of working buffers (renderer.cpp sizes its batch from it); with
  // sorting, each path's sorted places (its bounce ray or its shadow and occlusion slots) and the histogram, so
  // that the batch is what it is without sorting.
  uint64_t per_path = 200 + 64 * (uint64_t(num_lights) + 1);
  uint64_t fixed = 1u << 16;
  if (sort) {
    per_path += fw::RaySorter::kBytesPerRay * (uint64_t(num_lights) + 2);
    fixed += fw::RaySorter::fixed_bytes(sort->radix_bits);
  }
  m.arena_bytes = fixed + std::min<uint64_t>(m.paths, 1u << 18) * per_path;
  m.arena_base = top;
  res.device_memory_bytes = align64(m.arena_base + m.arena_bytes);
  check_memory("render: the unit's device memory", res.device_memory_bytes);
  return m;
}

// The scene image, the renderer's records and the job into device memory, at the job's addresses.
void write_device_memory(hw::DeviceMemory& mem, const fw::RenderJob& job, const MemoryLayout& m,
                         const std::vector<uint64_t>& image_words, const ShadingRecords& shading,
                         const std::vector<fw::LightRecord>& lights, const std::optional<fw::RaySortJob>& sort) {
  mem.write(job.scene_image, image_words.data(), image_words.size() * 8);
  mem.write(job.surfaces, shading.surfaces.data(), shading.surfaces.size() * sizeof(fw::SurfaceRecord));
  mem.write(job.materials, shading.materials.data(), shading.materials.size() * sizeof(fw::MaterialRecord));
  if (!lights.empty()) mem.write(job.lights, lights.data(), lights.size() * sizeof(fw::LightRecord));
  if (!shading.uvs.empty()) mem.write(job.uvs, shading.uvs.data(), shading.uvs.size() * sizeof(fw::UvRecord));
  if (!shading.textures.empty()) {
    mem.write(job.textures, shading.textures.data(), shading.textures.size() * sizeof(fw::TextureRecord));
    mem.write(m.texels, shading.texels.data(), shading.texels.size());
  }
  mem.write(m.job_addr, &job, sizeof job);
  if (sort) mem.write(m.job_addr + sizeof job, &*sort, sizeof *sort);
}

// Runs the firmware renderer on the device through the ring (with the progress line and poll when asked), into
// res.fw and res.seconds. Rethrows what the poll threw; throws Error when the render failed.
void run_firmware(FirmwareDevice& dev, const MemoryLayout& m, const RenderOptions& o, RenderResult& res) {
  const auto t0 = std::chrono::steady_clock::now();
  fw::Arena arena(m.arena_base, m.arena_bytes);
  fw::Ring ring;
  std::optional<ProgressHal> watched;
  if (o.progress || o.poll) watched.emplace(dev, res.fw, o.max_depth, o.progress, o.poll);
  fw::Hal& hal = watched ? static_cast<fw::Hal&>(*watched) : dev;
  fw::Status st = ring.init(hal, arena, 256);
  if (st == fw::Status::kOk) st = fw::render(hal, ring, arena, m.job_addr, res.fw);
  const std::exception_ptr stopped = watched ? watched->stopped() : nullptr;
  watched.reset();  // the progress line cleared before anything else is printed
  if (stopped) std::rethrow_exception(stopped);
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (st != fw::Status::kOk) {
    std::string why = std::string("render on the ") + hw::device_kind_name(o.device.kind) +
                      " device failed: " + fw::status_name(st);
    if (st == fw::Status::kDeviceError) {
      why += std::string(" (") + hw::reg::error_name(dev.processor().error()) + " at ring slot " +
             std::to_string(dev.read32(hw::reg::kErrorInfo)) + ")";
      if (!dev.processor().error_detail().empty()) why += ":\n" + dev.processor().error_detail();
    }
    throw Error(why);
  }
  res.ring = ring.counters();
}

// What the device counted and timed, the framebuffer and (RenderOptions::keep_primary) the primary hits.
void read_back(FirmwareDevice& dev, const fw::RenderJob& job, const MemoryLayout& m, const RenderOptions& o,
               RenderResult& res) {
  res.device = dev.processor().counters();
  res.counts = dev.engine().counts();
  res.uses_bvh = dev.engine().uses_bvh();
  res.device_clock = uint64_t(dev.read32(hw::reg::kClockLo));
  res.device_clock |= uint64_t(dev.read32(hw::reg::kClockHi)) << 32;
  if (const hw::TimedEngine* te = dev.timed()) {
    res.timed = true;
    res.timing = te->timing();
    res.timing_by_type = te->timing_by_type();
    res.timing_by_bounce = te->timing_by_bounce();
    res.sampling = te->sampling();
    res.timing_by_unit = te->timing_by_unit();
    if (te->timeline()) res.timeline = *te->timeline();
    res.raster_cycles = hw::raster_cycles(raster_work(res.fw.raster), te->config());
    res.sort_cycles = hw::sort_cycles(sort_work(res.fw.sort), te->config());
    res.frame_cycles = res.raster_cycles.cycles + res.sort_cycles.cycles + res.device_clock;
  }
  hw::DeviceMemory& mem = dev.memory();
  res.rgb.resize(size_t(res.width) * res.height * 3);
  mem.read(job.framebuffer, res.rgb.data(), res.rgb.size() * sizeof(float));
  if (o.keep_primary) {
    res.primary.resize(m.paths);
    mem.read(job.primary_hits, res.primary.data(), m.paths * sizeof(hw::Hit));
  }
}

}  // namespace

RenderResult render(const Scene& scene, const RenderOptions& o) {
  RenderResult res;
  res.width = o.width > 0 ? o.width : scene.camera.width;
  res.height = o.height > 0 ? o.height : scene.camera.height;
  check_render_size(res, o);

  // The offsets spawned rays need on this device. Float: each coordinate of the hit point o + t d carries a few
  // float ulps of the larger of |o_i| and |p_i| (the product t d_i and the sum round once each, and t's own error
  // is a few ulps); 2^-19 relative is 16 ulps of a 24-bit significand, 4x over a 4-ulp estimate. 2^-20 of the
  // scene's size covers coordinates near 0.
  const hw::Aabb bounds = scene.geometry.bounds();
  const float extent = bounds.empty() ? 1.0f : std::max({bounds.extent().x, bounds.extent().y, bounds.extent().z});
  res.offset_rel = std::ldexp(1.0f, -19);
  res.offset_abs = std::ldexp(extent, -20);
  // An instanced scene binds its two levels (hwmodel/datapath/instanced_fixed.h) on the fixed-point devices,
  // unless flattened or co-simulated (the RTL units trace one image).
  const bool two_level =
      scene.instanced() && !o.device.flatten && o.device.kind != hw::DeviceKind::kFloat &&
      (o.device.kind == hw::DeviceKind::kFixed ||
       (o.device.timing.box_unit == hw::UnitModel::kCpp && o.device.timing.tri_unit == hw::UnitModel::kCpp));
  add_scene_warnings(scene, o, two_level, res);
  hw::TracerOptions tracer = o.device.tracer;
  const std::vector<uint64_t> image_words = encode_scene_image(scene, o, two_level, tracer, res);
  res.scene_image_bytes = image_words.size() * 8;

  ShadingRecords shading = shading_records(scene);
  const std::vector<fw::LightRecord> lights = light_records(scene);
  fw::RenderJob job = render_job(scene, o, res, shading, lights.size(), extent);
  const std::optional<fw::RaySortJob> sort = ray_sort_job(scene, o);
  if (sort) job.flags |= fw::kRenderRaySort;
  const MemoryLayout layout = lay_out_memory(job, shading, lights.size(), o, sort, res);

  hw::EngineOptions eopt;
  eopt.threads = o.threads;
  eopt.tracer = tracer;
  eopt.max_steps = o.device.max_steps;
  if (o.device.kind == hw::DeviceKind::kTimed) {
    o.device.timing.validate();
    check_timing_memory(o.device.timing, hw::sample_step(o.device.sample.fraction) >= 2, res.device_memory_bytes);
  }
  FirmwareDevice dev(o.device.kind, res.device_memory_bytes, eopt, o.device.timing);
  // Opacity micromaps, baked over the same tables the firmware's any-hit stage reads (as a driver builds them).
  hw::MicromapSet maps;
  if (o.omm_level >= 0 && o.device.kind != hw::DeviceKind::kFloat && !scene.instanced()) {
    const SceneAnyHit alpha(scene);
    if (alpha.tables()) {
      maps = bake_micromaps(*alpha.tables(), scene.geometry.non_opaque, o.omm_level, &res.micromaps);
      res.micromap_bytes = maps.bytes();
      dev.set_micromaps(&maps);
    }
  }
  if (hw::TimedEngine* te = dev.timed()) {
    te->set_trace(o.pipeline_trace);
    te->set_sampling(o.device.sample);  // the firmware needs every hit: only the timing model is sampled
  }
  write_device_memory(dev.memory(), job, layout, image_words, shading, lights, sort);
  run_firmware(dev, layout, o, res);
  read_back(dev, job, layout, o, res);
  return res;
}

Image to_image(const RenderResult& r) {
  Image img;
  img.width = r.width;
  img.height = r.height;
  img.rgb.resize(r.rgb.size());
  for (size_t i = 0; i < r.rgb.size(); ++i) {
    const double v = double(r.rgb[i]);
    const double c = v > 0.0 ? std::min(v, 1.0) : 0.0;  // NaN -> 0
    const double s = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
    img.rgb[i] = uint8_t(std::lround(s * 255.0));
  }
  return img;
}

std::vector<std::string> render_warnings(const RenderResult& r) {
  std::vector<std::string> out = r.warnings;
  const hw::TraversalStats all = r.device.total();
  if (all.invalid_rays == 0) return out;
  const uint64_t traced = all.rays + all.invalid_rays;
  std::string by_type, by_reason;
  for (uint8_t k = 0; k < hw::cmd::kRayTypeCount; ++k) {
    const uint64_t n = r.device.stats_by_type[k].invalid_rays;
    if (n == 0) continue;
    by_type += (by_type.empty() ? "" : ", ") + std::string(hw::cmd::ray_type_name(hw::cmd::RayType(k))) + " " +
               std::to_string(n) + " of " + std::to_string(n + r.device.stats_by_type[k].rays);
  }
  for (size_t k = 1; k < all.invalid_by_reason.size(); ++k)
    if (all.invalid_by_reason[k] > 0)
      by_reason += (by_reason.empty() ? "" : ", ") + std::string(hw::ray_status_name(hw::RayStatus(k))) + " " +
                   std::to_string(all.invalid_by_reason[k]);
  char pct[32];
  std::snprintf(pct, sizeof pct, "%.3g%%", 100.0 * double(all.invalid_rays) / double(traced));
  out.push_back(std::to_string(all.invalid_rays) + " of " + std::to_string(traced) + " traced rays (" + pct +
                ") were invalid on the device and traced as misses: " + by_type + " (" + by_reason + ")");
  if (2 * all.invalid_rays > traced) {
    std::string why = "most rays were invalid: the image is mostly background";
    if (all.invalid_by_reason[size_t(hw::RayStatus::kOutOfFrame)] > 0)
      why +=
          "; out_of_frame: ray origins lie beyond the format's guard range around the scene (2^guard_bits "
          "frame sizes); move the camera closer or raise --guard-bits";
    out.push_back(why);
  }
  return out;
}

namespace {

using hw::cmd::RayType;

// The rays the firmware traced by type, their total and rate, and the primary rays the rasterizer made
// unnecessary (hybrid: every camera sample; raytrace: none).
void add_rays_json(Json& j, const RenderResult& r) {
  Json rays;
  uint64_t total = 0;
  for (int t = 0; t < hw::cmd::kRayTypeCount; ++t) {
    rays[hw::cmd::ray_type_name(RayType(t))] = r.fw.rays[t];
    total += r.fw.rays[t];
  }
  j["rays"] = rays;
  j["rays_total"] = total;
  j["rays_per_second"] = r.seconds > 0 ? double(total) / r.seconds : 0.0;
  j["rays_saved"] = {{"primary", r.fw.primary_rasterized}};
}

// The rasterizer's work (hybrid mode).
Json raster_stats_json(const fw::RasterStats& rs) {
  return {{"passes", rs.passes},
          {"prims_read", rs.prims_read},
          {"setups", rs.setups},
          {"samples_tested", rs.samples_tested},
          {"fragments", rs.fragments},
          {"depth_writes", rs.depth_writes},
          {"clears", rs.clears},
          {"triangles_culled", rs.triangles_culled},
          {"triangles_clipped", rs.triangles_clipped},
          {"triangles_degenerate", rs.triangles_degenerate}};
}

// Ray sorting: what the firmware sorted by key `key` (its cycles are under timing).
Json sort_stats_json(const fw::SortStats& ss, const std::string& key) {
  Json by_type = Json::object();
  for (int t = 0; t < hw::cmd::kRayTypeCount; ++t)
    if (ss.by_type[t] > 0) by_type[hw::cmd::ray_type_name(RayType(t))] = ss.by_type[t];
  return {{"key", key},          {"sorts", ss.sorts},         {"rays", ss.rays},
          {"passes", ss.passes}, {"pass_rays", ss.pass_rays}, {"by_ray_type", by_type}};
}

// What the scene did not need, and why: decided before any ray was built.
Json skipped_json(const RenderResult& r, const RenderOptions& o) {
  Json skipped = Json::object();
  const bool any_diffuse = r.fw.need_shadow || r.fw.need_diffuse || r.fw.need_occlusion;
  if (!r.fw.need_shadow)
    skipped["shadow"] =
        r.fw.rays[int(RayType::kShadow)] == 0 && any_diffuse ? "no lights" : "no lights or no diffuse surface";
  if (!r.fw.need_reflection)
    skipped["reflection"] = o.max_depth == 0 ? "max depth 0" : "no mirror or glass material";
  if (!r.fw.need_refraction) skipped["refraction"] = o.max_depth == 0 ? "max depth 0" : "no glass material";
  if (!r.fw.need_diffuse)
    skipped["diffuse"] = o.ao ? "ambient occlusion instead"
                              : (!o.indirect ? "indirect light off" : "no diffuse material or max depth 0");
  if (!r.fw.need_occlusion) skipped["occlusion"] = o.ao ? "no diffuse material" : "ambient occlusion off";
  if (r.fw.hybrid) skipped["primary"] = "rasterized (hybrid mode)";
  if (r.counts.triangles == 0) skipped["triangle_unit"] = "no triangles";
  if (r.counts.spheres == 0) skipped["sphere_unit"] = "no spheres";
  if (r.counts.planes == 0) skipped["plane_unit"] = "no planes";
  if (!r.uses_bvh) skipped["bvh"] = "brute force is cheaper for this scene (hw::choose_accel)";
  return skipped;
}

// The unit: its primitives, acceleration structure, memory, packets and traversal statistics by ray type.
Json unit_json(const RenderResult& r) {
  Json unit;
  unit["primitives"] = {
      {"triangles", r.counts.triangles}, {"spheres", r.counts.spheres}, {"planes", r.counts.planes}};
  unit["accel"] = r.uses_bvh ? "bvh" : "brute_force";
  unit["memory_bytes"] = r.device_memory_bytes;
  unit["scene_image_bytes"] = r.scene_image_bytes;
  unit["packets"] = r.device.packets;
  Json by_type;
  for (int t = 0; t < hw::cmd::kRayTypeCount; ++t) {
    if (r.device.rays_by_type[t] == 0) continue;
    by_type[hw::cmd::ray_type_name(RayType(t))] = traversal_json(r.device.stats_by_type[t]);
  }
  unit["by_ray_type"] = by_type;
  unit["total"] = traversal_json(r.device.total());
  return unit;
}

Json raster_cycles_json(const hw::RasterCycles& rc) {
  return {{"cycles", rc.cycles},
          {"latency_cycles", rc.latency_cycles},
          {"setup_cycles", rc.setup_cycles},
          {"scan_cycles", rc.scan_cycles},
          {"fragment_cycles", rc.fragment_cycles},
          {"dram_cycles", rc.dram_cycles},
          {"dram_bytes", rc.dram_bytes},
          {"limit", rc.limit}};
}

Json sort_cycles_json(const hw::SortCycles& sc) {
  return {{"cycles", sc.cycles},
          {"latency_cycles", sc.latency_cycles},
          {"key_cycles", sc.key_cycles},
          {"pass_cycles", sc.pass_cycles},
          {"permute_cycles", sc.permute_cycles},
          {"return_cycles", sc.return_cycles},
          {"compute_cycles", sc.compute_cycles},
          {"dram_cycles", sc.dram_cycles},
          {"dram_bytes", sc.dram_bytes},
          {"limit", sc.limit}};
}

// The timed device's figures: the unit's breakdown, fence interrupts, sampling, per-unit figures, notes and
// timeline, then the frame: the rasterizer's cycles (hybrid), the sort's (ray sorting) and the unit's (every
// packet), which do not overlap.
Json render_timing_json(const RenderResult& r, const RenderOptions& o) {
  Json t = timing_breakdown_json(r.timing, r.timing_by_type, r.timing_by_bounce, o.device.timing, o.device.format);
  t["device_clock"] = r.device_clock;
  // Fence interrupts: the host sees the frame's last fence irq_latency after the device clock's end.
  t["fence_irqs"] = r.device.fence_irqs;
  t["last_irq_cycle"] = r.device.last_irq_cycle;
  t["sample"] = sample_json(r.sampling);
  if (!r.timing_by_unit.empty()) t["units"] = units_json(r.timing_by_unit, o.device.timing);
  t["notes"] = timing_notes(r.timing, o.device.timing, &r.sampling);
  add_timeline(t, &r.timeline, r.sampling);
  t["raster"] = raster_cycles_json(r.raster_cycles);
  t["raster_cycles"] = r.raster_cycles.cycles;
  if (r.fw.sorted) {  // the controller's sorting, while the unit waits
    t["sort"] = sort_cycles_json(r.sort_cycles);
    t["sort_cycles"] = r.sort_cycles.cycles;
  }
  t["trace_cycles"] = r.device_clock;
  t["frame_cycles"] = r.frame_cycles;
  t["config"] = timing_json(o.device.timing);
  return t;
}

}  // namespace

Json render_json(const RenderResult& r, const RenderOptions& o) {
  Json j;
  j["device"] = hw::device_kind_name(o.device.kind);
  j["width"] = r.width;
  j["height"] = r.height;
  j["spp"] = o.spp;
  j["max_depth"] = o.max_depth;
  j["seed"] = o.seed;
  j["mode"] = o.ao ? "ambient_occlusion" : (o.indirect ? "path_tracing" : "direct_and_specular");
  j["render_mode"] = o.hybrid ? "hybrid" : "raytrace";
  j["seconds"] = r.seconds;
  add_rays_json(j, r);
  if (o.hybrid) j["raster"] = raster_stats_json(r.fw.raster);
  if (r.micromaps.triangles > 0) {
    const MicromapStats& m = r.micromaps;
    j["micromaps"] = {{"level", o.omm_level},
                      {"triangles", m.triangles},
                      {"micro_triangles", m.micro_triangles},
                      {"known", double(m.opaque + m.transparent) / double(m.micro_triangles)},
                      {"two_state", m.two_state},
                      {"bytes", r.micromap_bytes}};
    // The lookup's logic, one in each triangle unit (host::omm_lookup_cost), and on the timed device its energy.
    const hw::UnitCost c = omm_lookup_cost(o.omm_level);
    const hw::Technology& tech = hw::nangate45();
    Json l = {{"nand2_eq", c.nand2_eq},
              {"area_mm2", hw::logic_area_mm2(c.nand2_eq * o.device.timing.tri_units, tech)},
              {"pj_each", c.toggles_per_test * tech.pj_per_transition()},
              {"source", c.source}};
    if (r.timed) {
      l["lookups"] = r.timing.omm_lookups;
      l["pj"] = double(r.timing.omm_lookups) * c.toggles_per_test * tech.pj_per_transition();
    }
    j["micromaps"]["lookup"] = l;
  }
  if (r.fw.sorted) j["sort"] = sort_stats_json(r.fw.sort, hw::name_of(o.device.timing.ray_sort));
  j["paths"] = r.fw.paths;
  j["batches"] = r.fw.batches;
  j["batch_paths"] = r.fw.batch_paths;
  j["bounces"] = r.fw.bounces;
  j["commands"] = {{"packets", r.ring.packets},
                   {"trace", r.fw.traces},
                   {"fences", r.ring.fences},
                   {"doorbells", r.ring.doorbells},
                   {"ring_full", r.ring.full}};
  j["skipped"] = skipped_json(r, o);
  j["unit"] = unit_json(r);
  j["spawn_offset"] = {{"abs", r.offset_abs}, {"rel", r.offset_rel}};
  j["warnings"] = render_warnings(r);
  if (o.device.kind != hw::DeviceKind::kFloat) j["format"] = format_json(o.device.format);
  if (r.timed) j["timing"] = render_timing_json(r, o);
  return j;
}

}  // namespace rtu::host
