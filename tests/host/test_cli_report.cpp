// rtusim end to end: report (the static page) and pareto, and their bad input.
#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <vector>

#include "host/io/image.h"
#include "host/jobs/sweep.h"
#include "hwmodel/timing/timing_config.h"
#include "tests/host/cli_checks.h"

namespace fs = std::filesystem;
using namespace rtu::test;

namespace {

// Every src="..." of an HTML page.
std::vector<std::string> html_sources(const std::string& html) {
  std::vector<std::string> srcs;
  for (size_t p = html.find("src=\""); p != std::string::npos; p = html.find("src=\"", p)) {
    p += 5;
    const size_t e = html.find('"', p);
    if (e == std::string::npos) break;
    srcs.push_back(html.substr(p, e - p));
    p = e;
  }
  return srcs;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

TEST_CASE("report --quick: a static page, its images, consistent figures", "[cli][report][scale]") {
  const fs::path d = temp_dir("cli") / "report";
  fs::remove_all(d);
  REQUIRE_RTUSIM_OK(r, "report --quick --threads 2 --out " + d.string());
  for (const char* f :
       {"index.html", "report.json", "render_float.png", "render_fixed.png", "render_heatmap.png", "sweep.csv"})
    CHECK(fs::exists(d / f));
  const std::string html = slurp(d / "index.html");
  CHECK(html.rfind("<!DOCTYPE html>", 0) == 0);
  CHECK(html.find("</html>") != std::string::npos);
  CHECK(html.find("<script") == std::string::npos);  // no JavaScript needed
  CHECK(html.find("href=\"report.json\"") != std::string::npos);
  const nlohmann::json j = read_json(d / "report.json");
  // The page embeds exactly the images report.json lists; each is a relative path to a readable PNG.
  const std::vector<std::string> srcs = html_sources(html);
  std::vector<std::string> listed = j.at("images").get<std::vector<std::string>>();
  CHECK(srcs == listed);
  for (const std::string& s : srcs) {
    INFO(s);
    CHECK(s.find('/') == std::string::npos);
    const rtu::host::Image img = rtu::host::read_png((d / s).string());
    CHECK(img.width > 0);
  }
  for (const char* f : {"render_float.png", "render_fixed.png", "render_heatmap.png"})
    CHECK(std::count(srcs.begin(), srcs.end(), f) == 1);
  // Renders: PSNR finite (>= the 32 dB the render tests hold) or null (identical); cycles per frame > 0.
  const auto& rj = j.at("renders");
  CHECK(rj.at("scene") == "builtin:seed");
  if (!rj.at("psnr_db").is_null()) {
    CHECK(std::isfinite(rj.at("psnr_db").get<double>()));
    CHECK(rj.at("psnr_db").get<double>() >= 32.0);
  } else {
    CHECK(rj.at("pixels_differing") == 0);
  }
  CHECK(rj.at("fixed").at("cycles_per_frame").get<uint64_t>() > 0);
  CHECK(rj.at("fixed").at("rays").get<uint64_t>() >=
        uint64_t(rj.at("width").get<int>() * rj.at("height").get<int>()));
  // Cycles: one row per preset and scene, cycles > 0, cycles/ray = cycles / rays.
  const auto& cyc = j.at("cycles");
  REQUIRE(cyc.size() == rtu::hw::timing_preset_names().size() * 2);
  for (const auto& c : cyc) {
    INFO(c.dump());
    CHECK(c.at("cycles").get<uint64_t>() > 0);
    CHECK(c.at("cycles_per_ray").get<double>() ==
          Approx(double(c.at("cycles").get<uint64_t>()) / double(c.at("rays").get<uint64_t>())));
    CHECK(c.at("cycles_over_bound").get<double>() >= 1.0);
    std::string cell = ">";
    cell += std::to_string(c.at("cycles").get<uint64_t>());
    cell += "<";
    CHECK(html.find(cell) != std::string::npos);
  }
  // The sweep run here: 5 formats x 1 width x 1 preset on each of the two scenes; plots when gnuplot exists.
  const auto& sw = j.at("sweep");
  CHECK(sw.at("points") == 10);
  std::ifstream csv(d / "sweep.csv");
  size_t lines = 0;
  for (std::string l; std::getline(csv, l);) ++lines;
  CHECK(lines == 11);
  if (!sw.at("gnuplot").is_null()) {
    CHECK(sw.at("message") == "ok");
    REQUIRE(sw.at("plots").size() == 4);  // 2 scenes x 2 error measures
    for (const auto& p : sw.at("plots")) {
      CHECK(std::count(srcs.begin(), srcs.end(), p.at("image").get<std::string>()) == 1);
      CHECK(p.at("points") == 5);
      CHECK(!p.at("front").at("cycles").empty());
      CHECK(p.at("front").at("cycles").size() <= 5);
    }
  } else {
    CHECK(html.find("gnuplot was not found") != std::string::npos);
  }
  // Stress: every category, no failures at the default format.
  CHECK(j.at("stress").at("failures") == 0);
  CHECK(j.at("stress").at("categories").size() >= 10);
  CHECK(j.at("seconds").get<double>() > 0.0);

  // Without gnuplot the page says so instead of failing; `pareto` exits 2.
  {
    const fs::path d2 = temp_dir("cli") / "report_nognuplot";
    fs::remove_all(d2);
    // rtusim by its absolute path needs no PATH; gnuplot is not found on it.
    const Run r2 = run_rtusim("PATH=/nonexistent", "report --quick --threads 2 --scene builtin:cornell --sweep " +
                                                       (d / "sweep.csv").string() + " --out " + d2.string());
    INFO(r2.output);
    CHECK(r2.status == 0);
    const std::string h2 = slurp(d2 / "index.html");
    CHECK(h2.find("gnuplot was not found") != std::string::npos);
    const nlohmann::json j2 = read_json(d2 / "report.json");
    CHECK(j2.at("sweep").at("gnuplot").is_null());
    CHECK(j2.at("sweep").at("plots").empty());
    CHECK(j2.at("sweep").at("points") == 10);  // the given sweep's rows
    for (const std::string& s : html_sources(h2)) CHECK(fs::exists(d2 / s));
    // The message goes to stderr: the command sends stderr to a file.
    const Run p2 = run_rtusim("PATH=/nonexistent", "pareto --sweep " + (d / "sweep.csv").string() + " --out " +
                                                       (d2 / "p").string() + " 2>" + (d2 / "err.txt").string());
    CHECK(p2.exited);
    CHECK(p2.status == 2);
    CHECK(slurp(d2 / "err.txt").find("gnuplot not found") != std::string::npos);
  }
}

TEST_CASE("report and pareto: bad input gives a clear error and exit 2", "[cli][report]") {
  const fs::path d = temp_dir("cli") / "report_bad";
  fs::remove_all(d);
  fs::create_directories(d);
  {
    std::ofstream(d / "file.txt") << "x\n";
    std::ofstream(d / "foreign.csv") << "a,b,c\n1,2,3\n";
    std::ofstream(d / "short.csv") << rtu::host::sweep_csv_header() << "\nbuiltin:seed,default,4\n";
    std::ofstream(d / "nan.csv") << rtu::host::sweep_csv_header()
                                 << "\nbuiltin:seed,default,4,rdna2,10,1,48,0,x,1,0,0,0,0,0,0,0,inf,5,0.5,64,100,"
                                    "100,2.5,-1,-1,0.5,900,0.1,0123456789abcdef\n";
    std::ofstream(d / "empty_rows.csv") << rtu::host::sweep_csv_header() << "\n";
  }
  const std::string out = " --out " + (d / "o").string();
  for (const auto& [args, words] : std::vector<std::pair<std::string, std::string>>{
           {"report --quick --out " + (d / "file.txt" / "sub").string(), "cannot create the directory"},
           {"report --quick --sweep " + (d / "foreign.csv").string() + out, "not a sweep file"},
           {"report --quick --sweep " + (d / "short.csv").string() + out, "fields, expected"},
           {"report --quick --sweep " + (d / "nan.csv").string() + out, "not a number"},
           {"report --quick --sweep " + (d / "empty_rows.csv").string() + out, "no rows"},
           {"report --quick --sweep " + (d / "missing.csv").string() + out, "file not found"},
           {"report --quick --scene nosuch.obj" + out, "nosuch.obj"},
           {"report --quick --area " + (d / "foreign.csv").string() + out, "params,cells"},
           {"pareto --sweep " + (d / "foreign.csv").string() + out, "not a sweep file"},
           {"pareto --sweep " + (d / "missing.csv").string() + out, "file not found"}}) {
    const auto t0 = std::chrono::steady_clock::now();
    const Run r = run_rtusim(args);
    INFO(args << "\n" << r.output);
    CHECK(r.status == 2);
    CHECK(r.output.find(words) != std::string::npos);
    CHECK(r.output.find("rtusim: error:") != std::string::npos);
    // Rejected before any long step.
    CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 5.0);
  }
}
