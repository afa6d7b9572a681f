#include "host/jobs/compare.h"

#include <algorithm>
#include <cmath>

#include "hwmodel/interface/enum_names.h"

namespace rtu::host {

const char* disagreement_name(Disagreement d) {
  static constexpr const char* names[] = {"false_miss", "false_hit", "other_primitive"};
  static_assert(hw::count_of(names) == std::size_t(Disagreement::kOtherPrimitive) + 1, "a name for every kind");
  return hw::enum_name(names, d, "?");
}

HitComparison compare_hits(const std::vector<hw::Hit>& ref, const std::vector<hw::Hit>& dev,
                           const std::vector<bool>& valid, bool any_hit, const std::vector<hw::Ray>* rays,
                           double grid_step) {
  HitComparison c;
  c.rays = ref.size();
  double t_sum = 0.0, t_sq = 0.0, abs_sum = 0.0;
  for (size_t i = 0; i < ref.size(); ++i) {
    if (!valid[i]) continue;
    const hw::Hit& a = ref[i];
    const hw::Hit& b = dev[i];
    ++c.compared;
    c.hit_agree += a.hit() == b.hit();
    c.prim_agree += a.prim == b.prim;
    if (a.hit() && !b.hit()) {
      ++c.false_misses;
      c.disagreements.push_back({i, Disagreement::kFalseMiss});
    } else if (!a.hit() && b.hit()) {
      ++c.false_hits;
      c.disagreements.push_back({i, Disagreement::kFalseHit});
    } else if (a.prim != b.prim && !any_hit) {
      ++c.other_prim;
      c.disagreements.push_back({i, Disagreement::kOtherPrimitive});
    }
    if (a.hit() && b.hit() && a.prim == b.prim && !any_hit) {
      const double rel = std::abs(double(b.t) - double(a.t)) / std::max(std::abs(double(a.t)), 1e-30);
      ++c.t_compared;
      t_sum += rel;
      t_sq += rel * rel;
      if (rel > c.t_rel_max) {
        c.t_rel_max = rel;
        c.t_rel_max_ray = i;
      }
      if (rays && grid_step > 0.0) {
        const hw::Vec3& d = (*rays)[i].dir;
        const double len = std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z);
        const double steps = std::abs(double(b.t) - double(a.t)) * len / grid_step;
        abs_sum += steps;
        if (steps > c.t_abs_steps_max) {
          c.t_abs_steps_max = steps;
          c.t_abs_steps_max_ray = i;
        }
      }
    }
  }
  c.t_rel_mean = c.t_compared ? t_sum / double(c.t_compared) : 0.0;
  if (c.t_compared > 1)
    c.t_rel_sd = std::sqrt(std::max(0.0, (t_sq - t_sum * c.t_rel_mean) / double(c.t_compared - 1)));
  c.t_abs_steps_mean = c.t_compared ? abs_sum / double(c.t_compared) : 0.0;
  return c;
}

}  // namespace rtu::host
