// The numerical-stability suite (`rtusim stress`): generated scenes and rays aimed at the places where ray
// tracers break, run on the float and fixed devices. Each category says what it checks and what counts as a
// failure: a broken promise of docs/architecture.md (a leak through a closed mesh, a box rejected that exact
// arithmetic accepts, a bad ray not rejected, a hit on a degenerate triangle, a self-hit from a properly offset
// origin, results that depend on the thread count). Figures that are not promises (precision losses the format
// implies) are reported beside the failures.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hwmodel/numeric/fixed_format.h"

namespace rtu::host {

struct StressOptions {
  uint64_t count = 20000;  // rays per category and scene variant
  hw::FixedFormat format;  // the fixed device's format
  int threads = 0;         // 0 = all cores; results do not depend on it
  uint64_t seed = 1;       // PCG32 seed of every generated case
};

struct StressResult {
  std::string name;          // category
  std::string checks;        // what it exercises
  std::string failure_rule;  // what counts as a failure
  uint64_t cases = 0;        // rays (or ray x device pairs, as the category says)
  uint64_t failures = 0;
  nlohmann::ordered_json figures;  // per-device counts and figures
  double seconds = 0.0;
};

// Names of the categories, in run order.
const std::vector<std::string>& stress_categories();
// Runs the named categories (all when empty). Throws Error for an unknown name.
std::vector<StressResult> run_stress(const StressOptions& o, const std::vector<std::string>& only = {});

}  // namespace rtu::host
