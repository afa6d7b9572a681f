// The command processor (hwmodel/device/command_processor.cpp) on an in-process unit: the input is a program of
// register writes and reads, raw 32-byte packets and well-formed packets rung through the ring, resets and memory
// pokes. The first byte picks the engine: float, fixed, timed, or timed with a 64-cycle watchdog. Checked after
// every step: the error code is a defined one and shows in STATUS, an enabled ring's head and tail lie inside it,
// and the watchdog fires only on the engine configured to (a valid image never reaches the automatic step bound).
#include <memory>

#include "host/devices/firmware_device.h"
#include "hwmodel/datapath/float_tracer.h"
#include "hwmodel/device/engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/interface/commands.h"
#include "hwmodel/interface/regs.h"
#include "hwmodel/numeric/fixed_format.h"
#include "tests/fuzz/fuzz.h"

namespace rtu::fuzz {

namespace {

namespace cmd = hw::cmd;
namespace reg = hw::reg;

constexpr uint64_t kMem = 512 << 10;
constexpr uint64_t kImageAt = 64 << 10, kRaysAt = 192 << 10, kHitsAt = 320 << 10;
constexpr uint32_t kMaxRays = (kHitsAt - kRaysAt) / 32;

std::vector<uint64_t> image_of(bool fixed) {
  const hw::Geometry& g = tiny_geometry();
  if (!fixed) return hw::encode_float_scene(g);
  hw::TracerOptions opt;
  const hw::FixedFormat f;
  opt.bvh.width = f.width;
  const std::optional<hw::Bvh> bvh = hw::choose_accel(g, opt);
  const hw::DeviceImage img = hw::encode_scene(g, f, bvh ? &*bvh : nullptr);
  std::vector<uint64_t> w(img.size() / 8);
  std::memcpy(w.data(), img.data(), img.size());
  return w;
}

}  // namespace

int command_processor(const uint8_t* data, size_t size) {
  init();
  static const std::vector<uint64_t> fixed_image = image_of(true), float_image = image_of(false);
  static const std::vector<hw::Ray> rays = rays_around(tiny_geometry().bounds(), kMaxRays, 1);
  Bytes in(data, size);
  const int engine = in.get<uint8_t>() % 4;
  hw::TimingConfig tc;
  if (engine == 3) tc.watchdog_cycles = 64;
  host::FirmwareDevice dev(engine == 0   ? hw::DeviceKind::kFloat
                           : engine == 1 ? hw::DeviceKind::kFixed
                                         : hw::DeviceKind::kTimed,
                           kMem, hw::EngineOptions{}, tc);
  const std::vector<uint64_t>& image = engine == 0 ? float_image : fixed_image;
  const uint64_t image_bytes = image.size() * 8;
  dev.memory().write(kImageAt, image.data(), image_bytes);
  dev.memory().write(kRaysAt, rays.data(), rays.size() * 32);
  hw::CommandProcessor& cp = dev.processor();
  auto setup_ring = [&](uint32_t slots) {
    cp.write(reg::kControl, reg::kCtrlReset);
    cp.write(reg::kRingBaseLo, 0);
    cp.write(reg::kRingBaseHi, 0);
    cp.write(reg::kRingSize, slots);
    cp.write(reg::kControl, reg::kCtrlEnable);
  };
  setup_ring(16);
  auto ring = [&](const cmd::Packet& p) {
    const uint32_t n = cp.read(reg::kRingSize), tail = cp.read(reg::kRingTail);
    if (n < 2 || n > reg::kMaxRingSlots || tail >= n) return;
    dev.memory().write(uint64_t(tail) * 32, &p, sizeof p);  // the ring lies at 0 in every program
    cp.write(reg::kRingTail, (tail + 1) & (n - 1));
  };
  for (int step = 0; step < 256 && !in.empty(); ++step) {
    switch (in.get<uint8_t>() % 6) {
      case 0: {  // a register write: any offset of the window and a little past it, aligned or not
        const uint32_t off = in.get<uint8_t>() % (reg::kWindowBytes + 8);
        const uint32_t value = in.get<uint32_t>();
        if (off == reg::kControl && (value & reg::kCtrlEnable)) cp.write(reg::kRingBaseHi, 0);  // keep it at 0
        if (off == reg::kRingBaseLo || off == reg::kRingBaseHi) break;                          // (see ring())
        cp.write(off, value);
        break;
      }
      case 1:
        cp.read(in.get<uint8_t>() % (reg::kWindowBytes + 8));
        break;
      case 2: {  // a raw packet
        cmd::Packet p;
        for (size_t i = 0; i < sizeof p; ++i) reinterpret_cast<uint8_t*>(&p)[i] = in.get<uint8_t>();
        ring(p);
        break;
      }
      case 3: {  // a well-formed packet on the prepared buffers, with fuzzed sizes
        const uint8_t kind = in.get<uint8_t>();
        const uint16_t count = in.get<uint16_t>();
        const uint8_t flags = in.get<uint8_t>();
        cmd::Packet p = cmd::nop();
        switch (kind % 5) {
          case 1:
            p = cmd::bind_scene(kImageAt, (flags & 1) ? image_bytes : (uint64_t(count) * 8) % (image_bytes + 64));
            break;
          case 2:
            p = (flags & 2) ? cmd::trace_all_hits(kRaysAt, kHitsAt, 1 + count % kMaxRays, (flags >> 2) % 9,
                                                  cmd::RayType(flags % 7), flags >> 3)
                            : cmd::trace(kRaysAt, kHitsAt, 1 + count % kMaxRays, flags & 1,
                                         cmd::RayType(flags % 7), flags >> 3);
            break;
          case 3:
            p = cmd::fence(kHitsAt + 8 * (count % 64), count, flags & 1);
            break;
          case 4:
            p = cmd::timestamp(kHitsAt + 8 * (count % 64));
            break;
          default:
            break;
        }
        ring(p);
        break;
      }
      case 4:
        setup_ring(uint32_t(1) << (1 + in.get<uint8_t>() % 8));
        break;
      default: {  // a poke into the ray buffer or the image (which may then be bound)
        const uint64_t at = kImageAt + 8 * uint64_t(in.get<uint16_t>() % ((kHitsAt - kImageAt) / 8));
        dev.memory().store<uint64_t>(at, in.get<uint64_t>());
        break;
      }
    }
    const uint32_t code = cp.read(reg::kErrorCode), status = cp.read(reg::kStatus);
    RTU_FUZZ_CHECK(code <= uint32_t(reg::ErrorCode::kWatchdog));
    RTU_FUZZ_CHECK((code != 0) == ((status & reg::kStatusError) != 0));
    RTU_FUZZ_CHECK(code != uint32_t(reg::ErrorCode::kWatchdog) || engine == 3);
    RTU_FUZZ_CHECK(code != uint32_t(reg::ErrorCode::kWatchdog) || !cp.error_detail().empty());
    if (status & reg::kStatusEnabled) {
      const uint32_t n = cp.read(reg::kRingSize);
      RTU_FUZZ_CHECK(cp.read(reg::kRingHead) < n && cp.read(reg::kRingTail) < n);
    }
  }
  return 0;
}

}  // namespace rtu::fuzz

RTU_FUZZ_ENTRY(command_processor)
