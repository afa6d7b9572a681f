// hair_coverage: how the triangle forms of builtin:hair see the same strands as round linear curves do. Embree
// traces the strands as curves (RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE, the reference); the float device traces
// each form (curves, ribbons, dots) on the camera's primary rays. Per form, over the pixels: how many the
// reference sees hair at and the form does not (missed), the form sees hair and the reference does not (added),
// and over the pixels both see hair, the mean and the 99th percentile of |t - t_ref| / t_ref.
//
//   hair_coverage WIDTH STRANDS     one line per form: FORM PIXELS REF_HAIR MISSED ADDED MEAN_DT P99_DT
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "host/jobs/trace_job.h"
#include "host/oracle/embree_oracle.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"

using namespace rtu;

namespace {

// The hair material's index in builtin:hair (suite_scenes.cpp: skin 0, hair 1).
constexpr uint32_t kHair = 1;

bool is_hair(const host::Scene& s, const hw::Hit& h) {
  return h.hit() && h.prim < s.prim_material.size() && s.prim_material[h.prim] == kHair;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: hair_coverage WIDTH STRANDS\n");
    return 2;
  }
  try {
    const int w = std::stoi(argv[1]);
    const std::string strands = argv[2];
    if (w < 1 || w > 4096) throw std::invalid_argument("WIDTH must be in 1..4096");
    const host::Scene ref_scene = host::load_scene("builtin:hair?strands=" + strands);
    const oracle::EmbreeScene embree(ref_scene.geometry);
    const std::vector<hw::Ray> rays = host::primary_rays(ref_scene.camera, w, w);
    std::vector<hw::Hit> ref(rays.size());
    uint64_t ref_hair = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      ref[i] = embree.intersect(rays[i]);
      ref_hair += is_hair(ref_scene, ref[i]);
    }
    for (const char* form : {"curves", "ribbons", "dots"}) {
      const host::Scene scene = host::load_scene("builtin:hair?as=" + std::string(form) + "&strands=" + strands);
      host::TraceRequest req;
      req.scene = &scene;
      req.rays = rays;
      req.kind = hw::DeviceKind::kFloat;
      const host::TraceRun run = host::run_trace(req);
      uint64_t missed = 0, added = 0;
      std::vector<double> dt;
      for (size_t i = 0; i < rays.size(); ++i) {
        const bool a = is_hair(ref_scene, ref[i]), b = is_hair(scene, run.hits[i]);
        missed += a && !b;
        added += b && !a;
        if (a && b) dt.push_back(std::fabs(double(run.hits[i].t) - double(ref[i].t)) / double(ref[i].t));
      }
      std::sort(dt.begin(), dt.end());
      double mean = 0.0;
      for (double x : dt) mean += x;
      mean = dt.empty() ? 0.0 : mean / double(dt.size());
      const double p99 = dt.empty() ? 0.0 : dt[std::min(dt.size() - 1, size_t(0.99 * double(dt.size())))];
      std::printf("%s %zu %llu %llu %llu %.3g %.3g\n", form, rays.size(), (unsigned long long)ref_hair,
                  (unsigned long long)missed, (unsigned long long)added, mean, p99);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hair_coverage: %s\n", e.what());
    return 2;
  }
  return 0;
}
