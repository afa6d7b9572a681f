// The node-kind seam (format/node_kind.h, node_kinds.h, datapath/node_test.h): the image names its kind, an
// unknown kind is refused, the quantized AABB kind's parts agree with each other (encode contains its boxes, the
// packed fields round-trip, the check accepts what the encoder writes and names what it refuses), and the
// datapath's reference path, fast kernel and exact oracle agree on the kind's nodes. The oriented kind
// (format/oriented_aabb.h): its rotation table, its test never rejecting what exact arithmetic accepts (random
// nodes at several widths, and every rotation and direction of a small format), its images checked and refused
// by name, and its hits equal to the axis-aligned kind's.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
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
#include "image_checks.h"
#include "tests/common/test_util.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;

using rtu::hw::image_checks::encode;

namespace {

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
    for (uint32_t kind : {2u, 7u, 15u}) {
      CAPTURE(kind);
      std::vector<uint8_t> bad = b;
      ImageHeader bh;
      std::memcpy(&bh, bad.data(), sizeof bh);
      bh.flags |= kind << kImageNodeKindShift;
      std::memcpy(bad.data(), &bh, sizeof bh);
      CHECK_THROWS_WITH(DeviceImage::from_bytes(bad.data(), bad.size()),
                        "scene image: unknown node kind " + std::to_string(kind));
    }
    // Rotation table fields belong to the oriented kind only.
    std::vector<uint8_t> bad = b;
    ImageHeader bh;
    std::memcpy(&bh, bad.data(), sizeof bh);
    bh.flags |= 12u << kImageRotBitsShift;
    std::memcpy(bad.data(), &bh, sizeof bh);
    CHECK_THROWS_WITH(DeviceImage::from_bytes(bad.data(), bad.size()),
                      "scene image: rotation table fields in an image of quantized-aabb nodes");
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
    const NodeRay nr = T::ray(r, f);
    const int k = T::test<int64_t>(nr, r, n, r.tmin, r.tmax, ref_refs, ref_d, [&](int i, bool hit) {
      ++tested;
      // Conservative: a child the exact oracle hits is never rejected.
      if (T::exact(nr, r, n, i, r.tmin, r.tmax)) CHECK(hit);
    });
    CHECK(tested == count);
    hits += k;
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

TEST_CASE("node cost: the oriented class adds the rotation stage to the latency", "[timing]") {
  TimingConfig c;
  c.box_rate = 4;
  c.box_latency = 6;
  c.obb_latency = 5;
  const BoxCost a = box_cost(c, NodeCostClass::kAxisAligned), o = box_cost(c, NodeCostClass::kOriented);
  CHECK(o.latency == 11);
  CHECK(o.issue == a.issue);
}

TEST_CASE("rotation table: the identity first, each entry a rotation within its rounding", "[fixed][obb]") {
  for (int bits : {4, 12, 16}) {
    CAPTURE(bits);
    const std::vector<Rotation>& t = rotation_table(104, bits);
    REQUIRE(t.size() == 104);
    CHECK(&t == &rotation_table(104, bits));  // built once
    const int64_t one = int64_t(1) << bits;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) CHECK(t[0].m[r][c] == (r == c ? one : 0));
    for (size_t k = 0; k < t.size(); ++k) {
      CAPTURE(k);
      // Entries are the exact matrix's rounded to nearest (error <= 1/2 each): M M^T = 2^(2b) (I + E) with
      // |E_ij| <= 2 sqrt(3) (1/2) 2^-b + 3 (1/4) 2^-2b, below 2 2^-b + 2^-2b for b >= 4.
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          int64_t dot = 0;
          for (int c = 0; c < 3; ++c) dot += int64_t(t[k].m[i][c]) * t[k].m[j][c];
          CHECK(std::abs(dot - (i == j ? one * one : 0)) <= 2 * one + 1);
        }
      // Every entry differs from every other: no rotation is listed twice.
      for (size_t l = 0; l < k && bits == 16; ++l) CHECK(std::memcmp(&t[k], &t[l], sizeof(Rotation)) != 0);
    }
  }
  // Entry 1 turns about x by a ninth of 90 degrees (rotation_table.h): cos and sin of 10 degrees at 12 bits.
  const Rotation& r1 = rotation_table(104, 12)[1];
  CHECK(r1.m[0][0] == 4096);
  CHECK(r1.m[1][1] == 4034);  // round(4096 cos 10)
  CHECK(r1.m[2][1] == 711);   // round(4096 sin 10)
  CHECK(r1.m[1][2] == -711);
  CHECK_THROWS_AS(rotation_table(0, 12), std::invalid_argument);
  CHECK_THROWS_AS(rotation_table(104, 3), std::invalid_argument);
}

namespace {

// The oriented test of one node against the exact oracle on rays of `r`'s kind; counts false positives.
template <class K>
void check_oriented_node(const typename NodeTest<K>::RayState& st, const FixedRay& r, const typename K::Node& n,
                         uint64_t& checked, uint64_t& false_pos, uint64_t& hits) {
  using T = NodeTest<K>;
  uint32_t refs[K::kWidth];
  int64_t d[K::kWidth];
  int tested = 0;
  const int k = T::template test<Wide>(st, r, n, r.tmin, r.tmax, refs, d, [&](int i, bool hit) {
    ++tested;
    const bool exact = T::exact(st, r, n, i, r.tmin, r.tmax);
    if (exact && !hit) FAIL("a child the exact oracle hits is rejected: child " << i << ", rotation " << n.rot);
    false_pos += uint64_t(hit && !exact);
    ++checked;
  });
  hits += uint64_t(k);
  CHECK(tested == K::count(n));
}

}  // namespace

TEST_CASE("oriented kind's test: never a false negative against exact arithmetic", "[fixed][obb]") {
  using K = OrientedAabb<4, uint16_t>;
  using T = NodeTest<K>;
  for (const char* spec : {"default:node_kind=1", "default:node_kind=1:child_bits=12:rot_bits=14",
                           "compact:node_kind=1:rot_bits=4:rotations=13", "default:node_kind=1:rotations=1024"}) {
    CAPTURE(spec);
    FixedFormat f = format_from_spec(spec);
    f.width = 4;
    const QuantFrame frame = unit_frame(f.coord_bits);
    const RaySetup setup(frame, f);
    Pcg32 rng(43);
    uint64_t checked = 0, false_pos = 0, hits = 0;
    for (int trial = 0; trial < 6000; ++trial) {
      const int count = 1 + int(rng.next_u32() % 4);
      // Boxes anywhere in the rotated grid (a rotated point of the grid stays within +-2^(B+1)).
      std::vector<GridBox> boxes = random_boxes(rng, count, f.coord_bits + 1);
      for (GridBox& b : boxes)
        for (int a = 0; a < 3; ++a) {
          b.lo[a] -= int64_t(1) << f.coord_bits;
          b.hi[a] -= int64_t(1) << f.coord_bits;
        }
      const uint32_t refs[4] = {10, 11, 12, 13};
      K::Node n;
      K::encode_rotated(n, int(rng.next_u32() % uint32_t(f.rotations)), boxes.data(), refs, count, f);
      REQUIRE(K::check(n, f).empty());
      Ray ray;
      ray.origin = Vec3(rand_float(rng, -0.2f, 1.2f), rand_float(rng, -0.2f, 1.2f), rand_float(rng, -0.2f, 1.2f));
      ray.dir = Vec3(rand_float(rng, -1, 1), rand_float(rng, -1, 1), rand_float(rng, -1, 1));
      if (trial % 5 == 0) ray.dir[trial % 3] = 0.0f;  // parallel to a world axis (not to a rotated one)
      if (trial % 7 == 0) ray.dir = Vec3(0.0f, trial % 2 ? 1.0f : -1.0f, 0.0f);
      ray.tmin = 0.0f;
      ray.tmax = trial % 3 == 0 ? rand_float(rng, 0.0f, 2.0f) : 1e30f;
      FixedRay r;
      if (setup(ray, r) != RayStatus::kOk) continue;
      check_oriented_node<K>(T::ray(r, f), r, n, checked, false_pos, hits);
    }
    INFO(checked << " children, " << hits << " hit, " << false_pos << " false positives");
    CHECK(checked > 10000);
    CHECK(hits > 1000);
    // Conservative rounding accepts a child only within a few reciprocal ulps (2^-R relative) of its box: with
    // R >= 16 that is rare on random boxes.
    CHECK(false_pos * 100 < checked);
  }
}

TEST_CASE("oriented kind's test: every rotation and direction of a small format", "[fixed][obb]") {
  // B = 4, F = 1, D = 4, R = 6, rb = 4: every rotation of a 104-entry table, every direction with components
  // in a set that holds the axes, diagonals and shallow slopes, origins on a lattice inside and around the grid,
  // against one node of boxes that cover the rotated grid in slabs and cells.
  FixedFormat f = format_from_spec(
      "default:coord_bits=4:guard_bits=2:frac_bits=1:dir_bits=4:rcp_bits=6:t_frac_bits=4:t_bits=20:child_bits=4:"
      "node_kind=1:rot_bits=4");
  using K = OrientedAabb<8, uint8_t>;
  using T = NodeTest<K>;
  const int64_t comps[] = {-16, -11, -8, -3, -1, 0, 1, 3, 8, 11, 16};
  std::vector<std::array<int64_t, 3>> dirs;
  for (int64_t x : comps)
    for (int64_t y : comps)
      for (int64_t z : comps)
        if (std::max({std::abs(x), std::abs(y), std::abs(z)}) >= 8) dirs.push_back({x, y, z});
  Pcg32 rng(44);
  uint64_t checked = 0, false_pos = 0, hits = 0;
  for (int rot = 0; rot < f.rotations; ++rot) {
    // Eight boxes: slabs and cells of the rotated grid [-32, 32).
    std::vector<GridBox> boxes(8);
    for (int i = 0; i < 8; ++i)
      for (int a = 0; a < 3; ++a) {
        const int64_t lo = rand_int(rng, -32, 31), hi = rand_int(rng, lo, 31);
        boxes[size_t(i)].lo[a] = lo;
        boxes[size_t(i)].hi[a] = i < 3 && a == i ? lo + 1 : hi;
      }
    const uint32_t refs[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    K::Node n;
    K::encode_rotated(n, rot, boxes.data(), refs, 8, f);
    REQUIRE(K::check(n, f).empty());
    for (const auto& dv : dirs) {
      FixedRay r{};
      set_format_fields(r, f);
      const int64_t o[3] = {rand_int(rng, -40, 72), rand_int(rng, -40, 72), rand_int(rng, -40, 72)};  // grid.1
      for (int a = 0; a < 3; ++a) r.o[a] = o[a];
      set_direction(r, dv.data(), f);
      r.tmin = 0;
      r.tmax = r.t_limit;
      check_oriented_node<K>(T::ray(r, f), r, n, checked, false_pos, hits);
    }
  }
  INFO(checked << " children, " << hits << " hit, " << false_pos << " false positives");
  CHECK(hits > 1000);
  CHECK(checked == uint64_t(f.rotations) * dirs.size() * 8);  // every child of every node was checked
}

TEST_CASE("oriented images: encode, check and format round trip, corrupt fields refused by name",
          "[fixed][obb][image]") {
  const Geometry g = random_scene(6, 500, 12);
  for (const char* spec : {"default:node_kind=1", "wide8:node_kind=1:child_bits=12:rotations=40:rot_bits=10",
                           "packed:node_kind=1", "cwbvh:node_kind=1:child_bits=12", "rdna4:node_kind=1"}) {
    CAPTURE(spec);
    const FixedFormat f = format_from_spec(spec);
    const DeviceImage img = encode(g, f);
    const ImageHeader& h = img.header();
    CHECK(node_kind(h) == NodeKindId::kOrientedAabb);
    CHECK(img.format().node_kind == 1);
    CHECK(img.format().rotations == f.rotations);
    CHECK(img.format().rot_bits == f.rot_bits);
    if (f.node_layout == 0) CHECK(img.node_bytes() == onode_bytes(f.width, f.offset_bytes()));
    std::vector<uint8_t> b(img.data(), img.data() + img.size());
    CHECK_NOTHROW(DeviceImage::from_bytes(b.data(), b.size()));
    REQUIRE(h.node_count > 1);
    // The encoder picked rotations other than the identity somewhere (random triangles are not axis-aligned).
    bool turned = false;
    with_node_kind(node_kind(h), h.width, h.q_bytes, [&](auto k) {
      using K = decltype(k);
      if constexpr (K::kId == NodeKindId::kOrientedAabb)
        for (uint32_t i = 0; i < h.node_count; ++i) turned |= img.nodes<typename K::Node>()[i].rot != 0;
    });
    CHECK(turned);
    if (f.node_layout != 0)
      continue;  // packed nodes decoded (the check above); the corruptions below address structs
    auto corrupt = [&](size_t offset, uint16_t value, const std::string& why) {
      std::vector<uint8_t> bad = b;
      std::memcpy(bad.data() + h.node_offset + offset, &value, 2);
      CHECK_THROWS_WITH(DeviceImage::from_bytes(bad.data(), bad.size()), "scene image: node 0: " + why);
    };
    corrupt(16, uint16_t(f.rotations),
            "rotation index " + std::to_string(f.rotations) + " beyond the table's " +
                std::to_string(f.rotations) + " rotations");
    corrupt(18, 1, "reserved field not zero");
    // The header's table fields: a rotation count below an index in use, rot_bits out of range.
    std::vector<uint8_t> bad = b;
    ImageHeader bh;
    std::memcpy(&bh, bad.data(), sizeof bh);
    bh.flags = (bh.flags & ~kImageRotBitsMask) | (31u << kImageRotBitsShift);
    std::memcpy(bad.data(), &bh, sizeof bh);
    CHECK_THROWS_WITH(DeviceImage::from_bytes(bad.data(), bad.size()),
                      Catch::Contains("rot_bits = 31 outside [4, 16]"));
  }
  CHECK_THROWS_WITH(format_from_spec("precise:node_kind=1"), Catch::Contains("must be <="));
}
