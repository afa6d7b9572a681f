// An A/B of two timed runs of one ray set: how design point B compares with design point A in cycles, rays per
// clock, what limits each, area, energy per ray and performance per mm^2, and whether the two found the same hits.
// `rtusim trace --against...` and the Python module's `rtu.ab` print and return the same figures from it.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "host/devices/device_settings.h"
#include "host/io/stats_json.h"
#include "hwmodel/interface/ray.h"

namespace rtu::host {

// One side of an A/B: its label, its statistics as `rtusim trace --stats` writes them (with a "timing" object),
// and its hits (empty when the run traced for cycles only, with --sample and no hits).
struct AbSide {
  std::string label;
  const Json* stats = nullptr;
  std::span<const hw::Hit> hits;
};

// {"a": {...}, "b": {...}, "speedup", "area_ratio", "energy_ratio", "unit_energy_ratio", "perf_per_area_ratio",
// "hits_compared", "hits_differ" (hit against miss or another primitive), "t_differ" (the same primitive at
// another t), "estimated", "verdict"}; each side carries label, config, format, cycles, rays_per_clock,
// limited_by, cycles_over_bound, area_mm2, pj_per_ray, unit_pj_per_ray, rays_per_clock_per_mm2. Ratios are B over
// A except speedup, A's cycles over B's (above 1: B is faster). Throws Error when a side has no timing or the two
// traced different numbers of rays.
Json ab_json(const AbSide& a, const AbSide& b);
// The comparison as lines of text: a table of the two sides and the verdict.
std::vector<std::string> ab_lines(const Json& ab);

// What `--against-config`, `--against-set` and `--against-format` change of design point A to make B.
struct AgainstSpec {
  std::string config;             // a timing preset replacing A's (and dropping A's --set), or "": A's
  std::vector<std::string> sets;  // KEY=VALUE applied after B's own, in order
  std::string format;             // a format spec replacing A's, or "": A's
  bool empty() const { return config.empty() && sets.empty() && format.empty(); }
};
DeviceSettings against_settings(const DeviceSettings& a, const AgainstSpec& spec);
// "rdna4-chip + l2_bytes_per_cycle=128, format rdna4": the configuration, its overrides and the format named.
std::string settings_label(const DeviceSettings& s);

}  // namespace rtu::host
