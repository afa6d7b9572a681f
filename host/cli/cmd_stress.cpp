// rtusim stress: the numerical-stability suite (host/jobs/stress.h) on the float and fixed devices. Prints one
// line per category and exits 1 when any promise of docs/architecture.md broke.
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/jobs/stress.h"

namespace rtu::host::cli {

namespace {

struct StressArgs {
  uint64_t count = 20000;
  uint64_t seed = 1;
  int threads = 0;
  std::string json;
  std::vector<std::string> only;
  DeviceArgs dev;
};

void run(const StressArgs& a) {
  StressOptions o;
  o.count = a.count;
  o.seed = a.seed;
  o.threads = a.threads;
  o.format = a.dev.fixed_format();
  const std::vector<StressResult> results = run_stress(o, a.only);
  uint64_t failures = 0, cases = 0;
  std::printf("rtusim stress: float and fixed (%s), %llu rays per category\n", o.format.describe().c_str(),
              (unsigned long long)o.count);
  std::printf("%-21s %10s %9s %8s\n", "category", "cases", "failures", "seconds");
  Json cats = Json::array();
  for (const StressResult& r : results) {
    std::printf("%-21s %10llu %9llu %8.2f\n", r.name.c_str(), (unsigned long long)r.cases,
                (unsigned long long)r.failures, r.seconds);
    failures += r.failures;
    cases += r.cases;
    cats.push_back({{"name", r.name},
                    {"checks", r.checks},
                    {"failure_rule", r.failure_rule},
                    {"cases", r.cases},
                    {"failures", r.failures},
                    {"seconds", r.seconds},
                    {"figures", r.figures}});
  }
  std::printf("%-21s %10llu %9llu\n", "total", (unsigned long long)cases, (unsigned long long)failures);
  if (!a.json.empty()) {
    Json j;
    j["format"] = format_json(o.format);
    j["count"] = o.count;
    j["seed"] = o.seed;
    j["cases"] = cases;
    j["failures"] = failures;
    j["categories"] = cats;
    write_json(a.json, j);
  }
  if (failures > 0) {
    std::fprintf(stderr, "rtusim: stress: %llu failures (see the categories above%s)\n",
                 (unsigned long long)failures, a.json.empty() ? "; --json F gives details" : " and the JSON");
    throw ExitStatus(1);
  }
}

}  // namespace

void add_stress(CLI::App& app) {
  const auto [sub, a] = add_command<StressArgs>(
      app, "stress", "Numerical-stability suite on the float and fixed devices; exits 1 if a promise breaks",
      [](StressArgs& a, CLI::App&) { run(a); });
  sub->add_option("--count", a->count, "rays per category and scene variant")
      ->check(CLI::Range(uint64_t(1), uint64_t(100000000)))
      ->capture_default_str();
  sub->add_option("--seed", a->seed, "seed of the generated cases")->capture_default_str();
  sub->add_option("--threads", a->threads, "worker threads (0 = all cores); results do not depend on it")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  sub->add_option("--category", a->only, "run only these categories (repeatable)")
      ->check(CLI::IsMember(stress_categories()));
  sub->add_option("--json", a->json, "write per-category results as JSON to this file");
  add_format_args(*sub, a->dev);
}

}  // namespace rtu::host::cli
