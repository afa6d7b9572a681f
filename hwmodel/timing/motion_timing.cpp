#include "hwmodel/timing/motion_timing.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "hwmodel/format/node_kinds.h"

namespace rtu::hw {

const char* motion_unit_name(MotionUnit u) {
  switch (u) {
    case MotionUnit::kStatic:
      return "static";
    case MotionUnit::kTimeAware:
      return "time-aware";
    case MotionUnit::kTimeOblivious:
      return "time-oblivious";
  }
  return "?";
}

TimingConfig motion_timing_config(const TimingConfig& c, MotionUnit u, const MotionInterpolationClocks& k) {
  TimingConfig out = c;
  if (u == MotionUnit::kTimeAware) {
    out.box_latency += k.box;
    out.tri_latency += k.triangle;
    out.sphere_latency += k.round;
    out.curve_latency += k.round;
  }
  out.validate();
  return out;
}

uint64_t motion_node_bytes(const FixedFormat& f, MotionUnit u) {
  const uint64_t base = node_struct_bytes(NodeKindId::kQuantizedAabb, f.width, f.offset_bytes());
  return u == MotionUnit::kTimeAware ? base + 6u * uint64_t(f.width) * uint64_t(f.offset_bytes()) : base;
}

TimingModel::Layout motion_layout(const MotionImage& im, MotionUnit u) {
  TimingModel::Layout l;
  l.node_bytes = motion_node_bytes(im.format, u);
  l.node_offset = 0;
  const uint64_t nodes_end = im.node_count() * l.node_bytes;
  l.record_offset = (nodes_end + 63) / 64 * 64;
  uint64_t at = l.record_offset;
  l.record_spans.reserve(im.prim_ids.size());
  for (const uint32_t p : im.prim_ids) {
    const uint32_t bytes = u == MotionUnit::kTimeAware && im.moving[p] ? (p < im.triangles() ? 76u : 72u) : 40u;
    l.record_spans.push_back(DeviceImage::Span{at, bytes});
    at += bytes;
  }
  l.plane_offset = l.total_bytes = (at + 63) / 64 * 64;
  return l;
}

void check_motion_config(const TimingConfig& c) {
  if (c.units > 1)
    throw std::invalid_argument("motion blur is timed on one unit; the configuration has " +
                                std::to_string(c.units) + " units (set units=1, or a one-unit preset)");
}

MotionTiming time_motion_rays(const MotionImage& im, MotionUnit u, const TimingConfig& c,
                              const std::vector<Ray>& rays, const std::vector<float>& times, bool any_hit) {
  validate_shutter_times(times, rays.size());
  if (c.units > 1)
    throw std::invalid_argument("motion blur is timed on one unit; the configuration has " +
                                std::to_string(c.units) + " units (set units=1, or a one-unit preset)");
  if (u == MotionUnit::kTimeOblivious && im.motion.box_time_bits != 0)
    throw std::invalid_argument("the time-oblivious unit tests boxes over the whole shutter: box_time_bits 0");
  if (u == MotionUnit::kStatic && std::find(im.moving.begin(), im.moving.end(), 1) != im.moving.end())
    throw std::invalid_argument("the static unit's scene must not move");
  const TimingConfig cfg = motion_timing_config(c, u);
  const MotionFixedTracer tracer(im);
  TimingModel model(cfg, motion_layout(im, u));
  MotionTiming out;
  out.hits.resize(rays.size());
  constexpr size_t kChunk = 4096;
  std::vector<std::vector<TraceEvent>> events(kChunk);
  model.begin(rays.size(), out.timing);
  for (size_t first = 0; first < rays.size(); first += kChunk) {
    const size_t m = std::min(kChunk, rays.size() - first);
    for (size_t i = 0; i < m; ++i) {
      events[i].clear();
      out.hits[first + i] =
          tracer.trace_recorded(rays[first + i], times.empty() ? 0.0f : times[first + i], any_hit, out.traversal,
                                events[i], u == MotionUnit::kTimeOblivious);
    }
    model.feed(events.data(), m);
  }
  out.cycles = model.finish();
  return out;
}

}  // namespace rtu::hw
