// The primitive kinds the unit knows (prim_kind.h), one row each, and the dispatch from a scene kind (the
// encoder, the shading normal) or a record (the image check, the tracers) to the kind's type.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>

#include "hwmodel/format/prim_curve.h"
#include "hwmodel/format/prim_kind.h"
#include "hwmodel/format/prim_plane.h"
#include "hwmodel/format/prim_sphere.h"
#include "hwmodel/format/prim_triangle.h"

namespace rtu::hw {

struct PrimitiveKindInfo {
  PrimKind id;
  const char* name;  // as reports and errors name it
  bool bounded;      // in the BVH, as a 40-byte record (else per ray, in the plane section)
};
inline constexpr PrimitiveKindInfo kPrimitiveKinds[] = {
    {TrianglePrim::kId, TrianglePrim::kName, true},
    {SpherePrim::kId, SpherePrim::kName, true},
    {PlanePrim::kId, PlanePrim::kName, false},
    {CurvePrim::kId, CurvePrim::kName, true},
};

// Calls f with a value of the kind type of scene kind k and returns what it returns.
template <class F>
decltype(auto) with_prim_kind(PrimKind k, F&& f) {
  switch (k) {
    case PrimKind::kTriangle:
      return f(TrianglePrim{});
    case PrimKind::kSphere:
      return f(SpherePrim{});
    case PrimKind::kCurve:
      return f(CurvePrim{});
    case PrimKind::kPlane:
      return f(PlanePrim{});
  }
  throw std::logic_error("with_prim_kind: no kind " + std::to_string(int(k)));
}

// Calls f with the bounded kind type of a record's kind (a triangle pair's records are triangles); returns false
// without calling f for an instance or an unknown kind.
template <class F>
bool with_record_prim(RecordKind k, F&& f) {
  switch (k) {
    case RecordKind::kTriangle:
    case RecordKind::kTrianglePair:
      f(TrianglePrim{});
      return true;
    case RecordKind::kSphere:
      f(SpherePrim{});
      return true;
    case RecordKind::kCurve:
      f(CurvePrim{});
      return true;
    case RecordKind::kInstance:
    case RecordKind::kUnknown:
      break;
  }
  return false;
}

// The shading normal of a hit on scene primitive p at `at` (not normalized; u as the hit's).
// The cost class of a record (its kind field and round word, record_kind): its primitive kind's, but a triangle
// pair's two tests are one request and an instance record is a transform.
inline TestCost record_cost(RecordKind k) {
  if (k == RecordKind::kTrianglePair) return TestCost::kTrianglePair;
  if (k == RecordKind::kInstance) return TestCost::kTransform;
  TestCost cost{};
  if (!with_record_prim(k, [&](auto kind) { cost = decltype(kind)::kCost; }))
    throw std::logic_error("record_cost: a record of no kind (the image check refuses it)");
  return cost;
}

inline Vec3 prim_normal(const Geometry& g, uint32_t p, const Vec3& at, float u) {
  return with_prim_kind(g.kind(p), [&](auto k) { return decltype(k)::normal(g, p, at, u); });
}

static_assert(PrimitiveKind<TrianglePrim> && PrimitiveKind<SpherePrim> && PrimitiveKind<CurvePrim>);

}  // namespace rtu::hw
