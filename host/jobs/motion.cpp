#include "host/jobs/motion.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>

#include "host/cost/cost_model.h"
#include "host/io/error.h"
#include "host/io/files.h"
#include "host/io/ray_io.h"
#include "host/scene/motion_scene.h"
#include "host/scene/ray_spec.h"
#include "hwmodel/numeric/rng.h"

namespace rtu::host {

namespace {

// A sample's color: its ball's color (the floor grey) times (0.2 + 0.8 |n . l|), sky blue on a miss.
hw::Vec3 shade(const MotionScene& s, const hw::Ray& r, const hw::Hit& h, float time) {
  if (!h.hit()) return hw::Vec3(0.55f, 0.7f, 0.9f);
  static const hw::Vec3 kColors[] = {{0.9f, 0.3f, 0.2f},  {0.2f, 0.7f, 0.3f},  {0.2f, 0.4f, 0.9f},
                                     {0.9f, 0.8f, 0.2f},  {0.8f, 0.3f, 0.8f},  {0.2f, 0.8f, 0.8f},
                                     {0.95f, 0.6f, 0.3f}, {0.6f, 0.6f, 0.95f}, {0.85f, 0.85f, 0.85f}};
  hw::Vec3 color(0.5f);
  for (size_t b = 0; b < s.balls.size(); ++b)
    if (h.prim >= s.balls[b].first && h.prim < s.balls[b].first + s.balls[b].count) color = kColors[b % 9];
  hw::Vec3 n;
  if (h.prim < s.geometry.triangles.size()) {
    const hw::Triangle t = s.geometry.triangles[h.prim].at(time);
    n = glm::normalize(glm::cross(t.v1 - t.v0, t.v2 - t.v0));
  } else if (h.prim < s.geometry.triangles.size() + s.geometry.spheres.size()) {
    const hw::Sphere sp = s.geometry.spheres[h.prim - s.geometry.triangles.size()].at(time);
    n = glm::normalize(r.origin + h.t * r.dir - sp.center);
  } else {  // from the axis point of the sphere the hit lies on (u: its s)
    const hw::CurveSegment c =
        s.geometry.curves[h.prim - s.geometry.triangles.size() - s.geometry.spheres.size()].at(time);
    n = glm::normalize(r.origin + h.t * r.dir - (c.p0 + h.u * (c.p1 - c.p0)));
  }
  return color * (0.2f + 0.8f * std::abs(glm::dot(n, glm::normalize(hw::Vec3(0.4f, 1.0f, 0.6f)))));
}

Image frame_image(const MotionScene& s, const MotionRays& rays, const std::vector<hw::Hit>& hits, int w, int h,
                  int spp) {
  Image img;
  img.width = w;
  img.height = h;
  img.rgb.resize(size_t(w) * size_t(h) * 3);
  for (size_t p = 0; p < size_t(w) * size_t(h); ++p) {
    hw::Vec3 sum(0.0f);
    for (int k = 0; k < spp; ++k) {
      const size_t i = p * size_t(spp) + size_t(k);
      sum += shade(s, rays.rays[i], hits[i], rays.times[i]);
    }
    for (int c = 0; c < 3; ++c)
      img.rgb[3 * p + size_t(c)] = uint8_t(std::lround(std::clamp(sum[c] / float(spp), 0.0f, 1.0f) * 255.0f));
  }
  return img;
}

}  // namespace

std::vector<float> read_shutter_times(const std::string& spec, size_t n, uint64_t seed) {
  std::vector<float> t;
  char* end = nullptr;
  const float value = std::strtof(spec.c_str(), &end);
  if (spec == "uniform") {
    hw::Pcg32 rng(seed);
    for (size_t i = 0; i < n; ++i) t.push_back(rng.next_float());
  } else if (!spec.empty() && end == spec.c_str() + spec.size()) {
    t.assign(n, value);
  } else if (is_csv_path(spec)) {
    check_input_file(spec);
    std::ifstream in(spec);
    std::string line;
    if (!std::getline(in, line) || (line != "time" && line != "time\r"))
      throw Error(spec + ": expected a header line 'time'");
    for (size_t no = 2; std::getline(in, line); ++no) {
      if (!line.empty() && line.back() == '\r') line.pop_back();
      const float v = std::strtof(line.c_str(), &end);
      if (line.empty() || end != line.c_str() + line.size())
        throw Error(spec + ":" + std::to_string(no) + ": not a number: '" + line + "'");
      if (t.size() >= n) throw Error(spec + ": more shutter times than the " + std::to_string(n) + " rays");
      t.push_back(v);
    }
  } else {
    check_input_file(spec);
    std::ifstream in(spec, std::ios::binary | std::ios::ate);
    const std::streamoff bytes = in.tellg();
    if (bytes < 0 || uint64_t(bytes) != 4 * uint64_t(n))
      throw Error(spec + ": " + std::to_string(bytes) + " bytes, not a float32 for each of the " +
                  std::to_string(n) + " rays");
    t.resize(n);
    in.seekg(0);
    if (n && !in.read(reinterpret_cast<char*>(t.data()), std::streamsize(4 * n)))
      throw Error(spec + ": read error");
  }
  if (t.size() != n)
    throw Error(spec + ": " + std::to_string(t.size()) + " shutter times for " + std::to_string(n) + " rays");
  try {
    hw::validate_shutter_times(t, n);
  } catch (const std::invalid_argument& e) {
    throw Error(spec + ": " + e.what());
  }
  return t;
}

namespace {

void count_agreement(const std::vector<hw::Hit>& fh, const std::vector<hw::Hit>& xh, MotionJobResult& r) {
  for (size_t i = 0; i < fh.size(); ++i) {
    r.hits_agree += fh[i].hit() == xh[i].hit();
    r.both_hit += fh[i].hit() && xh[i].hit();
    r.same_prim += fh[i].hit() && xh[i].hit() && fh[i].prim == xh[i].prim;
  }
}

// Design d's figures from its timed run; the moving units' hits must be the fixed unit's.
void fill_design(MotionDesign& m, int d, const hw::MotionTiming& t, const hw::TimingModel::Layout& l,
                 const std::vector<hw::Hit>& xh) {
  for (size_t i = 0; i < t.hits.size() && d > 0; ++i)
    if (t.hits[i].t != xh[i].t)  // the same tests at the same times: the same closest t
      throw std::logic_error("motion: a timed unit's hit differs from the fixed unit's");
  m.unit = hw::MotionUnit(d);
  m.cycles = t.cycles;
  m.timing = t.timing;
  m.traversal = t.traversal;
  m.node_bytes = l.node_bytes;
  m.image_bytes = l.total_bytes;
}

// The time-aware unit's box interpolators (all units) and, with `prims`, its triangle interpolators; their energy.
void price_interpolators(const MotionJobOptions& o, MotionDesign& m, bool prims) {
  const MotionInterpolators ip = motion_interpolators(o.format, o.motion.time_bits, o.motion.box_time_bits);
  const hw::Technology& tech = hw::nangate45();
  m.interp_mm2 = hw::logic_area_mm2(
      ip.box.nand2_eq * o.timing.box_rate * o.timing.box_units +
          (prims ? ip.tri.nand2_eq * o.timing.tri_units + ip.round.nand2_eq * o.timing.curve_units : 0.0),
      tech);
  // A sphere interpolates 4 of the triangle interpolator's 9 lanes, a curve segment 8.
  const hw::TimingStats& s = m.timing;
  const double lanes =
      double(s.tri_tests) + 4.0 / 9.0 * double(s.sphere_tests) + 8.0 / 9.0 * double(s.curve_tests);
  m.interp_pj = (double(s.box_tests) * ip.box.toggles_per_test + (prims ? lanes * ip.tri.toggles_per_test : 0.0)) *
                tech.pj_per_transition();
}

void finish_ratios(MotionJobResult& r) {
  for (MotionDesign& m : r.designs)
    m.ratio = double(m.cycles) / double(std::max<uint64_t>(1, r.designs[0].cycles));
}

// The rays of the job: the user's, generated ones (ray_spec, time_spec) of a scene of this camera and bounds, or
// the camera's frame at stratified shutter times.
MotionRays job_rays(const MotionJobOptions& o, const Camera& camera, const hw::Aabb& bounds) {
  if (!o.rays.empty()) return MotionRays{o.rays, o.times};
  if (o.ray_spec.empty()) return motion_frame_rays(camera, o.width, o.height, o.samples, o.seed);
  MotionRays r;
  r.rays = rays_from_spec(o.ray_spec, camera, bounds, o.seed);
  r.times = read_shutter_times(o.time_spec, r.rays.size(), o.seed);
  return r;
}

// The job over instances with two transforms (the built-in moving instances, or a scene's instances moved):
// two-level tracers, the static unit seeing every transform frozen at mid-shutter.
MotionJobResult run_instances(const MotionJobOptions& o, const Scene* src) {
  const MotionInstanceScene ms = src ? MotionInstanceScene{moving_instances(*src, o.move), src->camera, {}}
                                     : builtin_motion_instances(o.level, o.motion_scale);
  const MotionScene view{ms.set.flatten(), ms.camera, ms.balls};  // shading: triangles at the ray's time
  const bool user = o.user_rays();
  hw::Aabb bounds;
  for (uint32_t i = 0; i < ms.set.set.instances.size(); ++i)
    for (int k = 0; k < 2; ++k) bounds.extend(ms.set.key_bounds(i, k));
  const MotionRays rays = job_rays(o, view.camera, bounds);
  hw::TracerOptions opt;
  opt.bvh.width = o.format.width;
  MotionJobResult r;
  r.triangles = view.geometry.triangles.size();
  r.spheres = view.geometry.spheres.size();
  r.curves = view.geometry.curves.size();
  r.instances = ms.set.set.instances.size();
  for (uint32_t i = 0; i < r.instances; ++i)
    if (ms.set.moving(i)) {
      ++r.moving_instances;
      r.moving += ms.set.set.meshes[ms.set.set.instances[i].mesh].triangles.size();
    }
  r.rays = rays.rays.size();
  const hw::MotionInstancedFixedTracer aware(ms.set, o.format, o.motion, opt);
  std::vector<hw::Hit> fh, xh;
  hw::TraversalStats fs, xs;
  hw::MotionInstancedFloatTracer(ms.set, opt).trace_batch(rays.rays, rays.times, fh, false, o.threads, fs);
  aware.trace_batch(rays.rays, rays.times, xh, false, o.threads, xs);
  count_agreement(fh, xh, r);
  if (!user) {
    r.float_image = frame_image(view, rays, fh, o.width, o.height, o.samples);
    r.fixed_image = frame_image(view, rays, xh, o.width, o.height, o.samples);
  }
  hw::MotionInstanceSet frozen = ms.set;
  for (uint32_t i = 0; i < frozen.end.size(); ++i) {
    const hw::AffineD mid = ms.set.at(i, 0.5);
    for (int row = 0; row < 3; ++row)
      for (int c = 0; c < 4; ++c) frozen.end[i].m[row][c] = float(mid.m[row][c]);
    frozen.set.instances[i].to_world = frozen.end[i];
  }
  hw::MotionFormat whole = o.motion;
  whole.box_time_bits = 0;
  const hw::MotionInstancedFixedTracer still(frozen, o.format, o.motion, opt),
      oblivious(ms.set, o.format, whole, opt);
  const hw::MotionInstancedFixedTracer* units[3] = {&still, &aware, &oblivious};
  for (int d = 0; d < 3; ++d) {
    const hw::MotionTiming t =
        hw::time_motion_instance_rays(*units[d], hw::MotionUnit(d), o.timing, rays.rays, rays.times);
    fill_design(r.designs[d], d, t, hw::motion_instance_layout(*units[d], hw::MotionUnit(d)), xh);
  }
  price_interpolators(o, r.designs[1], false);
  finish_ratios(r);
  if (user) r.hits = std::move(xh);
  return r;
}

}  // namespace

MotionJobResult run_motion_job(const MotionJobOptions& o) {
  if (o.width < 1 || o.height < 1 || o.width > 8192 || o.height > 8192)
    throw std::invalid_argument("motion: width and height must be in 1..8192");
  o.format.validate();
  o.motion.validate();
  o.timing.validate();
  hw::check_motion_config(o.timing);  // before the frames are traced
  if (!o.rays.empty()) hw::validate_shutter_times(o.times, o.rays.size());
  std::optional<Scene> own;
  const Scene* src = o.loaded;
  if (!src && !o.scene.empty()) src = &own.emplace(load_scene(o.scene));
  if (o.instances || (src && src->instanced())) return run_instances(o, src);
  const MotionScene scene = src ? moving_scene(*src, o.move) : builtin_motion_scene(o.level, o.motion_scale);
  const bool user = o.user_rays();
  hw::BvhBuildParams bp;
  bp.width = o.format.width;
  const hw::MotionBvh bvh = hw::MotionBvh::build(scene.geometry, bp);
  hw::Aabb bounds = bvh.key_bounds[0];  // the scene over both key frames
  bounds.extend(bvh.key_bounds[1]);
  const MotionRays rays = job_rays(o, scene.camera, bounds);
  MotionJobResult r;
  r.triangles = scene.geometry.triangles.size();
  r.spheres = scene.geometry.spheres.size();
  r.curves = scene.geometry.curves.size();
  r.rays = rays.rays.size();
  // Float and fixed frames.
  const hw::MotionFloatTracer flt(scene.geometry, bvh);
  const hw::MotionImage aware = hw::MotionImage::encode(scene.geometry, bvh, o.format, o.motion);
  r.moving = uint64_t(std::count(aware.moving.begin(), aware.moving.end(), 1));
  std::vector<hw::Hit> fh, xh;
  hw::TraversalStats fs, xs;
  flt.trace_batch(rays.rays, rays.times, fh, false, o.threads, fs);
  hw::MotionFixedTracer(aware).trace_batch(rays.rays, rays.times, xh, false, o.threads, xs);
  count_agreement(fh, xh, r);
  if (!user) {
    r.float_image = frame_image(scene, rays, fh, o.width, o.height, o.samples);
    r.fixed_image = frame_image(scene, rays, xh, o.width, o.height, o.samples);
  }
  // The three units. The static one sees the scene frozen at mid-shutter.
  const hw::Geometry mid = scene.geometry.at(0.5f);
  hw::MotionGeometry frozen;
  for (const hw::Triangle& t : mid.triangles) frozen.triangles.push_back(hw::MotionTriangle{{t, t}});
  for (const hw::Sphere& t : mid.spheres)
    frozen.spheres.push_back(hw::MotionSphere{{t.center, t.center}, {t.radius, t.radius}});
  for (const hw::CurveSegment& t : mid.curves) frozen.curves.push_back(hw::MotionCurve{{t, t}});
  const hw::MotionBvh frozen_bvh = hw::MotionBvh::build(frozen, bp);
  const hw::MotionImage still = hw::MotionImage::encode(frozen, frozen_bvh, o.format, o.motion);
  hw::MotionFormat whole = o.motion;
  whole.box_time_bits = 0;
  const hw::MotionImage oblivious = hw::MotionImage::encode(scene.geometry, bvh, o.format, whole);
  const hw::MotionImage* images[3] = {&still, &aware, &oblivious};
  for (int d = 0; d < 3; ++d) {
    const hw::MotionTiming t =
        hw::time_motion_rays(*images[d], hw::MotionUnit(d), o.timing, rays.rays, rays.times);
    fill_design(r.designs[d], d, t, hw::motion_layout(*images[d], hw::MotionUnit(d)), xh);
  }
  price_interpolators(o, r.designs[1], true);
  finish_ratios(r);
  if (user) r.hits = std::move(xh);
  return r;
}

Json motion_json(const MotionJobOptions& o, const MotionJobResult& r) {
  Json j;
  const bool builtin = o.scene.empty() && !o.loaded;
  j["scene"] = o.loaded  ? o.loaded->name
               : builtin ? std::string(o.instances ? "builtin moving instances" : "builtin motion") + " (level " +
                               std::to_string(o.level) + ")"
                         : o.scene;
  if (!builtin) j["move"] = {o.move.x, o.move.y, o.move.z};
  if (!o.user_rays()) {
    j["width"] = o.width;
    j["height"] = o.height;
    j["samples"] = o.samples;
  }
  j["format"] = o.format.describe();
  j["motion_format"] = o.motion.describe();
  if (builtin) j["motion_scale"] = o.motion_scale;
  j["triangles"] = r.triangles;
  j["spheres"] = r.spheres;
  j["curve_segments"] = r.curves;
  j["moving_primitives"] = r.moving;
  if (r.instances > 0) {
    j["instances"] = r.instances;
    j["moving_instances"] = r.moving_instances;
  }
  j["rays"] = r.rays;
  j["fixed_vs_float"] = {
      {"hit_miss_agree", r.hits_agree}, {"both_hit", r.both_hit}, {"same_triangle", r.same_prim}};
  j["designs"] = Json::array();
  for (const MotionDesign& m : r.designs)
    j["designs"].push_back({{"unit", hw::motion_unit_name(m.unit)},
                            {"cycles", m.cycles},
                            {"ratio_to_static", m.ratio},
                            {"nodes_visited", m.traversal.nodes_visited},
                            {"box_tests", m.traversal.box_tests},
                            {"triangle_tests", m.traversal.prim_tests},
                            {"shader_calls", m.timing.any_hit_requests},
                            {"node_bytes", m.node_bytes},
                            {"image_bytes", m.image_bytes},
                            {"dram_bytes", m.timing.dram_bytes},
                            {"interpolators_mm2", m.interp_mm2},
                            {"interpolation_pj", m.interp_pj}});
  return j;
}

}  // namespace rtu::host
