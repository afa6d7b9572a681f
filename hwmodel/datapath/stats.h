// Traversal statistics, counted around the datapath (never inside it) and summed over rays and threads.
#pragma once

#include <array>
#include <cstdint>

#include "hwmodel/interface/ray.h"

namespace rtu::hw {

struct TraversalStats {
  uint64_t rays = 0;                            // rays traced (valid ones)
  uint64_t hits = 0;                            // rays with a hit
  uint64_t nodes_visited = 0;                   // inner nodes popped and tested
  uint64_t leaves_visited = 0;                  // leaves whose primitives were tested
  uint64_t box_tests = 0;                       // child-box slab tests (occupied slots of visited nodes)
  uint64_t prim_tests = 0;                      // triangle, sphere and plane tests
  uint64_t invalid_rays = 0;                    // rays rejected at ray setup (reported as misses)
  std::array<uint64_t, 8> invalid_by_reason{};  // indexed by RayStatus
  uint64_t any_hit_calls = 0;    // candidate hits on non-opaque triangles handed to the any-hit stage (any_hit.h)
  uint64_t any_hit_ignored = 0;  // of those, the ones the stage ignored
  // Candidate hits on non-opaque triangles the unit resolved from their opacity micromap (micromap.h) without the
  // stage: an opaque micro-triangle (a hit) and a transparent one (no hit).
  uint64_t omm_opaque = 0, omm_transparent = 0;
  uint64_t first_invalid = UINT64_MAX;  // index of the first invalid ray of a batch (run_batch)
  RayStatus first_invalid_reason = RayStatus::kOk;
  // Fixed-point devices only (0 on the float device):
  uint64_t saturations = 0;          // values clamped to their format (fixed.h saturation_count) while tracing
  uint64_t box_checks = 0;           // box tests repeated by the exact checker (when checking is on)
  uint64_t box_false_negatives = 0;  // boxes the fixed test rejected and the exact test accepts: must be 0
  uint64_t box_false_positives = 0;  // boxes the fixed test accepted and the exact test rejects (looseness)
  uint64_t watchdog_rays = 0;        // rays stopped by the traversal watchdog (step bound); traced as misses

  void add(const TraversalStats& o);
  // A ray's setup status: false for kOk; else counts the ray as rejected for that reason and returns true.
  bool rejected(RayStatus status) {
    if (status == RayStatus::kOk) return false;
    ++invalid_rays;
    ++invalid_by_reason[size_t(status)];
    return true;
  }
  // What a bottom level's trace counts inside a top level's (instancing): work, not rays, hits or rejected rays
  // (the instanced ray is one ray, counted once by the top level).
  void add_work(const TraversalStats& o);
};

// The counters of work, which add() and add_work() sum; and those of rays, which add() sums too.
inline constexpr uint64_t TraversalStats::*kTraversalWorkCounters[] = {
    &TraversalStats::nodes_visited,       &TraversalStats::leaves_visited, &TraversalStats::box_tests,
    &TraversalStats::prim_tests,          &TraversalStats::any_hit_calls,  &TraversalStats::any_hit_ignored,
    &TraversalStats::saturations,         &TraversalStats::box_checks,     &TraversalStats::box_false_negatives,
    &TraversalStats::box_false_positives, &TraversalStats::watchdog_rays,  &TraversalStats::omm_opaque,
    &TraversalStats::omm_transparent};
inline constexpr uint64_t TraversalStats::*kTraversalRayCounters[] = {&TraversalStats::rays, &TraversalStats::hits,
                                                                      &TraversalStats::invalid_rays};

inline void TraversalStats::add_work(const TraversalStats& o) {
  for (uint64_t TraversalStats::*c : kTraversalWorkCounters) this->*c += o.*c;
}

inline void TraversalStats::add(const TraversalStats& o) {
  for (uint64_t TraversalStats::*c : kTraversalRayCounters) this->*c += o.*c;
  add_work(o);
  for (size_t i = 0; i < invalid_by_reason.size(); ++i) invalid_by_reason[i] += o.invalid_by_reason[i];
  if (o.first_invalid < first_invalid) {
    first_invalid = o.first_invalid;
    first_invalid_reason = o.first_invalid_reason;
  }
}

}  // namespace rtu::hw
