// Packed layouts (packed_layout.h): node and block encodings decode to exactly the values encoded, their sizes are
// the ones the layouts' formulas give, scenes in every layout trace to the same hits as the struct layout (and the
// timed device to the fixed device's), the bytes shrink with the bits, and the image checker refuses malformed
// packed nodes and blocks with the field named. Randomized parts print their seed.
#include <catch2/catch.hpp>

#include <array>
#include <cstring>
#include <string>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/hw_format.h"
#include "hwmodel/format/packed_layout.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/timing_config.h"
#include "image_checks.h"
#include "tests/common/test_util.h"
#include "timing_checks.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;
using namespace rtu::hw::image_checks;

using rtu::test::contains;

namespace {

// Node layout 1's formula, written out: origins B + 2 bits, scales bits_for(B + 1), count bits_for(N - 1), the
// two bases, per child a leaf bit and the group field, 6 N offsets of k bits.
uint64_t packed_bits(const FixedFormat& f, int base, int prim, int group) {
  const int B = f.coord_bits, N = f.width;
  return 3 * uint64_t(B + 2) + 3 * uint64_t(bits_for(uint64_t(B) + 1)) + uint64_t(bits_for(uint64_t(N) - 1)) +
         uint64_t(base + prim) + uint64_t(N) * uint64_t(1 + group) + 6 * uint64_t(N) * uint64_t(f.child_bits);
}

PackedNode random_node(Pcg32& rng, const NodeFields& fl, int B) {
  PackedNode n;
  auto below = [&](uint64_t lim) { return lim == 0 ? 0 : uint64_t(rng.next_u32()) % lim; };
  auto field = [&](int bits) {
    const uint64_t v = (uint64_t(rng.next_u32()) << 32) | rng.next_u32();
    return bits >= 64 ? v : v & ((uint64_t(1) << bits) - 1);
  };
  n.count = 1 + int(below(uint64_t(fl.width)));
  // QNode's origin is an int32: at B = 30 the top of the range is INT32_MAX. Oriented nodes' origins span
  // [-2^(B+2), 2^(B+2)] (their bias says which: B or B + 2).
  const bool oriented = fl.origin_bias == B + 2;
  const int64_t lo = std::max<int64_t>(-(int64_t(1) << fl.origin_bias), INT32_MIN),
                hi = std::min<int64_t>(int64_t(1) << (oriented ? B + 2 : B + 1), INT32_MAX);
  for (int a = 0; a < 3; ++a) {
    // The origin's range ends, and values in between.
    const uint64_t pick = below(4);
    n.origin[a] = int32_t(pick == 0 ? lo : pick == 1 ? hi : lo + int64_t(below(uint64_t(hi - lo + 1))));
    n.exp[a] = int(below(uint64_t(B) + (oriented ? 4 : 2)));
  }
  n.rot = uint32_t(field(fl.rot));
  n.node_base = field(fl.node_base);
  n.prim_base = field(fl.prim_base);
  for (int i = 0; i < n.count; ++i) {
    n.leaf[i] = (rng.next_u32() & 1) != 0;
    n.group[i] = n.leaf[i] ? uint32_t(field(fl.group)) + 1 : 0;
    for (int r = 0; r < 6; ++r) n.q[r][i] = uint32_t(below(3) == 0 ? field(fl.q) : (r % 2 ? field(fl.q) : 0));
  }
  return n;
}

void check_same(const PackedNode& a, const PackedNode& b, int width) {
  for (int x = 0; x < 3; ++x) {
    CHECK(a.origin[x] == b.origin[x]);
    CHECK(a.exp[x] == b.exp[x]);
  }
  CHECK(a.count == b.count);
  CHECK(a.rot == b.rot);
  CHECK(a.node_base == b.node_base);
  CHECK(a.prim_base == b.prim_base);
  for (int i = 0; i < width; ++i) {
    CHECK(a.leaf[i] == b.leaf[i]);
    CHECK(a.group[i] == b.group[i]);
    for (int r = 0; r < 6; ++r) CHECK(a.q[r][i] == b.q[r][i]);
  }
}

// count triangle records on a 2^B grid: random, with vertices shared and at the grid's ends, and degenerate ones.
std::vector<uint8_t> triangle_records(Pcg32& rng, int count, int B, int spread) {
  const int64_t gmax = (int64_t(1) << B) - 1;
  const int64_t base = int64_t(rng.next_u32()) % (gmax + 1);
  std::vector<std::array<int32_t, 3>> pool;
  for (int i = 0; i < 2 * count + 1; ++i) {
    std::array<int32_t, 3> v;
    for (int a = 0; a < 3; ++a) {
      const uint32_t pick = rng.next_u32() % 8;
      int64_t c = pick == 0   ? 0
                  : pick == 1 ? gmax
                              : base + int64_t(rng.next_u32() % uint32_t(spread)) - spread / 2;
      c = std::clamp<int64_t>(c, 0, gmax);
      v[size_t(a)] = int32_t(c);
    }
    pool.push_back(v);
  }
  std::vector<uint8_t> out(size_t(count) * kRecordBytes);
  for (int i = 0; i < count; ++i) {
    TriangleRecord t{};
    const uint32_t kind = rng.next_u32() % 6;
    for (int k = 0; k < 3; ++k) {
      // kind 0: all three vertices the same (degenerate); kind 1: two the same; else from the shared pool.
      const size_t j = kind == 0 ? 0 : (kind == 1 && k == 2) ? 1 : rng.next_u32() % pool.size();
      const size_t jj = kind == 1 && k < 2 ? 1 : j;
      for (int a = 0; a < 3; ++a) t.v[k][a] = pool[jj][size_t(a)];
    }
    t.prim = (uint32_t(RecordKind::kTriangle) << 30) | (rng.next_u32() % 4096 + (i % 3 == 0 ? 1000000u : 0u));
    std::memcpy(out.data() + size_t(i) * kRecordBytes, &t, sizeof t);
  }
  return out;
}

}  // namespace

TEST_CASE("packed node sizes are the layouts' formulas", "[fixed][image]") {
  static_assert(compressed_wide_node_bytes(8, 1) == 80 && compressed_wide_node_bytes(4, 1) == 52 &&
                compressed_wide_node_bytes(6, 1) == 66 && compressed_wide_node_bytes(8, 2) == 128);
  // xe6: 6-wide bit-packed nodes of the default format fit Intel's 64 bytes at up to 2^24 nodes and primitive
  // units (bases of 24 bits, groups of 128 granules).
  CHECK(node_fields(format_preset("xe6"), 24, 24, 7).bytes(1) <= 64);
  CHECK(node_fields(format_preset("xe6"), 24, 24, 7).bytes(64) == 64);
  // rdna4: 8-wide bit-packed nodes with 12-bit child boxes fit AMD RDNA4's 128-byte BVH8 node, likewise.
  CHECK(node_fields(format_preset("rdna4"), 24, 24, 7).bytes(1) <= 128);
  CHECK(node_fields(format_preset("rdna4"), 24, 24, 7).bytes(128) == 128);
  for (int width : {2, 4, 6, 8}) {
    for (int k : {4, 8, 12}) {
      FixedFormat f = format_preset("default");
      f.width = width;
      f.child_bits = k;
      f.node_layout = 2;
      CAPTURE(width, k);
      CHECK(node_fields(f, 0, 0, 0).bytes(1) == compressed_wide_node_bytes(width, f.offset_bytes()));
      f.node_layout = 1;
      for (int base : {0, 7, 20}) {
        const NodeFields fl = node_fields(f, base, base + 1, 4);
        CHECK(fl.bits() == packed_bits(f, base, base + 1, 4));
        for (int align : {1, 8, 64}) {
          const uint64_t b = fl.bytes(align);
          CHECK(b % uint64_t(align) == 0);
          CHECK(b * 8 >= fl.bits());
          CHECK((b - uint64_t(align)) * 8 < fl.bits());  // the smallest multiple that holds the bits
        }
      }
    }
  }
  // Fewer bits, fewer bytes: a bit-packed 8-wide node at k = 4 is under half the 8-bit struct's 96 bytes.
  FixedFormat f = format_preset("wide8");
  f.node_layout = 1;
  f.child_bits = 4;
  CHECK(node_fields(f, 20, 21, 4).bytes(1) < 48);
}

TEST_CASE("packed nodes round-trip: every field at its ends and at random", "[fixed][image]") {
  const uint64_t seed = 2612;
  INFO("seed " << seed);
  Pcg32 rng(seed);
  for (int kind : {0, 1})
    for (int layout : {1, 2})
      for (int width : {2, 4, 6, 8})
        for (int B : {2, 16, kind ? 28 : 30}) {
          FixedFormat f = format_preset("default");
          f.width = width;
          f.coord_bits = B;
          f.node_kind = kind;
          f.rotations = 1 + int(rng.next_u32() % 1024);
          f.child_bits = layout == 2 ? 8 : 1 + int(rng.next_u32() % 16);
          f.node_layout = layout;
          const int base = int(rng.next_u32() % 33), prim = int(rng.next_u32() % 33),
                    group = int(rng.next_u32() % 8);
          const NodeFields fl = node_fields(f, base, prim, group);
          const uint64_t bytes = fl.bytes(layout == 1 ? 8 : 1);
          CAPTURE(kind, layout, width, B, f.child_bits, base, prim, group, f.rotations);
          for (int i = 0; i < 200; ++i) {
            const PackedNode n = random_node(rng, fl, B);
            std::vector<uint8_t> out;
            pack_node(n, fl, bytes, out);
            REQUIRE(out.size() == bytes);
            check_same(unpack_node(out.data(), bytes, fl, "node"), n, width);
          }
        }
}

TEST_CASE("triangle blocks round-trip exactly: 1 to 16 triangles, grid ends, degenerate triangles",
          "[fixed][image]") {
  const uint64_t seed = 2613;
  INFO("seed " << seed);
  Pcg32 rng(seed);
  for (int B : {2, 8, 16, 24, 30})
    for (int count : {1, 2, 5, 16})
      for (int spread : {3, 1000, 1 << 20})
        for (int rep = 0; rep < 20; ++rep) {
          const std::vector<uint8_t> recs = triangle_records(rng, count, B, spread);
          std::vector<uint8_t> block;
          const uint32_t size = encode_block(recs.data(), count, B, block);
          CAPTURE(B, count, spread, rep);
          REQUIRE(block.size() == size * kGranuleBytes);
          CHECK(size <= 1 + uint32_t(count) * 5);  // never above the raw records and their header
          std::vector<uint8_t> back;
          CHECK(decode_block(block.data(), block.size(), B, back, "block") == size);
          REQUIRE(back.size() == recs.size());
          CHECK(std::memcmp(back.data(), recs.data(), recs.size()) == 0);
        }
  // A block of spheres (or of a sphere and triangles) keeps its 40-byte records behind an 8-byte header.
  std::vector<uint8_t> mixed = triangle_records(rng, 3, 16, 100);
  SphereRecord s{};
  s.center[0] = 5;
  s.radius = 7;
  s.prim = (uint32_t(RecordKind::kSphere) << 30) | 9;
  std::memcpy(mixed.data() + kRecordBytes, &s, sizeof s);
  std::vector<uint8_t> block, back;
  CHECK(encode_block(mixed.data(), 3, 16, block) == 16);
  CHECK(decode_block(block.data(), block.size(), 16, back, "block") == 16);
  CHECK(back == mixed);
}

TEST_CASE("triangle blocks: bytes follow the bits the block needs", "[fixed][image]") {
  // 16 triangles of a strip (18 shared vertices) in a small extent: per vertex 3 x 4 bits, per index 5 bits.
  std::vector<uint8_t> recs(16 * kRecordBytes);
  for (int i = 0; i < 16; ++i) {
    TriangleRecord t{};
    for (int k = 0; k < 3; ++k) {
      const int j = i + k;  // vertex j of the strip
      t.v[k][0] = 1000 + (j / 2) * 2;
      t.v[k][1] = 2000 + (j % 2) * 9;
      t.v[k][2] = 3000;
    }
    t.prim = uint32_t(100 + i);
    std::memcpy(recs.data() + size_t(i) * kRecordBytes, &t, sizeof t);
  }
  std::vector<uint8_t> block;
  const uint32_t g = encode_block(recs.data(), 16, 24, block);
  // Header 1+4+6+15 bits, anchor 72, prim bits 5 + base 30, 16 x 4 prim offsets, 18 x (4 + 4 + 0) vertex bits,
  // 48 x 5 index bits = 26 + 72 + 35 + 64 + 144 + 240 = 581 bits: 10 granules (80 bytes) for 640 raw bytes.
  CHECK(g == 10);
}

TEST_CASE("every layout traces to the struct layout's hits, and timed to fixed", "[fixed][image][timed]") {
  const Geometry g = random_scene(77, 3000, 40);
  const std::vector<Ray> rs = rays(78, 4000);
  for (int width : {2, 4, 6, 8}) {
    FixedFormat base = format_preset("default");
    base.width = width;
    const DeviceImage ref = encode(g, base);
    std::vector<Hit> want(rs.size());
    TraversalStats ws;
    FixedTracer(ref).trace_batch(rs.data(), want.data(), rs.size(), false, 1, ws);
    for (const char* spec :
         {"node_layout=1", "node_layout=2", "node_layout=1:prim_layout=1", "node_layout=2:prim_layout=1",
          "node_layout=1:node_align=64:prim_layout=1", "node_layout=1:child_bits=5:prim_layout=1"}) {
      FixedFormat f = format_from_spec(std::string("default:") + spec);
      f.width = width;
      CAPTURE(width, spec);
      const DeviceImage img = encode(g, f);
      // The bound copy decodes to the same values as the encoder's.
      const std::vector<uint8_t> b = bytes_of(img);
      const DeviceImage bound = DeviceImage::from_bytes(b.data(), b.size());
      std::vector<Hit> got(rs.size());
      TraversalStats s;
      FixedTracer(bound).trace_batch(rs.data(), got.data(), rs.size(), false, 1, s);
      if (f.child_bits == base.child_bits) {
        CHECK(s.nodes_visited == ws.nodes_visited);
        CHECK(s.prim_tests == ws.prim_tests);
        size_t differ = 0;
        for (size_t i = 0; i < rs.size(); ++i)
          differ += got[i].prim != want[i].prim || got[i].t != want[i].t || got[i].u != want[i].u;
        CHECK(differ == 0);
        CHECK(img.records_size() <= ref.records_size());
        CHECK(img.header().node_count == ref.header().node_count);
        // Bit-packed, unpadded nodes are smaller than structs at every width; compressed-wide byte fields are
        // from width 4 (at width 2 their 24-byte head outweighs the struct's 4-byte references).
        if (f.node_align == 1 && (f.node_layout == 1 || width >= 4)) CHECK(img.nodes_size() < ref.nodes_size());
      }
      {
        const ImageHeader& h = img.header();
        CHECK(img.node_bytes() == node_fields(f, h.base_bits, h.prim_bits, h.group_bits).bytes(f.node_align));
      }
      CHECK(s.box_false_negatives == 0);
      // Timed: the same hits as the fixed device, whatever the bytes it fetches.
      TimingConfig c = timing_preset("rdna2");
      c.bvh_width = width;
      TimedEngine timed(EngineOptions{}, c);
      timed.bind(b.data(), b.size());
      std::vector<Hit> th(rs.size());
      TraversalStats ts;
      timed.trace_cycles(rs.data(), th.data(), rs.size(), false, ts, 0, 0);
      size_t tdiffer = 0;
      for (size_t i = 0; i < rs.size(); ++i) tdiffer += th[i].prim != got[i].prim || th[i].t != got[i].t;
      CHECK(tdiffer == 0);
    }
  }
}

TEST_CASE("the timed device fetches the packed bytes", "[timing][image]") {
  const Geometry g = random_scene(91, 4000, 0);
  const std::vector<Ray> rs = rays(92, 3000);
  auto dram = [&](const std::string& spec) {
    const FixedFormat f = format_from_spec(spec);
    const DeviceImage img = encode(g, f);
    const std::vector<uint8_t> b = bytes_of(img);
    TimingConfig c = timing_preset("rdna2-mem");
    c.bvh_width = f.width;
    TimedEngine timed(EngineOptions{}, c);
    timed.bind(b.data(), b.size());
    std::vector<Hit> h(rs.size());
    TraversalStats s;
    timed.trace_cycles(rs.data(), h.data(), rs.size(), false, s, 0, 0);
    const TimingStats t = timed.timing();
    INFO(spec << ": image " << img.size() << " bytes, DRAM " << t.dram_bytes << " bytes, " << t.cycles
              << " cycles");
    return std::pair<uint64_t, uint64_t>(img.size(), t.dram_bytes);
  };
  const auto structs = dram("default"), packed = dram("packed"), cw = dram("cwbvh");
  // Smaller images, and a small cache (16 KiB) in front of DRAM: fewer bytes fetched.
  CHECK(packed.first < structs.first);
  CHECK(packed.second < structs.second);
  CHECK(cw.first < dram("wide8").first);
}

TEST_CASE("from_bytes refuses malformed packed nodes and blocks, naming the field", "[fixed][image][limits]") {
  const Geometry g = random_scene(55, 400, 5);
  FixedFormat f = format_from_spec("packed");
  const DeviceImage img = encode(g, f, 4);
  const ImageHeader& h = img.header();
  REQUIRE(h.node_count > 2);
  const std::vector<uint8_t> good = bytes_of(img);
  CHECK(refusal(good).empty());
  const NodeFields fl = node_fields(img.format(), h.base_bits, h.prim_bits, h.group_bits);
  // Rewrites node n's fields with `change` applied, packed again.
  auto node_changed = [&](uint32_t n, auto change) {
    std::vector<uint8_t> b = good;
    uint8_t* at = b.data() + h.node_offset + size_t(n) * h.node_bytes;
    PackedNode pn = unpack_node(at, h.node_bytes, fl, "node");
    change(pn);
    std::vector<uint8_t> out;
    pack_node(pn, fl, h.node_bytes, out);
    std::memcpy(at, out.data(), out.size());
    return b;
  };
  CHECK(contains(refusal(node_changed(0, [](PackedNode& n) { n.exp[1] = 31; })), "node 0: scale out of range"));
  CHECK(contains(refusal(node_changed(1,
                                      [&](PackedNode& n) {
                                        n.node_base = h.node_count;
                                        n.leaf[0] = false;
                                        n.group[0] = 0;
                                      })),
                 "node 1: child node out of range"));
  // A leaf child pointing into the middle of a block, and one whose size disagrees with its block's.
  uint32_t leafy = 0;
  for (uint32_t n = 0; n < h.node_count && !leafy; ++n) {
    const PackedNode pn =
        unpack_node(good.data() + h.node_offset + size_t(n) * h.node_bytes, h.node_bytes, fl, "node");
    if (pn.leaf[0]) leafy = n;
  }
  REQUIRE(leafy > 0);
  CHECK(contains(refusal(node_changed(leafy, [](PackedNode& n) { n.prim_base += 1; })), "start of a block"));
  CHECK(contains(refusal(node_changed(leafy, [](PackedNode& n) { n.group[0] += 1; })), "group size differs"));
  // Padding and empty slots must be zero.
  {
    std::vector<uint8_t> b = good;
    b[h.node_offset + h.node_bytes - 1] ^= 0x80;
    const std::string why = refusal(b);
    CHECK((contains(why, "padding not zero") || contains(why, "empty slot")));
  }
  // Blocks: a vertex index beyond the block's vertices, a truncated section, a wrong header.
  {
    std::vector<uint8_t> b = good;
    b[h.record_offset] ^= 0x1E;  // the first block's count
    CHECK(contains(refusal(b), "block at byte 0 of the primitive section"));
  }
  {
    std::vector<uint8_t> b = good;
    ImageHeader hh = h;
    hh.record_bytes -= 8;
    std::memcpy(b.data(), &hh, sizeof hh);
    CHECK(!refusal(b).empty());
  }
  {
    std::vector<uint8_t> b = good;
    ImageHeader hh = h;
    hh.node_bytes += 8;
    std::memcpy(b.data(), &hh, sizeof hh);
    CHECK(contains(refusal(b), "node_bytes"));
  }
  // Every single-bit flip of a few nodes and blocks is refused or traces without leaving the image (the
  // checker's guarantee; no crash, no sanitizer report).
  Pcg32 rng(56);
  const std::vector<Ray> rs = rays(57, 50);
  for (int i = 0; i < 400; ++i) {
    std::vector<uint8_t> b = good;
    const size_t at = h.node_offset + size_t(rng.next_u32() % (h.total_bytes - h.node_offset));
    b[at] ^= uint8_t(1u << (rng.next_u32() % 8));
    try {
      const DeviceImage bad = DeviceImage::from_bytes(b.data(), b.size());
      std::vector<Hit> hits(rs.size());
      TraversalStats s;
      FixedTracer(bad).trace_batch(rs.data(), hits.data(), rs.size(), false, 1, s);
    } catch (const std::invalid_argument&) {
    }
  }
}
