// Triangle clusters (format prim_layout 2, format/cluster_layout.h): clusters decode to exactly the records and
// nodes encoded, in every width, node kind and node layout; a cluster image traces bit for bit as the struct and
// block layouts over the same tree (and timed as fixed); the image check refuses malformed clusters naming the
// field, and no bit flip crashes; the cluster engine's cycles to the cycle on a hand-counted ray. Randomized parts
// print their seed.
#include <catch2/catch.hpp>

#include <cstring>
#include <string>
#include <vector>

#include "fixed_checks.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/cluster_layout.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/format/hw_format.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/numeric/rng.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/timing_config.h"
#include "hwmodel/timing/timing_model.h"
#include "image_checks.h"
#include "tests/common/test_util.h"
#include "timing_checks.h"

using namespace rtu::hw;
using namespace rtu::hw::fixed_checks;
using namespace rtu::hw::image_checks;

using rtu::test::contains;

namespace {

// A strip of n triangles on a small grid patch: neighbours share two vertices, as a mesh's do.
Geometry strip_mesh(int rows, int cols) {
  Geometry g;
  auto at = [](int r, int c) {
    return Vec3(float(c) * 0.25f, float(r) * 0.25f, 0.1f * float((r * 7 + c * 3) % 5));
  };
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      g.triangles.push_back(Triangle{at(r, c), at(r, c + 1), at(r + 1, c)});
      g.triangles.push_back(Triangle{at(r, c + 1), at(r + 1, c + 1), at(r + 1, c)});
    }
  return g;
}

uint32_t clusters_with_nodes(const DeviceImage& img) {
  uint32_t n = 0;
  for (const DeviceImage::Span& s : img.cluster_node_spans()) n += s.bytes > 0;
  return n;
}

}  // namespace

TEST_CASE("triangle clusters: format fields, validation and presets", "[fixed][format][cluster]") {
  const FixedFormat c = format_preset("clusters");
  CHECK(c.prim_layout == 2);
  CHECK(c.node_layout == 1);
  CHECK(contains(c.describe(), "triangle clusters"));
  CHECK_THROWS_WITH(format_from_spec("default:prim_layout=2"), Catch::Contains("needs packed nodes"));
  CHECK_THROWS_WITH(format_from_spec("packed:cluster_tris=64"), Catch::Contains("applies to triangle clusters"));
  CHECK_THROWS_WITH(format_from_spec("clusters:cluster_tris=8"), Catch::Contains("cluster_tris = 8 outside"));
  CHECK_THROWS_WITH(format_from_spec("clusters:cluster_tris=257"), Catch::Contains("cluster_tris = 257 outside"));
  CHECK_THROWS_WITH(format_from_spec("clusters:prim_layout=3"), Catch::Contains("prim_layout = 3 outside"));
  CHECK_NOTHROW(format_from_spec("clusters:cluster_tris=64"));
}

TEST_CASE("a flat cluster round-trips exactly: 1 to 16 triangles, grid ends, shared vertices",
          "[fixed][image][cluster]") {
  const uint64_t seed = 4501;
  INFO("seed " << seed);
  Pcg32 rng(seed);
  for (int B : {2, 8, 16, 24, 30})
    for (int count : {1, 3, 16})
      for (int rep = 0; rep < 30; ++rep) {
        FixedFormat f = format_preset("clusters");
        f.coord_bits = B;
        const int64_t gmax = (int64_t(1) << B) - 1;
        Cluster c;
        c.records.resize(size_t(count) * kRecordBytes);
        for (int i = 0; i < count; ++i) {
          TriangleRecord t{};
          for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a) {
              const uint32_t pick = rng.next_u32() % 4;
              // Grid ends, and a few shared values so vertices repeat.
              t.v[k][a] = int32_t(pick == 0   ? 0
                                  : pick == 1 ? gmax
                                  : pick == 2 ? gmax / 2
                                              : int64_t(rng.next_u32()) % (gmax + 1));
            }
          t.prim = (uint32_t(RecordKind::kTriangle) << 30) | (rng.next_u32() & kRecordPrimMask);
          std::memcpy(c.records.data() + size_t(i) * kRecordBytes, &t, sizeof t);
        }
        CAPTURE(B, count, rep);
        std::vector<uint8_t> out;
        const uint32_t lines = encode_cluster(c, f, out);
        REQUIRE(lines > 0);
        REQUIRE(out.size() == lines * kClusterLineBytes);
        Cluster back;
        CHECK(decode_cluster_unit(out.data(), out.size(), f, back, "cluster") == lines);
        CHECK(back.nodes.empty());
        CHECK(back.records == c.records);
      }
  // Spheres and non-opaque triangles are no cluster's: they stay raw blocks, padded to a line.
  Cluster c;
  c.records.resize(2 * kRecordBytes);
  SphereRecord s{};
  s.radius = 3;
  s.prim = (uint32_t(RecordKind::kSphere) << 30) | 4;
  std::memcpy(c.records.data() + kRecordBytes, &s, sizeof s);
  const FixedFormat f = format_preset("clusters");
  std::vector<uint8_t> out;
  CHECK_THROWS_AS(encode_cluster(c, f, out), std::logic_error);
  CHECK(encode_raw_unit(c.records.data(), 2, f, out) == 2);  // 8 + 80 bytes: two lines
  Cluster back;
  CHECK(decode_cluster_unit(out.data(), out.size(), f, back, "unit") == 2);
  CHECK(back.records == c.records);
  // A cluster of one triangle fills far less than its line: the line's last byte is padding, which must be zero.
  Cluster one;
  one.records.resize(kRecordBytes);
  TriangleRecord t{};
  t.v[1][0] = 5;
  std::memcpy(one.records.data(), &t, sizeof t);
  out.clear();
  REQUIRE(encode_cluster(one, f, out) == 1);
  out[kClusterLineBytes - 1] = 1;
  CHECK_THROWS_WITH(decode_cluster_unit(out.data(), out.size(), f, back, "unit"), "unit: padding not zero");
  CHECK_THROWS_WITH(decode_cluster_unit(out.data(), 16, f, back, "unit"), "unit: truncated");
}

TEST_CASE("cluster images decode to the tree and records of the struct layout", "[fixed][image][cluster]") {
  const Geometry mixed = random_scene(4511, 2500, 30);
  const Geometry mesh = strip_mesh(30, 40);
  for (const Geometry* g : {&mixed, &mesh})
    for (int kind : {0, 1})
      for (int width : {2, 4, 6, 8}) {
        // The struct layout's tree of this kind and width: the nodes every cluster layout must account for.
        FixedFormat s = format_preset("clusters");
        s.width = width;
        s.node_kind = kind;
        s.node_layout = 0;
        s.prim_layout = 0;
        s.node_align = 1;
        s.cluster_tris = 256;
        const uint64_t ref_nodes = encode(*g, s).header().node_count;
        for (int layout : {1, 2})
          for (int tris : {16, 100, 256}) {
            FixedFormat f = format_preset("clusters");
            f.width = width;
            f.node_kind = kind;
            f.node_layout = layout;
            f.cluster_tris = tris;
            CAPTURE(g == &mesh, kind, layout, width, tris);
            // encode_scene decodes the image and holds the decoding to the values encoded (a std::logic_error
            // otherwise); the bound copy is checked again.
            const DeviceImage img = encode(*g, f);
            const std::vector<uint8_t> b = bytes_of(img);
            REQUIRE(refusal(b).empty());
            const DeviceImage bound = DeviceImage::from_bytes(b.data(), b.size());
            CHECK(bound.node_total() == img.node_total());
            CHECK(bound.header().record_offset % kClusterLineBytes == 0);
            CHECK(clusters_with_nodes(bound) > 0);
            CHECK(bound.cluster_record_flags().size() == bound.header().record_count);
            // As many nodes in all as the struct layout's tree has: the clusters hold the rest.
            CHECK(bound.node_total() == ref_nodes);
            CHECK(bound.header().node_count < ref_nodes);
          }
      }
}

TEST_CASE("cluster images trace bit for bit as records and blocks over the same tree, timed as fixed",
          "[fixed][image][timed][cluster]") {
  const Geometry g = random_scene(4521, 3000, 40);
  const std::vector<Ray> rs = rays(4522, 3000);
  for (int width : {2, 4, 8})
    for (bool any : {false, true}) {
      FixedFormat base = format_preset("default");
      base.width = width;
      const DeviceImage ref = encode(g, base);
      std::vector<Hit> want(rs.size());
      TraversalStats ws;
      FixedTracer(ref).trace_batch(rs.data(), want.data(), rs.size(), any, 1, ws);
      for (const char* spec : {"packed", "clusters", "clusters:cluster_tris=32", "clusters:node_layout=2"}) {
        FixedFormat f = format_from_spec(spec);
        f.width = width;
        CAPTURE(width, any, spec);
        const std::vector<uint8_t> b = bytes_of(encode(g, f));
        const DeviceImage img = DeviceImage::from_bytes(b.data(), b.size());
        std::vector<Hit> got(rs.size());
        TraversalStats s;
        FixedTracer(img).trace_batch(rs.data(), got.data(), rs.size(), any, 1, s);
        CHECK(std::memcmp(got.data(), want.data(), rs.size() * sizeof(Hit)) == 0);
        CHECK(s.nodes_visited == ws.nodes_visited);
        CHECK(s.box_tests == ws.box_tests);
        CHECK(s.prim_tests == ws.prim_tests);
        if (any) continue;
        for (int rate : {0, 4}) {
          TimingConfig c = timing_preset("rdna2");
          c.bvh_width = width;
          c.cluster_tri_rate = rate;
          std::vector<Hit> th;
          TimingStats t;
          trace_timed(c, b, rs, 2, th, &t);
          CHECK(std::memcmp(th.data(), got.data(), rs.size() * sizeof(Hit)) == 0);
          const bool clusters = f.prim_layout == 2 && rate > 0;
          CHECK((t.cluster_tri_tests > 0) == clusters);
          CHECK((t.cluster_box_tests > 0) == clusters);
          // Every test is made once, by the units or by the cluster engine.
          CHECK(t.box_tests + t.cluster_box_tests == s.box_tests);
          CHECK(t.tri_tests + t.sphere_tests + t.plane_tests + t.cluster_tri_tests == s.prim_tests);
        }
      }
    }
}

TEST_CASE("malformed clusters are refused naming the field, and no bit flip crashes",
          "[fixed][image][limits][cluster]") {
  const Geometry g = strip_mesh(20, 20);
  const DeviceImage img = encode(g, format_preset("clusters"));
  const ImageHeader& h = img.header();
  REQUIRE(clusters_with_nodes(img) > 0);
  const std::vector<uint8_t> good = bytes_of(img);
  REQUIRE(refusal(good).empty());
  // The first unit with internal nodes, decoded, changed and encoded again in its place.
  const FixedFormat f = img.format();
  uint64_t at = 0;
  Cluster c;
  for (;;) {
    const uint32_t lines =
        decode_cluster_unit(good.data() + h.record_offset + at, h.record_bytes - at, f, c, "cluster");
    if (!c.nodes.empty()) break;
    at += lines * kClusterLineBytes;
    REQUIRE(at < h.record_bytes);
  }
  auto changed = [&](auto change) {
    Cluster d = c;
    change(d);
    std::vector<uint8_t> out;
    REQUIRE(encode_cluster(d, f, out) > 0);
    std::vector<uint8_t> b = good;
    REQUIRE(at + out.size() <= h.record_bytes);
    std::memset(b.data() + h.record_offset + at, 0, out.size());
    std::memcpy(b.data() + h.record_offset + at, out.data(), out.size());
    return b;
  };
  const std::string where = "scene image: cluster at byte " + std::to_string(at) + " of the primitive section";
  CHECK(contains(refusal(changed([](Cluster& d) { d.nodes[0].exp[0] = 31; })), "scale out of range"));
  // A leaf one triangle larger than the records hold (the count field says otherwise).
  CHECK(contains(refusal(changed([](Cluster& d) {
                   for (PackedNode& n : d.nodes)
                     for (int i = 0; i < n.count; ++i)
                       if (n.leaf[i] && n.group[i] < 16) {
                         ++n.group[i];
                         return;
                       }
                 })),
                 "its leaves hold"));
  // Raw bit edits of the header fields (the bit offsets of cluster_layout.h).
  auto bits_changed = [&](int from, int bits, uint64_t value) {
    std::vector<uint8_t> b = good;
    uint8_t* p = b.data() + h.record_offset + at;
    for (int i = 0; i < bits; ++i) {
      const int q = from + i;
      p[q / 8] = uint8_t((p[q / 8] & ~(1u << (q % 8))) | (((value >> i) & 1u) << (q % 8)));
    }
    return b;
  };
  // Internal nodes (bits 9..16): one more than the cluster has, none while it holds more than 16 triangles.
  CHECK(contains(refusal(bits_changed(9, 8, c.nodes.size() + 1)), where));
  if (c.records.size() / kRecordBytes > 16)
    CHECK(contains(refusal(bits_changed(9, 8, 0)), "without internal nodes of more than 16 triangles"));
  // Vertices - 1 (bits 17..26): more than three per triangle.
  CHECK(contains(refusal(bits_changed(17, 10, 1023)), "more vertices than its triangles have"));
  // Bits per axis (27..44): wider than the anchor's field.
  CHECK(contains(refusal(bits_changed(27, 6, 63)), "vertex offsets wider than the anchor's field"));
  // A section not on a line.
  {
    std::vector<uint8_t> b = good;
    ImageHeader hh = h;
    hh.record_bytes -= 8;
    std::memcpy(b.data(), &hh, sizeof hh);
    CHECK(contains(refusal(b), "not on a 64-byte line"));
  }
  // Single-bit flips anywhere past the header are refused or trace inside the image.
  const uint64_t seed = 4531;
  INFO("seed " << seed);
  Pcg32 rng(seed);
  const std::vector<Ray> rs = rays(4532, 40);
  size_t refused = 0;
  for (int i = 0; i < 600; ++i) {
    std::vector<uint8_t> b = good;
    const size_t pos = h.node_offset + size_t(rng.next_u32() % (h.total_bytes - h.node_offset));
    b[pos] ^= uint8_t(1u << (rng.next_u32() % 8));
    try {
      const DeviceImage bad = DeviceImage::from_bytes(b.data(), b.size());
      std::vector<Hit> hits(rs.size());
      TraversalStats s;
      FixedTracer(bad).trace_batch(rs.data(), hits.data(), rs.size(), false, 1, s);
      CHECK(s.watchdog_rays == 0);
    } catch (const std::invalid_argument&) {
      ++refused;
    }
  }
  CHECK(refused > 0);
}

TEST_CASE("the cluster engine: one ray's cycles by hand, engine on and off", "[timing][cluster]") {
  // A top node (line 0), then a cluster whose root (node 1) carries its one line at record_offset, an internal
  // node 2 that fetches nothing, and four triangles of it: a leaf of three (records 0..2) and a leaf of one.
  TimingModel::Layout l;
  l.node_offset = 0;
  l.node_bytes = 64;
  l.record_offset = 1 << 20;
  l.plane_offset = 2 << 20;
  l.record_spans.assign(4, DeviceImage::Span{0, 0});
  l.cluster_node_begin = 1;
  l.cluster_node_spans = {DeviceImage::Span{1 << 20, 64}, DeviceImage::Span{0, 0}};
  const uint8_t in = DeviceImage::kRecordInCluster, start = DeviceImage::kRecordLeafStart;
  l.cluster_record_flags = {uint8_t(in | start), in, in, uint8_t(in | start)};
  auto tri = [](uint32_t r) { return TraceEvent{TraceEvent::kPrim, uint8_t(RecordKind::kTriangle), 0, 0, r}; };
  const std::vector<TraceEvent> ray = {TraceEvent{TraceEvent::kNode, 4, 0, 0, 0},
                                       TraceEvent{TraceEvent::kNode, 2, 0, 0, 1},
                                       TraceEvent{TraceEvent::kNode, 2, 0, 0, 2},
                                       tri(0),
                                       tri(1),
                                       tri(2),
                                       tri(3)};
  for (int rate : {0, 2}) {
    TimingConfig c = test_config();
    c.cluster_tri_rate = rate;
    TimingModel m(c, l);
    TimingStats s;
    std::vector<std::vector<TraceEvent>> rays = {ray};
    m.begin(1, s);
    m.feed(rays.data(), 1);
    const uint64_t cycles = m.finish();
    const uint64_t miss = uint64_t(c.cache_latency) + 8 + uint64_t(c.dram_latency);  // one 64-byte line
    const uint64_t box = uint64_t(c.box_latency) + uint64_t(c.traversal_latency);
    const uint64_t tri_test = uint64_t(c.tri_latency) + uint64_t(c.traversal_latency);
    const uint64_t into = uint64_t(c.packet_latency + c.ray_fetch_latency + c.setup_latency);
    // Both ways: the top node and the cluster's root each a line from DRAM; node 2 nothing. The cluster engine
    // (rate 2) tests the leaf of three in one request of two issue clocks and the leaf of one in another; the
    // triangle unit tests the four one after another.
    const uint64_t tris = rate ? (tri_test + 1) + tri_test : 4 * tri_test;
    CAPTURE(rate);
    CHECK(cycles == into + (miss + box) + (miss + box) + box + tris + uint64_t(c.writeback_latency));
    CHECK(s.cache_misses == 2);
    CHECK(s.box_tests == (rate ? 4u : 8u));
    CHECK(s.tri_tests == (rate ? 0u : 4u));
    CHECK(s.cluster_box_tests == (rate ? 4u : 0u));
    CHECK(s.cluster_tri_tests == (rate ? 4u : 0u));
    CHECK(s.cluster_requests == (rate ? 4u : 0u));
  }
}
