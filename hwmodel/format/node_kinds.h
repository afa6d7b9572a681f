// The node kinds the unit knows (node_kind.h), one row each, and the one dispatch from an image's (kind, width,
// offset bytes) to the kind's type.
#pragma once

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>

#include "hwmodel/format/node_kind.h"
#include "hwmodel/format/oriented_aabb.h"
#include "hwmodel/format/quantized_aabb.h"

namespace rtu::hw {

struct NodeKindInfo {
  NodeKindId id;
  const char* name;  // as reports and errors name it
  NodeCostClass cost;
  uint32_t image_flags;                                    // the header flag bits of the kind's own (image_flags)
  void (*from_image_flags)(uint32_t flags, FixedFormat&);  // the format fields they hold; null: none
  const char* flag_fields;                                 // what those bits are, as errors name them
};
inline constexpr NodeKindInfo kNodeKinds[] = {
    {NodeKindId::kQuantizedAabb, "quantized-aabb", NodeCostClass::kAxisAligned, 0, nullptr, ""},
    {NodeKindId::kOrientedAabb, "oriented-aabb", NodeCostClass::kOriented, kOrientedImageFlags,
     oriented_from_image_flags, "rotation table"},
};

// The kind's row, or null for an id no kind has.
inline const NodeKindInfo* find_node_kind(uint32_t id) {
  for (const NodeKindInfo& k : kNodeKinds)
    if (uint32_t(k.id) == id) return &k;
  return nullptr;
}

// Calls f with a value of the kind type for (id, width, q_bytes) and returns what it returns. Widths 2, 4, 6, 8;
// q_bytes 1 or 2 (the image check has refused anything else; std::logic_error here means a caller skipped it).
template <template <int, class> class Kind, class F>
decltype(auto) with_kind_width(int width, bool q8, F&& f) {
  switch (width) {
    case 2:
      return q8 ? f(Kind<2, uint8_t>{}) : f(Kind<2, uint16_t>{});
    case 4:
      return q8 ? f(Kind<4, uint8_t>{}) : f(Kind<4, uint16_t>{});
    case 6:
      return q8 ? f(Kind<6, uint8_t>{}) : f(Kind<6, uint16_t>{});
    case 8:
      return q8 ? f(Kind<8, uint8_t>{}) : f(Kind<8, uint16_t>{});
    default:
      throw std::logic_error("with_node_kind: width " + std::to_string(width));
  }
}

template <class F>
decltype(auto) with_node_kind(NodeKindId id, int width, int q_bytes, F&& f) {
  if (q_bytes != 1 && q_bytes != 2)
    throw std::logic_error("with_node_kind: no kind with " + std::to_string(q_bytes) + "-byte offsets");
  switch (id) {
    case NodeKindId::kQuantizedAabb:
      return with_kind_width<QuantizedAabb>(width, q_bytes == 1, std::forward<F>(f));
    case NodeKindId::kOrientedAabb:
      return with_kind_width<OrientedAabb>(width, q_bytes == 1, std::forward<F>(f));
  }
  throw std::logic_error("with_node_kind: no kind " + std::to_string(int(id)));
}

// Bytes of the kind's stored struct (a node in the struct layout, and as a bound image decodes packed nodes).
inline size_t node_struct_bytes(NodeKindId id, int width, int q_bytes) {
  return with_node_kind(id, width, q_bytes, [](auto k) { return sizeof(typename decltype(k)::Node); });
}

static_assert(NodeKind<QuantizedAabb<4, uint8_t>> && NodeKind<QuantizedAabb<8, uint16_t>>);
static_assert(NodeKind<OrientedAabb<4, uint8_t>> && NodeKind<OrientedAabb<8, uint16_t>>);

}  // namespace rtu::hw
