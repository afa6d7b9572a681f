// Fuzzing the unit's untrusted inputs:
// - the command processor (hwmodel/device/command_processor.cpp): >= 100000 random packets, valid and malformed
// (random
//   opcodes, addresses near the end of memory and past it, random counts, flags and reserved fields, overlapping
//   buffers), rung through the ring of a 1 MiB model device with a tiny scene bound, mixed with random writes to
//   every register offset (reset included) and random reads. Checked after every step: the error code is a defined
//   one and shows in the status, an enabled ring's head is inside it, a doorbell either consumes everything or
//   stops on the packet named by the error info, the errors counted by the device are the ones seen; at the end,
//   the same seed gives the same memory and counters (and another seed does not);
// - DeviceImage::from_bytes: >= 20000 corruptions of a valid image (bit flips, header fields, truncations, node
//   and record bytes): each either throws std::invalid_argument or gives an image FixedTracer traces rays over,
//   with every hit naming a primitive of the image.
// The sanitizer build runs the same cases: no read or write outside memory goes unnoticed there.
// The seed is printed on failure; RTU_FUZZ_SEED overrides it.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "host/devices/firmware_device.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/device/command_processor.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/interface/regs.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/scene/bvh.h"

using namespace rtu;
namespace cmd = hw::cmd;
namespace reg = hw::reg;
using reg::ErrorCode;

namespace {

uint64_t fuzz_seed(uint64_t fallback) {
  if (const char* s = std::getenv("RTU_FUZZ_SEED")) return std::strtoull(s, nullptr, 0);
  return fallback;
}

uint64_t fnv1a(const uint8_t* p, size_t n, uint64_t h = 0xcbf29ce484222325ull) {
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
  return h;
}
template <class T>
uint64_t fnv1a_of(const T& v, uint64_t h) {
  return fnv1a(reinterpret_cast<const uint8_t*>(&v), sizeof v, h);
}

// Catch2's CHECK on every step would record millions of assertions; report only failures.
#define CHECK_SILENT(cond)                    \
  do {                                        \
    if (!(cond)) {                            \
      FAIL_CHECK("invariant broken: " #cond); \
    }                                         \
  } while (0)

constexpr uint32_t kLastErrorCode = uint32_t(ErrorCode::kBadRegister);

// A tiny scene with every primitive kind: an icosahedron (20 triangles), two spheres, a plane.
hw::Geometry tiny_geometry() {
  hw::Geometry g = host::load_scene("builtin:icosphere?subdiv=0").geometry;
  g.spheres = {{hw::Vec3(1.5f, 0.0f, 0.0f), 0.5f}, {hw::Vec3(-1.0f, 1.0f, 0.5f), 0.25f}};
  g.planes = {{hw::Vec3(0.0f, 1.0f, 0.0f), 1.5f}};
  return g;
}

// The scene image of `engine` for g, as 8-byte words.
std::vector<uint64_t> scene_image(const std::string& engine, const hw::Geometry& g) {
  if (engine == "float") return hw::encode_float_scene(g);
  hw::TracerOptions opt;
  const hw::FixedFormat format;
  opt.bvh.width = format.width;
  const std::optional<hw::Bvh> bvh = hw::choose_accel(g, opt);
  const hw::DeviceImage img = hw::encode_scene(g, format, bvh ? &*bvh : nullptr);
  std::vector<uint64_t> words(img.size() / 8);
  std::memcpy(words.data(), img.data(), img.size());
  return words;
}

// Device memory map of the fuzzed device.
constexpr uint64_t kMem = 1 << 20;
constexpr uint64_t kRingArea = 64 << 10;  // [0, 64 KiB): rings
constexpr uint64_t kImageAt = 64 << 10;   // the scene image
constexpr uint64_t kRaysAt = 128 << 10;   // [128 KiB, 512 KiB): rays, written once, overwritten by stray hits
constexpr uint64_t kRaysEnd = 512 << 10;
constexpr uint64_t kHitsAt = 512 << 10;  // [512 KiB, 1 MiB): hits, fences, timestamps
constexpr uint32_t kMaxCount = 300;

struct FuzzResult {
  uint64_t mem_hash = 0;
  uint64_t counters_hash = 0;
  uint64_t packets_rung = 0;     // packets written into ring slots and made visible by a doorbell
  uint64_t packets_run = 0;      // packets the device consumed
  uint64_t register_writes = 0;  // random register writes
  uint64_t resets = 0;           // random kCtrlReset writes and driver restarts
  uint64_t rays = 0;             // rays traced
  std::array<uint64_t, kLastErrorCode + 1> errors{};  // errors raised, by code
};

class CpFuzzer {
 public:
  CpFuzzer(const std::string& engine, const std::vector<uint64_t>& image, uint64_t seed)
      : m_dev(rtu::hw::parse_device_kind(engine), kMem),
        m_rng(seed),
        m_image(image),
        m_image_bytes(image.size() * 8) {
    REQUIRE(kImageAt + m_image_bytes <= kRaysAt);
    std::memcpy(m_dev.mem() + kImageAt, image.data(), m_image_bytes);
    // Rays through the scene's neighbourhood (stray hits turn some into garbage later: fuzzing too).
    hw::Aabb box = tiny_geometry().bounds();
    box.lo = box.lo - hw::Vec3(1.0f);
    box.hi = box.hi + hw::Vec3(1.0f);
    const std::vector<hw::Ray> rays = host::incoherent_rays(box, (kRaysEnd - kRaysAt) / 32, seed);
    std::memcpy(m_dev.mem() + kRaysAt, rays.data(), rays.size() * 32);
  }

  FuzzResult run(uint64_t packets) {
    restart();
    while (m_res.packets_rung < packets) step();
    const hw::DeviceCounters& c = m_dev.processor().counters();
    m_res.packets_run = c.packets;
    for (uint64_t n : c.rays_by_type) m_res.rays += n;
    m_res.mem_hash = fnv1a(m_dev.mem(), kMem);
    uint64_t h = fnv1a_of(c.packets, 0xcbf29ce484222325ull);
    h = fnv1a_of(c.by_opcode, h);
    h = fnv1a_of(c.rays_by_type, h);
    h = fnv1a_of(c.any_hit_rays, h);
    h = fnv1a_of(c.max_bounce, h);
    h = fnv1a_of(c.errors, h);
    h = fnv1a_of(c.irqs, h);
    const hw::TraversalStats t = c.total();
    for (uint64_t v :
         {t.rays, t.hits, t.nodes_visited, t.leaves_visited, t.box_tests, t.prim_tests, t.invalid_rays})
      h = fnv1a_of(v, h);
    for (uint32_t off = 0; off < reg::kWindowBytes; off += 4) h = fnv1a_of(m_dev.read32(off), h);
    m_res.counters_hash = h;
    // Every error the device counted is one this fuzzer saw appear, and the other way round.
    uint64_t seen = 0;
    for (uint64_t n : m_res.errors) seen += n;
    CHECK(c.errors == seen);
    return m_res;
  }

 private:
  uint32_t u32() { return uint32_t(m_rng()); }
  uint64_t u64() { return m_rng(); }
  uint64_t below(uint64_t n) { return m_rng() % n; }
  bool chance(uint32_t percent) { return below(100) < percent; }
  uint32_t rd(uint32_t off) { return m_dev.read32(off); }
  // Every write goes through here: one write raises at most one error (the first is kept until reset).
  void wr(uint32_t off, uint32_t v) {
    const ErrorCode before = m_dev.processor().error();
    m_dev.write32(off, v);
    const ErrorCode after = m_dev.processor().error();
    if (before == ErrorCode::kNone && after != ErrorCode::kNone) {
      const uint32_t code = uint32_t(after);
      CHECK_SILENT(code >= 1 && code <= kLastErrorCode);
      ++m_res.errors[code <= kLastErrorCode ? code : 0];
      CHECK_SILENT((rd(reg::kIrqStatus) & reg::kIrqError) != 0);
      CHECK_SILENT(m_dev.processor().irq_line() == ((rd(reg::kIrqStatus) & rd(reg::kIrqEnable)) != 0));
      // A register write that faults names itself; a doorbell that faults on a packet names the packet's slot.
      if (off == reg::kRingTail && after != ErrorCode::kRingMisuse)
        CHECK_SILENT(rd(reg::kErrorInfo) == rd(reg::kRingHead));
      else
        CHECK_SILENT(rd(reg::kErrorInfo) == off);
    }
    const bool reset =
        off == reg::kControl && (v & reg::kCtrlReset) && !(v & ~(reg::kCtrlReset | reg::kCtrlEnable));
    if (reset) CHECK_SILENT(after == ErrorCode::kNone);
    if (before != ErrorCode::kNone && !reset) CHECK_SILENT(after == before);  // the first error is kept
  }

  // What the firmware does after an error: reset, a ring (usually valid, at a random place and size; sometimes
  // not), enable, and (usually) bind the scene.
  void restart() {
    ++m_res.resets;
    wr(reg::kControl, reg::kCtrlReset);
    CHECK_SILENT(rd(reg::kStatus) == reg::kStatusIdle);
    // A fresh copy of the image: stray writes may have landed on it (binding what they left is fuzzing too).
    if (chance(90)) std::memcpy(m_dev.mem() + kImageAt, m_image.data(), m_image_bytes);
    uint32_t size = 2u << below(10);  // 2 .. 1024 slots
    uint64_t base = 32 * below((kRingArea - uint64_t(size) * 32) / 32 + 1);
    const bool valid = chance(85);
    if (!valid) {
      switch (below(4)) {
        case 0:
          size = below(2) ? u32() : uint32_t(below(9));
          break;
        case 1:
          base += 1 + below(31);
          break;
        case 2:
          base = kMem - 32 * below(size);
          break;
        default:
          base = u64() & ~uint64_t(31);
          break;
      }
    }
    wr(reg::kRingBaseLo, uint32_t(base));
    wr(reg::kRingBaseHi, uint32_t(base >> 32));
    wr(reg::kRingSize, size);
    wr(reg::kIrqEnable, chance(90) ? reg::kIrqFence | reg::kIrqError : u32());
    wr(reg::kControl, reg::kCtrlEnable);
    if (valid) CHECK_SILENT(rd(reg::kStatus) == (reg::kStatusEnabled | reg::kStatusIdle));
    if (chance(90)) put_packets({cmd::bind_scene(kImageAt, m_image_bytes)});
  }

  cmd::Packet valid_packet() {
    const uint64_t k = below(100);
    if (k < 10) return cmd::nop();
    if (k < 55) {
      const uint32_t n = 1 + uint32_t(chance(80) ? below(16) : below(kMaxCount));
      const uint64_t rays = kRaysAt + 32 * below((kRaysEnd - kRaysAt) / 32 - n + 1);
      if (chance(20)) {  // all hits: a list of k + 1 records a ray
        const uint32_t k = uint32_t(below(5));
        const uint64_t lists = kHitsAt + 16 * below((kMem - kHitsAt) / 16 - uint64_t(n) * (k + 1) + 1);
        return cmd::trace_all_hits(rays, lists, n, k, cmd::RayType(below(cmd::kRayTypeCount)), uint8_t(below(8)));
      }
      const uint64_t hits = kHitsAt + 16 * below((kMem - kHitsAt) / 16 - n + 1);
      return cmd::trace(rays, hits, n, chance(30), cmd::RayType(below(cmd::kRayTypeCount)), uint8_t(below(8)));
    }
    if (k < 75) return cmd::fence(kHitsAt + 8 * below((kMem - kHitsAt) / 8), u64(), chance(50));
    if (k < 95) return cmd::timestamp(kHitsAt + 8 * below((kMem - kHitsAt) / 8));
    return cmd::bind_scene(kImageAt, m_image_bytes);
  }

  // An address somewhere it hurts: near the end of memory (inside, straddling, past), at the top of the 64-bit
  // space, anywhere in the buffers with any alignment, or anything.
  uint64_t nasty_address() {
    switch (below(5)) {
      case 0:
        return kMem - below(1024);
      case 1:
        return kMem + below(1024);
      case 2:
        return ~uint64_t(0) - below(1024);
      case 3:
        return kRaysAt + below(kMem - kRaysAt);
      default:
        return u64();
    }
  }

  cmd::Packet mutated_packet() {
    cmd::Packet p = valid_packet();
    const uint64_t mutations = 1 + below(2);
    for (uint64_t m = 0; m < mutations; ++m) {
      switch (below(13)) {
        case 0:
          p.opcode = uint8_t(u32());
          break;
        case 1:
          p.opcode = uint8_t(below(cmd::kOpcodeCount + 2));
          break;
        case 2:
          p.addr0 = nasty_address();
          break;
        case 3:
          p.addr1 = nasty_address();
          break;
        case 4:
          p.count = uint32_t(below(2 * kMaxCount));
          break;
        case 5:
          p.count = chance(50) ? u32() : cmd::kMaxTraceCount + uint32_t(below(3)) - 1;
          break;
        case 6:
          p.flags = uint8_t(1u << below(8));
          break;
        case 7:
          p.ray_type = uint8_t(below(10));
          break;
        case 8:
          p.bounce = uint8_t(u32());
          break;
        case 9:
          p.value = chance(50) ? u64() : below(4);
          break;
        case 10:  // overlapping or touching buffers
          p.addr1 = p.addr0 + 16 * below(2 * kMaxCount) - 16 * below(kMaxCount);
          break;
        case 11:  // a scene image somewhere else, or only part of it
          p = cmd::bind_scene(8 * below(kMem / 8), 8 * below(m_image_bytes / 8 + 2));
          break;
        default: {  // random bytes
          uint8_t b[sizeof p];
          for (uint8_t& x : b) x = uint8_t(u32());
          std::memcpy(&p, b, sizeof p);
          break;
        }
      }
    }
    return p;
  }

  // Writes packets at the device's tail (when the ring registers describe a ring in memory) and rings the
  // doorbell; otherwise rings a doorbell on a ring that is not there.
  void put_packets(const std::vector<cmd::Packet>& packets) {
    const uint32_t size = rd(reg::kRingSize), tail = rd(reg::kRingTail), head = rd(reg::kRingHead);
    const uint64_t base = uint64_t(rd(reg::kRingBaseLo)) | (uint64_t(rd(reg::kRingBaseHi)) << 32);
    const bool ring_ok = size >= 2 && size <= reg::kMaxRingSlots && (size & (size - 1)) == 0 && tail < size &&
                         head < size && base % 32 == 0 && base <= kMem && uint64_t(size) * 32 <= kMem - base;
    if (!ring_ok) {
      wr(reg::kRingTail, u32() % 8);
      return;
    }
    const uint32_t free = size - 1 - ((tail - head) & (size - 1));
    const uint32_t n = std::min<uint32_t>(free, uint32_t(packets.size()));
    for (uint32_t i = 0; i < n; ++i)
      std::memcpy(m_dev.mem() + base + uint64_t((tail + i) & (size - 1)) * 32, &packets[i], 32);
    const uint32_t new_tail = (tail + n) & (size - 1);
    const bool live = rd(reg::kStatus) == (reg::kStatusEnabled | reg::kStatusIdle) ||
                      rd(reg::kStatus) == (reg::kStatusEnabled | reg::kStatusIdle | reg::kStatusBound);
    wr(reg::kRingTail, new_tail);
    m_res.packets_rung += n;
    // Synchronous: a live device consumes everything, or stops on the packet its error info names.
    if (live && m_dev.processor().error() == ErrorCode::kNone) {
      CHECK_SILENT(rd(reg::kRingHead) == new_tail);
      CHECK_SILENT((rd(reg::kStatus) & reg::kStatusIdle) != 0);
    }
  }

  void random_register_write() {
    ++m_res.register_writes;
    uint32_t off;
    const uint64_t k = below(100);
    if (k < 80)
      off = 4 * uint32_t(below(reg::kWindowBytes / 4 + 1));  // every register, and one past the window
    else if (k < 90)
      off = uint32_t(below(reg::kWindowBytes + 8));  // unaligned too
    else
      off = u32();
    uint32_t v;
    switch (below(6)) {
      case 0:
        v = u32();
        break;
      case 1:
        v = uint32_t(below(4));  // enable, reset, both, neither
        break;
      case 2:
        v = 1u << below(32);
        break;
      case 3:
        v = 2u << below(12);  // ring sizes
        break;
      case 4:
        v = uint32_t(32 * below(kMem / 32 + 4));  // ring bases
        break;
      default:
        v = uint32_t(below(1024));  // tails
        break;
    }
    if (off == reg::kControl && (v & reg::kCtrlReset)) ++m_res.resets;
    wr(off, v);
  }

  void step() {
    const bool stopped = m_dev.processor().error() != ErrorCode::kNone;
    const uint64_t k = below(100);
    if (stopped && k < 40) {
      restart();
    } else if (k < 6) {
      random_register_write();
    } else if (k < 9) {
      rd(uint32_t(below(reg::kWindowBytes + 16)));  // reads change nothing but the clock latch
    } else if (k < 10) {
      restart();
    } else {
      std::vector<cmd::Packet> packets(1 + below(8));
      for (cmd::Packet& p : packets) p = chance(4) ? mutated_packet() : valid_packet();
      put_packets(packets);
    }
    check_invariants();
  }

  void check_invariants() {
    const uint32_t code = rd(reg::kErrorCode);
    const uint32_t status = rd(reg::kStatus);
    CHECK_SILENT(code <= kLastErrorCode);
    CHECK_SILENT(std::string(reg::error_name(ErrorCode(code))) != "unknown");
    CHECK_SILENT(((status & reg::kStatusError) != 0) == (code != 0));
    CHECK_SILENT(((status & reg::kStatusBound) != 0) == m_dev.engine().bound());
    if (status & reg::kStatusEnabled) {
      const uint32_t size = rd(reg::kRingSize);
      CHECK_SILENT(rd(reg::kRingHead) < size);
      CHECK_SILENT(rd(reg::kRingTail) < size);
      CHECK_SILENT(((status & reg::kStatusIdle) != 0) == (rd(reg::kRingHead) == rd(reg::kRingTail)));
    }
  }

  host::FirmwareDevice m_dev;
  std::mt19937_64 m_rng;
  std::vector<uint64_t> m_image;
  uint64_t m_image_bytes;
  FuzzResult m_res;
};

}  // namespace

TEST_CASE("fuzz: random packets and register writes never break the command processor", "[fuzz]") {
  const hw::Geometry g = tiny_geometry();
  struct Run {
    const char* engine;
    uint64_t packets;
  };
  for (const Run& run : {Run{"fixed", 100000}, Run{"float", 100000}}) {
    const uint64_t seed = fuzz_seed(0xF0220001);
    INFO("engine " << run.engine << ", seed " << seed << " (set RTU_FUZZ_SEED to repeat another)");
    const std::vector<uint64_t> image = scene_image(run.engine, g);
    const FuzzResult a = CpFuzzer(run.engine, image, seed).run(run.packets);
    const FuzzResult b = CpFuzzer(run.engine, image, seed).run(run.packets);
    CHECK(a.packets_rung >= run.packets);
    // The mix did something: most packets ran, rays were traced, and every packet error occurred.
    CHECK(a.packets_run > run.packets / 2);
    CHECK(a.rays > 5 * run.packets);
    CHECK(a.register_writes > run.packets / 100);
    CHECK(a.resets > run.packets / 100);
    for (ErrorCode e :
         {ErrorCode::kBadOpcode, ErrorCode::kBadAddress, ErrorCode::kMisaligned, ErrorCode::kBadCount,
          ErrorCode::kReservedBits, ErrorCode::kRingMisuse, ErrorCode::kBadScene, ErrorCode::kOverlap,
          ErrorCode::kBadRegister, ErrorCode::kNoScene, ErrorCode::kBadRing}) {
      INFO("error " << reg::error_name(e));
      CHECK(a.errors[size_t(e)] > 0);
    }
    // Deterministic: the same seed, the same bytes and counters.
    CHECK(a.mem_hash == b.mem_hash);
    CHECK(a.counters_hash == b.counters_hash);
    CHECK(a.packets_run == b.packets_run);
    CHECK(a.errors == b.errors);
    // ... and the hashes see a difference: another seed ends elsewhere.
    const FuzzResult c = CpFuzzer(run.engine, image, seed + 1).run(2000);
    const FuzzResult d = CpFuzzer(run.engine, image, seed).run(2000);
    CHECK(c.mem_hash != d.mem_hash);
    CHECK(c.counters_hash != d.counters_hash);
  }
}

TEST_CASE("fuzz: DeviceImage::from_bytes rejects or safely traces corrupted images", "[fuzz]") {
  const uint64_t seed = fuzz_seed(0xF0220002);
  INFO("seed " << seed << " (set RTU_FUZZ_SEED to repeat another)");
  std::mt19937_64 rng(seed);
  auto below = [&](uint64_t n) { return rng() % n; };

  const host::Scene scene = host::load_scene("builtin:seed");
  hw::TracerOptions opt;
  const hw::FixedFormat format;
  opt.bvh.width = format.width;
  const std::optional<hw::Bvh> bvh = hw::choose_accel(scene.geometry, opt);
  REQUIRE(bvh);
  const hw::DeviceImage original = hw::encode_scene(scene.geometry, format, &*bvh);
  const size_t size = original.size();
  const hw::ImageHeader& oh = original.header();

  // A few hundred rays: camera rays and rays from everywhere around the scene.
  std::vector<hw::Ray> rays = host::primary_rays(scene.camera, 160);
  hw::Aabb box = scene.geometry.bounds();
  box.lo = box.lo - hw::Vec3(2.0f);
  box.hi = box.hi + hw::Vec3(2.0f);
  const std::vector<hw::Ray> inc = host::incoherent_rays(box, 96, seed);
  rays.insert(rays.end(), inc.begin(), inc.end());

  // The unchanged bytes are accepted and trace like the original.
  {
    const hw::DeviceImage copy = hw::DeviceImage::from_bytes(original.data(), size);
    const hw::FixedTracer a(original), b(copy);
    std::vector<hw::Hit> ha(rays.size()), hb(rays.size());
    hw::TraversalStats s;
    a.trace_batch(rays.data(), ha.data(), rays.size(), false, 1, s);
    b.trace_batch(rays.data(), hb.data(), rays.size(), false, 1, s);
    REQUIRE(std::memcmp(ha.data(), hb.data(), ha.size() * sizeof(hw::Hit)) == 0);
    REQUIRE(s.hits > 0);
  }

  std::vector<uint64_t> words((size + 7) / 8 + 1);
  auto* bytes = reinterpret_cast<uint8_t*>(words.data());
  const uint64_t sections[] = {sizeof(hw::ImageHeader), oh.node_offset, oh.record_offset, oh.plane_offset, size};
  uint64_t accepted = 0, rejected = 0, traced_hits = 0;
  std::array<uint64_t, 6> accepted_by_kind{};
  std::vector<hw::Hit> hits(rays.size());
  constexpr int kVariants = 20000;
  for (int v = 0; v < kVariants; ++v) {
    std::memcpy(bytes, original.data(), size);
    size_t len = size;
    const uint64_t kind = below(6);
    switch (kind) {
      case 0:  // flip a few bits anywhere
        for (uint64_t i = 0, n = 1 + below(4); i < n; ++i) bytes[below(size)] ^= uint8_t(1u << below(8));
        break;
      case 1:  // random bytes in the header
        for (uint64_t i = 0, n = 1 + below(3); i < n; ++i) bytes[below(sizeof(hw::ImageHeader))] = uint8_t(rng());
        break;
      case 2: {  // an edge value in a header field
        const uint32_t edge[] = {0, 1, 2, 7, 8, 0x7F, 0x80, 0xFF, 0xFFFF, 0x7FFFFFFF, 0x80000000u, 0xFFFFFFFFu};
        const uint32_t val = edge[below(std::size(edge))];
        const size_t at = 4 * below(sizeof(hw::ImageHeader) / 4);
        const size_t w = size_t(1) << below(3);  // 1, 2 or 4 bytes
        std::memcpy(bytes + at, &val, w);
        break;
      }
      case 3: {  // truncated, with total_bytes left or made to agree
        len = below(size);
        if (below(2)) len &= ~size_t(7);
        if (below(2) && len >= sizeof(hw::ImageHeader)) {
          const uint64_t t = len;
          std::memcpy(bytes + offsetof(hw::ImageHeader, total_bytes), &t, 8);
        }
        break;
      }
      case 4: {  // random bytes inside one section (nodes, records or planes)
        const size_t s = 1 + below(3);
        const uint64_t lo = sections[s], hi = sections[s + 1];
        if (hi > lo)
          for (uint64_t i = 0, n = 1 + below(6); i < n; ++i) bytes[lo + below(hi - lo)] = uint8_t(rng());
        break;
      }
      default: {  // a 32-bit word of the node section set to an edge value (child refs, counts, offsets)
        const uint64_t lo = sections[1], hi = sections[2];
        const uint32_t edge[] = {
            0, 1, 0xFFFFFFFFu, 0x80000000u, 0x80000001u, oh.node_count, oh.node_count - 1, oh.record_count};
        if (hi - lo >= 4) {
          const uint32_t val = edge[below(std::size(edge))];
          std::memcpy(bytes + lo + 4 * below((hi - lo) / 4), &val, 4);
        }
        break;
      }
    }
    std::optional<hw::DeviceImage> img;
    try {
      img = hw::DeviceImage::from_bytes(bytes, len);
    } catch (const std::invalid_argument&) {
      ++rejected;
      continue;
    } catch (const std::exception& e) {
      FAIL("variant " << v << " (kind " << kind << "): from_bytes threw something else: " << e.what());
    }
    ++accepted;
    ++accepted_by_kind[kind];
    const hw::ImageHeader& h = img->header();
    const uint64_t prims = uint64_t(h.num_triangles) + h.num_spheres + h.plane_count;
    const hw::FixedTracer tracer(*img);
    hw::TraversalStats s;
    const bool any_hit = (v & 1) != 0;
    tracer.trace_batch(rays.data(), hits.data(), rays.size(), any_hit, 1, s);
    for (const hw::Hit& hit : hits) {
      if (!hit.hit()) {
        if (!std::isinf(hit.t)) FAIL("variant " << v << ": a miss with t = " << hit.t);
        continue;
      }
      ++traced_hits;
      if (hit.prim >= prims || std::isnan(hit.t))
        FAIL("variant " << v << " (kind " << kind << "): hit of primitive " << hit.prim << " of " << prims
                        << " at t = " << hit.t);
    }
  }
  INFO("accepted " << accepted << ", rejected " << rejected);
  CHECK(accepted + rejected == kVariants);
  CHECK(rejected > kVariants / 10);  // the checks do reject
  CHECK(accepted > kVariants / 10);  // and what they let through was traced
  CHECK(traced_hits > 0);
  CHECK(accepted_by_kind[0] > 0);
  CHECK(accepted_by_kind[4] > 0);
}
