// The node-kind seam (format/node_kind.h, node_kinds.h, datapath/node_test.h): the image names its kind, an
// unknown kind is refused, the quantized AABB kind's parts agree with each other (encode contains its boxes, the
// packed fields round-trip, the check accepts what the encoder writes and names what it refuses), and the
// datapath's reference path, fast kernel and exact oracle agree on the kind's nodes.
#include <catch2/catch.hpp>

#include <cstring>
#include <string>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/node_test.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/node_kinds.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/node_cost.h"
#include "tests/common/test_util.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

namespace {

DeviceImage encode(const Geometry& g, const FixedFormat& f) {
  BvhBuildParams bp;
  bp.width = f.width;
  const Bvh bvh = Bvh::build(g, bp);
  return encode_scene(g, f, &bvh);
}

// count random child boxes on a 2^B grid.
std::vector<GridBox> random_boxes(Pcg32& rng, int count, int B) {
  std::vector<GridBox> boxes;
  boxes.resize(size_t(count));
  const int64_t gmax = (int64_t(1) << B) - 1;
  for (GridBox& b : boxes)
    for (int a = 0; a < 3; ++a) {
      const int64_t x = rand_int(rng, 0, gmax), y = rand_int(rng, 0, gmax);
      b.lo[a] = std::min(x, y);
      b.hi[a] = std::max(x, y);
    }
  return boxes;
}

}  // namespace

TEST_CASE("node kind: images name the quantized AABB, unknown kinds are refused", "[fixed][image][limits]") {
  const Geometry g = random_scene(5, 400, 10);
  for (const char* spec : {"default", "default:node_layout=1", "default:node_layout=2"}) {
    CAPTURE(spec);
    const DeviceImage img = encode(g, format_from_spec(spec));
    const ImageHeader& h = img.header();
    CHECK(node_kind(h) == NodeKindId::kQuantizedAabb);
    CHECK((h.flags & kImageNodeKindMask) == 0);  // images written before kinds existed read the same
    REQUIRE(find_node_kind(uint32_t(node_kind(h))) != nullptr);
    CHECK(std::string(find_node_kind(uint32_t(node_kind(h)))->name) == "quantized-aabb");
    std::vector<uint8_t> b(img.data(), img.data() + img.size());
    CHECK_NOTHROW(DeviceImage::from_bytes(b.data(), b.size()));
    for (uint32_t kind : {1u, 7u, 15u}) {
      CAPTURE(kind);
      std::vector<uint8_t> bad = b;
      ImageHeader bh;
      std::memcpy(&bh, bad.data(), sizeof bh);
      bh.flags |= kind << kImageNodeKindShift;
      std::memcpy(bad.data(), &bh, sizeof bh);
      CHECK_THROWS_WITH(DeviceImage::from_bytes(bad.data(), bad.size()),
                        "scene image: unknown node kind " + std::to_string(kind));
    }
  }
}

TEST_CASE("node kind: the dispatch gives each width and offset size its struct", "[fixed][image]") {
  for (int width : {2, 4, 6, 8})
    for (int q_bytes : {1, 2}) {
      CAPTURE(width, q_bytes);
      const size_t bytes = with_node_kind(NodeKindId::kQuantizedAabb, width, q_bytes, [](auto k) {
        using K = decltype(k);
        CHECK(K::kWidth == sizeof(K::Node::child) / sizeof(uint32_t));
        return sizeof(typename K::Node);
      });
      CHECK(bytes == qnode_bytes(width, q_bytes));
    }
  CHECK_THROWS_AS(with_node_kind(NodeKindId::kQuantizedAabb, 3, 1, [](auto) { return 0; }), std::logic_error);
  CHECK_THROWS_AS(with_node_kind(NodeKindId(9), 4, 1, [](auto) { return 0; }), std::logic_error);
}

TEST_CASE("quantized AABB kind: encode contains, check accepts, packed fields round-trip", "[fixed][image]") {
  Pcg32 rng(41);
  using K = QuantizedAabb<8, uint8_t>;
  for (int child_bits : {3, 5, 8}) {
    FixedFormat f = format_preset("wide8");
    f.child_bits = child_bits;
    for (int trial = 0; trial < 2000; ++trial) {
      const int count = 1 + int(rng.next_u32() % 8);
      const std::vector<GridBox> boxes = random_boxes(rng, count, f.coord_bits);
      uint32_t refs[8];
      for (int i = 0; i < 8; ++i) refs[i] = uint32_t(100 + i);
      K::Node n;
      K::encode(n, boxes.data(), refs, count, f);
      REQUIRE(K::count(n) == count);
      REQUIRE(K::check(n, f).empty());
      for (int i = 0; i < 8; ++i) {
        CHECK(K::child(n, i) == (i < count ? refs[i] : kEmptyChild));
        if (i >= count) continue;
        int64_t lo[3], hi[3];
        K::child_box(n, i, lo, hi);
        for (int a = 0; a < 3; ++a) {
          CHECK(lo[a] <= boxes[size_t(i)].lo[a]);
          CHECK(hi[a] >= boxes[size_t(i)].hi[a]);
        }
      }
      PackedNode pn;
      K::to_packed(n, pn);
      K::Node back;
      REQUIRE(K::from_packed(pn, back).empty());
      for (int i = 0; i < 8; ++i) K::set_child(back, i, K::child(n, i));
      CHECK(std::memcmp(&back, &n, sizeof n) == 0);
    }
  }
  // What the check refuses, by name.
  FixedFormat f = format_preset("wide8");
  const std::vector<GridBox> boxes = random_boxes(rng, 3, f.coord_bits);
  const uint32_t refs[3] = {1, 2, 3};
  K::Node n;
  K::encode(n, boxes.data(), refs, 3, f);
  K::Node bad = n;
  bad.count = 0;
  CHECK(K::check(bad, f) == "child count out of range");
  bad = n;
  bad.exp[1] = int8_t(f.coord_bits + 2);
  CHECK(K::check(bad, f) == "scale out of range");
  bad = n;
  f.child_bits = 4;
  bad.q[1][0] = 16;
  CHECK(K::check(bad, f) == "child offset wider than child_bits");
  PackedNode pn;
  K::to_packed(n, pn);
  pn.exp[2] = 128;
  CHECK(K::from_packed(pn, bad) == "scale out of range");
}

TEST_CASE("quantized AABB kind's test: reference, fast kernel and the exact oracle agree", "[fixed][image]") {
  using K = QuantizedAabb<4, uint8_t>;
  using T = NodeTest<K>;
  const FixedFormat f = format_preset("default");
  const QuantFrame frame = unit_frame(f.coord_bits);
  const RaySetup setup(frame, f);
  Pcg32 rng(42);
  int fast_runs = 0, hits = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const int count = 1 + int(rng.next_u32() % 4);
    const std::vector<GridBox> boxes = random_boxes(rng, count, f.coord_bits);
    const uint32_t refs[4] = {10, 11, 12, 13};
    K::Node n;
    K::encode(n, boxes.data(), refs, count, f);
    Ray ray;
    ray.origin = Vec3(rand_float(rng, -0.2f, 1.2f), rand_float(rng, -0.2f, 1.2f), rand_float(rng, -0.2f, 1.2f));
    ray.dir = Vec3(rand_float(rng, -1, 1), rand_float(rng, -1, 1), rand_float(rng, -1, 1));
    ray.tmin = 0.0f;
    ray.tmax = 1e30f;
    FixedRay r;
    if (setup(ray, r) != RayStatus::kOk) continue;
    uint32_t ref_refs[4], fast_refs[4];
    int64_t ref_d[4], fast_d[4];
    int tested = 0;
    const int k = T::test<int64_t>(r, n, r.tmin, r.tmax, ref_refs, ref_d, [&](int i, bool hit) {
      ++tested;
      // Conservative: a child the exact oracle hits is never rejected.
      if (T::exact(r, n, i, r.tmin, r.tmax)) CHECK(hit);
    });
    CHECK(tested == count);
    hits += k;
    const NodeRay nr = T::ray(r, f);
    if (!nr.fast) continue;
    const int kf = T::fast(nr, n, r.tmin, r.tmax, fast_refs, fast_d);
    if (kf < 0) continue;
    ++fast_runs;
    REQUIRE(kf == k);
    for (int j = 0; j < k; ++j) {
      CHECK(fast_refs[j] == ref_refs[j]);
      CHECK(fast_d[j] == ref_d[j]);
    }
  }
  CHECK(fast_runs > 10000);  // the comparison ran on most nodes, not on a few
  CHECK(hits > 1000);
}

TEST_CASE("node cost: the axis-aligned class prices a node as box_rate and box_latency", "[timing]") {
  TimingConfig c;
  c.box_rate = 3;
  c.box_latency = 7;
  const BoxCost b = box_cost(c, NodeCostClass::kAxisAligned);
  CHECK(b.latency == 7);
  CHECK(b.issue[0] == 1);  // a node takes one clock even without children
  CHECK(b.issue[3] == 1);
  CHECK(b.issue[4] == 2);
  CHECK(b.issue[8] == 3);
}
