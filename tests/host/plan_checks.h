// Shared by the tests of plan as a host function (test_jobs.cpp, test_energy.cpp): a plan together with the
// candidates it weighed.
#pragma once

#include <vector>

#include "host/jobs/plan.h"
#include "host/jobs/sweep.h"

struct PlanWithCandidates {
  rtu::host::PlanResult result;
  std::vector<rtu::host::SweepRow> candidates;  // those that met the budget, in the order measured
};

// plan_format on `o`, with the candidates that met the budget. The base format, measured after
// PlanStage::kDefault for comparison only, is no candidate.
inline PlanWithCandidates plan_with_candidates(const rtu::host::PlanOptions& o) {
  PlanWithCandidates p;
  bool comparison = false;
  p.result = rtu::host::plan_format(o, [&](const rtu::host::PlanStep& s) {
    comparison = comparison || s.stage == rtu::host::PlanStage::kDefault;
    if (s.stage == rtu::host::PlanStage::kCandidate && s.meets && !comparison) p.candidates.push_back(*s.row);
  });
  return p;
}
