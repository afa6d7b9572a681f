// Curve sets as scene files and generators describe them (Embree's round linear curves): points, a radius per
// point, and the index of each segment's first point (segment i joins points[start[i]] and points[start[i] + 1]).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "hwmodel/scene/geometry.h"

namespace rtu::host {

// Appends one curve set's segments to g. A segment holds its start sphere (kCurveCapStart) when no segment of
// the set ends at its first point (no segment starts at start[i] - 1), as Embree caps a strand's first segment.
// Throws host::Error naming `what` for an index out of range or a segment check_curve_segment refuses.
void add_curve_set(hw::Geometry& g, std::span<const hw::Vec3> points, std::span<const float> radii,
                   std::span<const uint32_t> starts, const std::string& what);

// One strand: consecutive points, a segment between each pair.
void add_strand(hw::Geometry& g, std::span<const hw::Vec3> points, std::span<const float> radii,
                const std::string& what);

}  // namespace rtu::host
