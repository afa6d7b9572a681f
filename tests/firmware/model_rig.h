// Shared by the tests of the ring driver on the model device (test_ring.cpp) and of the command processor's error
// paths (test_command_processor_errors.cpp): the seed scene and its images for both engines, the hits the tracers
// give when called directly, rays of every kind, and Rig, a host::FirmwareDevice driven by the firmware ring
// driver with the scene image of its engine in device memory.
#pragma once

#include <catch2/catch.hpp>

#include <cstdint>
#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "firmware/hal.h"
#include "firmware/ring.h"
#include "host/devices/firmware_device.h"
#include "host/scene/scene.h"
#include "hwmodel/datapath/fixed_tracer.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/device/device_kind.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/interface/regs.h"
#include "hwmodel/scene/bvh.h"

namespace rtu::test {

// The names the ring tests use.
namespace cmd = hw::cmd;
namespace reg = hw::reg;
using fw::Status;
using reg::ErrorCode;

inline constexpr uint64_t kMemBytes = 8u << 20;        // device memory of every rig
inline constexpr uint64_t kRingArenaBytes = 64 << 10;  // [0, 64 KiB): the ring and its fence word; buffers above
inline const char* const kEngines[] = {"float", "fixed"};

// The seed scene and its images for both engines, built once. The float engine builds its BVH from the float
// image with default options; the fixed image is encoded over the BVH the host would choose
// (host/devices/direct_device.cpp).
struct SceneData {
  host::Scene scene;
  hw::TracerOptions tracer;
  std::optional<hw::Bvh> bvh;
  std::unique_ptr<hw::DeviceImage> fixed_image;
  std::vector<uint64_t> float_image;
  std::unique_ptr<hw::FloatTracer> float_tracer;
  std::unique_ptr<hw::FixedTracer> fixed_tracer;
};
const SceneData& seed_scene();

// What the engine `name` computes for these rays when called directly (no device, no ring).
std::vector<hw::Hit> direct_hits(const std::string& name, const std::vector<hw::Ray>& rays, bool any_hit,
                                 hw::TraversalStats& s);
std::vector<hw::Hit> direct_hits(const std::string& name, const std::vector<hw::Ray>& rays, bool any_hit);

// Rays of every kind: camera rays, incoherent rays, and rays every device rejects at setup.
std::vector<hw::Ray> test_rays(size_t primary, size_t incoherent, uint64_t seed);

bool same_hits(const std::vector<hw::Hit>& a, const std::vector<hw::Hit>& b);

// A model device driven by the firmware ring driver, with the scene image of its engine in device memory.
struct Rig {
  explicit Rig(const std::string& engine, uint32_t ring_slots = 16)
      : name(engine),
        dev(rtu::hw::parse_device_kind(engine), kMemBytes),
        slots(ring_slots),
        buffers(kRingArenaBytes, kMemBytes - kRingArenaBytes) {
    const SceneData& sd = seed_scene();
    if (engine == "float") {
      image_bytes = sd.float_image.size() * 8;
      image = put(sd.float_image.data(), image_bytes, 8);
    } else {
      image_bytes = sd.fixed_image->size();
      image = put(sd.fixed_image->data(), image_bytes, 8);
    }
    start();
  }

  uint32_t rd(uint32_t offset) { return dev.read32(offset); }
  void wr(uint32_t offset, uint32_t value) { dev.write32(offset, value); }
  const hw::DeviceCounters& counters() { return dev.processor().counters(); }

  uint64_t alloc(uint64_t bytes, uint64_t align = 16) {
    const uint64_t a = buffers.alloc(bytes, align);
    REQUIRE(a != fw::Arena::kNull);
    return a;
  }
  uint64_t put(const void* src, uint64_t bytes, uint64_t align = 16) {
    const uint64_t a = alloc(bytes, align);
    std::memcpy(dev.mem() + a, src, bytes);
    return a;
  }
  template <class T>
  T load(uint64_t addr) {
    T v;
    std::memcpy(&v, dev.mem() + addr, sizeof v);
    return v;
  }

  // (Re)initializes the ring: resets the unit, which unbinds the scene.
  void start() {
    ring_arena = fw::Arena(0, kRingArenaBytes);
    REQUIRE(ring.init(dev, ring_arena, slots) == fw::Status::kOk);
    REQUIRE(rd(hw::reg::kStatus) == (hw::reg::kStatusEnabled | hw::reg::kStatusIdle));
  }
  void bind() {
    REQUIRE(ring.submit(hw::cmd::bind_scene(image, image_bytes)) == fw::Status::kOk);
    REQUIRE(ring.sync() == fw::Status::kOk);
    REQUIRE((rd(hw::reg::kStatus) & hw::reg::kStatusBound) != 0);
  }
  void submit(const hw::cmd::Packet& p) { REQUIRE(ring.submit(p) == fw::Status::kOk); }

  // A TRACE of `rays` through the ring; returns the hits the device wrote.
  std::vector<hw::Hit> trace(const std::vector<hw::Ray>& rays, bool any_hit) {
    const uint64_t r = put(rays.data(), rays.size() * sizeof(hw::Ray));
    const uint64_t h = alloc(rays.size() * sizeof(hw::Hit));
    submit(hw::cmd::trace(r, h, uint32_t(rays.size()), any_hit, hw::cmd::RayType::kPrimary, 0));
    REQUIRE(ring.sync() == fw::Status::kOk);
    std::vector<hw::Hit> hits(rays.size());
    std::memcpy(hits.data(), dev.mem() + h, hits.size() * sizeof(hw::Hit));
    return hits;
  }

  std::string name;
  host::FirmwareDevice dev;
  uint32_t slots;
  fw::Arena ring_arena, buffers;
  fw::Ring ring;
  uint64_t image = 0, image_bytes = 0;
};

// kCtrlReset clears the error, the interrupts, the ring and the scene; the ring driver then starts over and a
// valid job runs and gives the hits of the direct tracer.
void recover_and_run(Rig& r);

}  // namespace rtu::test
