// PrimTest<K>: the datapath's half of primitive kind K, declared here and specialized in prim_<kind>_test.h
// (prim_test.h says what each gives).
#pragma once

#include "hwmodel/format/prim_kinds.h"
#include "hwmodel/interface/vec.h"

namespace rtu::hw {

// A leaf-ordered copy of a bounded primitive, so a leaf's primitives are contiguous in memory.
struct LeafPrim {
  Vec3 a, b, c;   // triangle vertices; a sphere has its center in a and its radius in b.x; a curve segment has
                  // p0 in a, p1 in b, r0 and r1 in c.x and c.y
  uint32_t prim;  // scene primitive index, with kLeafNonOpaque for a non-opaque triangle, kLeafCurve for a curve
                  // segment (and kLeafCapStart for its start sphere)
};
inline constexpr uint32_t kLeafNonOpaque = 1u << 31;
inline constexpr uint32_t kLeafCurve = 1u << 30;
inline constexpr uint32_t kLeafCapStart = 1u << 29;
inline constexpr uint32_t kLeafPrimMask = kLeafCapStart - 1;  // scene indices are below kMaxBvhPrims = 2^27
static_assert(sizeof(LeafPrim) == 40);

template <class K>
struct PrimTest;

}  // namespace rtu::hw
