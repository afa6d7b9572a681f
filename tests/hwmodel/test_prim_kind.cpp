// The primitive-kind seam (format/prim_kind.h, prim_kinds.h, datapath/prim_test.h): the prim word's kind field
// keeps the bytes of the two-bit field it widened, record_kind tells the round records apart, every kind's record
// round-trips through the encoder and the image check, a free kind value is refused, and each kind's shading
// normal is the host's.
#include <catch2/catch.hpp>

#include <cstring>
#include <string>

#include "hwmodel/datapath/prim_test.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/prim_kinds.h"
#include "hwmodel/scene/bvh.h"

using namespace rtu::hw;

namespace {

Geometry one_of_each() {
  Geometry g;
  g.triangles.push_back(Triangle{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)});
  g.spheres.push_back(Sphere{Vec3(2, 2, 2), 0.5f});
  g.curves.push_back(CurveSegment{Vec3(-1, 0, 0), 0.1f, Vec3(-1, 1, 0), 0.2f, kCurveCapStart});
  g.planes.push_back(Plane{Vec3(0, 0, 1), -3.0f});
  return g;
}

}  // namespace

TEST_CASE("prim kind: the kind field keeps the two-bit field's bytes", "[fixed][image]") {
  CHECK(record_word(RecordKind::kTriangle, 5) == 5u);
  CHECK(record_word(RecordKind::kTriangle, 5, true) == (kRecordNonOpaque | 5u));
  CHECK(record_word(RecordKind::kSphere, 7) == ((1u << 30) | 7u));
  CHECK(record_word(RecordKind::kCurve, 7) == ((1u << 30) | 7u));  // a round record; its round word says curve
  CHECK(record_word(RecordKind::kInstance, 9) == ((2u << 30) | 9u));
  CHECK(record_word(RecordKind::kTrianglePair, 3) == ((3u << 30) | 3u));
  CHECK(with_record_kind(record_word(RecordKind::kTriangle, 11, true), RecordKind::kTrianglePair) ==
        ((3u << 30) | kRecordNonOpaque | 11u));
  CHECK(kRecordPrimMask == (1u << 27) - 1);
  CHECK((kRecordKindMask & (kRecordNonOpaque | kRecordPrimMask)) == 0);
}

TEST_CASE("prim kind: records of every kind encode, check and read back their kind", "[fixed][image]") {
  const Geometry g = one_of_each();
  FixedFormat f;
  BvhBuildParams bp;
  bp.width = f.width;
  const Bvh bvh = Bvh::build(g, bp);
  const DeviceImage img = encode_scene(g, f, &bvh);
  int seen[5] = {};
  for (uint32_t i = 0; i < img.header().record_count; ++i) {
    const RecordKind k = record_kind(img.record(i));
    REQUIRE(uint8_t(k) < 5);
    ++seen[uint8_t(k)];
    uint32_t word;
    std::memcpy(&word, img.record(i) + 36, 4);
    const PrimKind want = g.kind(word & kRecordPrimMask);
    CHECK(want == (k == RecordKind::kCurve    ? PrimKind::kCurve
                   : k == RecordKind::kSphere ? PrimKind::kSphere
                                              : PrimKind::kTriangle));
  }
  CHECK(seen[uint8_t(RecordKind::kTriangle)] == 1);
  CHECK(seen[uint8_t(RecordKind::kSphere)] == 1);
  CHECK(seen[uint8_t(RecordKind::kCurve)] == 1);
  // The image reads back through the check; a free kind value (field 4: a high bit set) is refused by name.
  std::vector<uint8_t> bytes(img.data(), img.data() + img.size());
  CHECK_NOTHROW(DeviceImage::from_bytes(bytes.data(), bytes.size()));
  const size_t at = img.header().record_offset + 39;
  bytes[at] = uint8_t((bytes[at] & 0x27) | 0x08);  // kind field 4: low bits 0, high bits 01
  CHECK_THROWS_WITH(DeviceImage::from_bytes(bytes.data(), bytes.size()), Catch::Contains("unknown kind"));
}

TEST_CASE("prim kind: the table and the normals", "[fixed]") {
  for (const PrimitiveKindInfo& k : kPrimitiveKinds)
    CHECK(std::string(with_prim_kind(k.id, [](auto t) { return decltype(t)::kName; })) == k.name);
  const Geometry g = one_of_each();
  CHECK(prim_normal(g, 0, Vec3(0.2f, 0.2f, 0), 0.0f) == Vec3(0, 0, 1));
  CHECK(prim_normal(g, 1, Vec3(2, 2, 2.5f), 0.0f) == Vec3(0, 0, 0.5f));
  CHECK(prim_normal(g, 2, Vec3(-0.9f, 0.5f, 0), 0.5f) == Vec3(-0.9f, 0.5f, 0) - Vec3(-1, 0.5f, 0));
  CHECK(prim_normal(g, 3, Vec3(0, 0, -3), 0.0f) == Vec3(0, 0, 1));
}
