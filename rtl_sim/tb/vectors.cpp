#include "rtl_sim/tb/vectors.h"

#include <cstring>
#include <optional>
#include <stdexcept>

#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/float_tracer.h"

namespace rtu::rtl {

hw::FixedRay grid_ray(const hw::FixedFormat& f, const int64_t o[3], const int64_t d[3]) {
  hw::FixedRay r{};
  for (int a = 0; a < 3; ++a) r.o[a] = o[a];
  hw::set_format_fields(r, f);
  r.t_exp = f.t_frac_bits;
  r.tmin = 0;
  r.tmax = r.t_limit;
  hw::set_direction(r, d, f);
  return r;
}

void capture_traversals(RaySet& s, const std::string& scene, uint64_t seed, const std::function<bool()>& full,
                        const TraversalVisit& visit) {
  s.name = "traversal " + scene.substr(scene.find_last_of('/') + 1);
  const host::Scene sc = host::load_scene(scene);
  hw::TracerOptions opt;
  opt.accel = hw::AccelMode::kBvh;
  opt.bvh.width = s.format.width;
  const std::optional<hw::Bvh> bvh = hw::choose_accel(sc.geometry, opt);
  const hw::DeviceImage img = hw::encode_scene(sc.geometry, s.format, bvh ? &*bvh : nullptr);
  if (img.header().flags & hw::kImageNoBvh) throw std::logic_error("capture_traversals: the image has no BVH");
  const hw::FixedTracer tracer(img);
  const hw::QuantFrame frame = img.frame();
  const hw::FixedFormat imgf = img.format();

  const std::vector<hw::Ray> primary = host::primary_rays(sc.camera, 320, 240);
  const std::vector<hw::Ray> incoherent = host::incoherent_rays(sc.geometry.bounds(), primary.size(), seed);
  std::vector<hw::TraceEvent> events;
  hw::TraversalStats stats;
  for (size_t k = 0; k < 2 * primary.size() && !full(); ++k) {
    const hw::Ray& ray = (k % 2 == 0) ? primary[k / 2] : incoherent[k / 2];
    hw::FixedRay fr;
    if (hw::setup_ray(ray, frame, imgf, fr) != hw::RayStatus::kOk) continue;
    events.clear();
    const hw::Hit h = tracer.trace_recorded(ray, false, stats, events);
    ++s.traced_rays;
    s.rays.push_back(fr);
    const uint32_t ri = uint32_t(s.rays.size() - 1);
    int64_t closest = fr.tmax;
    bool any = false;
    for (const hw::TraceEvent& e : events) {
      visit(img, e, ri, closest);
      hw::FixedPrimHit ph;
      bool hit = false;
      if (e.kind == hw::TraceEvent::kPlane) {
        hit = hw::plane_test(fr, img.planes()[e.index], fr.tmin, closest, ph);
      } else if (e.kind == hw::TraceEvent::kPrim) {
        const uint8_t* rec = img.record(e.index);
        if (hw::record_kind(rec) == hw::RecordKind::kTriangle) {
          hw::TriangleRecord t;
          std::memcpy(&t, rec, sizeof t);
          hit = hw::triangle_test(fr, t.v, fr.tmin, closest, ph);
        } else {
          hw::SphereRecord sp;
          std::memcpy(&sp, rec, sizeof sp);
          hit = hw::sphere_test(fr, sp, fr.tmin, closest, ph);
        }
      }
      if (hit) {
        closest = ph.t;
        any = true;
      }
    }
    if (any != h.hit() || (any && hw::t_to_world(closest, fr) != h.t)) ++s.replay_mismatches;
  }
}

}  // namespace rtu::rtl
