// Procedural meshes for built-in scenes and the "generate" entries of scene files.
//
// Every generator builds an indexed mesh: each vertex is computed exactly once, and faces refer to vertices by
// index. Expanding the faces into triangles copies the vertices, so triangles that share a vertex share its
// exact float bits, and a closed generated mesh stays watertight (docs/architecture.md, "Numerics promises"). To
// keep that, transform the indexed vertices (once each) before expanding, never the expanded triangles.
// All generated closed meshes are consistently wound, counter-clockwise seen from outside.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "hwmodel/interface/vec.h"
#include "hwmodel/scene/geometry.h"

namespace rtu::host {

struct IndexedMesh {
  std::vector<hw::Vec3> vertices;              // each computed once
  std::vector<std::array<uint32_t, 3>> faces;  // indices into vertices
  std::vector<std::array<float, 2>> uvs;       // texture coordinates per vertex, or empty (none)
};

inline constexpr int kMaxIcosphereSubdiv = 8;  // 20 * 4^8 = 1,310,720 triangles
inline constexpr int kMinTorusSegments = 3;
inline constexpr int kMaxTorusSegments = 4096;

// Subdivided icosahedron: 20 * 4^subdiv triangles, 10 * 4^subdiv + 2 vertices. Each vertex is the unit-sphere
// direction (computed in double, edge midpoints cached per edge) times `radius`, rounded to float, plus `offset`
// added in float, once per vertex. Closed and watertight. subdiv in [0, kMaxIcosphereSubdiv], radius > 0.
IndexedMesh make_icosphere(int subdiv, float radius, hw::Vec3 offset = hw::Vec3(0.0f));

// Torus around the y axis, centered at the origin: major_segments * minor_segments * 2 triangles. Closed.
// Radii > 0; segment counts in [kMinTorusSegments, kMaxTorusSegments].
IndexedMesh make_torus(float major_radius, float minor_radius, int major_segments, int minor_segments);

// Axis-aligned box centered at the origin with edge lengths `size` (> 0): 8 vertices, 12 triangles. Closed.
IndexedMesh make_box(hw::Vec3 size);

// Rectangle in the y = 0 plane centered at the origin, size_x by size_z (> 0), facing +y: 2 triangles. Texture
// coordinates s = x / size_x + 1/2, t = z / size_z + 1/2: the texture covers it once.
IndexedMesh make_quad(float size_x, float size_z);

// Appends the faces of `mesh` to `out` as triangles, in face order.
void append_triangles(const IndexedMesh& mesh, std::vector<hw::Triangle>& out);

}  // namespace rtu::host
