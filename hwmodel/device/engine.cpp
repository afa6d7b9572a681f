#include "hwmodel/device/engine.h"

#include <cmath>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "hwmodel/datapath/hit_list.h"
#include "hwmodel/datapath/instanced_fixed.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/interface/regs.h"

namespace rtu::hw {

namespace {

constexpr uint64_t align8(uint64_t x) {
  return (x + 7) & ~uint64_t(7);
}

// Bytes before the curve section (its count word starts at the next multiple of 4).
uint64_t float_scene_body(uint64_t nt, uint64_t ns, uint64_t np, bool flags) {
  return sizeof(FloatSceneHeader) + nt * sizeof(Triangle) + ns * sizeof(Sphere) + np * sizeof(Plane) +
         (flags ? nt : 0);
}
constexpr uint64_t align4(uint64_t x) {
  return (x + 3) & ~uint64_t(3);
}
uint64_t float_scene_bytes(uint64_t nt, uint64_t ns, uint64_t np, bool flags, bool curves, uint64_t nc) {
  const uint64_t body = float_scene_body(nt, ns, np, flags);
  return align8(curves ? align4(body) + 4 + nc * sizeof(CurveSegment) : body);
}

[[noreturn]] void bad_scene(const std::string& why) {
  throw std::invalid_argument("float scene image: " + why);
}

// Finite and within kMaxCoordinate.
bool finite3(const Vec3& v) {
  return std::fabs(v.x) <= kMaxCoordinate && std::fabs(v.y) <= kMaxCoordinate && std::fabs(v.z) <= kMaxCoordinate;
}

}  // namespace

std::vector<uint64_t> encode_float_scene(const Geometry& g) {
  FloatSceneHeader h{};
  h.magic = kFloatSceneMagic;
  h.version = kFloatSceneVersion;
  h.num_triangles = uint32_t(g.triangles.size());
  h.num_spheres = uint32_t(g.spheres.size());
  h.num_planes = uint32_t(g.planes.size());
  const bool flags = !g.non_opaque.empty();
  if (flags && g.non_opaque.size() != g.triangles.size())
    throw std::invalid_argument("float scene: non_opaque has not one flag per triangle");
  const bool curves = !g.curves.empty();
  h.flags = (flags ? kFloatSceneNonOpaque : 0) | (curves ? kFloatSceneCurves : 0);
  h.total_bytes = float_scene_bytes(h.num_triangles, h.num_spheres, h.num_planes, flags, curves, g.curves.size());
  std::vector<uint64_t> words(h.total_bytes / 8, 0);
  auto* p = reinterpret_cast<uint8_t*>(words.data());
  std::memcpy(p, &h, sizeof h);
  size_t off = sizeof h;
  auto put = [&](const auto& v) {
    const size_t n = v.size() * sizeof(v[0]);
    if (n) std::memcpy(p + off, v.data(), n);
    off += n;
  };
  put(g.triangles);
  put(g.spheres);
  put(g.planes);
  if (flags) put(g.non_opaque);
  if (curves) {
    off = align4(off);
    const uint32_t nc = uint32_t(g.curves.size());
    std::memcpy(p + off, &nc, 4);
    off += 4;
    put(g.curves);
  }
  return words;
}

Geometry decode_float_scene(const uint8_t* data, size_t bytes) {
  FloatSceneHeader h;
  if (bytes < sizeof h) bad_scene("smaller than its header");
  std::memcpy(&h, data, sizeof h);
  if (h.magic != kFloatSceneMagic) bad_scene("bad magic");
  if (h.version != kFloatSceneVersion) bad_scene("unsupported version " + std::to_string(h.version));
  if (h.reserved != 0) bad_scene("reserved fields not zero");
  if (h.flags & ~(kFloatSceneNonOpaque | kFloatSceneCurves)) bad_scene("unknown flags");
  const bool flags = h.flags & kFloatSceneNonOpaque, curves = h.flags & kFloatSceneCurves;
  if (uint64_t(h.num_triangles) + h.num_spheres + h.num_planes >= kMaxBvhPrims) bad_scene("too many primitives");
  uint32_t nc = 0;
  if (curves) {
    const uint64_t at = align4(float_scene_body(h.num_triangles, h.num_spheres, h.num_planes, flags));
    if (at + 4 > bytes) bad_scene("size does not match the primitive counts");
    std::memcpy(&nc, data + at, 4);
    if (nc == 0) bad_scene("curve flag set with no curve segments");
    if (uint64_t(h.num_triangles) + h.num_spheres + h.num_planes + nc >= kMaxBvhPrims)
      bad_scene("too many primitives");
  }
  if (h.total_bytes != bytes ||
      float_scene_bytes(h.num_triangles, h.num_spheres, h.num_planes, flags, curves, nc) != bytes)
    bad_scene("size does not match the primitive counts");
  Geometry g;
  g.triangles.resize(h.num_triangles);
  g.spheres.resize(h.num_spheres);
  g.planes.resize(h.num_planes);
  size_t off = sizeof h;
  auto get = [&](auto& v) {
    const size_t n = v.size() * sizeof(v[0]);
    if (n) std::memcpy(v.data(), data + off, n);
    off += n;
  };
  get(g.triangles);
  get(g.spheres);
  get(g.planes);
  if (flags) {
    g.non_opaque.resize(h.num_triangles);
    get(g.non_opaque);
    for (size_t i = 0; i < g.non_opaque.size(); ++i)
      if (g.non_opaque[i] > 1) bad_scene("triangle " + std::to_string(i) + ": opacity flag neither 0 nor 1");
  }
  if (curves) {
    off = align4(off) + 4;
    g.curves.resize(nc);
    get(g.curves);
    for (size_t i = 0; i < g.curves.size(); ++i)
      if (const std::string why = check_curve_segment(g.curves[i]); !why.empty())
        bad_scene("curve segment " + std::to_string(i) + ": " + why);
  }
  for (size_t i = 0; i < g.triangles.size(); ++i)
    if (!finite3(g.triangles[i].v0) || !finite3(g.triangles[i].v1) || !finite3(g.triangles[i].v2))
      bad_scene("triangle " + std::to_string(i) + " is not finite or beyond 2^62");
  for (size_t i = 0; i < g.spheres.size(); ++i)
    if (!finite3(g.spheres[i].center) || !(g.spheres[i].radius > 0.0f) || !(g.spheres[i].radius <= kMaxCoordinate))
      bad_scene("sphere " + std::to_string(i) + " is not finite, beyond 2^62 or has no positive radius");
  for (size_t i = 0; i < g.planes.size(); ++i) {
    const Plane& p = g.planes[i];
    if (!finite3(p.normal) || !(std::fabs(p.offset) <= kMaxCoordinate) ||
        (p.normal.x == 0 && p.normal.y == 0 && p.normal.z == 0))
      bad_scene("plane " + std::to_string(i) + " is not finite, beyond 2^62 or has a zero normal");
  }
  return g;
}

namespace {

class FloatEngine final : public TraceEngine {
 public:
  explicit FloatEngine(const EngineOptions& o) : m_opt(o) {}
  const char* name() const override { return "float"; }
  uint32_t caps() const override {
    return reg::kCapTriangles | reg::kCapSpheres | reg::kCapPlanes | reg::kCapAnyHit | reg::kCapAllHits;
  }
  void bind(const uint8_t* data, size_t bytes) override {
    unbind();
    Geometry g = decode_float_scene(data, bytes);  // throws before anything changes
    m_geom = std::make_unique<Geometry>(std::move(g));
    m_tracer = std::make_unique<FloatTracer>(*m_geom, m_opt.tracer);
    m_tracer->set_any_hit(m_any_hit);
  }
  void set_any_hit(const AnyHitStage* stage) override {
    m_any_hit = stage;
    if (m_tracer) m_tracer->set_any_hit(stage);
  }
  bool bound() const override { return m_tracer != nullptr; }
  void unbind() override {
    m_tracer.reset();
    m_geom.reset();
  }
  void trace(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s) const override {
    m_tracer->trace_batch(rays, hits, n, any_hit, m_opt.threads, s);
  }
  uint64_t trace_all_cycles(const Ray* rays, size_t n, const AllHitsOut& out, TraversalStats& s, uint8_t,
                            uint8_t) override {
    all_hits_batch(n, m_opt.threads, out, s,
                   [&](size_t i, HitList& l, TraversalStats& st) { return m_tracer->trace_all(rays[i], l, st); });
    return 1;
  }
  Geometry::Counts counts() const override { return m_geom ? m_geom->counts() : Geometry::Counts{}; }
  bool uses_bvh() const override { return m_tracer && m_tracer->uses_bvh(); }

 private:
  EngineOptions m_opt;
  std::unique_ptr<Geometry> m_geom;
  std::unique_ptr<FloatTracer> m_tracer;
  const AnyHitStage* m_any_hit = nullptr;
};

class FixedEngine final : public TraceEngine {
 public:
  explicit FixedEngine(const EngineOptions& o) : m_opt(o) {}
  const char* name() const override { return "fixed"; }
  uint32_t caps() const override {
    return reg::kCapTriangles | reg::kCapSpheres | reg::kCapPlanes | reg::kCapAnyHit | reg::kCapFixed |
           reg::kCapAllHits;
  }
  void bind(const uint8_t* data, size_t bytes) override {
    unbind();
    FixedTraceOptions to{m_opt.check_boxes, m_opt.max_steps};
    to.any_hit = m_any_hit;
    if (is_two_level(
            data, bytes)) {  // (micromaps: one level only)  // an instanced scene's two levels (instanced_fixed.h)
      m_two = InstancedFixedTracer::from_bytes(data, bytes, to);
      return;
    }
    DeviceImage img = DeviceImage::from_bytes(data, bytes);  // throws before anything changes
    if (img.header().flags & kImageTopLevel)                 // its bottom levels are not in the image
      throw std::invalid_argument("scene image: a top level, whose bottom levels this engine does not hold");
    m_image = std::make_unique<DeviceImage>(std::move(img));
    to.micromaps = m_micromaps;
    m_tracer = std::make_unique<FixedTracer>(*m_image, to);
  }
  void set_any_hit(const AnyHitStage* stage) override {
    m_any_hit = stage;
    if (m_tracer) m_tracer->set_any_hit(stage);
    if (m_two) m_two->set_any_hit(stage);
  }
  void set_micromaps(const MicromapSet* maps) override {
    m_micromaps = maps;
    if (m_tracer) m_tracer->set_micromaps(maps);
  }
  bool bound() const override { return m_tracer != nullptr || m_two != nullptr; }
  void unbind() override {
    m_tracer.reset();
    m_image.reset();
    m_two.reset();
  }
  void trace(const Ray* rays, Hit* hits, size_t n, bool any_hit, TraversalStats& s) const override {
    TraversalStats local;
    const FixedTracer& t = m_two ? m_two->top_tracer() : *m_tracer;
    t.trace_batch(rays, hits, n, any_hit, m_opt.threads, local);
    if (local.watchdog_rays > 0) throw WatchdogError(t.watchdog_report(rays, n, any_hit, local.watchdog_rays), 0);
    s.add(local);
  }
  uint64_t trace_all_cycles(const Ray* rays, size_t n, const AllHitsOut& out, TraversalStats& s, uint8_t,
                            uint8_t) override {
    TraversalStats local;
    const FixedTracer& t = m_two ? m_two->top_tracer() : *m_tracer;
    all_hits_batch(n, m_opt.threads, out, local,
                   [&](size_t i, HitList& l, TraversalStats& st) { return t.trace_all(rays[i], l, st); });
    if (local.watchdog_rays > 0) throw WatchdogError(t.watchdog_report(rays, n, false, local.watchdog_rays), 0);
    s.add(local);
    return 1;
  }
  Geometry::Counts counts() const override {
    if (!bound()) return {};
    const ImageHeader& h = image().header();
    return {h.num_triangles, h.num_spheres, h.plane_count};
  }
  bool uses_bvh() const override { return bound() && !(image().header().flags & kImageNoBvh); }

 private:
  const DeviceImage& image() const { return m_two ? m_two->top() : *m_image; }
  EngineOptions m_opt;
  std::unique_ptr<DeviceImage> m_image;
  std::unique_ptr<FixedTracer> m_tracer;
  std::unique_ptr<InstancedFixedTracer> m_two;
  const AnyHitStage* m_any_hit = nullptr;
  const MicromapSet* m_micromaps = nullptr;
};

}  // namespace

std::unique_ptr<TraceEngine> make_engine(DeviceKind kind, const EngineOptions& o, const TimingConfig& c,
                                         std::unique_ptr<BoxUnit> unit, std::unique_ptr<TriUnit> tri) {
  if (kind == DeviceKind::kTimed) return make_timed_engine(o, c, std::move(unit), std::move(tri));
  if (unit)
    throw std::invalid_argument(std::string("the ") + device_kind_name(kind) + " engine takes no box unit");
  if (tri)
    throw std::invalid_argument(std::string("the ") + device_kind_name(kind) + " engine takes no triangle unit");
  return kind == DeviceKind::kFloat ? make_float_engine(o) : make_fixed_engine(o);
}

std::unique_ptr<TraceEngine> make_float_engine(const EngineOptions& o) {
  return std::make_unique<FloatEngine>(o);
}
std::unique_ptr<TraceEngine> make_fixed_engine(const EngineOptions& o) {
  return std::make_unique<FixedEngine>(o);
}

}  // namespace rtu::hw
