// Oriented nodes (format/oriented_aabb.h) change which nodes a ray visits, never what it hits: on the built-in
// scenes, a real mesh and both ray kinds the fixed device's closest hits with oriented nodes are the axis-aligned
// image's bit for bit, and its any-hit answers the same (so they agree with the float reference exactly as the
// axis-aligned kind's do), and no box test rejects a child the exact oracle accepts. Watertightness is in
// test_watertight.cpp.
#include <catch2/catch.hpp>

#include <cstdio>
#include <cstring>
#include <filesystem>

#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/format/device_image.h"

using namespace rtu;

namespace {

constexpr const char* kEngine = "/usr/share/assimp/models/glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb";

void check_same_hits(const std::string& spec, int width, uint64_t n, const char* layout = "default") {
  const host::Scene scene = host::load_scene(spec);
  hw::BvhBuildParams bp;
  bp.width = width;
  const hw::Bvh bvh = hw::Bvh::build(scene.geometry, bp);
  hw::FixedFormat aabb = hw::format_preset(layout);
  aabb.width = width;
  hw::FixedFormat obb = aabb;
  obb.node_kind = 1;
  const hw::DeviceImage ai = hw::encode_scene(scene.geometry, aabb, &bvh);
  const hw::DeviceImage oi = hw::encode_scene(scene.geometry, obb, &bvh);
  for (const char* kind : {"primary", "incoherent"}) {
    const std::vector<hw::Ray> rays = std::string(kind) == "primary"
                                          ? host::primary_rays(scene.camera, n)
                                          : host::incoherent_rays(scene.geometry.bounds(), n, 42);
    for (bool any : {false, true}) {
      std::vector<hw::Hit> ah(rays.size()), oh(rays.size());
      hw::TraversalStats as, os;
      hw::FixedTraceOptions opt;
      opt.check_boxes = true;
      hw::FixedTracer(ai, opt).trace_batch(rays.data(), ah.data(), rays.size(), any, 2, as);
      hw::FixedTracer(oi, opt).trace_batch(rays.data(), oh.data(), rays.size(), any, 2, os);
      uint64_t differ = 0, hits = 0;
      for (size_t i = 0; i < rays.size(); ++i) {
        // An any-hit query reports the first hit it finds, which the order of the visit decides: only whether
        // it hit is the query's answer.
        differ += any ? ah[i].hit() != oh[i].hit() : std::memcmp(&ah[i], &oh[i], sizeof(hw::Hit)) != 0;
        hits += ah[i].hit();
      }
      std::printf("%s w%d %s%s: %zu rays, %llu hit; nodes %llu -> %llu, primitive tests %llu -> %llu\n",
                  spec.c_str(), width, kind, any ? " any-hit" : "", rays.size(), (unsigned long long)hits,
                  (unsigned long long)as.nodes_visited, (unsigned long long)os.nodes_visited,
                  (unsigned long long)as.prim_tests, (unsigned long long)os.prim_tests);
      INFO(spec << " width " << width << " " << kind << (any ? " any-hit" : "") << ": " << differ << " of "
                << rays.size() << " hits differ");
      CHECK(differ == 0);
      CHECK(hits > rays.size() / 20);
      CHECK(os.box_false_negatives == 0);
      CHECK(os.box_checks > 0);
    }
  }
}

}  // namespace

TEST_CASE("oriented nodes hit what axis-aligned nodes hit: built-in scenes", "[fixed][obb]") {
  for (const char* spec : {"builtin:seed", "builtin:cornell", "builtin:hairball", "builtin:forest"})
    for (int width : {4, 8}) check_same_hits(spec, width, 6000);
}

TEST_CASE("oriented nodes hit what axis-aligned nodes hit: packed layouts", "[fixed][obb]") {
  check_same_hits("builtin:hairball", 8, 4000, "packed");
  check_same_hits("builtin:forest", 8, 4000, "rdna4");
  check_same_hits("builtin:seed", 8, 4000, "cwbvh");
}

TEST_CASE("oriented nodes hit what axis-aligned nodes hit: 2CylinderEngine.glb", "[fixed][obb][mesh]") {
  if (!std::filesystem::exists(kEngine)) {
    WARN("skipped: " << kEngine << " is missing (Debian package assimp-testmodels)");
    return;
  }
  check_same_hits(kEngine, 8, 6000);
}
