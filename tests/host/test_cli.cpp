// rtusim end to end, what every subcommand shares: --help, usage errors, bad input giving a clear error
// and a non-zero exit (never a crash), and the device options each command takes or refuses. The subcommands
// themselves: test_cli_trace.cpp (rays, trace, info), test_cli_compare.cpp (compare, stress),
// test_cli_render.cpp (render, demo, diff), test_cli_timing.cpp (config, timed and sampled trace),
// test_cli_sweep.cpp (sweep, plan), test_cli_manifest.cpp (sweep manifests), test_cli_report.cpp (report,
// pareto).
#include <catch2/catch.hpp>

#include <fstream>
#include <sstream>
#include <vector>

#include "tests/host/cli_checks.h"

namespace fs = std::filesystem;
using namespace rtu::test;

TEST_CASE("every subcommand has --help", "[cli]") {
  for (const char* sub : {"info", "rays", "trace", "compare", "stress", "demo", "diff", "config", "sweep", "plan",
                          "report", "pareto"}) {
    const Run r = run_rtusim(std::string(sub) + " --help");
    INFO(r.output);
    CHECK(r.status == 0);
    CHECK(r.output.find("--") != std::string::npos);
  }
  CHECK(run_rtusim("frobnicate").status != 0);
  CHECK(run_rtusim("").status != 0);
}

TEST_CASE("bad input: clear error, non-zero exit, no crash", "[cli]") {
  const fs::path d = temp_dir("cli");
  std::ofstream(d / "odd.rays", std::ios::binary) << std::string(45, 'x');
  std::ofstream(d / "broken.json") << "{ \"spheres\": [ {\"center\": [0,0,0], \"radius\": 1 ";
  std::ofstream(d / "unknown.json") << R"({"spheres": [{"center": [0,0,0], "radius": 1, "colour": 3}]})";
  const std::string out = (d / "h.bin").string();
  const std::vector<Refusal> cases = {
      {"trace --scene builtin:seed --rays " + (d / "odd.rays").string() + " --out " + out, "multiple of 32"},
      {"trace --scene builtin:nosuch --rays " + (d / "odd.rays").string() + " --out " + out, "nosuch"},
      {"info --scene " + (d / "missing.obj").string(), "missing.obj"},
      {"info --scene " + (d / "broken.json").string(), "broken.json"},
      {"info --scene " + (d / "unknown.json").string(), "colour"},
      {"trace --scene builtin:seed --rays " + (d / "none.rays").string() + " --out " + out, "none.rays"},
      {"rays --scene builtin:seed --kind sideways --count 5 --out " + out, "sideways"},
      {"rays --scene builtin:seed --kind incoherent --out " + out, "--count"},
      {"info --scene builtin:seed --bvh-width 3", "bvh-width"},
      {"info --scene builtin:seed --format nosuch", "nosuch"},
      {"info --scene builtin:seed --coord-bits 31", "coord_bits"},
      {"info --scene builtin:seed --coord-bits 30 --guard-bits 8 --frac-bits 20 --t-bits 60", "edge function"},
      {"info --scene builtin:seed --dir-bits 30 --rcp-bits 40", "rcp"},
      {"compare --scene builtin:seed --rays primary:0", "count"},
      {"compare --scene builtin:seed --rays incoherent:x", "count"},
      {"stress --count 10 --category nosuch", "nosuch"},
  };
  check_failed(cases);
}

TEST_CASE("usage errors exit 2 with CLI11's message, --help and --version exit 0", "[cli]") {
  const fs::path d = temp_dir("cli");
  struct Case {
    std::string args, words;
  };
  const Case cases[] = {
      {"info --scene builtin:seed --frobnicate", "--frobnicate"},  // an unknown option
      {"stress --count 0", "--count"},                             // a value out of range
      {"info --scene builtin:seed --bvh-width x", "--bvh-width"},  // a value that does not parse
      {"rays --scene builtin:seed", "--out"},                      // a required option missing
      {"frobnicate", "subcommand"},                                // an unknown subcommand
      {"", "subcommand"},                                          // none
  };
  for (const Case& c : cases) {
    const Run r = run_rtusim(c.args);
    INFO(c.args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(c.words) != std::string::npos);
    CHECK(r.output.find("--help") != std::string::npos);  // "Run with --help for more information."
  }
  CHECK(run_rtusim("--version").status == 0);
  CHECK(run_rtusim("trace --help").status == 0);
}

TEST_CASE("device options: a command lists only those it uses, and refuses those the device ignores", "[cli]") {
  const fs::path d = temp_dir("cli");
  const std::string rays = (d / "dev_opts.rays").string(), hits = (d / "dev_opts.hits").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --count 500 --out " + rays).status == 0);
  auto help = [](const std::string& sub) {
    const Run r = run_rtusim(sub + " --help");
    REQUIRE(r.status == 0);
    return r.output;
  };
  // An option is listed when a line of the help starts with it (descriptions may name other options).
  auto lists = [](const std::string& text, const std::string& option) {
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
      const size_t at = line.find_first_not_of(' ');
      if (at == std::string::npos || line.compare(at, option.size(), option) != 0) continue;
      const size_t end = at + option.size();
      if (end == line.size() || line[end] == ' ' || line[end] == ',') return true;
    }
    return false;
  };
  // info and stress never run the timed device; stress builds no BVH of its own options either.
  for (const char* sub : {"info", "stress"}) {
    const std::string h = help(sub);
    INFO(h);
    for (const char* option : {"--config", "--set", "--sample", "--sample-unit", "--sample-warmup",
                               "--sample-seed", "--watchdog-steps", "--device"})
      CHECK_FALSE(lists(h, option));
    CHECK(lists(h, "--format"));
    CHECK(lists(h, "--coord-bits"));
    CHECK(lists(h, "--bvh-width"));
  }
  CHECK(lists(help("info"), "--leaf-size"));
  CHECK_FALSE(lists(help("stress"), "--leaf-size"));
  CHECK_FALSE(lists(help("stress"), "--accel"));
  // compare reports no cycles: the timing configuration (the timed device's format) but no sampling.
  const std::string ch = help("compare");
  CHECK(lists(ch, "--config"));
  CHECK(lists(ch, "--watchdog-steps"));
  CHECK_FALSE(lists(ch, "--sample"));
  for (const char* sub : {"trace", "render"})
    for (const char* option : {"--config", "--set", "--sample", "--sample-seed", "--watchdog-steps"})
      CHECK(lists(help(sub), option));
  CHECK(run_rtusim("info --scene builtin:seed --sample 0.1").status == 2);

  // Given for a device that does not use them: a usage error naming the option and the device it applies to.
  const std::string trace = "trace --scene builtin:seed --rays " + rays + " --out " + hits + " ";
  const std::vector<Refusal> cases = {
      {trace + "--device float --sample 0.1", "--sample applies to --device timed only"},
      {trace + "--device fixed --sample-seed 3", "--sample-seed applies to --device timed only"},
      {trace + "--device fixed --config intel", "--config applies to --device timed only"},
      {trace + "--device fixed --set cache_kib=64", "--set applies to --device timed only"},
      {trace + "--device fixed --pipeline-trace " + (d / "p.json").string(), "--pipeline-trace applies"},
      {trace + "--device float --watchdog-steps 10", "--watchdog-steps applies to --device fixed or timed only"},
      {trace + "--device float --coord-bits 16", "--coord-bits applies to --device fixed or timed only"},
      {"compare --scene builtin:seed --rays primary:100 --device fixed --config intel", "--config applies"},
      {"render --scene builtin:seed --width 8 --height 8 --out " + (d / "x.png").string() +
           " --device float --sample 0.5",
       "--sample applies"},
  };
  check_refused(cases);
  // The same options where the device uses them, and defaults given on no device, are fine.
  CHECK(run_rtusim(trace + "--device timed --config intel --sample 0.5 --sample-seed 3").status == 0);
  CHECK(run_rtusim(trace + "--device fixed --watchdog-steps 100000 --coord-bits 16").status == 0);
  CHECK(run_rtusim(trace + "--device float --bvh-width 8").status == 0);
  CHECK(run_rtusim(trace + "--device fixed --bvh-width 6").status == 0);
}

TEST_CASE("options that would be ignored are refused: diff, info, report, sweep --merge, render", "[cli]") {
  const fs::path d = temp_dir("cli");
  const std::string png = (d / "ign.png").string();
  REQUIRE(run_rtusim("render --scene builtin:cornell --width 8 --height 8 --out " + png).status == 0);
  for (const auto& [args, words] : std::vector<std::pair<std::string, std::string>>{
           {"diff " + png + " " + png + " --scale 4", "--heatmap"},
           {"info --formats --json " + (d / "f.json").string(), "--scene"},
           {"report --sweep " + (d / "s.csv").string() + " --area " + (d / "a.csv").string() + " --out " +
                (d / "rep").string(),
            "--area"},
           {"sweep --merge " + png + " --rays 64 --out " + (d / "m.csv").string(), "--rays"},
           {"render --scene builtin:cornell --ao-distance 2 --out " + png, "--ao"},
           {"render --scene builtin:cornell --ao --no-indirect --out " + png, "--no-indirect"}}) {
    const Run r = run_rtusim(args);
    INFO(args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(words) != std::string::npos);
  }
}

TEST_CASE("a directory or a missing folder where a file is named: the path and the problem, exit 2", "[cli][io]") {
  const fs::path d = temp_dir("cli_files");
  const std::string dir = (d / "folder").string(), png = (d / "a.png").string();
  fs::create_directories(dir);
  REQUIRE(run_rtusim("render --scene builtin:seed --width 8 --height 8 --out " + png).status == 0);
  const std::string trace = "trace --scene builtin:seed --rays primary:16 ";
  struct Case {
    std::string args, words;
  };
  const std::string input = dir + ": is a directory, not a file", output = input + " (name a file to write)";
  const Case cases[] = {
      // Files read.
      {"trace --scene " + dir + " --rays primary:16", input},
      {"trace --scene builtin:seed --rays " + dir, input},
      {"diff " + png + " " + dir, input},
      {"pareto --sweep " + dir + " --out " + (d / "p").string(), input},
      // Files written.
      {trace + "--out " + dir, output},
      {trace + "--stats " + dir, output},
      {trace + "--device timed --pipeline-trace " + dir, output},
      {"rays --scene builtin:seed --count 5 --out " + dir, output},
      {"render --scene builtin:seed --width 8 --height 8 --out " + dir, output},
      {"diff " + png + " " + png + " --heatmap " + dir, output},
      {"compare --scene builtin:seed --rays primary:16 --json " + dir, output},
      {"info --scene builtin:seed --json " + dir, output},
      {"sweep --scene builtin:seed --rays 16 --image-width 0 --out " + dir, output},
      {"sweep --scene builtin:seed --rays 16 --image-width 0 --write-manifest " + dir, output},
      {"render --scene builtin:seed --width 8 --height 8 --out " + png + " --stats " + dir, output},
      {"compare --scene builtin:seed --rays primary:16 --disagreements " + dir, output},
      {"plan --scene builtin:seed --max-error 0.5 --rays 64 --json " + dir, output},
      // A file in a folder that is not there.
      {trace + "--out " + dir + "/none/h.bin",
       dir + "/none/h.bin: cannot write: the folder " + dir + "/none does not exist"},
      {"rays --scene builtin:seed --count 5 --out " + png + "/r.bin", "cannot write: " + png + " is not a folder"},
  };
  for (const Case& c : cases) {
    const Run r = run_rtusim(c.args);
    INFO(c.args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(c.words) != std::string::npos);
    CHECK(r.output.find("Is a directory") == std::string::npos);  // the system's words, without the path
    CHECK(r.output.find("filesystem error") == std::string::npos);
    // Refused before the job: nothing traced, rendered or written first.
    CHECK(r.output.find("traced ") == std::string::npos);
    CHECK(r.output.find(" rays (primary") == std::string::npos);
    CHECK(r.output.find("wrote ") == std::string::npos);
  }
  CHECK(run_rtusim(trace + "--out /dev/null").status == 0);  // a device is a fine place to write
}
