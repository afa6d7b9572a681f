#include "host/scene/curves.h"

#include <algorithm>
#include <limits>
#include <numeric>

#include "host/io/error.h"
#include "host/scene/scene.h"

namespace rtu::host {

void add_curve_set(hw::Geometry& g, std::span<const hw::Vec3> points, std::span<const float> radii,
                   std::span<const uint32_t> starts, const std::string& what) {
  if (radii.size() != points.size())
    throw Error(what + ": " + std::to_string(radii.size()) + " radii for " + std::to_string(points.size()) +
                " points");
  std::vector<uint32_t> sorted(starts.begin(), starts.end());
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < starts.size(); ++i) {
    const uint32_t s = starts[i];
    if (uint64_t(s) + 1 >= points.size())
      throw Error(what + ": segment " + std::to_string(i) + " starts at point " + std::to_string(s) +
                  ", which has no next point (" + std::to_string(points.size()) + " points)");
    const bool joined = s > 0 && std::binary_search(sorted.begin(), sorted.end(), s - 1);
    const hw::CurveSegment c{points[s], radii[s], points[s + 1], radii[s + 1], joined ? 0u : hw::kCurveCapStart};
    if (const std::string why = hw::check_curve_segment(c); !why.empty())
      throw Error(what + ": segment " + std::to_string(i) + ": " + why);
    g.curves.push_back(c);
  }
}

void add_lines(hw::Geometry& g, std::span<const ImportedLine> lines, float radius,
               const std::function<hw::Vec3(const hw::Vec3&)>& transform, const std::string& what) {
  for (size_t i = 0; i < lines.size(); ++i) {
    const hw::CurveSegment c{transform(lines[i].p0), radius, transform(lines[i].p1), radius,
                             lines[i].joined ? 0u : hw::kCurveCapStart};
    if (const std::string why = hw::check_curve_segment(c); !why.empty())
      throw Error(what + ": line " + std::to_string(i) + ": " + why);
    g.curves.push_back(c);
  }
}

float default_line_radius(const hw::Aabb& bounds) {
  const double d = bounds.empty() ? 0.0 : glm::length(hw::DVec3(bounds.hi) - hw::DVec3(bounds.lo));
  return std::max(float(1e-3 * d), std::numeric_limits<float>::min());
}

void add_strand(hw::Geometry& g, std::span<const hw::Vec3> points, std::span<const float> radii,
                const std::string& what) {
  std::vector<uint32_t> starts(points.size() > 1 ? points.size() - 1 : 0);
  std::iota(starts.begin(), starts.end(), 0u);
  add_curve_set(g, points, radii, starts, what);
}

}  // namespace rtu::host
