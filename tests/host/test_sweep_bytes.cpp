// Bytes in the design sweep (issue 26): the sweep's bytes per primitive and DRAM bytes per ray, through the CSV,
// resume and merge; `plan --minimise bytes`; and the trade-off packed layouts make on a memory-bound preset, where
// a format with fewer coordinate bits fetches fewer bytes and so runs faster than the most precise one.
#include <catch2/catch.hpp>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "host/io/json_io.h"
#include "host/jobs/pareto.h"
#include "host/jobs/plan.h"
#include "host/jobs/sweep.h"
#include "host/scene/scene.h"
#include "hwmodel/timing/timing_config.h"
#include "tests/host/cli_checks.h"

namespace fs = std::filesystem;
using rtu::host::SweepRow;
using namespace rtu::test;

TEST_CASE("sweep: bytes per primitive and DRAM bytes per ray in the CSV, through resume and merge",
          "[cli][sweep]") {
  const TempDir t("bytes_csv");
  const fs::path whole = t.path / "whole.csv", a = t.path / "a.csv", b = t.path / "b.csv",
                 merged = t.path / "merged.csv";
  // Layouts are format specs: the default's structs and records against bit-packed nodes and triangle blocks.
  const std::string grid =
      "sweep --scene builtin:icosphere --formats default,packed,packed:coord_bits=12 --config rdna2-mem --rays "
      "500 "
      "--image-width 0 --threads 2 ";
  Run r = run_rtusim(grid + "--out " + whole.string());
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("DRAM bytes/ray") != std::string::npos);
  const std::vector<std::string> w = read_lines(whole);
  REQUIRE(w.size() == 4);
  CHECK(w[0].find(",cycles,cycles_per_ray,dram_bytes_per_ray,bvh_bytes,float_bvh_bytes,bytes_per_prim,") !=
        std::string::npos);
  const std::vector<SweepRow> rows = rtu::host::read_sweep_csv(whole.string());
  REQUIRE(rows.size() == 3);
  // The columns round-trip: a row read back writes the line it was read from.
  for (size_t i = 0; i < rows.size(); ++i) CHECK(rtu::host::sweep_csv_line(rows[i]) == w[i + 1]);
  const double triangles = double(rtu::host::load_scene("builtin:icosphere").geometry.triangles.size());
  for (const SweepRow& row : rows) {
    CAPTURE(row.p.format);
    CHECK(row.bytes_per_prim > 0.0);
    CHECK(row.bytes_per_prim * triangles < double(row.bvh_bytes));  // nodes + primitives: the image less the rest
    CHECK(row.dram_bytes_per_ray > 0.0);
    // DRAM moves whole 64-byte lines (rdna2-mem's line_bytes).
    const double dram = row.dram_bytes_per_ray * double(row.rays);
    CHECK(std::abs(dram - std::round(dram)) < 1e-6 * dram);
    CHECK(std::llround(dram) % rtu::hw::timing_preset("rdna2-mem").line_bytes == 0);
  }
  // Packed nodes and triangle blocks take fewer bytes than structs and records, and fewer bits fewer still; the
  // DRAM traffic follows.
  CHECK(rows[1].bytes_per_prim < rows[0].bytes_per_prim);
  CHECK(rows[2].bytes_per_prim < rows[1].bytes_per_prim);
  CHECK(rows[1].dram_bytes_per_ray < rows[0].dram_bytes_per_ray);
  // The same figure as `rtusim info` gives for the image.
  const fs::path info = t.path / "info.json";
  REQUIRE(run_rtusim("info --scene builtin:icosphere --format packed --json " + info.string()).status == 0);
  const auto ij = rtu::host::read_json_file(info.string());
  CHECK(ij["bvh"]["image"]["bytes_per_prim"].get<double>() == Approx(rows[1].bytes_per_prim).epsilon(1e-12));
  CHECK(ij["bvh"]["image"]["node_layout"] == "bit-packed");
  CHECK(ij["bvh"]["image"]["prim_layout"] == "blocks");
  CHECK(ij["bvh"]["image"]["total_bytes"] == rows[1].bvh_bytes);

  // Resume: nothing to run, the file unchanged.
  r = run_rtusim(grid + "--out " + whole.string());
  CHECK(r.output.find("0 run, 3 already") != std::string::npos);
  CHECK(read_lines(whole) == w);
  // Shards merge into the same rows, new columns and all.
  REQUIRE(run_rtusim(grid + "--shard 1/2 --out " + a.string()).status == 0);
  REQUIRE(run_rtusim(grid + "--shard 2/2 --out " + b.string()).status == 0);
  REQUIRE(run_rtusim("sweep --merge " + a.string() + " " + b.string() + " --out " + merged.string()).status == 0);
  check_same_rows(read_lines(merged), w);

  // A file of the previous version (no DRAM or per-primitive bytes) is refused by resume, merge and the plots,
  // saying what it lacks.
  // The columns every earlier version began with.
  const std::string first_columns =
      "scene,format,bvh_width,config,rays,seed,image_width,hit_agreement,prim_agreement,false_misses,false_hits,"
      "t_rel_error_mean,t_rel_error_max,node_visit_overhead,prim_test_overhead,box_false_negatives,psnr_db,cycles,"
      "cycles_per_ray,";
  const fs::path old = t.write("old.csv", first_columns +
                                              "bvh_bytes,float_bvh_bytes,rtl_cells,rtl_transistors,seconds\n"
                                              "builtin:icosphere,default,4,rdna2-mem,1000,1,0,1,1,0,0,0,0,0,0,0,0,"
                                              "5000,5,281192,300000,-1,-1,0.1\n");
  for (const std::string& args :
       {grid + "--out " + old.string(), "sweep --merge " + old.string() + " --out " + (t.path / "m2.csv").string(),
        "pareto --sweep " + old.string() + " --out " + (t.path / "p").string()}) {
    const Run e = run_rtusim(args);
    INFO(args << "\n" << e.output);
    CHECK(e.status == 2);
    CHECK(e.output.find("an earlier rtusim wrote it") != std::string::npos);
    CHECK(e.output.find("dram_bytes_per_ray") != std::string::npos);
  }
  CHECK(read_lines(old).size() == 2);  // left as it was

  // And one of the version before the area and energy columns.
  const fs::path pre_energy =
      t.write("pre_energy.csv", first_columns +
                                    "dram_bytes_per_ray,bvh_bytes,float_bvh_bytes,bytes_per_prim,rtl_cells,"
                                    "rtl_transistors,seconds\n");
  const Run e = run_rtusim("sweep --merge " + pre_energy.string() + " --out " + (t.path / "m3.csv").string());
  INFO(e.output);
  CHECK(e.status == 2);
  CHECK(e.output.find("without the columns area_mm2 and pj_per_ray") != std::string::npos);
}

TEST_CASE("plan --minimise bytes: no more bytes than the cycles plan, within the budget", "[jobs][plan]") {
  rtu::host::PlanOptions o;
  o.scene = "builtin:icosphere?subdiv=2";
  o.config = "rdna2-mem";
  o.format = "packed";  // packed candidates: their bytes follow their bits
  o.max_error = 0.02;
  o.widths = {4, 8};
  o.coord_bits = {4, 6, 8, 12, 16};
  o.child_bits = {4, 8};
  o.sweep.rays = 300;
  o.sweep.image_width = 0;
  o.sweep.threads = 1;
  std::vector<SweepRow> candidates;
  const auto collect = [&](const rtu::host::PlanStep& s) {
    if (s.stage == rtu::host::PlanStage::kCandidate) candidates.push_back(*s.row);
  };
  const rtu::host::PlanResult cyc = rtu::host::plan_format(o);
  o.minimise = "bytes";
  const rtu::host::PlanResult byt = rtu::host::plan_format(o, collect);
  REQUIRE(cyc.found);
  REQUIRE(byt.found);
  CHECK(cyc.json["minimise"] == "cycles");
  CHECK(byt.json["minimise"] == "bytes");
  CHECK(cyc.json["cost"].get<std::string>().rfind("cycles on rdna2-mem", 0) == 0);
  CHECK(byt.json["cost"].get<std::string>().rfind("image bytes", 0) == 0);
  CHECK(byt.json["base_format"] == "packed");
  // Every candidate is packed: the base's layouts with other bits.
  for (const SweepRow& c : candidates) {
    CAPTURE(c.p.format);
    CHECK(c.p.format.rfind("packed", 0) == 0);
  }
  CHECK(byt.best.bvh_bytes <= cyc.best.bvh_bytes);
  CHECK(byt.json["plan"]["bytes"] == byt.best.bvh_bytes);
  CHECK(byt.json["plan"]["bytes_per_prim"] == byt.best.bytes_per_prim);
  CHECK(byt.json["plan"]["dram_bytes_per_ray"] == byt.best.dram_bytes_per_ray);
  CHECK(rtu::host::plan_meets(byt.best, o));
  // No measured candidate within the budget is smaller, and among those as small none is faster.
  for (const SweepRow& c : candidates) {
    if (!rtu::host::plan_meets(c, o)) continue;
    CAPTURE(c.p.format, c.p.bvh_width);
    CHECK(c.bvh_bytes >= byt.best.bvh_bytes);
    if (c.bvh_bytes == byt.best.bvh_bytes) CHECK(c.cycles >= byt.best.cycles);
  }
  // The chosen format, run again as a sweep point of its own, has the figures the plan gave and meets the budget.
  const rtu::host::Scene scene = rtu::host::load_scene(o.scene);
  auto cache = rtu::host::make_sweep_cache();
  const SweepRow again = rtu::host::run_sweep_point(scene, byt.best.p, o.sweep, {}, *cache);
  CHECK(again.bvh_bytes == byt.best.bvh_bytes);
  CHECK(again.cycles == byt.best.cycles);
  CHECK(again.false_misses + again.false_hits == byt.best.false_misses + byt.best.false_hits);
  CHECK(rtu::host::plan_meets(again, o));
  CHECK(rtu::host::plan_error_bound(again, o) <= o.max_error);

  // A bad cost or base format is refused before the scene is loaded.
  o.scene = "no/such/scene.obj";
  o.minimise = "foo";
  CHECK_THROWS_WITH(rtu::host::plan_format(o), Catch::Contains("--minimise"));
  o.minimise = "bytes";
  o.format = "nosuch";
  CHECK_THROWS_WITH(rtu::host::plan_format(o), Catch::Contains("--format"));
}

TEST_CASE("plan on the command line: --minimise and its alias --minimize, --format", "[cli][sweep]") {
  const TempDir t("bytes_plan");
  const std::string base =
      "plan --scene builtin:cornell --max-error 2e-2 --bvh-width 4 --coord-bits 8,12 --child-bits 8 --rays 200 "
      "--image-width 0 --config rdna2-mem --format packed ";
  for (const char* option : {"--minimise", "--minimize"}) {
    const fs::path json = t.path / (std::string(option + 2) + ".json");
    REQUIRE_RTUSIM_OK(r, base + option + " bytes --json " + json.string());
    CHECK(r.output.find("cheapest: image bytes (bvh_bytes), then cycles on rdna2-mem") != std::string::npos);
    const auto j = rtu::host::read_json_file(json.string());
    CHECK(j["minimise"] == "bytes");
    CHECK(j["plan"]["format"].get<std::string>().rfind("packed:", 0) == 0);
  }
  const Run bad = run_rtusim(base + "--minimise foo");
  CHECK(bad.status == 2);
  CHECK(bad.output.find("--minimise") != std::string::npos);
  const Run help = run_rtusim("plan --help");
  CHECK(help.output.find("--minimise") != std::string::npos);
  CHECK(help.output.find("--format") != std::string::npos);
}

TEST_CASE(
    "memory-bound preset, packed layout: fewer coordinate bits, fewer bytes and fewer cycles than the most "
    "precise format",
    "[timed][sweep][scale]") {
  // On rdna2-mem (a 16 KiB cache, 3.2 bytes per clock of VRAM bandwidth) incoherent rays are limited by DRAM
  // (test_timed.cpp). Bit-packed nodes and triangle blocks take bytes in proportion to the coordinate bits, so a
  // format with fewer bits fetches fewer lines and runs faster, up to where the coarser boxes' extra node visits
  // cost more than the bytes save: the error-against-cycles front is a trade-off, not one point. A real mesh
  // (Debian assimp-testmodels) and a built-in one.
  const std::vector<int> bits = {10, 12, 16, 20, 24, 28};
  for (const std::string& spec :
       {std::string("/usr/share/assimp/models/IFC/AC14-FZK-Haus.ifc"), std::string("builtin:icosphere")}) {
    CAPTURE(spec);
    const rtu::host::Scene scene = rtu::host::load_scene(spec);
    rtu::host::SweepOptions so;
    so.rays = 2000;  // camera and incoherent rays: 4000
    so.image_width = 0;
    so.threads = 2;
    auto cache = rtu::host::make_sweep_cache();
    std::vector<SweepRow> rows;
    for (int b : bits)
      rows.push_back(rtu::host::run_sweep_point(
          scene, rtu::host::SweepPoint{spec, "packed:coord_bits=" + std::to_string(b), 4, "rdna2-mem"}, so, {},
          *cache));
    const SweepRow& precise = rows.back();
    for (size_t i = 0; i < rows.size(); ++i) {
      CAPTURE(rows[i].p.format, rows[i].cycles, rows[i].dram_bytes_per_ray, rows[i].bytes_per_prim,
              rows[i].t_rel_error_mean);
      CHECK(rows[i].box_false_negatives == 0);
      if (i > 0) CHECK(rows[i].bytes_per_prim > rows[i - 1].bytes_per_prim);  // bytes follow bits
    }
    // Some format with fewer bits is faster than the most precise one, and fetched fewer DRAM bytes.
    const auto fastest = std::min_element(
        rows.begin(), rows.end(), [](const SweepRow& x, const SweepRow& y) { return x.cycles < y.cycles; });
    CAPTURE(fastest->p.format, fastest->cycles, precise.cycles);
    CHECK(fastest->p.format != precise.p.format);
    CHECK(fastest->cycles < precise.cycles);
    CHECK(fastest->dram_bytes_per_ray < precise.dram_bytes_per_ray);
    CHECK(fastest->t_rel_error_mean > precise.t_rel_error_mean);
    // So the front of error (mean relative t error) against cycles holds both: more than one point.
    std::vector<std::pair<double, double>> pts;
    for (const SweepRow& r : rows)
      pts.emplace_back(rtu::host::pareto_cost(r, rtu::host::ParetoCost::kCycles),
                       rtu::host::pareto_error(r, rtu::host::ParetoError::kTRelErrorMean));
    const std::vector<size_t> front = rtu::host::pareto_front(pts);
    CHECK(front.size() >= 2);
    CHECK(std::find(front.begin(), front.end(), rows.size() - 1) != front.end());  // the most precise
  }
}
