// suite_agree: the float device against Embree on one scene and ray files: how many rays both call a hit or both a
// miss (hit agreement), and how many name the same primitive. The float device traces as `rtusim trace --device
// float` does (two levels for instanced scenes, the scene's any-hit stage for alpha-masked triangles); Embree
// traces the same scene (instances as Embree instances) and asks the same any-hit stage from a context filter.
// bench/scene_suite.sh runs it. Two tracers may name different primitives at the same t (coplanar faces, a shared
// edge): TIES counts the primitive disagreements whose t differ by at most 1e-4 relative. Why 1e-4: on instanced
// scenes both tracers compute t in object space from a ray transformed and rounded to float, so the same surface's
// t differ by up to about 1e-5 relative (measured on builtin:city); the suite's distinct surfaces that face a ray
// are further apart than 1e-4 of its t.
//
//   suite_agree SCENE RAYS_FILE...   one line per ray file:  FILE RAYS HIT_DISAGREE PRIM_DISAGREE TIES HIT% PRIM%
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "host/io/ray_io.h"
#include "host/jobs/trace_job.h"
#include "host/oracle/embree_oracle.h"
#include "host/scene/scene.h"
#include "host/scene/shading.h"

using namespace rtu;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: suite_agree SCENE RAYS_FILE...\n");
    return 2;
  }
  try {
    const host::Scene scene = host::load_scene(argv[1]);
    const host::SceneAnyHit alpha(scene);
    std::unique_ptr<oracle::EmbreeScene> embree =
        scene.instanced() ? std::make_unique<oracle::EmbreeScene>(scene.instances, scene.geometry)
                          : std::make_unique<oracle::EmbreeScene>(scene.geometry);
    embree->set_any_hit(alpha.stage());
    for (int a = 2; a < argc; ++a) {
      const std::vector<hw::Ray> rays = host::read_rays(argv[a]);
      host::TraceRequest req;
      req.scene = &scene;
      req.rays = rays;
      req.kind = hw::DeviceKind::kFloat;
      const host::TraceRun run = host::run_trace(req);
      uint64_t hit_disagree = 0, prim_disagree = 0, ties = 0;
      for (size_t i = 0; i < rays.size(); ++i) {
        const hw::Hit e = embree->intersect(rays[i]), &f = run.hits[i];
        if (e.hit() != f.hit()) ++hit_disagree;
        if (e.prim != f.prim) {
          ++prim_disagree;
          if (e.hit() && f.hit() && std::fabs(e.t - f.t) <= 1e-4f * std::max(std::fabs(e.t), std::fabs(f.t)))
            ++ties;
        }
      }
      const double n = rays.empty() ? 1.0 : double(rays.size());
      std::printf("%s %zu %llu %llu %llu %.4f %.4f\n", argv[a], rays.size(), (unsigned long long)hit_disagree,
                  (unsigned long long)prim_disagree, (unsigned long long)ties,
                  100.0 * (1.0 - double(hit_disagree) / n), 100.0 * (1.0 - double(prim_disagree) / n));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "suite_agree: %s\n", e.what());
    return 2;
  }
  return 0;
}
