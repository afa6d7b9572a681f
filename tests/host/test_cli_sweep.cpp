// rtusim end to end: sweep (rows, resume, shards and merge) and plan. Sweep manifests and point files:
// test_cli_manifest.cpp.
#include <catch2/catch.hpp>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/jobs/sweep.h"
#include "tests/host/cli_checks.h"

namespace fs = std::filesystem;
using namespace rtu::test;

TEST_CASE("sweep: rows per point, resume, shards that merge into the whole, bad input", "[cli][sweep]") {
  const fs::path d = temp_dir("cli");
  const std::string whole = (d / "sweep_whole.csv").string(), a = (d / "sweep_a.csv").string(),
                    b = (d / "sweep_b.csv").string(), merged = (d / "sweep_merged.csv").string();
  for (const std::string& f : {whole, a, b, merged}) fs::remove(f);
  const std::string grid =
      "sweep --scene builtin:seed --formats default,compact,default:coord_bits=12 --bvh-width 4,8 --rays 3000 "
      "--image-width 48 ";
  Run r = run_rtusim(grid + "--out " + whole);
  INFO(r.output);
  REQUIRE(r.status == 0);
  const std::vector<std::string> w = read_lines(whole);
  REQUIRE(w.size() == 7);  // header + 3 formats x 2 widths
  CHECK(w[0].rfind("scene,format,bvh_width,config,rays,seed,image_width,flatten,hit_agreement", 0) == 0);
  // The default format agrees with float on every ray of the seed scene (3000 + 3000 rays, seed 1, 48 wide).
  CHECK(w[1].find("builtin:seed,default,4,rdna2,6000,1,48,0,1,") == 0);
  // At every width the fixed device traverses the float reference's tree of the same width: quantized boxes
  // only grow, so it visits a few percent more nodes, never far fewer (a reference of another width would).
  for (size_t i = 1; i < w.size(); ++i) {
    std::vector<std::string> f;
    std::stringstream ss(w[i]);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    REQUIRE(f.size() == 30);  // the last is the model identity
    const double node_overhead = std::stod(f[14]);
    INFO(w[i]);
    CHECK(node_overhead >= -0.01);
    CHECK(node_overhead <= 0.25);
  }
  // Resume: nothing left to run, the file unchanged.
  r = run_rtusim(grid + "--out " + whole);
  CHECK(r.status == 0);
  CHECK(r.output.find("0 run, 6 already") != std::string::npos);
  CHECK(read_lines(whole) == w);
  // An interrupted row (no newline at the end) is dropped and run again.
  {
    std::ofstream f(whole, std::ios::app);
    f << "builtin:seed,default,4";
  }
  r = run_rtusim(grid + "--out " + whole);
  CHECK(r.status == 0);
  CHECK(r.output.find("unfinished row") != std::string::npos);
  CHECK(read_lines(whole).size() == 7);
  // Two shards merge into the same rows.
  REQUIRE(run_rtusim(grid + "--shard 1/2 --out " + a).status == 0);
  REQUIRE(run_rtusim(grid + "--shard 2/2 --out " + b).status == 0);
  CHECK(read_lines(a).size() == 4);
  CHECK(read_lines(b).size() == 4);
  REQUIRE(run_rtusim("sweep --merge " + a + " " + b + " --out " + merged).status == 0);
  check_same_rows(read_lines(merged), w);
  // Bad input: a clear error naming it, exit 2, nothing crashes.
  for (const auto& [args, words] :
       std::vector<std::pair<std::string, std::string>>{{"--formats nosuch", "unknown format preset"},
                                                        {"--formats default:coord_bits=99", "coord_bits"},
                                                        {"--formats default:bits=3", "format key"},
                                                        {"--shard 3/2", "--shard"},
                                                        {"--shard x", "--shard"},
                                                        {"--bvh-width 3", "2, 4, 6 or 8"},
                                                        {"--config nosuch", "nosuch"}}) {
    const Run e =
        run_rtusim("sweep --scene builtin:seed " + args + " --rays 10 --out " + (d / "bad.csv").string());
    INFO(args << ": " << e.output);
    CHECK(e.status == 2);
    CHECK(e.output.find(words) != std::string::npos);
  }
  {
    std::ofstream f(d / "foreign.csv");
    f << "a,b,c\n1,2,3\n";
  }
  const Run e = run_rtusim("sweep --scene builtin:seed --rays 10 --out " + (d / "foreign.csv").string());
  CHECK(e.status == 2);
  CHECK(e.output.find("not a sweep file") != std::string::npos);
}

TEST_CASE(
    "plan: the fewest coordinate bits within the budget and the chosen, the reason, an impossible budget fails",
    "[cli][sweep]") {
  const fs::path d = temp_dir("cli");
  const std::string json = (d / "plan.json").string();
  REQUIRE_RTUSIM_OK(r,
                    "plan --scene builtin:cornell --max-error 2e-3 --bvh-width 4 --coord-bits 6,8,10,12,16 "
                    "--child-bits 6,8 --rays 3000 --image-width 0 --json " +
                        json);
  const nlohmann::json j = read_json(json);
  const auto& w = j["widths"][0];
  REQUIRE(w["feasible"] == true);
  const int b = w["coord_bits"];
  // The chosen width's error bound meets the budget; the next fewer tried does not (or it was the fewest tried).
  CHECK(w["error_bound_at_coord_bits"].get<double>() <= 2e-3);
  CHECK(w["error_at_coord_bits"].get<double>() <= w["error_bound_at_coord_bits"].get<double>());
  if (w.contains("fewer_coord_bits")) {
    CHECK(w["fewer_coord_bits"].get<int>() < b);
    CHECK(w["error_bound_at_fewer_coord_bits"].get<double>() > 2e-3);
    CHECK(r.output.find("why " + std::to_string(b) + " coordinate bits at least") != std::string::npos);
  }
  // Minimising cycles, the plan may take more bits than the fewest within the budget, never fewer.
  CHECK(w["chosen_coord_bits"].get<int>() >= b);
  // Every step up it weighed is printed with its measured cause, weighed against the bits kept so far; the steps
  // taken lead to the chosen bits, and one not taken saved too little (--min-gain) or was a placement tie.
  int reached = b;
  for (size_t i = 0; i < w["more_coord_bits"].size(); ++i) {
    const auto& m = w["more_coord_bits"][i];
    const std::string cause = m["cause"];
    CHECK(m["from_coord_bits"] == reached);
    CHECK(r.output.find(cause) != std::string::npos);
    if (m["taken"] == true)
      reached = m["to_coord_bits"];
    else
      CHECK((cause.find("below --min-gain 2%") != std::string::npos || cause.find("a tie") != std::string::npos));
  }
  CHECK(reached == w["chosen_coord_bits"].get<int>());
  CHECK(r.output.find("(fewer node visits)") == std::string::npos);  // no cause claimed unmeasured
  CHECK(j["plan"]["coord_bits"] == w["chosen_coord_bits"]);
  CHECK(j["plan"]["error_bound"].get<double>() <= 2e-3);
  CHECK(j["plan"]["cycles"].get<uint64_t>() > 0);
  // The plan skips bits: fewer than the default format's 24 are enough for this budget.
  CHECK(b < 24);
  // Every child-bit candidate that met the budget costs at least the chosen cycles, or is larger and saves no more
  // than --min-gain, which the plan prints.
  for (const auto& k : w["child_bits"]) {
    if (k["meets"] != true || k["cycles"].get<uint64_t>() >= j["plan"]["cycles"].get<uint64_t>()) continue;
    REQUIRE(k.contains("passed_over"));
    CHECK(k["cycles"].get<double>() >= 0.98 * j["plan"]["cycles"].get<double>());
    CHECK(r.output.find(k["passed_over"].get<std::string>()) != std::string::npos);
  }
  // No format can have a mean t error of exactly 0 at 2 coordinate bits only: exit 1, saying so.
  const Run none = run_rtusim(
      "plan --scene builtin:cornell --metric t --max-error 0 --bvh-width 4 --coord-bits 2 "
      "--child-bits 8 --rays 500 --image-width 0");
  CHECK(none.status == 1);
  CHECK(none.output.find("no format meets") != std::string::npos);
  CHECK(run_rtusim("plan --scene builtin:cornell --max-error -1").status == 2);
  CHECK(run_rtusim("plan --scene builtin:cornell --max-error 1e-3 --metric psnr").status != 0);
}

TEST_CASE("plan --min-gain and --minimise area or perf-per-area on the command line, and bad values exit 2",
          "[cli][sweep]") {
  const fs::path d = temp_dir("cli");
  const std::string json = (d / "plan_gain.json").string();
  // 12 and 16 coordinate bits both meet the budget; 16 save a few percent of the cycles (1-3% on these rays).
  const std::string base =
      "plan --scene builtin:seed --max-error 1e-2 --bvh-width 4 --coord-bits 12,16 --child-bits 8 --rays 1000 "
      "--image-width 0 --threads 1 ";
  REQUIRE_RTUSIM_OK(r, base + "--min-gain 5 --json " + json);
  const nlohmann::json j = read_json(json);
  CHECK(j["plan"]["coord_bits"] == 12);
  CHECK(j["min_gain_pct"] == 5.0);
  CHECK(j["minimise"] == "cycles");
  CHECK(r.output.find("more bits or area only for a saving over 5% (--min-gain)") != std::string::npos);
  CHECK(r.output.find("kept 12 coordinate bits over 16 on rdna2: ") != std::string::npos);
  CHECK(r.output.find("% area, below --min-gain 5% (") != std::string::npos);
  CHECK(r.output.find("rays/clock/mm^2") != std::string::npos);  // every candidate's ratio
  for (const auto& c : j["widths"][0]["candidates"]) CHECK(c["perf_per_mm2"].get<double>() > 0.0);
  // Any saving: 16 bits.
  const Run any = run_rtusim(base + "--min-gain 0 --json " + json);
  REQUIRE(any.status == 0);
  CHECK(read_json(json)["plan"]["coord_bits"] == 16);
  CHECK(any.output.find("took 16 coordinate bits over 12 on rdna2: ") != std::string::npos);
  // The smallest unit, and the best ratio, each named as the cost.
  const Run area = run_rtusim(base + "--minimise area --json " + json);
  REQUIRE(area.status == 0);
  CHECK(read_json(json)["plan"]["coord_bits"] == 12);
  CHECK(area.output.find("cheapest: area (area_mm2), then cycles on rdna2\n") != std::string::npos);
  const Run ppa = run_rtusim(base + "--minimize perf-per-area --json " + json);
  REQUIRE(ppa.status == 0);
  const nlohmann::json jp = read_json(json);
  CHECK(jp["minimise"] == "perf-per-area");
  CHECK(ppa.output.find("cheapest: rays per clock per mm^2 on rdna2, then cycles\n") != std::string::npos);
  for (const auto& c : jp["widths"][0]["candidates"])
    if (c["meets"] == true) CHECK(c["perf_per_mm2"].get<double>() <= jp["plan"]["perf_per_mm2"].get<double>());
  // Bad values: a usage error naming the option, exit 2.
  for (const char* bad : {"--minimise foo", "--min-gain -1", "--min-gain nan", "--min-gain 101"}) {
    const Run e = run_rtusim(base + bad);
    INFO(bad << ": " << e.output);
    CHECK(e.status == 2);
    CHECK(e.output.find(std::string(bad).substr(0, std::string(bad).find(' ')) + ": ") != std::string::npos);
  }
}

TEST_CASE("sweep: resume reruns points made with other --rays, --seed or --image-width, merge refuses a mix",
          "[cli][sweep]") {
  const fs::path d = temp_dir("cli");
  const std::string f = (d / "params.csv").string(), g = (d / "params_g.csv").string(),
                    m = (d / "params_m.csv").string();
  for (const std::string& x : {f, g, m}) fs::remove(x);
  const std::string grid = "sweep --scene builtin:cornell --formats default,compact ";
  Run r = run_rtusim(grid + "--rays 64 --image-width 0 --out " + f);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("2 run, 0 already") != std::string::npos);
  r = run_rtusim(grid + "--rays 64 --image-width 0 --out " + f);  // the same parameters: nothing to do
  CHECK(r.output.find("0 run, 2 already") != std::string::npos);
  r = run_rtusim(grid + "--rays 128 --image-width 0 --out " + f);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("2 run, 0 already") != std::string::npos);
  CHECK(r.output.find("other run parameters") != std::string::npos);
  r = run_rtusim(grid + "--rays 128 --seed 2 --image-width 0 --out " + f);
  CHECK(r.output.find("2 run, 0 already") != std::string::npos);
  r = run_rtusim(grid + "--rays 128 --seed 2 --image-width 8 --out " + f);
  CHECK(r.output.find("2 run, 0 already") != std::string::npos);
  const std::vector<rtu::host::SweepRow> rows = rtu::host::read_sweep_csv(f);
  REQUIRE(rows.size() == 8);
  CHECK(rows[0].rays == 128);  // 64 camera + 64 incoherent rays
  CHECK(rows[2].rays == 256);
  CHECK(rows[4].seed == 2);
  CHECK(rows[6].image_width == 8);
  CHECK(rtu::host::sweep_run_params(rows[6]) == "--rays 128 --seed 2 --image-width 8");

  REQUIRE(run_rtusim(grid + "--rays 128 --image-width 0 --out " + g).status == 0);
  const Run mixed = run_rtusim("sweep --merge " + f + " --out " + m);
  CHECK(mixed.status == 2);
  CHECK(mixed.output.find("only rows made with the same run parameters merge") != std::string::npos);
  REQUIRE(run_rtusim(grid + "--rays 64 --image-width 0 --out " + m).status == 0);
  const Run two = run_rtusim("sweep --merge " + g + " " + m + " --out " + (d / "params_mm.csv").string());
  INFO(two.output);
  CHECK(two.status == 2);
  CHECK(two.output.find("--rays 128 --seed 1 --image-width 0") != std::string::npos);
  CHECK(two.output.find("--rays 64 --seed 1 --image-width 0") != std::string::npos);
}

TEST_CASE(
    "sweep: a PSNR not measured is an empty cell, merge warns of conflicting duplicates, CRLF and a BOM read",
    "[cli][sweep]") {
  const fs::path d = temp_dir("cli") / "sweep_cells";
  fs::remove_all(d);
  fs::create_directories(d);
  const std::string a = (d / "a.csv").string(), b = (d / "b.csv").string();
  const Run r =
      run_rtusim("sweep --scene builtin:cornell --formats default,compact --rays 64 --image-width 0 --out " + a);
  INFO(r.output);
  REQUIRE(r.status == 0);
  CHECK(r.output.find("no render") != std::string::npos);
  std::vector<std::string> lines;
  {
    std::ifstream in(a);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
  }
  REQUIRE(lines.size() == 3);
  // psnr_db (the 18th column) is empty, not 0: no render measured it.
  for (size_t i = 1; i < lines.size(); ++i) {
    std::vector<std::string> f;
    std::stringstream ss(lines[i]);
    for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
    REQUIRE(f.size() == 30);  // the last is the model identity
    CHECK(f[17].empty());
    CHECK(lines[i].find("nan") == std::string::npos);
  }
  const std::vector<rtu::host::SweepRow> rows = rtu::host::read_sweep_csv(a);
  REQUIRE(rows.size() == 2);
  CHECK_FALSE(rows[0].psnr_measured());

  // The same rows with CRLF line ends and a UTF-8 byte order mark (as a spreadsheet saves them) read the same.
  const std::string crlf = (d / "crlf.csv").string();
  {
    std::ofstream f(crlf, std::ios::binary);
    f << "\xEF\xBB\xBF";
    for (const std::string& l : lines) f << l << "\r\n";
  }
  const std::vector<rtu::host::SweepRow> again = rtu::host::read_sweep_csv(crlf);
  REQUIRE(again.size() == 2);
  CHECK(again[1].p.key() == rows[1].p.key());
  CHECK(rtu::host::same_sweep_results(again[1], rows[1]));

  // Identical duplicates merge silently; a duplicate point with other results is kept out with a warning that
  // names the point and the column.
  const std::string m1 = (d / "m1.csv").string();
  Run mr = run_rtusim("sweep --merge " + a + " " + crlf + " --out " + m1);
  INFO(mr.output);
  REQUIRE(mr.status == 0);
  CHECK(mr.output.find("warning") == std::string::npos);
  CHECK(mr.output.find("2 duplicates dropped, 0 of them with other results") != std::string::npos);
  CHECK(rtu::host::read_sweep_csv(m1).size() == 2);
  {
    std::ofstream f(b);
    f << lines[0] << '\n';
    rtu::host::SweepRow row = rows[1];  // compact, its cycles changed
    row.cycles += 1;
    f << rtu::host::sweep_csv_line(row) << '\n';
  }
  mr = run_rtusim("sweep --merge " + a + " " + b + " --out " + (d / "m2.csv").string());
  INFO(mr.output);
  REQUIRE(mr.status == 0);
  CHECK(mr.output.find("warning: --merge: point " + rows[1].p.key()) != std::string::npos);
  // The kept row's value first.
  CHECK(mr.output.find("(cycles " + std::to_string(rows[1].cycles) + " against " +
                       std::to_string(rows[1].cycles + 1) + ")") != std::string::npos);
  CHECK(mr.output.find("1 of them with other results") != std::string::npos);
  const std::vector<rtu::host::SweepRow> kept = rtu::host::read_sweep_csv((d / "m2.csv").string());
  REQUIRE(kept.size() == 2);
  CHECK(kept[1].cycles == rows[1].cycles);  // the first file's row

  // A file of the version before the flatten column (and the model column) reads as two-level rows of no known
  // model; a resumed sweep rewrites it in this version, keeps its row and runs its point again (which build made
  // the row is not known).
  const std::string old = (d / "old.csv").string();
  {
    std::string header = lines[0];
    header.replace(header.find(",flatten"), 8, "");
    header.erase(header.rfind(",model"));
    std::string row = lines[1];
    size_t comma = 0;
    for (int i = 0; i < 7; ++i) comma = row.find(',', comma) + 1;  // after image_width
    row.erase(comma, 2);                                           // "0,"
    row.erase(row.rfind(','));                                     // the model
    std::ofstream f(old);
    f << header << '\n' << row << '\n';
  }
  const std::vector<rtu::host::SweepRow> old_rows = rtu::host::read_sweep_csv(old);
  REQUIRE(old_rows.size() == 1);
  CHECK_FALSE(old_rows[0].flatten);
  CHECK(old_rows[0].model.empty());
  rtu::host::SweepRow as_new = old_rows[0];
  as_new.model = rows[0].model;
  CHECK(rtu::host::same_sweep_results(as_new, rows[0]));
  const Run resumed =
      run_rtusim("sweep --scene builtin:cornell --formats default,compact --rays 64 --image-width 0 --out " + old);
  INFO(resumed.output);
  REQUIRE(resumed.status == 0);
  CHECK(resumed.output.find("1 rows of another model") != std::string::npos);
  CHECK(resumed.output.find("2 run, 0 already") != std::string::npos);
  CHECK(rtu::host::read_sweep_csv(old).size() == 3);

  // Rows of two models (two builds) do not merge into one table: the user is told which files they came from.
  const std::string other = (d / "other_model.csv").string();
  {
    std::ofstream f(other);
    f << lines[0] << '\n';
    rtu::host::SweepRow row = rows[0];
    row.model = "ffffffffffffffff";
    f << rtu::host::sweep_csv_line(row) << '\n';
  }
  const Run mixed = run_rtusim("sweep --merge " + a + " " + other + " --out " + (d / "m3.csv").string());
  INFO(mixed.output);
  CHECK(mixed.status == 2);
  CHECK(mixed.output.find("rows of different models") != std::string::npos);
  CHECK(mixed.output.find("ffffffffffffffff (in " + other + ")") != std::string::npos);
}

TEST_CASE("sweep, plan and report --flatten: one image for an instanced scene, recorded in the CSV and JSON",
          "[cli][sweep][scale]") {
  const fs::path d = temp_dir("cli") / "flatten";
  fs::remove_all(d);
  fs::create_directories(d);
  const std::string csv = (d / "city.csv").string();
  const std::string grid =
      "sweep --scene " RTU_SOURCE_DIR "/scenes/instances.json --rays 64 --image-width 0 --threads 2 --out " + csv;
  REQUIRE(run_rtusim(grid).status == 0);
  REQUIRE_RTUSIM_OK(r, grid + " --flatten");
  CHECK(r.output.find("flattened") != std::string::npos);
  CHECK(r.output.find("1 run, 0 already") != std::string::npos);  // another run parameter: not resumed
  const std::vector<rtu::host::SweepRow> rows = rtu::host::read_sweep_csv(csv);
  REQUIRE(rows.size() == 2);
  CHECK_FALSE(rows[0].flatten);
  CHECK(rows[1].flatten);
  CHECK(rtu::host::sweep_run_params(rows[1]) == "--rays 64 --seed 1 --image-width 0 --flatten");
  // The example places three meshes 40 times: flattened, the image (9.4x: 882 against 94 kB) and the DRAM
  // traffic are larger. (builtin:city, 51x, takes minutes here under ASan.)
  CHECK(rows[1].bvh_bytes > 5 * rows[0].bvh_bytes);
  CHECK(rows[1].dram_bytes_per_ray != rows[0].dram_bytes_per_ray);
  // --merge refuses the mix (other run parameters).
  CHECK(run_rtusim("sweep --merge " + csv + " --out " + (d / "m.csv").string()).status == 2);
  CHECK(run_rtusim("sweep --merge " + csv + " --flatten --out " + (d / "m.csv").string()).status != 0);

  const std::string plan = "plan --scene " RTU_SOURCE_DIR
                           "/scenes/instances.json --max-error 0.05 --bvh-width 4 --coord-bits 16 "
                           "--child-bits 8 --rays 64 --image-width 0 --threads 2 --json ";
  const std::string one = (d / "one.json").string(), two = (d / "two.json").string();
  REQUIRE_RTUSIM_OK(p1, plan + one + " --flatten");
  CHECK(p1.output.find("instanced scene flattened") != std::string::npos);
  REQUIRE(run_rtusim(plan + two).status == 0);
  const nlohmann::json j1 = read_json(one), j2 = read_json(two);
  CHECK(j1["flatten"] == true);
  CHECK(j2["flatten"] == false);
  CHECK(j1["plan"]["bytes"].get<uint64_t>() > 5 * j2["plan"]["bytes"].get<uint64_t>());
  CHECK(j1["plan"]["psnr_db"].is_null());  // no render: not measured

  // The report: its cycles table and the sweep it runs trace the example flattened, and report.json says so.
  const fs::path r1 = d / "report1", r2 = d / "report2";
  REQUIRE(run_rtusim("report --quick --threads 2 --scene " RTU_SOURCE_DIR "/scenes/instances.json --out " +
                     r1.string())
              .status == 0);
  const Run rf =
      run_rtusim("report --quick --threads 2 --flatten --scene " RTU_SOURCE_DIR "/scenes/instances.json --out " +
                 r2.string());
  INFO(rf.output);
  REQUIRE(rf.status == 0);
  const nlohmann::json k1 = read_json(r1 / "report.json"), k2 = read_json(r2 / "report.json");
  CHECK(k1["flatten"] == false);
  CHECK(k2["flatten"] == true);
  REQUIRE(k1["cycles"].size() == k2["cycles"].size());
  CHECK(k1["cycles"][0]["cycles"] != k2["cycles"][0]["cycles"]);
  const auto s1 = rtu::host::read_sweep_csv((r1 / "sweep.csv").string());
  const auto s2 = rtu::host::read_sweep_csv((r2 / "sweep.csv").string());
  REQUIRE(!s1.empty());
  REQUIRE(s1.size() == s2.size());
  CHECK_FALSE(s1[0].flatten);
  CHECK(s2[0].flatten);
  CHECK(s2[0].bvh_bytes > 5 * s1[0].bvh_bytes);
}

TEST_CASE("plan: budgets no sample can show and NaN options are refused up front, naming the option",
          "[cli][sweep]") {
  for (const char* m : {"0", "1e-20", "4.9e-324", "1e-12"}) {
    const Run r = run_rtusim(std::string("plan --scene builtin:cornell --max-error ") + m);
    INFO(r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find("below the smallest hit disagreement a plan can show") != std::string::npos);
  }
  // Reachable with more rays: the message names how many.
  const Run more = run_rtusim("plan --scene builtin:cornell --max-error 1e-6");
  CHECK(more.status == 2);
  CHECK(more.output.find("use --rays 1497866 or more") != std::string::npos);
  for (const char* opt : {"--max-error", "--min-psnr", "--confidence", "--area-budget", "--min-gain"}) {
    const std::string args = std::string("plan --scene builtin:cornell ") +
                             (std::string(opt) == "--max-error" ? "" : "--max-error 0.01 ") + opt + " nan";
    const Run r = run_rtusim(args);
    INFO(args << ": " << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(std::string(opt) + ": 'nan' is not a finite number") != std::string::npos);
  }
}
