// The jobs behind rtusim's plan, demo and report called as host functions, without the command line, on small
// inputs; and the helpers the command line shares (ray specs, timing overrides, pipeline-trace windows).
#include <catch2/catch.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "host/demo.h"
#include "host/device_settings.h"
#include "host/error.h"
#include "host/json_io.h"
#include "host/pipeline_trace.h"
#include "host/plan.h"
#include "host/ray_spec.h"
#include "host/report.h"
#include "host/scene.h"

namespace fs = std::filesystem;
using rtu::host::Json;

namespace {

// A fresh, empty directory under the system's temporary directory, removed at the end of the test.
struct TempDir {
  explicit TempDir(const std::string& name)
      : path(fs::temp_directory_path() / ("rtu_test_jobs_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  fs::path path;
};

// A small scene of every primitive kind with a light and a 40x30 camera, so that a whole demo runs in seconds.
std::string small_scene(const fs::path& dir) {
  const fs::path p = dir / "small.json";
  std::ofstream(p) << R"({
  "camera": {"position": [0, 1.5, 5], "look_at": [0, 0.5, 0], "fov_y": 45, "width": 40, "height": 30},
  "materials": {"chrome": {"type": "mirror", "color": [0.9, 0.9, 0.9]}},
  "meshes": [{"generate": "icosphere", "subdiv": 2, "transform": {"translate": [-0.8, 0.6, 0]}}],
  "spheres": [{"center": [0.9, 0.5, 0], "radius": 0.5, "material": "chrome"}],
  "planes": [{"normal": [0, 1, 0], "offset": 0}],
  "lights": [{"type": "point", "position": [2, 4, 3], "intensity": [20, 20, 20]}]
})";
  return p.string();
}

Json read_json(const fs::path& p) {
  return rtu::host::read_json_file(p.string());  // depth-limited, as rtu reads JSON (host/json_io.h)
}

}  // namespace

TEST_CASE("plan: the chosen format meets its budget on the sample it measured, with the fewest coordinate bits",
          "[jobs][plan]") {
  rtu::host::PlanOptions o;
  o.scene = "builtin:icosphere?subdiv=2";
  o.max_error = 0.02;
  o.widths = {4};
  o.coord_bits = {3, 6, 10, 14, 18, 24};
  o.child_bits = {4, 8};
  o.sweep.rays = 300;
  o.sweep.image_width = 0;
  o.sweep.threads = 1;
  std::vector<rtu::host::SweepRow> candidates;
  std::vector<rtu::host::PlanStage> stages;
  const rtu::host::PlanResult r = rtu::host::plan_format(o, [&](const rtu::host::PlanStep& s) {
    stages.push_back(s.stage);
    if (s.stage == rtu::host::PlanStage::kCandidate) {
      REQUIRE(s.row != nullptr);
      CHECK(s.meets == rtu::host::plan_meets(*s.row, o));
      candidates.push_back(*s.row);
    }
  });
  REQUIRE(r.found);
  CHECK(r.scene == "builtin:icosphere?subdiv=2");
  CHECK(rtu::host::plan_meets(r.best, o));
  CHECK(rtu::host::plan_error(r.best, "hit") <= o.max_error);
  CHECK(r.best.box_false_negatives == 0);
  CHECK(r.best.rays == 2 * o.sweep.rays);
  CHECK(r.best.p.bvh_width == 4);
  CHECK(r.json["plan"]["coord_bits"] == r.format.coord_bits);
  // The coordinate bits are the first of the list that meet the budget: every candidate before them did not.
  const int bits = r.format.coord_bits;
  bool seen = false;
  for (const rtu::host::SweepRow& c : candidates) {
    if (c.p.format.find("child_bits=8") == std::string::npos || c.p.format == "default") continue;
    if (c.p.format.find("coord_bits=" + std::to_string(bits) + ":") != std::string::npos) seen = true;
    if (!seen) CHECK_FALSE(rtu::host::plan_meets(c, o));
  }
  CHECK(seen);
  // The reference is the default format at the plan's width, measured last.
  CHECK(r.reference.p.format == "default");
  CHECK(r.reference.p.bvh_width == r.best.p.bvh_width);
  REQUIRE(!stages.empty());
  CHECK(stages.front() == rtu::host::PlanStage::kCoordBits);
  CHECK(stages[stages.size() - 2] == rtu::host::PlanStage::kDefault);
  CHECK(stages.back() == rtu::host::PlanStage::kCandidate);
  CHECK(r.json["plan"]["format"] == r.best.p.format);
  CHECK(r.json["plan"]["cycles"] == r.best.cycles);
  CHECK(r.json["default"]["cycles"] == r.reference.cycles);
}

TEST_CASE("plan: a bad metric or budget is refused before the scene is loaded", "[jobs][plan]") {
  rtu::host::PlanOptions o;
  o.scene = "no/such/scene.obj";
  o.metric = "psnr";
  CHECK_THROWS_WITH(rtu::host::plan_format(o), Catch::Contains("--metric"));
  o.metric = "t";
  o.max_error = -1.0;
  CHECK_THROWS_WITH(rtu::host::plan_format(o), Catch::Contains("--max-error"));
  o.max_error = 0.1;
  o.config = "no-such-preset";
  CHECK_THROWS_AS(rtu::host::plan_format(o), rtu::host::Error);
}

TEST_CASE("demo: writes every file it lists, and its figures agree with the files", "[jobs][demo]") {
  TempDir dir("demo");
  rtu::host::DemoOptions o;
  o.scene = small_scene(dir.path);
  o.out = (dir.path / "out").string();
  o.threads = 1;
  o.spp = 1;
  o.max_depth = 2;
  std::vector<rtu::host::DemoStage> stages;
  const rtu::host::DemoResult r =
      rtu::host::run_demo(o, [&](rtu::host::DemoStage s, const rtu::host::DemoResult&) { stages.push_back(s); });
  using S = rtu::host::DemoStage;
  CHECK(stages == std::vector<S>{S::kLoaded, S::kTraced, S::kTraced, S::kCompared, S::kRendered, S::kRendered,
                                 S::kHybrid, S::kRenderDiff});
  REQUIRE(!r.written.empty());
  for (const std::string& f : r.written) {
    CAPTURE(f);
    CHECK(fs::is_regular_file(f));
    CHECK(fs::file_size(f) > 0);
  }
  CHECK(r.written.back() == o.out + "/report.json");
  // One hit of 16 bytes per primary ray in each hit file.
  CHECK(fs::file_size(o.out + "/primary_float.hits") == 40u * 30u * 16u);
  CHECK(fs::file_size(o.out + "/primary_fixed.hits") == 40u * 30u * 16u);
  CHECK(r.fixed_vs_float.rays == 40u * 30u);
  REQUIRE(r.traces.size() == 2);
  CHECK(r.traces[0].device == rtu::hw::DeviceKind::kFloat);
  CHECK(r.traces[1].device == rtu::hw::DeviceKind::kFixed);
  REQUIRE(r.renders.size() == 3);
  CHECK_FALSE(r.renders[0].result.timed);
  CHECK(r.renders[1].options.device.kind == rtu::hw::DeviceKind::kTimed);
  CHECK(r.renders[1].result.timed);
  CHECK(r.renders[1].result.device_clock > 0);
  CHECK(r.renders[2].options.hybrid);
  const Json j = read_json(o.out + "/report.json");
  CHECK(j["width"] == 40);
  CHECK(j["devices"]["float"]["hits"] == r.traces[0].stats.hits);
  CHECK(j["devices"]["fixed"]["hits"] == r.traces[1].stats.hits);
  CHECK(j["renders"]["fixed"]["device"] == "timed");
  CHECK(j["renders"]["fixed"]["timing"]["cycles_per_frame"] == r.renders[1].result.device_clock);
  CHECK(j["hybrid_vs_raytrace"]["raytrace_cycles"] == r.renders[1].result.device_clock);
  CHECK(j["render_fixed_vs_float"]["pixels_differing"] == r.render_fixed_vs_float.pixels_differing);
}

TEST_CASE("report: the page, report.json, the sweep CSV and every image it embeds are written", "[jobs][report]") {
  TempDir dir("report");
  rtu::host::ReportOptions o;
  o.out = (dir.path / "out").string();
  o.scenes = {"builtin:icosphere?subdiv=1"};
  o.quick = true;
  o.threads = 1;
  std::vector<rtu::host::ReportStage> stages;
  const rtu::host::ReportResult r =
      rtu::host::write_report(o, [&](const rtu::host::ReportStep& s) { stages.push_back(s.stage); });
  using S = rtu::host::ReportStage;
  CHECK(stages == std::vector<S>{S::kStart, S::kRender, S::kRender, S::kCycles, S::kSweep, S::kStress});
  for (const char* f :
       {"index.html", "report.json", "sweep.csv", "render_float.png", "render_fixed.png", "render_heatmap.png"}) {
    CAPTURE(f);
    CHECK(fs::file_size(o.out + "/" + f) > 0);
  }
  REQUIRE(!r.images.empty());
  std::ifstream page(o.out + "/index.html");
  const std::string html((std::istreambuf_iterator<char>(page)), std::istreambuf_iterator<char>());
  for (const std::string& img : r.images) {
    CAPTURE(img);
    CHECK(fs::is_regular_file(o.out + "/" + img));
    CHECK(html.find("src=\"" + img + "\"") != std::string::npos);
  }
  CHECK(r.stress_failures == 0);
  const Json j = read_json(o.out + "/report.json");
  CHECK(j["images"].size() == r.images.size());
  CHECK(j["cycles"].size() == rtu::hw::timing_preset_names().size());  // one scene: one row per preset
  CHECK(j["sweep"]["points"] == rtu::host::read_sweep_csv(o.out + "/sweep.csv").size());
  CHECK(j["stress"]["failures"] == 0);
}

TEST_CASE("report: an output directory that cannot be created is refused before any work", "[jobs][report]") {
  TempDir dir("report_bad");
  std::ofstream(dir.path / "file") << "x";
  rtu::host::ReportOptions o;
  o.out = (dir.path / "file" / "out").string();
  bool started = false;
  CHECK_THROWS_AS(rtu::host::write_report(o, [&](const rtu::host::ReportStep&) { started = true; }),
                  rtu::host::Error);
  CHECK_FALSE(started);
}

TEST_CASE("ray specs, timing overrides and pipeline-trace windows as the command line passes them", "[jobs]") {
  const rtu::host::Scene s = rtu::host::load_scene("builtin:icosphere?subdiv=1");
  CHECK(rtu::host::rays_from_spec("primary:4x3", s, 1).size() == 12);
  CHECK(rtu::host::rays_from_spec("incoherent:7", s, 1).size() == 7);
  CHECK_THROWS_WITH(rtu::host::rays_from_spec("primary:0", s, 1), Catch::Contains("bad count '0'"));

  const rtu::hw::TimingConfig c = rtu::host::timing_config_from("intel", {"box_rate=3", "ray_slots=7"});
  CHECK(c.name == "intel");
  CHECK(c.box_rate == 3);
  CHECK(c.ray_slots == 7);
  CHECK_THROWS_WITH(rtu::host::timing_config_from("intel", {"box_rate"}), Catch::Contains("is not key=value"));
  CHECK_THROWS_AS(rtu::host::timing_config_from("no-such-preset", {}), rtu::host::Error);

  rtu::host::DeviceSettings d;
  d.config = "intel";
  d.format_fields["coord_bits"] = 16;
  const rtu::host::DeviceOptions timed = d.options(rtu::hw::DeviceKind::kTimed);
  CHECK(timed.kind == rtu::hw::DeviceKind::kTimed);
  CHECK(timed.format.coord_bits == 16);
  CHECK(timed.format.width == timed.timing.bvh_width);  // the preset's width, as --config gives it
  CHECK(d.options(rtu::hw::DeviceKind::kFloat).kind == rtu::hw::DeviceKind::kFloat);

  const rtu::hw::PipelineTrace t = rtu::host::pipeline_trace_window("10:20");
  CHECK(t.from == 10);
  CHECK(t.to == 20);
  CHECK_THROWS_WITH(rtu::host::pipeline_trace_window("20:10"), Catch::Contains("--trace-window"));
  CHECK_THROWS_AS(rtu::host::pipeline_trace_window("10"), rtu::host::Error);
}
