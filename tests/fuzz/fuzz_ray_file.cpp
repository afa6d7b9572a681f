// Ray and hit files (host/io/ray_io.cpp), binary and CSV: a binary file is accepted exactly when its size is a
// multiple of the record and then holds the bytes unchanged; CSV is parsed line by line. The rays are then traced
// on the float, fixed and timed devices over a tiny scene (hostile floats through ray setup): every hit names a
// primitive or misses, and the timed device's hits equal the fixed device's bit for bit (docs/architecture.md).
#include <cmath>
#include <memory>

#include "host/devices/direct_device.h"
#include "host/io/error.h"
#include "host/io/ray_io.h"
#include "tests/fuzz/fuzz.h"

namespace rtu::fuzz {

namespace {

bool same_float(float a, float b) {
  return (std::isnan(a) && std::isnan(b)) || std::memcmp(&a, &b, 4) == 0;
}

struct Devices {
  std::unique_ptr<host::DirectDevice> flt, fix, tim;
  Devices() {
    host::DeviceOptions o;
    o.kind = rtu::hw::DeviceKind::kFloat;
    flt = host::make_device(tiny_geometry(), o);
    o.kind = rtu::hw::DeviceKind::kFixed;
    fix = host::make_device(tiny_geometry(), o);
    o.kind = rtu::hw::DeviceKind::kTimed;
    tim = host::make_device(tiny_geometry(), o);
  }
};

}  // namespace

int ray_file(const uint8_t* data, size_t size) {
  init();
  const std::string bin = scratch_file("r.rays", data, size), csv = scratch_file("r.csv", data, size);
  std::vector<hw::Ray> rays;
  try {
    rays = host::read_rays(bin);
    RTU_FUZZ_CHECK(size % 32 == 0 && rays.size() == size / 32);
    RTU_FUZZ_CHECK(rays.empty() || std::memcmp(rays.data(), data, size) == 0);
  } catch (const host::Error&) {
    RTU_FUZZ_CHECK(size % 32 != 0);
  }
  try {
    const std::vector<hw::Hit> hits = host::read_hits(bin);
    RTU_FUZZ_CHECK(size % 16 == 0 && hits.size() == size / 16);
  } catch (const host::Error&) {
    RTU_FUZZ_CHECK(size % 16 != 0);
  }
  try {
    host::read_hits(csv);
  } catch (const host::Error&) {
  }
  std::vector<hw::Ray> text_rays;
  try {
    text_rays = host::read_rays(csv);
  } catch (const host::Error&) {
  }
  // CSV written back and read again: the same floats (9 significant digits round-trip; NaNs stay NaN).
  if (!text_rays.empty() && text_rays.size() <= 64) {
    const std::string again = scratch_file("again.csv", nullptr, 0);
    host::write_rays(again, text_rays);
    const std::vector<hw::Ray> back = host::read_rays(again);
    RTU_FUZZ_CHECK(back.size() == text_rays.size());
    for (size_t i = 0; i < back.size(); ++i) {
      const float* a = &back[i].origin.x;
      const float* b = &text_rays[i].origin.x;
      for (int k = 0; k < 8; ++k) RTU_FUZZ_CHECK(same_float(a[k], b[k]));
    }
  }
  if (rays.empty()) rays = text_rays;
  if (rays.size() > 64) rays.resize(64);
  if (rays.empty()) return 0;

  static const Devices dev;
  const uint32_t nprims = tiny_geometry().num_prims();
  std::vector<hw::Hit> hf(rays.size()), hx(rays.size()), ht(rays.size());
  hw::TraversalStats sf, sx, st;
  dev.flt->trace_batch(rays.data(), hf.data(), rays.size(), false, 1, sf);
  dev.fix->trace_batch(rays.data(), hx.data(), rays.size(), false, 1, sx);
  dev.tim->trace_batch(rays.data(), ht.data(), rays.size(), false, 1, st);
  RTU_FUZZ_CHECK(std::memcmp(hx.data(), ht.data(), hx.size() * sizeof(hw::Hit)) == 0);
  RTU_FUZZ_CHECK(sx.invalid_rays == st.invalid_rays && sx.rays == st.rays);
  for (size_t i = 0; i < rays.size(); ++i) {
    RTU_FUZZ_CHECK(hf[i].prim == hw::kMissPrim || hf[i].prim < nprims);
    RTU_FUZZ_CHECK(hx[i].prim == hw::kMissPrim || hx[i].prim < nprims);
    if (hx[i].prim != hw::kMissPrim) RTU_FUZZ_CHECK(std::isfinite(hx[i].t));  // t < 0 when tmin < 0
  }
  // Any-hit on the fixed device: hits exactly where closest-hit finds one (same rays, same tree).
  std::vector<hw::Hit> ha(rays.size());
  hw::TraversalStats sa;
  dev.fix->trace_batch(rays.data(), ha.data(), rays.size(), true, 1, sa);
  for (size_t i = 0; i < rays.size(); ++i)
    RTU_FUZZ_CHECK((ha[i].prim == hw::kMissPrim) == (hx[i].prim == hw::kMissPrim));
  return 0;
}

}  // namespace rtu::fuzz

RTU_FUZZ_ENTRY(ray_file)
