// Where the timing model finds an image's items in device memory (TimingModel::layout_of): the sections of one
// image, or a two-level scene's top level with its bottom levels after it, each item at its own stride when the
// unit aligns them (layout_align) and a block's or cluster's bytes where the image's decoding placed them. The
// fetches of simulate() and the walks address lines through it.
#include "hwmodel/timing/timing_model.h"

#include <algorithm>
#include <vector>

#include "hwmodel/format/node_kinds.h"

namespace rtu::hw {

TimingModel::Layout TimingModel::layout_of(const DeviceImage& image, uint64_t align) {
  const ImageHeader& h = image.header();
  Layout l;
  l.node_bytes = image.node_bytes();
  l.node_cost = find_node_kind(uint32_t(node_kind(h)))->cost;  // the image check refused unknown kinds
  l.record_spans = image.record_spans();
  l.cluster_node_begin = h.node_count;
  l.cluster_node_spans = image.cluster_node_spans();
  l.cluster_record_flags = image.cluster_record_flags();
  if (align == 0) {
    l.node_offset = h.node_offset;
    l.record_offset = h.record_offset;
    l.plane_offset = h.plane_offset;
    l.total_bytes = h.total_bytes;
    return l;
  }
  auto up = [align](uint64_t v) { return (v + align - 1) / align * align; };
  l.node_stride = up(l.node_bytes);
  l.record_stride = up(kRecordBytes);
  l.plane_stride = up(sizeof(PlaneRecord));
  l.node_offset = up(h.node_offset);
  l.record_offset = up(l.node_offset + uint64_t(h.node_count) * l.node_stride);
  uint64_t record_end = l.record_offset + uint64_t(h.record_count) * l.record_stride;
  if (!l.cluster_node_spans.empty()) {  // each cluster or block starts on the alignment, in the image's order
    std::vector<DeviceImage::Span*> spans;
    for (DeviceImage::Span& s : l.record_spans)
      if (s.bytes > 0) spans.push_back(&s);
    for (DeviceImage::Span& s : l.cluster_node_spans)
      if (s.bytes > 0) spans.push_back(&s);
    std::sort(spans.begin(), spans.end(), [](const auto* a, const auto* b) { return a->offset < b->offset; });
    uint64_t at = l.record_offset;
    for (DeviceImage::Span* s : spans) {
      s->offset = at;
      at = up(at + s->bytes);
    }
    record_end = at;
  } else if (!l.record_spans.empty()) {  // each block starts on the alignment
    uint64_t at = l.record_offset;
    for (DeviceImage::Span& s : l.record_spans) {
      if (s.bytes == 0) continue;
      s.offset = at;
      at = up(at + s.bytes);
    }
    record_end = at;
  }
  l.plane_offset = up(record_end);
  l.total_bytes = l.plane_offset + uint64_t(h.plane_count) * l.plane_stride;
  return l;
}

TimingModel::Layout TimingModel::layout_of(const InstancedFixedTracer& t, uint64_t align,
                                           uint64_t instance_bytes) {
  auto up = [](uint64_t v, uint64_t to) { return (v + to - 1) / to * to; };
  Layout top = layout_of(t.top(), align);
  const ImageHeader& h = t.top().header();
  // The instance records grow by the stored transform and the bottom level's address; the planes move after.
  top.instance_bytes = instance_bytes > 0
                           ? instance_bytes
                           : kRecordBytes + t.transform_bytes() / std::max<size_t>(1, t.instance_count());
  top.record_stride = align ? up(top.instance_bytes, align) : top.instance_bytes;
  const uint64_t planes = top.plane_stride ? top.plane_stride : sizeof(PlaneRecord);
  top.plane_offset = up(top.record_offset + uint64_t(h.record_count) * top.record_stride, align ? align : 8);
  append_bottoms(top, t, top.plane_offset + uint64_t(h.plane_count) * planes, align);
  return top;
}

void TimingModel::append_bottoms(Layout& top, const InstancedFixedTracer& t, uint64_t end, uint64_t align) {
  const uint64_t a = std::max<uint64_t>(64, align);
  auto up = [](uint64_t v, uint64_t to) { return (v + to - 1) / to * to; };
  for (size_t m = 0; m < t.bottom_count(); ++m) {
    Layout b = layout_of(t.bottom(uint32_t(m)), align);
    const uint64_t base = up(end, a);
    b.node_offset += base;
    b.record_offset += base;
    b.plane_offset += base;
    for (DeviceImage::Span& sp : b.record_spans) sp.offset += base;
    for (DeviceImage::Span& sp : b.cluster_node_spans) sp.offset += base;
    end = base + b.total_bytes;
    b.total_bytes = end;
    top.bottoms.push_back(std::move(b));
  }
  top.total_bytes = end;
}

}  // namespace rtu::hw
