// Triangle pairs (format tri_pairs, hw_format.h's kTrianglePair): the encoder marks consecutive triangles of a
// leaf that share an edge, the image check refuses a pair without its second triangle or without a shared edge,
// the fixed device's hits are those without pairs bit for bit (the same triangles tested in the same order), and
// the timed device fetches and issues each pair as one request of two tests: the same triangle tests, one fetch
// fewer per pair, and no more cycles than without pairs when the unit issues two tests a clock.
#include <catch2/catch.hpp>

#include <cstring>
#include <string>
#include <vector>

#include "host/devices/direct_device.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/timing/timing_config.h"

using namespace rtu;

namespace {

hw::DeviceImage encode(const hw::Geometry& g, hw::FixedFormat f, bool bvh = true) {
  hw::BvhBuildParams bp;
  bp.width = f.width;
  const hw::Bvh b = hw::Bvh::build(g, bp);
  return hw::encode_scene(g, f, bvh ? &b : nullptr);
}

uint32_t count_pairs(const hw::DeviceImage& img) {
  uint32_t n = 0;
  for (uint32_t i = 0; i < img.header().record_count; ++i)
    n += hw::record_kind(img.record(i)) == hw::RecordKind::kTrianglePair;
  return n;
}

}  // namespace

TEST_CASE("triangle pairs: marked on shared edges, checked, refused by name", "[fixed][image][pairs]") {
  const host::Scene scene = host::load_scene("builtin:icosphere");
  hw::FixedFormat f = hw::format_preset("default");
  f.tri_pairs = 1;
  for (bool bvh : {true, false}) {
    CAPTURE(bvh);
    const hw::DeviceImage img = encode(scene.geometry, f, bvh);
    const uint32_t pairs = count_pairs(img);
    CHECK(pairs > img.header().record_count / 8);  // a closed mesh's leaves hold neighbours
    std::vector<uint8_t> b(img.data(), img.data() + img.size());
    REQUIRE_NOTHROW(hw::DeviceImage::from_bytes(b.data(), b.size()));
    uint32_t first = 0;
    while (hw::record_kind(img.record(first)) != hw::RecordKind::kTrianglePair) ++first;
    const size_t at = img.header().record_offset + size_t(first) * hw::kRecordBytes;
    // The second's vertex moved: no shared edge.
    std::vector<uint8_t> bad = b;
    int32_t v;
    std::memcpy(&v, bad.data() + at + hw::kRecordBytes, 4);
    v = v > 0 ? v - 1 : v + 1;
    std::memcpy(bad.data() + at + hw::kRecordBytes + 4 * 0, &v, 4);
    int32_t w;
    std::memcpy(&w, bad.data() + at + hw::kRecordBytes + 12, 4);
    w = w > 0 ? w - 1 : w + 1;
    std::memcpy(bad.data() + at + hw::kRecordBytes + 12, &w, 4);
    CHECK_THROWS_WITH(
        hw::DeviceImage::from_bytes(bad.data(), bad.size()),
        "scene image: record " + std::to_string(first) + ": a triangle pair whose triangles share no edge");
    // The second is itself marked a pair: not a single triangle.
    bad = b;
    bad[at + hw::kRecordBytes + 39] |= 0xC0;
    CHECK_THROWS_WITH(hw::DeviceImage::from_bytes(bad.data(), bad.size()),
                      Catch::Contains("record " + std::to_string(first) + ": a triangle pair without its second"));
  }
  CHECK_THROWS_WITH(hw::format_from_spec("packed:tri_pairs=1"), Catch::Contains("triangle blocks hold no pairs"));
  // Without the field nothing is marked: every existing image stays as it was.
  CHECK(count_pairs(encode(scene.geometry, hw::format_preset("default"))) == 0);
}

TEST_CASE("triangle pairs: the same hits, one request per pair", "[fixed][timing][pairs][scale]") {
  for (const char* spec : {"builtin:hairball", "builtin:icosphere", "builtin:seed"}) {
    CAPTURE(spec);
    const host::Scene scene = host::load_scene(spec);
    std::vector<hw::Ray> rays = host::primary_rays(scene.camera, 3000);
    const std::vector<hw::Ray> inc = host::incoherent_rays(scene.geometry.bounds(), 3000, 11);
    rays.insert(rays.end(), inc.begin(), inc.end());
    hw::TimingConfig c = hw::timing_preset("rdna2");
    c.tri_units = 2;  // two tests a clock: a pair issues in one
    hw::TimingStats ts[2];
    std::vector<hw::Hit> hits[2][2];
    for (int p = 0; p < 2; ++p) {
      host::DeviceOptions o;
      o.kind = hw::DeviceKind::kFixed;
      o.format = hw::format_preset("default");
      o.format.tri_pairs = p;
      for (bool any : {false, true}) {
        hits[p][any].assign(rays.size(), hw::Hit{});
        hw::TraversalStats s;
        host::make_device(scene.geometry, o)
            ->trace_batch(rays.data(), hits[p][any].data(), rays.size(), any, 2, s);
      }
      o.kind = hw::DeviceKind::kTimed;
      o.timing = c;
      std::vector<hw::Hit> timed(rays.size());
      hw::TraversalStats s;
      const auto dev = host::make_device(scene.geometry, o);
      dev->trace_batch(rays.data(), timed.data(), rays.size(), false, 2, s);
      ts[p] = dev->timed()->timing();
      CHECK(std::memcmp(timed.data(), hits[p][0].data(), rays.size() * sizeof(hw::Hit)) == 0);
    }
    CHECK(std::memcmp(hits[0][0].data(), hits[1][0].data(), rays.size() * sizeof(hw::Hit)) == 0);
    for (size_t i = 0; i < rays.size(); ++i) CHECK(hits[0][1][i].hit() == hits[1][1][i].hit());
    CHECK(ts[0].tri_pairs == 0);
    CHECK(ts[1].tri_pairs > 0);
    CHECK(ts[1].tri_tests == ts[0].tri_tests);
    CHECK(ts[1].prim_fetches + ts[1].tri_pairs == ts[0].prim_fetches);
    CHECK(ts[1].cycles <= ts[0].cycles);
  }
}
