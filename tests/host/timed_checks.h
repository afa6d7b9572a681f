// Shared by the timed device's tests (test_timed.cpp, test_timed_chip.cpp, test_energy.cpp): a device's options as
// a timing preset sets them (its node format and BVH width), and a scene's camera rays followed by incoherent
// rays.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "host/devices/direct_device.h"
#include "host/jobs/render.h"
#include "host/scene/ray_gen.h"
#include "host/scene/scene.h"
#include "hwmodel/timing/timing_config.h"

// The options of device `device` (float, fixed, timed) with timing preset `preset`, its format and BVH width.
inline rtu::host::DeviceOptions preset_options(const std::string& device, const std::string& preset) {
  rtu::host::DeviceOptions o;
  o.kind = rtu::hw::parse_device_kind(device);
  o.timing = rtu::hw::timing_preset(preset);
  o.format = rtu::hw::format_preset(o.timing.format);
  o.format.width = o.timing.bvh_width;
  o.tracer.bvh.width = o.format.width;
  return o;
}

// `n` camera rays of scene `s`, then `n` incoherent rays in its bounds (seed `seed`).
inline std::vector<rtu::hw::Ray> camera_and_incoherent_rays(const rtu::host::Scene& s, size_t n, uint64_t seed) {
  std::vector<rtu::hw::Ray> rays = rtu::host::primary_rays(s.camera, n);
  const std::vector<rtu::hw::Ray> inc = rtu::host::incoherent_rays(s.geometry.bounds(), n, seed);
  rays.insert(rays.end(), inc.begin(), inc.end());
  return rays;
}

// A render of a width x height image, spp samples per pixel, paths of up to max_depth bounces, on 2 threads.
inline rtu::host::RenderOptions render_options(int width, int height, int spp, int max_depth) {
  rtu::host::RenderOptions o;
  o.width = width;
  o.height = height;
  o.spp = spp;
  o.max_depth = max_depth;
  o.threads = 2;
  return o;
}
