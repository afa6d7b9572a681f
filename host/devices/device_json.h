// The JSON and byte figures of a direct device (direct_device.h): its acceleration structure and memory image, as
// rtusim writes them (info --json, trace and compare --stats, demo's report, the sweep's bytes).
#pragma once

#include <cstdint>

#include "host/devices/direct_device.h"
#include "host/io/stats_json.h"

namespace rtu::host {

// The device's BVH (or brute force) figures and, on the fixed and timed devices, its image (image_json, with the
// two levels' bytes on the two-level device).
Json bvh_json(const DirectDevice& d);

// The fixed device's memory: total bytes and bytes per bounded primitive of the scene it traces. On the two-level
// device both levels and the stored transforms over the flattened scene's primitives (instancing's saving shows
// as fewer bytes per primitive). {0, 0} for the float device.
struct ImageBytes {
  uint64_t total = 0;
  double per_prim = 0.0;
};
ImageBytes device_image_bytes(const DirectDevice& d);

}  // namespace rtu::host
