// The shared parts of the model-device ring tests (model_rig.h).
#include "tests/firmware/model_rig.h"

#include <limits>

#include "host/scene/ray_gen.h"
#include "hwmodel/numeric/fixed_format.h"

namespace rtu::test {

namespace reg = hw::reg;

const SceneData& seed_scene() {
  static const SceneData* data = [] {
    auto* d = new SceneData;
    d->scene = host::load_scene("builtin:seed");
    const hw::FixedFormat format;
    d->tracer.bvh.width = format.width;
    d->bvh = hw::choose_accel(d->scene.geometry, d->tracer);
    d->fixed_image = std::make_unique<hw::DeviceImage>(
        hw::encode_scene(d->scene.geometry, format, d->bvh ? &*d->bvh : nullptr));
    d->float_image = hw::encode_float_scene(d->scene.geometry);
    d->float_tracer = std::make_unique<hw::FloatTracer>(d->scene.geometry, hw::EngineOptions{}.tracer);
    d->fixed_tracer = std::make_unique<hw::FixedTracer>(*d->fixed_image);
    return d;
  }();
  return *data;
}

std::vector<hw::Hit> direct_hits(const std::string& name, const std::vector<hw::Ray>& rays, bool any_hit,
                                 hw::TraversalStats& s) {
  std::vector<hw::Hit> hits(rays.size());
  if (name == "float")
    seed_scene().float_tracer->trace_batch(rays.data(), hits.data(), rays.size(), any_hit, 1, s);
  else
    seed_scene().fixed_tracer->trace_batch(rays.data(), hits.data(), rays.size(), any_hit, 1, s);
  return hits;
}
std::vector<hw::Hit> direct_hits(const std::string& name, const std::vector<hw::Ray>& rays, bool any_hit) {
  hw::TraversalStats s;
  return direct_hits(name, rays, any_hit, s);
}

std::vector<hw::Ray> test_rays(size_t primary, size_t incoherent, uint64_t seed) {
  const host::Scene& sc = seed_scene().scene;
  std::vector<hw::Ray> rays = host::primary_rays(sc.camera, uint64_t(primary));
  const std::vector<hw::Ray> inc = host::incoherent_rays(sc.geometry.bounds(), incoherent, seed);
  rays.insert(rays.end(), inc.begin(), inc.end());
  hw::Ray bad = rays[0];
  bad.origin.x = std::numeric_limits<float>::quiet_NaN();
  rays.push_back(bad);
  bad = rays[0];
  bad.dir = hw::Vec3(0.0f);
  rays.push_back(bad);
  bad = rays[0];
  bad.tmin = 5.0f;
  bad.tmax = 1.0f;  // empty interval: valid, misses
  rays.push_back(bad);
  return rays;
}

bool same_hits(const std::vector<hw::Hit>& a, const std::vector<hw::Hit>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(hw::Hit)) == 0;
}

void recover_and_run(Rig& r) {
  r.wr(reg::kControl, reg::kCtrlReset);
  CHECK(r.rd(reg::kStatus) == reg::kStatusIdle);  // not enabled, no error, no scene
  CHECK(r.rd(reg::kErrorCode) == 0);
  CHECK(r.rd(reg::kErrorInfo) == 0);
  CHECK(r.rd(reg::kIrqStatus) == 0);
  CHECK(r.rd(reg::kControl) == 0);
  CHECK(r.rd(reg::kRingSize) == 0);
  CHECK(r.rd(reg::kRingHead) == 0);
  CHECK(r.rd(reg::kRingTail) == 0);
  CHECK(r.rd(reg::kFenceLo) == 0);
  CHECK(r.rd(reg::kFenceHi) == 0);
  CHECK_FALSE(r.dev.processor().irq_line());
  r.start();
  r.bind();
  const std::vector<hw::Ray> rays = test_rays(40, 24, 7);
  CHECK(same_hits(r.trace(rays, false), direct_hits(r.name, rays, false)));
  CHECK(same_hits(r.trace(rays, true), direct_hits(r.name, rays, true)));
  CHECK(r.rd(reg::kStatus) == (reg::kStatusEnabled | reg::kStatusIdle | reg::kStatusBound));
  CHECK(r.rd(reg::kErrorCode) == 0);
}

}  // namespace rtu::test
