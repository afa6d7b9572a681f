// Triangle clusters (format prim_layout 2, hwmodel/format/cluster_layout.h) on real scenes: built-in scenes (one
// with alpha-tested triangles, which stay raw blocks) and a real mesh trace to the hits of 40-byte records and of
// blocks bit for bit over the same tree, closest and any hit; the timed device's hits are the fixed device's with
// the cluster engine off and on, and the engine takes every cluster test when on.
#include <catch2/catch.hpp>

#include <cstring>
#include <string>
#include <vector>

#include "host/devices/direct_device.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/timing/timing_config.h"

using namespace rtu;

TEST_CASE("triangle clusters: the hits of records and blocks on built-in scenes and a real mesh, timed as fixed",
          "[fixed][timed][cluster][scale]") {
  for (const char* spec : {"builtin:seed", "builtin:cornell", "builtin:icosphere", "builtin:forest",
                           "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb"}) {
    CAPTURE(spec);
    const host::Scene scene = host::load_scene(spec);
    std::vector<hw::Ray> rays = host::primary_rays(scene.camera, 2000);
    const std::vector<hw::Ray> inc = host::incoherent_rays(scene.geometry.bounds(), 2000, 45);
    rays.insert(rays.end(), inc.begin(), inc.end());
    std::vector<hw::Hit> want[2];
    hw::TraversalStats want_s;
    for (const char* fmt : {"default", "packed", "clusters", "clusters:cluster_tris=64"}) {
      CAPTURE(fmt);
      host::DeviceOptions o;
      o.kind = hw::DeviceKind::kFixed;
      o.format = hw::format_from_spec(fmt);
      o.tracer.accel = hw::AccelMode::kBvh;
      o.tracer.bvh.width = o.format.width;
      const auto dev = host::make_device(scene.geometry, o);
      std::vector<hw::Hit> hits[2];
      hw::TraversalStats s;
      for (bool any : {false, true}) {
        hits[any].assign(rays.size(), hw::Hit{});
        hw::TraversalStats as;
        dev->trace_batch(rays.data(), hits[any].data(), rays.size(), any, 2, any ? as : s);
      }
      if (want[0].empty()) {
        want[0] = hits[0];
        want[1] = hits[1];
        want_s = s;
        continue;
      }
      // The same tree (the builder does not look at the format), the same tests in the same order.
      CHECK(std::memcmp(hits[0].data(), want[0].data(), rays.size() * sizeof(hw::Hit)) == 0);
      CHECK(std::memcmp(hits[1].data(), want[1].data(), rays.size() * sizeof(hw::Hit)) == 0);
      CHECK(s.box_tests == want_s.box_tests);
      CHECK(s.prim_tests == want_s.prim_tests);
      if (o.format.prim_layout != 2) continue;
      for (int rate : {0, 8}) {
        CAPTURE(rate);
        o.kind = hw::DeviceKind::kTimed;
        o.timing = hw::timing_preset("rdna2");
        o.timing.cluster_tri_rate = rate;
        const auto timed = host::make_device(scene.geometry, o);
        std::vector<hw::Hit> th(rays.size());
        hw::TraversalStats ts;
        timed->trace_batch(rays.data(), th.data(), rays.size(), false, 2, ts);
        CHECK(std::memcmp(th.data(), want[0].data(), rays.size() * sizeof(hw::Hit)) == 0);
        const hw::TimingStats t = timed->timed()->timing();
        CHECK((t.cluster_tri_tests > 0) == (rate > 0));
        CHECK(t.box_tests + t.cluster_box_tests == s.box_tests);
      }
    }
  }
}
