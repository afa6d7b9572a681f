// rtusim end to end: config (timing presets and keys) and the timed device through trace: statistics, chips,
// pipeline trace files, sampled timing.
#include <catch2/catch.hpp>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "hwmodel/timing/timing_config.h"
#include "tests/host/cli_checks.h"

namespace fs = std::filesystem;
using namespace rtu::test;

TEST_CASE("config: a preset's every key, --set overrides, JSON keys, --list", "[cli][timing][config]") {
  REQUIRE_RTUSIM_OK(r, "config --config rdna2");
  const std::vector<rtu::hw::TimingKey> keys = rtu::hw::timing_keys(rtu::hw::timing_preset("rdna2"));
  for (const rtu::hw::TimingKey& k : keys) {
    // A line "key<spaces> = value<spaces>   # description".
    const size_t at = r.output.find("\n" + k.key + " ");
    REQUIRE(at != std::string::npos);
    const std::string line = r.output.substr(at + 1, r.output.find('\n', at + 1) - at - 1);
    INFO(line);
    CHECK(line.find("= " + k.value + " ") != std::string::npos);
    CHECK(line.find("# " + k.description) != std::string::npos);
  }

  REQUIRE_RTUSIM_OK(s, "config --config intel --set ray_slots=64 --set box_latency=9");
  CHECK(s.output.find("ray_slots") != std::string::npos);
  CHECK(s.output.find("= 64 ") != std::string::npos);
  CHECK(s.output.find("= 9 ") != std::string::npos);
  CHECK(s.output.find("box_units                  = 2 ") != std::string::npos);  // intel's two box units

  const fs::path d = temp_dir("cli");
  const std::string json = (d / "timing.json").string();
  REQUIRE(run_rtusim("config --config embedded --set clock_ghz=0.8 --json " + json).status == 0);
  const nlohmann::ordered_json j = rtu::host::read_json_file(json);
  CHECK(j["preset"] == "embedded");
  std::vector<std::string> json_keys;
  for (auto it = j.begin(); it != j.end(); ++it)
    if (it.key() != "preset") json_keys.push_back(it.key());
  std::vector<std::string> want;
  for (const rtu::hw::TimingKey& k : keys) want.push_back(k.key);
  CHECK(json_keys == want);
  CHECK(j["format"] == "compact");
  CHECK(j["bvh_width"].is_number_integer());
  CHECK(j["bvh_width"] == 4);
  CHECK(j["clock_ghz"].is_number());
  CHECK(j["clock_ghz"].get<double>() == 0.8);
  CHECK(j["dram_bytes_per_cycle"].is_number());

  REQUIRE_RTUSIM_OK(l, "config --list");
  for (const std::string& n : rtu::hw::timing_preset_names()) CHECK(l.output.find(n + " ") != std::string::npos);
  CHECK(l.output.find("RDNA2") != std::string::npos);
}

TEST_CASE("config: unknown preset or key, bad values, malformed --set: exit 2 naming the problem",
          "[cli][timing][config]") {
  const std::vector<Refusal> cases = {
      {"config --config amd", "amd"},
      {"config --config rdna2 --set ray_slot=4", "ray_slot"},
      {"config --config rdna2 --set ray_slots=12x", "ray_slots"},
      {"config --config rdna2 --set ray_slots=0", "ray_slots"},
      {"config --config rdna2 --set ray_slots=", "ray_slots"},
      {"config --config rdna2 --set bvh_width=5", "bvh_width"},
      {"config --config rdna2 --set clock_ghz=fast", "clock_ghz"},
      {"config --config rdna2 --set format=nosuch", "nosuch"},
      {"config --config rdna2 --set ray_slots", "key=value"},
  };
  check_refused(cases);
}

namespace {

// What a pipeline trace file holds: spans (checked to overlap [from, to) and to be of a known kind), the units
// (processes) and (unit, slot) tracks with spans, those named by metadata, and counter samples.
struct PipelineFile {
  size_t spans = 0, counters = 0;
  std::set<uint64_t> units, named_units;
  std::set<std::pair<uint64_t, uint64_t>> slots, named_slots;
};

PipelineFile read_pipeline(const std::string& path, uint64_t from, uint64_t to) {
  const nlohmann::json p = read_json(path);
  REQUIRE(p["traceEvents"].is_array());
  PipelineFile f;
  const std::set<std::string> kinds = {"setup",  "node fetch", "box",          "record fetch", "triangle",
                                       "sphere", "plane",      "stack refill", "write-back"};
  for (const auto& e : p["traceEvents"]) {
    const uint64_t pid = e["pid"];
    if (e["ph"] == "M") {
      if (e["name"] == "process_name") {
        f.named_units.insert(pid);
      } else {
        CHECK(e["name"] == "thread_name");
        f.named_slots.insert({pid, e["tid"].get<uint64_t>()});
      }
      continue;
    }
    if (e["ph"] == "C") {
      ++f.counters;
      CHECK(e["args"]["bytes_per_cycle"].get<double>() >= 0.0);
      continue;
    }
    REQUIRE(e["ph"] == "X");
    ++f.spans;
    const uint64_t ts = e["ts"], dur = e["dur"];
    CHECK(ts < to);
    CHECK(ts + dur > from);
    CHECK(kinds.count(e["name"].get<std::string>()) == 1);
    f.units.insert(pid);
    f.slots.insert({pid, e["tid"].get<uint64_t>()});
  }
  CHECK(p["otherData"]["spans"] == f.spans);
  return f;
}

}  // namespace

TEST_CASE("trace --device timed: timing stats, the lower bound, breakdowns, the pipeline trace file",
          "[cli][timing]") {
  const fs::path d = temp_dir("cli");
  const std::string rays = (d / "t.rays").string(), stats = (d / "t.json").string(),
                    pipe = (d / "pipe.json").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind primary --count 3000 --out " + rays).status == 0);
  REQUIRE_RTUSIM_OK(r, "trace --scene builtin:seed --rays " + rays + " --out " + (d / "t.hits").string() +
                           " --device timed --config intel --stats " + stats + " --pipeline-trace " + pipe +
                           " --trace-window 100:1100");
  CHECK(r.output.find("timed (intel):") != std::string::npos);
  const nlohmann::json j = read_json(stats);
  const auto& t = j["timing"];
  const double cycles = t["cycles"].get<double>();
  CHECK(t["rays"] == 3000);
  CHECK(t["packets"] == 1);
  CHECK(cycles > 0);
  // The bound is the largest of its parts, named, and below the simulated cycles.
  const auto& b = t["lower_bound"];
  const double box = b["box"].get<double>(), tri = b["triangle"].get<double>(), dram = b["dram"].get<double>();
  const double latency = b["latency"].get<double>();
  CHECK(b["fetch"].get<double>() == 3000.0);  // one ray per clock
  CHECK(b["cycles"].get<double>() == std::max({box, tri, dram, 3000.0, latency}));
  // Little's law: the slots' busy cycles less the waits for units and memory, over the slots.
  const double slot_busy = t["utilization"]["ray_slots"].get<double>() * cycles * 64.0;  // intel: 64 slots
  CHECK(latency ==
        Approx((slot_busy - t["unit_wait_cycles"].get<double>() - t["mem_wait_cycles"].get<double>()) / 64.0));
  const std::string lim = b["limited_by"];
  REQUIRE((lim == "box" || lim == "triangle" || lim == "dram" || lim == "fetch" || lim == "latency"));
  CHECK(b[lim].get<double>() == b["cycles"].get<double>());
  CHECK(b["cycles"].get<double>() <= cycles);
  CHECK(b["cycles_over_bound"].get<double>() == Approx(cycles / b["cycles"].get<double>()));
  CHECK(box == Approx(t["utilization"]["box_units"].get<double>() * cycles));
  // One batch of rays (trace gives them the ray type "other", bounce 0): its breakdowns are the total.
  REQUIRE(t["by_ray_type"].size() == 1);
  CHECK(t["by_ray_type"]["other"]["cycles"] == t["cycles"]);
  CHECK(t["by_bounce"].size() == 1);
  CHECK(t["by_bounce"]["0"]["box_tests"] == t["box_tests"]);
  CHECK(t["config"]["box_units"] == 2);  // intel's two box units of 6 tests
  CHECK(t["config"]["box_rate"] == 6);
  // `config --stats` lists every statistic of the timing object, each with its unit and meaning.
  const Run list = run_rtusim("config --stats");
  REQUIRE(list.status == 0);
  std::vector<std::string> leaves;
  for (const auto& [key, v] : t.items()) {
    if (key == "by_ray_type" || key == "by_bounce" || key == "config" || key == "sample") continue;
    if (!v.is_object()) leaves.push_back(key);
    for (const auto& [sub, x] : v.items())
      if (v.is_object()) leaves.push_back(key + "." + sub);
  }
  for (const std::string& leaf : leaves) {
    CAPTURE(leaf);
    CHECK(list.output.find("\n" + leaf + " ") != std::string::npos);
  }
  CHECK(leaves.size() >= 30);
  // The memory timeline: the DRAM bytes over time add up to the total.
  uint64_t timeline_bytes = 0;
  for (const auto& b : t["timeline"]["dram_bytes"]) timeline_bytes += b.get<uint64_t>();
  CHECK(timeline_bytes == t["dram_bytes"].get<uint64_t>());
  CHECK(t.count("units") == 0);  // one unit: no per-unit list
  // The pipeline trace: Chrome trace events, spans overlapping the window, every slot named.
  const PipelineFile p = read_pipeline(pipe, 100, 1100);
  CHECK(p.spans > 100);
  CHECK(p.units == std::set<uint64_t>{0});
  CHECK(p.slots.rbegin()->second < 64);  // intel: 64 ray slots
  CHECK(p.named_slots == p.slots);
  CHECK(p.counters > 0);  // the memory's bandwidth tracks
  // A window that is not FROM < TO is refused.
  CHECK(run_rtusim("trace --scene builtin:seed --rays " + rays + " --out " + (d / "t.hits").string() +
                   " --device timed --pipeline-trace " + pipe + " --trace-window 9:9")
            .status == 2);
}

TEST_CASE("trace on a chip: per-unit statistics, the memory timeline, a pipeline track group per unit",
          "[cli][timing][chip]") {
  const fs::path d = temp_dir("cli");
  const std::string rays = (d / "c.rays").string(), stats = (d / "c.json").string(),
                    pipe = (d / "c-pipe.json").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind primary --count 3000 --out " + rays).status == 0);
  REQUIRE_RTUSIM_OK(r, "trace --scene builtin:seed --rays " + rays + " --out " + (d / "c.hits").string() +
                           " --device timed --config embedded-chip --stats " + stats + " --pipeline-trace " +
                           pipe + " --trace-window 0:2000");
  const nlohmann::json j = read_json(stats);
  const auto& t = j["timing"];
  // embedded-chip: 4 units; waves of 16 rays (the embedded unit's slots) in turn: 3000 rays are 187.5 waves.
  REQUIRE(t["units"].size() == 4);
  uint64_t rays_sum = 0, box_sum = 0;
  for (const auto& u : t["units"]) {
    rays_sum += u["rays"].get<uint64_t>();
    box_sum += u["box_tests"].get<uint64_t>();
    CHECK(u["utilization"]["box_units"].get<double>() > 0.0);
    CHECK(u["utilization"]["box_units"].get<double>() <= 1.0);
    CHECK(u["cache"]["hit_rate"].get<double>() > 0.0);
  }
  CHECK(rays_sum == 3000);
  CHECK(box_sum == t["box_tests"].get<uint64_t>());
  CHECK(t["units"][0]["rays"] == 47 * 16);
  CHECK(t["units"][3]["rays"] == 46 * 16 + 8);
  // The timeline: DRAM bytes and L2 line accesses add up to the totals.
  uint64_t dram = 0, l2 = 0;
  for (const auto& b : t["timeline"]["dram_bytes"]) dram += b.get<uint64_t>();
  for (const auto& b : t["timeline"]["l2_bytes"]) l2 += b.get<uint64_t>();
  CHECK(dram == t["dram_bytes"].get<uint64_t>());
  CHECK(l2 == 64 * (t["l2"]["hits"].get<uint64_t>() + t["l2"]["misses"].get<uint64_t>()) +
                  8 * (t["l2"]["stack_hits"].get<uint64_t>() + t["l2"]["stack_misses"].get<uint64_t>()));
  // The pipeline trace: a process per unit, each named, each with its slots' tracks; the memory's counters.
  const PipelineFile p = read_pipeline(pipe, 0, 2000);
  CHECK(p.units == std::set<uint64_t>{0, 1, 2, 3});
  CHECK(p.named_units.size() == 5);  // four units and the memory
  CHECK(p.named_slots == p.slots);
  CHECK(p.counters > 0);
}

TEST_CASE("trace --sample: --sample-seed draws the sample, the same seed, the same estimate", "[cli][timing]") {
  const fs::path d = temp_dir("cli");
  const std::string rays = (d / "s.rays").string(), stats = (d / "s.json").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --kind incoherent --count 20000 --out " + rays).status == 0);
  // Units of 16 rays with 16 warm-up rays: 1,250 units, every 20th measured (F = 0.05), cycles only.
  auto estimate = [&](int seed) {
    const Run r =
        run_rtusim("trace --scene builtin:seed --rays " + rays + " --device timed --sample 0.05 --sample-unit 16" +
                   " --sample-warmup 16 --sample-seed " + std::to_string(seed) + " --stats " + stats);
    INFO(r.output);
    REQUIRE(r.status == 0);
    const nlohmann::json j = read_json(stats);
    REQUIRE(j["timing"]["sample"]["units_measured"].get<uint64_t>() > 50);
    return j["timing"]["cycles"].get<uint64_t>();
  };
  const uint64_t a = estimate(1), b = estimate(1), c = estimate(2), e = estimate(3);
  CHECK(a == b);
  CHECK((c != a || e != a));  // other offsets, other units measured
  const Run bad =
      run_rtusim("trace --scene builtin:seed --rays " + rays + " --device timed --sample 0.05 --sample-seed x");
  CHECK(bad.status != 0);
  CHECK(bad.status < 128);
  CHECK(bad.output.find("--sample-seed") != std::string::npos);
}

TEST_CASE("config --config as everywhere else (--preset still works), timing presets listed and checked",
          "[cli][timing][config]") {
  const Run a = run_rtusim("config --config intel"), b = run_rtusim("config --preset intel");
  REQUIRE(a.status == 0);
  REQUIRE(b.status == 0);
  CHECK(a.output == b.output);
  CHECK(a.output.find("preset intel") != std::string::npos);
  const Run h = run_rtusim("config --help");
  CHECK(h.output.find("--config") != std::string::npos);
  CHECK(h.output.find("--preset") == std::string::npos);  // the old name, not listed
  for (const char* args :
       {"config --preset intel --config rdna2", "config --preset intel --list", "config --stats --json x.json",
        "config --stats --config intel", "config --list --set ray_slots=4"}) {
    const Run r = run_rtusim(args);
    INFO(args << "\n" << r.output);
    CHECK(r.status == 2);
  }
  // sweep and plan list the presets and refuse others, as the device options do.
  for (const char* sub : {"sweep", "plan"}) {
    const Run r = run_rtusim(std::string(sub) + " --help");
    INFO(r.output);
    CHECK(r.output.find("rdna2,intel,embedded") != std::string::npos);
  }
  const Run p = run_rtusim("plan --scene builtin:cornell --max-error 1e-3 --config amd");
  CHECK(p.status == 2);
  CHECK(p.output.find("amd not in") != std::string::npos);
  // sweep takes a preset with keys changed too, so its check names the preset and lists the known ones.
  const Run s = run_rtusim("sweep --scene builtin:cornell --config rdna2,amd --out " +
                           (temp_dir("cli") / "presets.csv").string());
  CHECK(s.status == 2);
  CHECK(s.output.find("unknown timing preset 'amd' (known: rdna2, intel, embedded") != std::string::npos);
}

TEST_CASE("format specs: --format SPEC, --set format=SPEC and the per-field options are one design point",
          "[cli][timing][format]") {
  const fs::path d = temp_dir("cli_spec");
  const std::string rays = (d / "r.rays").string(), hits = (d / "h.bin").string(), stats = (d / "s.json").string();
  REQUIRE(run_rtusim("rays --scene builtin:seed --count 3000 --out " + rays).status == 0);
  auto bytes = [](const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  // What a spelling traces: the hit file's bytes, the format's fields (its name aside: it records the spelling)
  // and, timed, the cycles.
  struct Traced {
    std::string hits;
    nlohmann::json format;
    uint64_t cycles = 0;
    bool operator==(const Traced&) const = default;
  };
  auto trace = [&](const std::string& device, const std::string& options) {
    const Run r = run_rtusim("trace --scene builtin:seed --rays " + rays + " --device " + device + " --out " +
                             hits + " --stats " + stats + " " + options);
    INFO(options << "\n" << r.output);
    REQUIRE(r.status == 0);
    Traced t;
    t.hits = bytes(hits);
    const nlohmann::json j = read_json(stats);
    t.format = j["format"];
    t.format.erase("name");
    if (device == "timed") t.cycles = j["timing"]["cycles"].get<uint64_t>();
    return t;
  };
  for (const auto& [spec, fields] : std::vector<std::pair<std::string, std::string>>{
           {"rdna4:node_kind=0", "--format rdna4 --node-kind 0"},
           {"packed:coord_bits=16", "--format packed --coord-bits 16"}}) {
    INFO(spec);
    const Traced fixed = trace("fixed", fields);
    CHECK(fixed.hits.size() == 3000 * 16);
    CHECK(trace("fixed", "--format " + spec) == fixed);
    const Traced timed = trace("timed", fields);
    CHECK(timed.hits == fixed.hits);
    CHECK(timed.cycles > 0);
    CHECK(trace("timed", "--format " + spec) == timed);
    CHECK(trace("timed", "--set format=" + spec) == timed);
  }
  // compare and render take the spec as trace does.
  const std::string compare = "compare --scene builtin:seed --rays primary:2000 --device fixed --json ";
  REQUIRE(run_rtusim(compare + (d / "c1.json").string() + " --format packed --coord-bits 12").status == 0);
  REQUIRE(run_rtusim(compare + (d / "c2.json").string() + " --format packed:coord_bits=12").status == 0);
  CHECK(read_json(d / "c1.json")["hit_agreement"] == read_json(d / "c2.json")["hit_agreement"]);
  CHECK(read_json(d / "c2.json")["format"]["coord_bits"] == 12);
  const std::string render = "render --scene builtin:seed --width 24 --height 16 --device timed --stats ";
  REQUIRE(run_rtusim(render + (d / "r1.json").string() + " --out " + (d / "r1.png").string() +
                     " --format packed --coord-bits 16")
              .status == 0);
  REQUIRE(run_rtusim(render + (d / "r2.json").string() + " --out " + (d / "r2.png").string() +
                     " --set format=packed:coord_bits=16")
              .status == 0);
  CHECK(read_json(d / "r1.json")["timing"]["frame_cycles"] == read_json(d / "r2.json")["timing"]["frame_cycles"]);
  CHECK(bytes(d / "r1.png") == bytes(d / "r2.png"));

  // A malformed spec: exit 2 naming the spec and what is wrong with it.
  const std::string run = "trace --scene builtin:seed --rays " + rays + " --out " + hits + " ";
  for (const auto& [args, words] : std::vector<std::pair<std::string, std::string>>{
           {"--device fixed --format packed:coord_bits=x", "'x' is not an integer"},
           {"--device fixed --format packed:frobs=3", "frobs=3"},
           {"--device fixed --format nosuch:coord_bits=16", "unknown format preset 'nosuch'"},
           {"--device fixed --format clusters:cluster_tris=8", "cluster_tris = 8 outside"},
           {"--device timed --set format=packed:coord_bits=x", "'x' is not an integer"},
           {"--device timed --set format=packed:frobs=3", "frobs=3"},
           {"--device timed --format packed:coord_bits=16 --set format=packed", "two values of one key"}}) {
    const Run r = run_rtusim(run + args);
    INFO(args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(words) != std::string::npos);
  }
}
