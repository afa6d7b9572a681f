// rtusim soak: random valid scenes and formats, traced and rendered twice, for a bounded time (host/jobs/soak.h).
#include <cstdio>
#include <memory>

#include "host/cli/common.h"
#include "host/io/error.h"
#include "host/jobs/soak.h"

namespace rtu::host::cli {

namespace {

struct SoakArgs {
  SoakOptions o;
  std::string json;
};

void run_soak(const SoakArgs& a) {
  const SoakResult r = soak(a.o);
  std::printf(
      "soak: %llu iterations in %.1f s (seeds %llu..%llu): %llu primitives, %llu rays traced, %llu renders "
      "(%llu pixels), %llu cycles simulated; %zu mismatches; digest %016llx\n",
      (unsigned long long)r.iterations, r.seconds, (unsigned long long)a.o.seed,
      (unsigned long long)(a.o.seed + r.iterations - 1), (unsigned long long)r.prims, (unsigned long long)r.rays,
      (unsigned long long)r.renders, (unsigned long long)r.pixels, (unsigned long long)r.cycles,
      r.mismatches.size(), (unsigned long long)r.digest);
  for (const std::string& m : r.mismatches) std::fprintf(stderr, "rtusim soak: mismatch: %s\n", m.c_str());
  if (!a.json.empty()) {
    Json j;
    j["iterations"] = r.iterations;
    j["seconds"] = r.seconds;
    j["seed"] = a.o.seed;
    j["primitives"] = r.prims;
    j["scenes_with_bvh"] = r.scenes_with_bvh;
    j["rays"] = r.rays;
    j["renders"] = r.renders;
    j["pixels"] = r.pixels;
    j["cycles"] = r.cycles;
    j["digest"] = r.digest;
    j["mismatches"] = r.mismatches;
    write_json(a.json, j);
  }
  if (!r.mismatches.empty()) throw ExitStatus(1);
}

}  // namespace

void add_soak(CLI::App& app) {
  const auto [sub, a] = add_command<SoakArgs>(
      app, "soak", "Random valid scenes and formats, traced and rendered twice each: identical bits and cycles",
      [](SoakArgs& a, CLI::App&) { run_soak(a); });
  sub->add_option("--seconds", a->o.seconds, "run new iterations until this much wall time has passed")
      ->check(CLI::Range(0.0, 1e6))
      ->capture_default_str();
  sub->add_option("--iterations", a->o.max_iterations, "at most this many iterations (0: no bound)")
      ->capture_default_str();
  sub->add_option("--seed", a->o.seed, "iteration i uses seed + i")->capture_default_str();
  sub->add_flag("--verbose", a->o.verbose, "one line per iteration on stderr");
  sub->add_option("--json", a->json, "write the figures as JSON to this file");
}

}  // namespace rtu::host::cli
