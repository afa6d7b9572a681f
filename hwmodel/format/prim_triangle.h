// The triangle primitive kind (prim_kind.h): its record, encoder, check, orientation points and shading normal.
// Its tests: datapath/prim_triangle_test.h. A triangle pair (RecordKind::kTrianglePair, format tri_pairs) is two
// records of this kind tested as one request.
#pragma once

#include <algorithm>
#include <cstring>
#include <string>

#include "hwmodel/format/prim_kind.h"

namespace rtu::hw {

// Vertices on the grid, rounded to nearest, so that triangles sharing an edge share it exactly (watertight).
struct TriangleRecord {
  int32_t v[3][3];  // vertices v0, v1, v2 on the grid (integers in [0, 2^B - 1]), rounded to nearest
  uint32_t prim;    // kind, kRecordNonOpaque, scene primitive index (prim_kind.h)
};
static_assert(sizeof(TriangleRecord) == kRecordBytes && offsetof(TriangleRecord, prim) == 36);

// True when triangles a and b share an edge: two of a's grid vertices are two of b's.
inline bool share_edge(const TriangleRecord& a, const TriangleRecord& b) {
  int same = 0;
  for (const auto& va : a.v)
    for (const auto& vb : b.v) same += va[0] == vb[0] && va[1] == vb[1] && va[2] == vb[2];
  return same == 2;
}

struct TrianglePrim {
  using Record = TriangleRecord;
  static constexpr PrimKind kId = PrimKind::kTriangle;
  static constexpr RecordKind kRecord = RecordKind::kTriangle;
  static constexpr const char* kName = "triangle";
  static constexpr TestCost kCost = TestCost::kTriangle;

  static void encode(const RecordEncoding& e, uint32_t p, uint8_t* out, GridBox& box) {
    const Triangle& t = e.g.triangles[p];
    TriangleRecord rec{};
    const Vec3* v[3] = {&t.v0, &t.v1, &t.v2};
    for (int i = 0; i < 3; ++i) {
      for (int a = 0; a < 3; ++a) {
        const int64_t g = e.frame.to_grid((*v[i])[a], a, Round::kNearestEven);
        rec.v[i][a] = int32_t(g);  // in [0, 2^B - 1]: the vertex lies inside the frame's bounds
        box.lo[a] = std::min(box.lo[a], g);
        box.hi[a] = std::max(box.hi[a], g);
      }
    }
    rec.prim = record_word(RecordKind::kTriangle, p, !e.g.opaque(p));
    std::memcpy(out, &rec, sizeof rec);
  }

  // Index in range, vertices on the grid; a pair's second the next record, a single triangle sharing an edge.
  static std::string check(const RecordCheck& c, const uint8_t* rec) {
    const std::string at = "record " + std::to_string(c.index);
    TriangleRecord t;
    std::memcpy(&t, rec, sizeof t);
    if ((t.prim & kRecordPrimMask) >= c.num_triangles) return at + ": triangle index out of range";
    const int64_t grid_max = (int64_t(1) << c.f.coord_bits) - 1;
    for (const auto& v : t.v)
      for (int32_t x : v)
        if (x < 0 || x > grid_max) return at + ": vertex outside the grid";
    if (record_kind(rec) == RecordKind::kTrianglePair) {
      TriangleRecord second;
      if (!c.next || record_kind(c.next) != RecordKind::kTriangle)
        return at + ": a triangle pair without its second triangle";
      std::memcpy(&second, c.next, sizeof second);
      if (!share_edge(t, second)) return at + ": a triangle pair whose triangles share no edge";
    }
    return "";
  }

  // Its vertices: its hull lies within them.
  static void orient_points(const uint8_t* rec, const GridBox&, const FixedFormat&, OrientPoints& pts) {
    TriangleRecord tr;
    std::memcpy(&tr, rec, sizeof tr);
    for (pts.n = 0; pts.n < 3; ++pts.n)
      for (int a = 0; a < 3; ++a) pts.p[pts.n][a] = tr.v[pts.n][a];
  }

  // The geometric normal (v1 - v0) x (v2 - v0).
  static Vec3 normal(const Geometry& g, uint32_t p, const Vec3&, float) {
    const Triangle& t = g.triangles[p];
    return glm::cross(t.v1 - t.v0, t.v2 - t.v0);
  }
};

}  // namespace rtu::hw
