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
    out.xform_latency += k.instance;
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

namespace {

// Records each chunk of rays' events with trace(i, events) and replays them in the model.
template <class Trace>
MotionTiming replay(TimingModel& model, const std::vector<Ray>& rays, const Trace& trace) {
  MotionTiming out;
  out.hits.resize(rays.size());
  constexpr size_t kChunk = 4096;
  std::vector<std::vector<TraceEvent>> events(kChunk);
  model.begin(rays.size(), out.timing);
  for (size_t first = 0; first < rays.size(); first += kChunk) {
    const size_t m = std::min(kChunk, rays.size() - first);
    for (size_t i = 0; i < m; ++i) {
      events[i].clear();
      out.hits[first + i] = trace(first + i, out.traversal, events[i]);
    }
    model.feed(events.data(), m);
  }
  out.cycles = model.finish();
  return out;
}

void check_unit(MotionUnit u, const MotionFormat& m, bool moves) {
  if (u == MotionUnit::kTimeOblivious && m.box_time_bits != 0)
    throw std::invalid_argument("the time-oblivious unit tests boxes over the whole shutter: box_time_bits 0");
  if (u == MotionUnit::kStatic && moves) throw std::invalid_argument("the static unit's scene must not move");
}

}  // namespace

MotionTiming time_motion_rays(const MotionImage& im, MotionUnit u, const TimingConfig& c,
                              const std::vector<Ray>& rays, const std::vector<float>& times, bool any_hit) {
  validate_shutter_times(times, rays.size());
  check_motion_config(c);
  check_unit(u, im.motion, std::find(im.moving.begin(), im.moving.end(), 1) != im.moving.end());
  const MotionFixedTracer tracer(im);
  TimingModel model(motion_timing_config(c, u), motion_layout(im, u));
  return replay(model, rays, [&](size_t i, TraversalStats& s, std::vector<TraceEvent>& ev) {
    return tracer.trace_recorded(rays[i], times.empty() ? 0.0f : times[i], any_hit, s, ev,
                                 u == MotionUnit::kTimeOblivious);
  });
}

TimingModel::Layout motion_instance_layout(const MotionInstancedFixedTracer& t, MotionUnit u) {
  const auto up = [](uint64_t v) { return (v + 63) / 64 * 64; };
  TimingModel::Layout l;
  l.node_bytes = motion_node_bytes(t.format(), u);
  l.record_offset = up(t.node_count() * l.node_bytes);
  const uint64_t xform = StoredXform::bytes(t.format().xform_bits);
  l.instance_bytes = kRecordBytes + (u == MotionUnit::kTimeAware ? 2 : 1) * xform;
  l.record_stride = l.instance_bytes;
  l.plane_offset = up(l.record_offset + uint64_t(t.record_count()) * l.record_stride);
  TimingModel::append_bottoms(l, t.bottoms(), l.plane_offset, 0);
  return l;
}

MotionTiming time_motion_instance_rays(const MotionInstancedFixedTracer& t, MotionUnit u, const TimingConfig& c,
                                       const std::vector<Ray>& rays, const std::vector<float>& times,
                                       bool any_hit) {
  validate_shutter_times(times, rays.size());
  check_motion_config(c);
  bool moves = false;
  for (uint32_t i = 0; i < t.record_count(); ++i) moves |= t.record_moving(i);
  check_unit(u, t.motion(), moves);
  TimingModel model(motion_timing_config(c, u), motion_instance_layout(t, u));
  return replay(model, rays, [&](size_t i, TraversalStats& s, std::vector<TraceEvent>& ev) {
    return t.trace_recorded(rays[i], times.empty() ? 0.0f : times[i], any_hit, s, ev,
                            u == MotionUnit::kTimeOblivious);
  });
}

}  // namespace rtu::hw
