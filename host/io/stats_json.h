// Figures as JSON, as rtusim writes them (--stats, --json, report.json): the device image, the number format and
// traversal statistics. The timing configuration and what a timed run measured, priced, are in
// host/cost/timing_json.h; the JSON of what a host device or job made sits beside them: bvh_json in
// host/devices/device_json.h, render_json in host/jobs/render.h.
#pragma once

#include <array>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "hwmodel/datapath/instanced_fixed.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

using Json = nlohmann::ordered_json;

Json format_json(const hw::FixedFormat& f);
// Bytes of the fixed device's image beside the float BVH's (nodes + leaf index) for the same tree: its storage
// layouts (by name), bytes per node and per primitive (nodes + primitive section over the bounded primitives).
Json image_json(const hw::DeviceImage& img, const hw::Bvh* bvh);
// The names of FixedFormat::node_layout (structs, bit-packed, compressed-wide) and prim_layout (records, blocks,
// clusters); "unknown" for another value.
const char* node_layout_name(int layout);
const char* prim_layout_name(int layout);
// The image's node and primitive bytes over its bounded primitives (triangles and spheres); 0 when it has none.
double image_bytes_per_prim(const hw::DeviceImage& img);
// The two levels' bytes: top image, bottom images, stored transforms, and the instance visits that moved their
// origin.
Json two_level_json(const hw::InstancedFixedTracer& t);
Json traversal_json(const hw::TraversalStats& s);
// Writes j indented by 2; throws Error when the file cannot be written.
void write_json(const std::string& path, const Json& j);

}  // namespace rtu::host
