// What one node's test costs the box unit, by the cost class of the image's node kind (format/node_kind.h): the
// clocks the unit's input is busy for a node of c children, and the clocks from issue to result. A kind with a
// new class adds a case here and its keys to timing_config.cpp.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <stdexcept>

#include "hwmodel/format/node_kind.h"
#include "hwmodel/timing/timing_config.h"

namespace rtu::hw {

struct BoxCost {
  std::array<uint64_t, 256> issue{};  // by child count
  uint64_t latency = 0;
};

inline BoxCost box_cost(const TimingConfig& c, NodeCostClass k) {
  BoxCost b;
  switch (k) {
    case NodeCostClass::kAxisAligned:
      // ceil(c / box_rate) clocks, at least one even for a node without children (as the RTL unit's sequencer).
      for (uint64_t n = 0; n < b.issue.size(); ++n)
        b.issue[n] = std::max<uint64_t>(1, (n + uint64_t(c.box_rate) - 1) / uint64_t(c.box_rate));
      b.latency = uint64_t(c.box_latency);
      return b;
    case NodeCostClass::kOriented:
      // The slab tests issue as the axis-aligned ones; the rotation stage in front adds its clocks.
      b = box_cost(c, NodeCostClass::kAxisAligned);
      b.latency += uint64_t(c.obb_latency);
      return b;
  }
  throw std::logic_error("box_cost: unknown cost class");
}

}  // namespace rtu::hw
