// Answers a user can trust: where the fixed-point devices cannot answer as the float reference does, the jobs say
// so (primitives below the quantization grid's step), refuse (a frame in the denormal range, NaN options), or
// warn (a render with nothing to light it); the trace job takes the ray specs compare takes and needs no --out.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "host/cost/timing_json.h"
#include "host/devices/direct_device.h"
#include "host/devices/grid_check.h"
#include "host/io/error.h"
#include "host/io/image.h"
#include "host/io/stats_json.h"
#include "host/scene/scene.h"
#include "tests/common/test_util.h"
#include "tests/host/run_process.h"

namespace fs = std::filesystem;
using Catch::Matchers::Contains;
using rtu::test::Run;
using rtu::test::run_rtusim;

using rtu::test::temp_dir;

namespace {

std::string write_scene(const std::string& name, const std::string& text) {
  const fs::path p = temp_dir("answers") / name;
  std::ofstream(p) << text;
  return p.string();
}

// Two unit boxes 10^12 apart (float: 144 of the camera's rays hit them; fixed: none, with exit 0 and no word).
const char* kFarBoxes = R"({"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "width": 64, "height": 48},
  "meshes": [{"generate": "box", "size": [1, 1, 1]},
             {"generate": "box", "size": [1, 1, 1], "transform": {"translate": [1e12, 0, 0]}}]})";

// The same boxes, each placed as an instance of one prototype: each mesh in its own frame.
const char* kFarInstances = R"({"camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "width": 64, "height": 48},
  "prototypes": {"cube": {"meshes": [{"generate": "box", "size": [1, 1, 1]}]}},
  "instances": [{"prototype": "cube"}, {"prototype": "cube", "transform": {"translate": [1e12, 0, 0]}}]})";

}  // namespace

TEST_CASE("primitives below the grid step: counted with the step, and instancing cures them", "[answers]") {
  const rtu::host::Scene flat = rtu::host::load_scene(write_scene("far_boxes.json", kFarBoxes));
  rtu::hw::FixedFormat f;  // 24 coordinate bits: a 10^12 extent has a step of 2^16 = 65536
  const rtu::host::GridCheck c = rtu::host::check_grid(flat.geometry, nullptr, false, f);
  CHECK(c.prims == 24);
  CHECK(c.below_step == 24);
  CHECK(c.step == 65536.0);
  const std::string w = rtu::host::grid_warning(c);
  CHECK_THAT(w, Contains("24 of 24 primitives are smaller than the grid step 6.55e+04") && Contains("instanc"));
  // With 40 bits the step is 1: a unit box is no longer below it.
  f.coord_bits = 40;
  CHECK(rtu::host::check_grid(flat.geometry, nullptr, false, f).below_step == 0);

  const rtu::host::Scene inst = rtu::host::load_scene(write_scene("far_instances.json", kFarInstances));
  REQUIRE(inst.instanced());
  rtu::hw::FixedFormat g;
  const rtu::host::GridCheck two = rtu::host::check_grid(inst.geometry, &inst.instances, false, g);
  CHECK(two.two_level);
  CHECK(two.below_step == 0);
  CHECK(rtu::host::grid_warning(two).empty());
  CHECK(rtu::host::check_grid(inst.geometry, &inst.instances, true, g).below_step == 24);  // flattened
}

TEST_CASE("trace and render warn of primitives below the grid step and compare shows what they cost",
          "[answers]") {
  const std::string flat = write_scene("far_boxes_cli.json", kFarBoxes);
  const std::string inst = write_scene("far_instances_cli.json", kFarInstances);
  for (const char* device : {"fixed", "timed"}) {
    const Run t = run_rtusim(std::string("trace --scene ") + flat + " --rays primary --device " + device);
    INFO(t.output);
    CHECK(t.status == 0);
    CHECK_THAT(t.output, Contains("warning: 24 of 24 primitives are smaller than the grid step"));
  }
  const fs::path png = temp_dir("answers") / "far.png";
  const Run r =
      run_rtusim("render --scene " + flat + " --device fixed --width 32 --height 24 --out " + png.string());
  INFO(r.output);
  CHECK(r.status == 0);
  CHECK_THAT(r.output, Contains("primitives are smaller than the grid step"));
  // The float reference has no grid; the instanced scene has a frame per mesh: no warning.
  CHECK_THAT(run_rtusim("trace --scene " + flat + " --rays primary --device float").output,
             !Contains("grid step"));
  CHECK_THAT(run_rtusim("trace --scene " + inst + " --rays primary --device fixed").output,
             !Contains("grid step"));
  // What the warning is about: compare finds the hits the flat scene loses and the instanced one keeps.
  const Run cf = run_rtusim("compare --scene " + flat + " --rays primary --device fixed");
  const Run ci = run_rtusim("compare --scene " + inst + " --rays primary --device fixed");
  INFO(cf.output << ci.output);
  CHECK_THAT(cf.output, Contains("grid step"));
  CHECK_THAT(cf.output, !Contains("hit agreement 100.000000%"));
  CHECK_THAT(ci.output, Contains("hit agreement 100.000000%"));
}

TEST_CASE("a frame whose grid step is below the smallest normal float is refused", "[answers]") {
  const std::string tiny = write_scene("tiny_sphere.json", R"({"spheres": [{"center": [0, 0, 0], "radius": 1e-38}],
    "camera": {"position": [0, 0, 1e-37], "look_at": [0, 0, 0], "width": 16, "height": 12}})");
  const rtu::host::Scene s = rtu::host::load_scene(tiny);
  rtu::host::DeviceOptions o;
  o.kind = rtu::hw::DeviceKind::kFixed;
  std::string e;
  try {
    rtu::host::make_device(s.geometry, o);
  } catch (const rtu::host::Error& x) {
    e = x.what();
  }
  CHECK_THAT(e, Contains("below the smallest normal float 2^-126") && Contains("scale the scene up"));
  for (const std::string& job :
       {std::string("trace --rays primary"), std::string("compare --rays primary"),
        "render --width 8 --height 6 --out " + (temp_dir("answers") / "tiny.png").string()}) {
    const Run r = run_rtusim(job.substr(0, job.find(' ')) + " --scene " + tiny + job.substr(job.find(' ')) +
                             " --device timed");
    INFO(job << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK_THAT(r.output, Contains("smallest normal float"));
  }
  // The float reference traces it.
  CHECK(run_rtusim("trace --scene " + tiny + " --rays primary --device float").status == 0);
}

TEST_CASE("NaN is refused by every floating-point option, naming it", "[answers]") {
  const std::string png = (temp_dir("answers") / "nan.png").string();
  const struct {
    const char* args;
    const char* option;
  } cases[] = {
      {"render --scene builtin:seed --width 8 --height 6 --background nan 0 0 --out ", "--background"},
      {"render --scene builtin:seed --width 8 --height 6 --ao --ao-distance nan --out ", "--ao-distance"},
      {"trace --scene builtin:seed --rays primary --device timed --sample nan --out ", "--sample"},
      {"diff --scale NaN --heatmap ", "--scale"},
  };
  for (const auto& c : cases) {
    const Run r =
        run_rtusim(std::string(c.args) + png + (std::string(c.args).rfind("diff", 0) == 0 ? " a b" : ""));
    INFO(c.args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK_THAT(r.output, Contains(c.option) && Contains("NaN"));
  }
}

TEST_CASE("trace takes ray specs and needs no --out for its statistics", "[answers]") {
  const Run r = run_rtusim("trace --scene builtin:seed --rays incoherent:500 --seed 3 --device timed");
  INFO(r.output);
  CHECK(r.status == 0);
  CHECK_THAT(r.output, Contains("traced 500 rays") && Contains("cycles"));
  const Run p = run_rtusim("trace --scene builtin:seed --rays primary:40x30 --device fixed");
  CHECK(p.status == 0);
  CHECK_THAT(p.output, Contains("traced 1200 rays"));
  CHECK(run_rtusim("trace --scene builtin:seed --rays primary --seed 3").status == 2);  // --seed: incoherent only
  CHECK_THAT(run_rtusim("trace --scene builtin:seed --rays nosuchfile.rays").output, Contains("not a ray spec"));
}

TEST_CASE("a render with nothing to light it warns and the instancing example is lit", "[answers]") {
  const std::string dark = write_scene("dark.json", R"({"meshes": [{"generate": "box", "size": [1, 1, 1]}]})");
  const std::string png = (temp_dir("answers") / "dark.png").string();
  const Run r = run_rtusim("render --scene " + dark + " --width 16 --height 12 --out " + png);
  INFO(r.output);
  CHECK(r.status == 0);
  CHECK_THAT(r.output, Contains("no light") && Contains("black"));
  CHECK_THAT(run_rtusim("render --scene " + dark + " --width 16 --height 12 --background 0.5 0.5 0.5 --out " + png)
                 .output,
             !Contains("no light"));
  const Run ex =
      run_rtusim("render --scene " RTU_SOURCE_DIR "/scenes/instances.json --width 64 --height 48 --out " + png +
                 " --stats " + (temp_dir("answers") / "ex.json").string());
  INFO(ex.output);
  CHECK(ex.status == 0);
  CHECK_THAT(ex.output, !Contains("no light"));
  const rtu::host::Image img = rtu::host::read_png(png);
  uint64_t sum = 0;
  for (uint8_t v : img.rgb) sum += v;
  CHECK(double(sum) / double(img.rgb.size()) > 20.0);  // not black: a mean above 20 of 255
}

TEST_CASE("a timed run's notes: queueing, far above the bound, spills, short packets, the sample",
          "[answers][timed]") {
  auto has = [](const std::vector<std::string>& notes, const std::string& what) {
    for (const std::string& n : notes)
      if (n.find(what) != std::string::npos) return true;
    return false;
  };
  // Hand-made counters on rdna2 (32 slots): 32000 rays of 1000 cycles each in the slots, 600 of them queued for
  // memory: the slots' time is 60% memory queueing, and the bound (latency 400 x 1000 / 32... ) is far below
  // cycles of 3x it.
  rtu::hw::TimingConfig c = rtu::hw::timing_preset("rdna2");
  rtu::hw::TimingStats s;
  s.packets = 1;
  s.rays = 32000;
  s.slot_busy_cycles = 32000ull * 1000;
  s.mem_wait_cycles = 32000ull * 600;
  const rtu::hw::LowerBound b0 = rtu::hw::lower_bound(s, c);
  s.cycles = uint64_t(3 * b0.cycles);
  std::vector<std::string> n = rtu::host::timing_notes(s, c, nullptr);
  CHECK(has(n, "queued for memory 60%"));
  CHECK(has(n, "memory queueing holds the slots"));
  // rdna2 has no L2: the note names the memory it has and the key that adds bandwidth there.
  CHECK(has(n, "(the DRAM channel)"));
  CHECK(has(n, "more DRAM bandwidth (dram_bytes_per_cycle)"));
  CHECK_FALSE(has(n, "L2"));
  CHECK(has(n, "warning: the cycles are 3.00 times the lower bound"));
  CHECK_FALSE(has(n, "stack:"));
  CHECK_FALSE(has(n, "sampled"));
  // Spills are shown, and where they go.
  s.stack_spills = s.stack_refills = 3200;
  CHECK(has(rtu::host::timing_notes(s, c, nullptr),
            "stack: 0.100 entries spilled and 0.100 refilled per ray (to DRAM)"));
  // A chip's short packet: 32000 rays for 80 units of 32 slots.
  rtu::hw::TimingConfig chip = rtu::hw::timing_preset("rdna2-chip");
  CHECK(has(rtu::host::timing_notes(s, chip, nullptr), "12.5 a slot"));
  CHECK(has(rtu::host::timing_notes(s, chip, nullptr), "(through the L2)"));
  CHECK(has(rtu::host::timing_notes(s, chip, nullptr), "(L2 ports, DRAM banks and channels)"));
  CHECK(has(rtu::host::timing_notes(s, chip, nullptr), "more L2 or DRAM bandwidth"));
  // What checks the cycles: the RTL traversal unit models rdna2's single unit, not a chip or a prefetcher.
  CHECK(has(n, "checked by: the RTL traversal unit models every part of this configuration"));
  CHECK(has(rtu::host::timing_notes(s, chip, nullptr),
            "no RTL checks these cycles, as the RTL traversal unit "
            "needs units 1"));
  rtu::hw::TimingConfig prefetching = c;
  rtu::hw::set_timing_key(prefetching, "prefetcher", "next_line");
  CHECK(has(rtu::host::timing_notes(s, prefetching, nullptr), "needs prefetcher none"));
  rtu::hw::TimingConfig slot_order = c;
  rtu::hw::set_timing_key(slot_order, "child_order", "slot");
  CHECK(has(rtu::host::timing_notes(s, slot_order, nullptr), "needs child_order nearest"));
  // Sampled: the interval is printed; an estimate below its own bound by more than the interval warns, one
  // within it does not; a warm-up longer than the packet warns.
  rtu::hw::SampleStats ss;
  ss.packets = ss.packets_sampled = 1;
  ss.rays = 32000;
  ss.rays_simulated = 3200;
  ss.variance = 100.0 * 100.0;  // ci95 196 cycles
  rtu::hw::TimingStats low = s;
  low.cycles = uint64_t(b0.cycles) - 1000;
  n = rtu::host::timing_notes(low, c, &ss);
  CHECK(has(n, "sampled: 1 of 1 packets estimated from 10.0% of their rays; cycles +- 196 (95%)"));
  CHECK(has(n, "is below its own lower bound"));
  low.cycles = uint64_t(b0.cycles) - 100;
  CHECK_FALSE(has(rtu::host::timing_notes(low, c, &ss), "is below its own lower bound"));
  ss.rays_simulated = 40000;
  CHECK(has(rtu::host::timing_notes(low, c, &ss), "simulated 40000 rays for packets of 32000"));
}

TEST_CASE("render and trace print the sampled interval and the notes", "[answers][timed][sample]") {
  const fs::path d = temp_dir("answers_notes");
  const Run r = run_rtusim(
      "render --scene builtin:cornell --width 64 --height 64 --spp 1 --device timed --sample "
      "0.2 --sample-unit 64 --out " +
      (d / "c.png").string());
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK_THAT(r.output, Contains("cycles +- "));
  const Run t = run_rtusim(
      "trace --scene builtin:seed --rays primary:64x64 --device timed --config rdna2-chip --set "
      "units=4");
  INFO(t.output);
  REQUIRE(t.status == 0);
  CHECK_THAT(t.output, Contains("32.0 a slot"));
}
