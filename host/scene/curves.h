// Curve sets as scene files and generators describe them (Embree's round linear curves): points, a radius per
// point, and the index of each segment's first point (segment i joins points[start[i]] and points[start[i] + 1]).
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "hwmodel/scene/geometry.h"

namespace rtu::host {

struct ImportedLine;  // scene.h

// Appends one curve set's segments to g. A segment holds its start sphere (kCurveCapStart) when no segment of
// the set ends at its first point (no segment starts at start[i] - 1), as Embree caps a strand's first segment.
// Throws host::Error naming `what` for an index out of range or a segment check_curve_segment refuses.
void add_curve_set(hw::Geometry& g, std::span<const hw::Vec3> points, std::span<const float> radii,
                   std::span<const uint32_t> starts, const std::string& what);

// A mesh file's lines (ImportedLine, scene.h) as curve segments of radius `radius`, in their order: a line that
// joins the one before it continues its strand, the others hold their start spheres. `transform` maps each end
// point (a scene file's mesh transform; identity for a bare mesh file). Throws host::Error naming `what` for a
// segment check_curve_segment refuses.
void add_lines(hw::Geometry& g, std::span<const ImportedLine> lines, float radius,
               const std::function<hw::Vec3(const hw::Vec3&)>& transform, const std::string& what);

// The radius a mesh file's lines get when the scene names none: a thousandth of the diagonal of `bounds` (the
// file's triangles and lines), at least the smallest normal float.
float default_line_radius(const hw::Aabb& bounds);

// One strand: consecutive points, a segment between each pair.
void add_strand(hw::Geometry& g, std::span<const hw::Vec3> points, std::span<const float> radii,
                const std::string& what);

}  // namespace rtu::host
