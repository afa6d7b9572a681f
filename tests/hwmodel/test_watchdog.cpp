// The watchdog and the scene-image limits, through the command processor as the firmware sees them:
// - timed device: a ray that stays in its ray slot longer than watchdog_cycles stops the TRACE with kWatchdog and
//   a dump of the unit's state; the limit is exact (a ray of residency R passes at R and fires at R - 1); 0 is
//   off;
// - fixed and timed devices: a traversal longer than the step bound stops the TRACE with kWatchdog; the automatic
//   bound stops a corrupted image with shared subtrees (exponential work) that bypassed DeviceImage::from_bytes;
// - from_bytes refuses a BVH with a shared subtree (a DAG) and one deeper than the traversal stack (kBadScene).
#include <catch2/catch.hpp>

#include <cstring>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/datapath/traverse.h"
#include "hwmodel/device/command_processor.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/scene/bvh.h"
#include "hwmodel/timing/timing_config.h"
#include "tests/common/test_util.h"

using namespace rtu;
using namespace rtu::hw;
using reg::ErrorCode;

using rtu::test::contains;

namespace {

// 200 small random triangles in the unit cube: a BVH of many levels at width 2 and leaf size 1.
Geometry soup(int n = 200, uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f), d(-0.05f, 0.05f);
  Geometry g;
  for (int i = 0; i < n; ++i) {
    const Vec3 c(u(rng), u(rng), u(rng));
    g.triangles.push_back({c, c + Vec3(d(rng), d(rng), d(rng)), c + Vec3(d(rng), d(rng), d(rng))});
  }
  return g;
}

DeviceImage soup_image(const Geometry& g, int width = 2) {
  TracerOptions opt;
  opt.accel = AccelMode::kBvh;
  opt.bvh.width = width;
  opt.bvh.max_leaf_size = 1;
  const std::optional<Bvh> bvh = choose_accel(g, opt);
  REQUIRE(bvh);
  FixedFormat f = format_preset(width == 2 ? "binary" : "default");
  return encode_scene(g, f, &*bvh);
}

std::vector<Ray> rays_at_cube(size_t n, uint32_t seed = 3) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-0.5f, 1.5f);
  std::vector<Ray> rays;
  for (size_t i = 0; i < n; ++i) {
    const Vec3 o(u(rng), u(rng), 3.0f);
    rays.push_back(Ray{o, 0.0f, Vec3(0.5f) - o, 1e30f});
  }
  return rays;
}

// A 1 MiB unit driven through its registers and a 16-slot ring, as the firmware would.
constexpr uint64_t kImageAt = 4096, kRaysAt = 512 << 10, kHitsAt = 768 << 10, kFenceAt = 1000 << 10;
struct Rig {
  DeviceMemory mem{1 << 20};
  std::unique_ptr<TraceEngine> engine;
  std::unique_ptr<CommandProcessor> cp;
  uint32_t tail = 0;

  explicit Rig(std::unique_ptr<TraceEngine> e) : engine(std::move(e)), cp(new CommandProcessor(mem, *engine)) {
    cp->write(reg::kRingBaseLo, 0);
    cp->write(reg::kRingBaseHi, 0);
    cp->write(reg::kRingSize, 16);
    cp->write(reg::kControl, reg::kCtrlEnable);
  }
  void submit(const cmd::Packet& p) {
    mem.write(uint64_t(tail) * 32, &p, sizeof p);
    tail = (tail + 1) % 16;
    cp->write(reg::kRingTail, tail);
  }
  // BIND the image, TRACE the rays, FENCE 7: returns the hits buffer.
  std::vector<Hit> run(const uint8_t* image, size_t bytes, const std::vector<Ray>& rays) {
    mem.write(kImageAt, image, bytes);
    mem.write(kRaysAt, rays.data(), rays.size() * sizeof(Ray));
    std::vector<Hit> sentinel(rays.size(), Hit{-1.0f, 12345u, -1.0f, -1.0f});
    mem.write(kHitsAt, sentinel.data(), sentinel.size() * sizeof(Hit));
    submit(cmd::bind_scene(kImageAt, bytes));
    submit(cmd::trace(kRaysAt, kHitsAt, uint32_t(rays.size()), false, cmd::RayType::kPrimary, 0));
    submit(cmd::fence(kFenceAt, 7, false));
    std::vector<Hit> hits(rays.size());
    mem.read(kHitsAt, hits.data(), hits.size() * sizeof(Hit));
    return hits;
  }
};

std::unique_ptr<TraceEngine> timed(int watchdog_cycles, uint64_t max_steps = 0) {
  TimingConfig c = timing_preset("rdna2");
  c.format = "binary";
  c.bvh_width = 2;
  c.watchdog_cycles = watchdog_cycles;
  EngineOptions o;
  o.max_steps = max_steps;
  return make_timed_engine(o, c);
}

}  // namespace

TEST_CASE("timed watchdog: a ray longer in its slot than watchdog_cycles stops the TRACE with a state dump",
          "[watchdog]") {
  const Geometry g = soup();
  const DeviceImage img = soup_image(g);
  const std::vector<Ray> rays = rays_at_cube(500);

  // The reference: fixed engine, and the timed engine with the watchdog off and at its default.
  Rig ref(make_fixed_engine({}));
  const std::vector<Hit> want = ref.run(img.data(), img.size(), rays);
  REQUIRE(ref.cp->error() == ErrorCode::kNone);
  for (int wd : {0, TimingConfig{}.watchdog_cycles}) {
    Rig ok(timed(wd));
    const std::vector<Hit> got = ok.run(img.data(), img.size(), rays);
    CHECK(ok.cp->error() == ErrorCode::kNone);
    CHECK(std::memcmp(got.data(), want.data(), want.size() * sizeof(Hit)) == 0);
    CHECK(ok.mem.load<uint64_t>(kFenceAt) == 7);
  }

  // 100 cycles: less than a DRAM miss (200), so the first ray cannot finish.
  Rig rig(timed(100));
  const std::vector<Hit> got = rig.run(img.data(), img.size(), rays);
  CHECK(rig.cp->error() == ErrorCode::kWatchdog);
  CHECK(rig.cp->read(reg::kErrorCode) == uint32_t(ErrorCode::kWatchdog));
  CHECK(rig.cp->read(reg::kErrorInfo) == 1);  // the TRACE's ring slot
  CHECK((rig.cp->read(reg::kStatus) & reg::kStatusError) != 0);
  CHECK((rig.cp->read(reg::kIrqStatus) & reg::kIrqError) != 0);
  CHECK(rig.cp->read(reg::kRingHead) == 1);  // stopped on the TRACE; the FENCE was not run
  CHECK(rig.mem.load<uint64_t>(kFenceAt) == 0);
  for (const Hit& h : got) REQUIRE(h.prim == 12345u);  // no hit of the stopped TRACE is written
  const std::string& dump = rig.cp->error_detail();
  INFO(dump);
  CHECK(contains(dump, "timed device watchdog: ray 0 of 500 has been in ray slot 0"));
  CHECK(contains(dump, "watchdog_cycles = 100"));
  CHECK(contains(dump, "unit state at cycle"));
  CHECK(contains(dump, "ray slots: 32 busy of 32"));
  CHECK(contains(dump, "slot 31: ray 31"));
  CHECK(contains(dump, "ray prefetch queue"));
  CHECK(contains(dump, "box units"));
  CHECK(contains(dump, "cache hits"));
  // The device clock advanced to the cycle the watchdog fired (packet decode + bind, then the TRACE's part).
  const uint64_t clock = rig.cp->read(reg::kClockLo);
  CHECK(clock > 100);
  CHECK(clock < 400);

  // Reset clears the error and its dump; the same unit then runs the same work once the limit allows it.
  rig.cp->write(reg::kControl, reg::kCtrlReset);
  CHECK(rig.cp->error() == ErrorCode::kNone);
  CHECK(rig.cp->error_detail().empty());
}

TEST_CASE("timed watchdog: the limit is exact for a single ray", "[watchdog]") {
  const DeviceImage img = soup_image(soup());
  const std::vector<Ray> one = rays_at_cube(1);
  TimingConfig c = timing_preset("rdna2");
  c.format = "binary";
  c.bvh_width = 2;
  c.watchdog_cycles = 0;
  TimedEngine probe({}, c);
  probe.bind(img.data(), img.size());
  Hit h;
  TraversalStats s;
  probe.trace_cycles(one.data(), &h, 1, false, s, 0, 0);
  const uint64_t residency = probe.timing().slot_busy_cycles;  // entering the slot to leaving it
  REQUIRE(residency > 200);
  for (const uint64_t wd : {residency, residency + 1}) {
    c.watchdog_cycles = int(wd);
    TimedEngine e({}, c);
    e.bind(img.data(), img.size());
    Hit h2;
    TraversalStats s2;
    CHECK_NOTHROW(e.trace_cycles(one.data(), &h2, 1, false, s2, 0, 0));
    CHECK(std::memcmp(&h, &h2, sizeof h) == 0);
  }
  c.watchdog_cycles = int(residency - 1);
  TimedEngine e({}, c);
  e.bind(img.data(), img.size());
  Hit h3;
  TraversalStats s3;
  try {
    e.trace_cycles(one.data(), &h3, 1, false, s3, 0, 0);
    FAIL("the watchdog did not fire at residency - 1");
  } catch (const WatchdogError& w) {
    INFO(w.what());
    CHECK(contains(w.what(), "ray 0 of 1 has been in ray slot 0"));
    CHECK(w.cycles() > residency - 1);
  }
  // The engine is usable after the error: a fresh packet runs (with a fresh cache) and gives the same hit.
  c.watchdog_cycles = 0;
  Hit h4;
  TraversalStats s4;
  TimedEngine again({}, c);
  again.bind(img.data(), img.size());
  again.trace_cycles(one.data(), &h4, 1, false, s4, 0, 0);
  CHECK(std::memcmp(&h, &h4, sizeof h) == 0);
}

TEST_CASE("traversal watchdog: a step bound stops fixed and timed TRACEs with kWatchdog", "[watchdog]") {
  const DeviceImage img = soup_image(soup());
  const std::vector<Ray> rays = rays_at_cube(64);
  for (const char* which : {"fixed", "timed"}) {
    INFO(which);
    EngineOptions o;
    o.max_steps = 2;
    Rig rig(std::string(which) == "fixed" ? make_fixed_engine(o) : timed(0, 2));
    const std::vector<Hit> got = rig.run(img.data(), img.size(), rays);
    CHECK(rig.cp->error() == ErrorCode::kWatchdog);
    CHECK(rig.cp->read(reg::kErrorInfo) == 1);
    for (const Hit& h : got) REQUIRE(h.prim == 12345u);
    INFO(rig.cp->error_detail());
    CHECK(contains(rig.cp->error_detail(), "traversal watchdog: ray "));
    CHECK(contains(rig.cp->error_detail(), "exceeded the step bound of 2 node and leaf visits"));
  }
  // The automatic bound never fires on a valid image: the same rays, no error.
  Rig ok(make_fixed_engine({}));
  ok.run(img.data(), img.size(), rays);
  CHECK(ok.cp->error() == ErrorCode::kNone);
}

TEST_CASE("traversal watchdog in a later chunk: the same error whether chunks are recorded ahead or not",
          "[watchdog]") {
  // 4100 rays that miss the scene (one node visit each), then rays into it: the bound of 2 visits is first
  // exceeded in the second chunk of 4096 rays, which the timed engine records in the background while it
  // replays the first when it has more than one thread.
  const DeviceImage img = soup_image(soup());
  std::vector<Ray> rays(4100, Ray{Vec3(5.0f), 0.0f, Vec3(1.0f), 1e30f});
  const std::vector<Ray> into = rays_at_cube(4000);
  rays.insert(rays.end(), into.begin(), into.end());
  std::string dump[2];
  for (int threads : {1, 2}) {
    INFO(threads);
    TimingConfig c = timing_preset("rdna2");
    c.format = "binary";
    c.bvh_width = 2;
    EngineOptions o;
    o.max_steps = 2;
    o.threads = threads;
    Rig rig(make_timed_engine(o, c));
    const std::vector<Hit> got = rig.run(img.data(), img.size(), rays);
    CHECK(rig.cp->error() == ErrorCode::kWatchdog);
    for (const Hit& h : got) REQUIRE(h.prim == 12345u);
    dump[threads - 1] = rig.cp->error_detail();
    CHECK(contains(dump[threads - 1], "exceeded the step bound of 2 node and leaf visits"));
  }
  CHECK(dump[0] == dump[1]);
}

namespace {

// Node i's children: every slot but the last points to node i + 1 (shared), the last to a leaf.
template <int N>
void make_dag(uint8_t* image, uint32_t nodes) {
  auto* h = reinterpret_cast<ImageHeader*>(image);
  using Node = QNode<N, uint8_t>;
  REQUIRE(h->node_count >= nodes);
  Node* nd = reinterpret_cast<Node*>(image + h->node_offset);
  for (uint32_t i = 0; i + 1 < nodes; ++i) {
    Node& n = nd[i];
    n.count = N;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < N; ++c) n.q[r][c] = r % 2 ? 255 : 0;  // every child box: the node's whole box
    for (int a = 0; a < 3; ++a) {
      n.origin[a] = 0;
      n.exp[a] = int8_t(h->coord_bits - 8 + 1);  // 255 << exp covers the grid
    }
    for (int c = 0; c < N - 1; ++c) n.child[c] = i + 1;
    n.child[N - 1] = make_leaf(0, 1);
  }
  nd[nodes - 1] = nd[nodes - 2];
  for (int c = 0; c < N; ++c) nd[nodes - 1].child[c] = make_leaf(0, 1);
}

}  // namespace

TEST_CASE("from_bytes refuses shared subtrees, the automatic step bound stops them anyway", "[watchdog]") {
  const DeviceImage good = soup_image(soup(), 4);
  REQUIRE(good.header().node_count >= 20);
  std::vector<uint64_t> words(good.size() / 8);
  std::memcpy(words.data(), good.data(), good.size());
  auto* bytes = reinterpret_cast<uint8_t*>(words.data());
  make_dag<4>(bytes, 20);  // 3^19 paths to the last node: a billion leaf visits per ray
  try {
    DeviceImage::from_bytes(bytes, good.size());
    FAIL("a DAG was accepted");
  } catch (const std::invalid_argument& e) {
    CHECK(contains(e.what(), "node 0: child node 1 has a second parent (the BVH must be a tree)"));
  }
  // Through the command processor: kBadScene, and the reason in the error detail.
  Rig rig(make_fixed_engine({}));
  rig.run(bytes, good.size(), rays_at_cube(4));
  CHECK(rig.cp->error() == ErrorCode::kBadScene);
  CHECK(rig.cp->read(reg::kErrorInfo) == 0);
  CHECK(contains(rig.cp->error_detail(), "second parent"));

  // Defence in depth: the same DAG behind from_bytes' back (the image's bytes changed after encoding) is stopped
  // by the automatic step bound (node_count * width + 1 visits) instead of running for ever.
  DeviceImage img = soup_image(soup(), 4);
  make_dag<4>(const_cast<uint8_t*>(img.data()), 20);
  FixedTracer t(img);
  CHECK(t.step_limit() == uint64_t(img.header().node_count) * 4 + 1);
  const std::vector<Ray> rays = rays_at_cube(8);
  std::vector<Hit> hits(rays.size());
  TraversalStats s;
  t.trace_batch(rays.data(), hits.data(), rays.size(), false, 1, s);
  CHECK(s.watchdog_rays > 0);
  CHECK(s.nodes_visited + s.leaves_visited <= rays.size() * (t.step_limit() + 1));
  CHECK(contains(t.watchdog_report(rays.data(), rays.size(), false, s.watchdog_rays), "exceeded the step bound"));
}

TEST_CASE("from_bytes refuses a BVH deeper than the traversal stack", "[watchdog][limits]") {
  // A chain of width-2 nodes: node i holds node i + 1 and a leaf. The stack holds kTraversalStackSize entries,
  // one per level at width 2, so a chain of that many levels must be refused and a shorter one accepted.
  const DeviceImage base = soup_image(soup(3), 2);
  auto chain = [&](uint32_t levels) {
    const ImageHeader& h0 = base.header();
    using Node = QNode<2, uint8_t>;
    ImageHeader h = h0;
    h.node_count = levels;
    h.node_offset = sizeof(ImageHeader);
    h.record_offset = (h.node_offset + uint64_t(levels) * sizeof(Node) + 7) / 8 * 8;
    h.plane_offset = h.record_offset + base.records_size();
    h.total_bytes = h.plane_offset + base.planes_size();
    std::vector<uint64_t> words(h.total_bytes / 8, 0);
    auto* p = reinterpret_cast<uint8_t*>(words.data());
    std::memcpy(p, &h, sizeof h);
    Node n{};
    n.count = 2;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 2; ++c) n.q[r][c] = r % 2 ? 255 : 0;
    for (int a = 0; a < 3; ++a) n.exp[a] = int8_t(h.coord_bits - 8 + 1);
    for (uint32_t i = 0; i < levels; ++i) {
      n.child[0] = i + 1 < levels ? i + 1 : make_leaf(0, 1);
      n.child[1] = make_leaf(1, 1);
      std::memcpy(p + h.node_offset + uint64_t(i) * sizeof(Node), &n, sizeof n);
    }
    std::memcpy(p + h.record_offset, base.data() + h0.record_offset, base.records_size());
    return words;
  };
  const std::vector<uint64_t> ok = chain(kTraversalStackSize - 1);
  const DeviceImage deep_ok = DeviceImage::from_bytes(reinterpret_cast<const uint8_t*>(ok.data()), ok.size() * 8);
  // It traces: every ray walks the whole chain without overflowing the stack.
  FixedTracer t(deep_ok);
  const Aabb b = soup(3).bounds();
  const Vec3 c = 0.5f * (b.lo + b.hi);
  std::vector<Ray> rays;
  for (int i = 0; i < 4; ++i) {
    const Vec3 o(c.x + 0.01f * float(i), c.y, c.z + 3.0f);
    rays.push_back(Ray{o, 0.0f, c - o, 1e30f});
  }
  std::vector<Hit> hits(rays.size());
  TraversalStats s;
  t.trace_batch(rays.data(), hits.data(), rays.size(), false, 1, s);
  CHECK(s.watchdog_rays == 0);
  CHECK(s.nodes_visited == rays.size() * uint64_t(kTraversalStackSize - 1));
  const std::vector<uint64_t> deep = chain(kTraversalStackSize);
  try {
    DeviceImage::from_bytes(reinterpret_cast<const uint8_t*>(deep.data()), deep.size() * 8);
    FAIL("a chain deeper than the stack was accepted");
  } catch (const std::invalid_argument& e) {
    CHECK(contains(e.what(), "too deep"));
  }
}
