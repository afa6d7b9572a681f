// The datapath's half of a node kind (format/node_kind.h): NodeTest<K> tests one node's children for a ray.
// A specialization provides
//   using RayState;                     the ray's constants for the kind's kernels, built once per ray, with a
//                                       bool `fast` the tracer clears when checking or when a unit is attached
//   RayState ray(FixedRay, FixedFormat)
//   int fast(RayState, Node, tmin, tlim, refs[], dists[])
//                                       the fast kernel: accepted children in slot order and their entry
//                                       distances, or -1 when the node is outside the kernel's bounds
//   int test<Int>(RayState, FixedRay, Node, tmin, tlim, refs[], dists[], on_child)
//                                       the reference path in Int arithmetic (int64_t for a narrow format,
//                                       Wide else), calling on_child(i, hit) for each occupied slot; bit for bit
//                                       the fast kernel's answer
//   BoxUnitNode unit_input(RayState, FixedRay, Node)   what an attached box unit (box_unit.h) is handed (a kind
//                                       no unit tests throws std::invalid_argument saying so)
//   bool exact(RayState, FixedRay, Node, i, tmin, tlim)   the exact oracle of child i (what the check counts
//                                       against)
// The one rule every kind keeps: conservative, no child the exact oracle hits is rejected (docs/numerics.md).
#pragma once

#include "hwmodel/format/node_kinds.h"

namespace rtu::hw {

template <class K>
struct NodeTest;

}  // namespace rtu::hw

// The kinds' tests, one include each.
#include "hwmodel/datapath/oriented_aabb_test.h"
#include "hwmodel/datapath/quantized_aabb_test.h"
