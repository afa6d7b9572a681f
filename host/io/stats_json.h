// Figures as JSON, as rtusim writes them (--stats, --json, report.json): the BVH and the device image, the number
// format, traversal statistics, the timing configuration and what a timed run measured, and a render's
// statistics.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "host/devices/direct_device.h"
#include "host/jobs/render.h"
#include "hwmodel/format/device_image.h"
#include "hwmodel/numeric/fixed_format.h"
#include "hwmodel/datapath/stats.h"
#include "hwmodel/device/timed_engine.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::host {

using Json = nlohmann::ordered_json;

Json bvh_json(const DirectDevice& d);
Json format_json(const hw::FixedFormat& f);
// Bytes of the fixed device's image beside the float BVH's (nodes + leaf index) for the same tree: its storage
// layouts (by name), bytes per node and per primitive (nodes + primitive section over the bounded primitives).
Json image_json(const hw::DeviceImage& img, const hw::Bvh* bvh);
// The names of FixedFormat::node_layout (structs, bit-packed, compressed-wide) and prim_layout (records, blocks);
// "unknown" for another value.
const char* node_layout_name(int layout);
const char* prim_layout_name(int layout);
// The image's node and primitive bytes over its bounded primitives (triangles and spheres); 0 when it has none.
double image_bytes_per_prim(const hw::DeviceImage& img);
// The fixed device's memory: total bytes and bytes per bounded primitive of the scene it traces. On the two-level
// device both levels and the stored transforms over the flattened scene's primitives (instancing's saving shows
// as fewer bytes per primitive). {0, 0} for the float device.
struct ImageBytes {
  uint64_t total = 0;
  double per_prim = 0.0;
};
ImageBytes device_image_bytes(const DirectDevice& d);
// The two levels' bytes: top image, bottom images, stored transforms, and the instance visits that moved their
// origin.
Json two_level_json(const hw::InstancedFixedTracer& t);
Json traversal_json(const hw::TraversalStats& s);
// Writes j indented by 2; throws Error when the file cannot be written.
void write_json(const std::string& path, const Json& j);

// {"preset": name, key: value, ...} in timing_keys() order: numbers as JSON numbers, text as strings.
Json timing_json(const hw::TimingConfig& c);
// What a timed run measured: cycles, cycles per ray, rays per clock, unit utilization, cache and DRAM figures,
// stack spills, queue stalls, and the lower bound max(box tests / box rate, triangle tests / triangle rate,
// DRAM bytes / bandwidth) with the cycles divided by it.
Json timing_stats_json(const hw::TimingStats& s, const hw::TimingConfig& c);
// The timed engine's statistics in total, by ray type and by bounce, with its configuration.
Json timed_json(const hw::TimedEngine& e);
// What sampled timing simulated (hw::SampleStats), with the 95% interval of the cycles.
Json sample_json(const hw::SampleStats& s);

// A render's statistics: rays by type, commands, what was skipped and why, the unit's counters, and on the timed
// device its timing (in total, by ray type and bounce, the rasterizer's cycles and the frame's).
Json render_json(const RenderResult& r, const RenderOptions& o);

}  // namespace rtu::host
